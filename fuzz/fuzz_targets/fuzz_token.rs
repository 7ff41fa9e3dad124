//! Connect-token bytes from the network: parsing never panics, what
//! parses writes back to the same bytes, and nothing opens without the
//! key's seal.
#![no_main]

use inertia_protocol::token::{open, ConnectToken, TokenError, TokenKey};
use libfuzzer_sys::fuzz_target;

const ADDR: &str = "127.0.0.1:7777";
const NOW: u64 = 1_750_000_000;

fuzz_target!(|data: &[u8]| {
    if let Ok(token) = ConnectToken::from_bytes(data) {
        assert_eq!(token.to_bytes(), data, "token parsing is not canonical");
    }
    let key = TokenKey::from_bytes([0x5A; 32]);
    match open(data, &key, NOW, ADDR) {
        // Forging a Poly1305 tag by chance is not something a fuzzer does.
        Ok(_) => panic!("random bytes opened as a token"),
        Err(TokenError::Malformed(_) | TokenError::Forged) => {}
        Err(e) => panic!("unsealed bytes refused as {e:?}"),
    }
});
