//! The connect token's own tests: minting, opening, tampering, the replay guard.

use super::*;

const ADDR: &str = "game-7.example.net:7777";
const NOW: u64 = 1_700_000_000;

fn key() -> TokenKey {
    TokenKey::from_bytes([7; KEY_BYTES])
}

fn token(ttl: u64) -> ConnectToken {
    mint(&key(), 42, ADDR, [9; 32], ttl, b"team=blue", NOW).unwrap()
}

#[test]
fn a_minted_token_opens_with_its_fields() {
    let t = token(30);
    let bytes = t.to_bytes();
    assert!(bytes.len() <= MAX_TOKEN_BYTES);
    assert_eq!(ConnectToken::from_bytes(&bytes).unwrap(), t);
    let o = open(&bytes, &key(), NOW + 29, ADDR).unwrap();
    assert_eq!(o.client_id, 42);
    assert_eq!(o.expires_at, NOW + 30);
    assert_eq!(o.server_addr, ADDR);
    assert_eq!(o.cert_fingerprint, [9; 32]);
    assert_eq!(o.user_data, b"team=blue");
}

#[test]
fn the_largest_token_fits_the_bound() {
    let addr = "a".repeat(MAX_SERVER_ADDR_BYTES);
    let t = mint(&key(), 1, &addr, [0; 32], 5, &[1; MAX_USER_DATA_BYTES], NOW).unwrap();
    assert_eq!(t.to_bytes().len(), MAX_TOKEN_BYTES);
    assert!(open(&t.to_bytes(), &key(), NOW, &addr).is_ok());
}

#[test]
fn every_flipped_bit_is_refused() {
    let bytes = token(30).to_bytes();
    for i in 0..bytes.len() * 8 {
        let mut b = bytes.clone();
        b[i / 8] ^= 1 << (i % 8);
        assert!(open(&b, &key(), NOW, ADDR).is_err(), "bit {i}");
    }
}

#[test]
fn expiry_server_and_key_are_checked() {
    let bytes = token(30).to_bytes();
    assert_eq!(
        open(&bytes, &key(), NOW + 30, ADDR),
        Err(TokenError::Expired {
            expires_at: NOW + 30,
            now: NOW + 30
        })
    );
    assert!(matches!(
        open(&bytes, &key(), NOW, "other:7777"),
        Err(TokenError::WrongServer { .. })
    ));
    let other = TokenKey::from_bytes([8; KEY_BYTES]);
    assert_eq!(open(&bytes, &other, NOW, ADDR), Err(TokenError::Forged));
}

#[test]
fn mint_refuses_out_of_bound_inputs() {
    let k = key();
    assert!(matches!(
        mint(&k, 1, &"a".repeat(256), [0; 32], 5, b"", NOW),
        Err(MintError::ServerAddrTooLong { len: 256, .. })
    ));
    assert!(matches!(
        mint(&k, 1, ADDR, [0; 32], 5, &[0; 257], NOW),
        Err(MintError::UserDataTooLong { len: 257, .. })
    ));
    assert!(matches!(
        mint(&k, 1, ADDR, [0; 32], 0, b"", NOW),
        Err(MintError::BadTtl { .. })
    ));
    assert!(matches!(
        mint(&k, 1, ADDR, [0; 32], 2, b"", u64::MAX),
        Err(MintError::BadTtl { .. })
    ));
}

#[test]
fn keys_round_trip_through_hex_and_hide_in_debug() {
    let k = TokenKey::generate().unwrap();
    assert_eq!(TokenKey::from_hex(&k.to_hex()).unwrap(), k);
    assert_eq!(
        TokenKey::from_hex(&format!(" {}\n", k.to_hex().to_uppercase())).unwrap(),
        k
    );
    assert_eq!(format!("{k:?}"), "TokenKey(..)");
    assert_eq!(
        TokenKey::from_hex("abc"),
        Err(KeyError::WrongLength { len: 3 })
    );
    let mut bad = k.to_hex();
    bad.replace_range(5..6, "g");
    assert_eq!(TokenKey::from_hex(&bad), Err(KeyError::NotHex { at: 5 }));
    assert_ne!(TokenKey::generate().unwrap(), k);
}

#[test]
fn replay_guard_allows_one_connection_per_token() {
    let mut g = ReplayGuard::new(4);
    let o = open(&token(30).to_bytes(), &key(), NOW, ADDR).unwrap();
    assert_eq!(g.admit(&o, 1, NOW), Ok(()));
    assert_eq!(g.admit(&o, 1, NOW + 1), Ok(()));
    assert_eq!(
        g.admit(&o, 2, NOW + 1),
        Err(TokenError::Reused {
            first_connection: 1
        })
    );
    assert!(matches!(
        g.admit(&o, 2, NOW + 30),
        Err(TokenError::Expired { .. })
    ));
}

#[test]
fn replay_guard_is_bounded_and_evicts_expired_first() {
    let mut g = ReplayGuard::new(3);
    let short: Vec<_> = (0..2)
        .map(|_| open(&token(10).to_bytes(), &key(), NOW, ADDR).unwrap())
        .collect();
    let long = open(&token(100).to_bytes(), &key(), NOW, ADDR).unwrap();
    for (i, o) in short.iter().enumerate() {
        g.admit(o, i as u64, NOW).unwrap();
    }
    g.admit(&long, 9, NOW).unwrap();
    let next = open(&token(100).to_bytes(), &key(), NOW, ADDR).unwrap();
    assert_eq!(
        g.admit(&next, 10, NOW + 5),
        Err(TokenError::ReplayGuardFull { capacity: 3 })
    );
    assert_eq!(g.len(), 3);
    // Once the short tokens expire, their places free up; the long one
    // is still remembered.
    assert_eq!(g.admit(&next, 10, NOW + 10), Ok(()));
    assert_eq!(g.len(), 2);
    assert!(matches!(
        g.admit(&long, 11, NOW + 10),
        Err(TokenError::Reused {
            first_connection: 9
        })
    ));
}
