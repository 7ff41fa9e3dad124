//! Connect tokens: what a client must show to join, in the manner of
//! netcode.io.
//!
//! A matchmaker (or any backend holding the server's [`TokenKey`]) mints a
//! [`ConnectToken`] for one client and hands it over a channel of its
//! choosing (HTTPS, a launcher). The token has two parts:
//!
//! - a **public** part the client reads: protocol version, expiry, the
//!   server address to dial and the SHA-256 fingerprint of the certificate
//!   to pin, and a 24-byte random nonce;
//! - a **private** part the client cannot read or alter, sealed with
//!   ChaCha20-Poly1305 under the server key, with the whole public part as
//!   associated data: the client id, a random token id, the expiry and
//!   server address again, and opaque user data for the game.
//!
//! The server [`open`]s the token with its key. Any flipped byte, in either
//! part, fails authentication ([`TokenError::Forged`]); a token past its
//! expiry or minted for another server is refused; and a [`ReplayGuard`]
//! remembers each token id until it expires, so a token copied off the wire
//! cannot open a second connection ([`TokenError::Reused`]).
//!
//! ## Nonces
//!
//! ring offers ChaCha20-Poly1305 with a 12-byte nonce only (no XChaCha).
//! Random 12-byte nonces under one key collide with probability about
//! 2⁻³² after 2³² tokens, and a collision under ChaCha20-Poly1305 leaks
//! the XOR of two plaintexts and the authentication key. So each token is
//! sealed under its own subkey, as XChaCha20 does with HChaCha20:
//!
//! ```text
//! subkey    = HKDF-SHA256(salt = nonce[12..24], ikm = server key,
//!                         info = "inertia connect token v1")
//! aead nonce = nonce[0..12]
//! ```
//!
//! A (subkey, nonce) pair then repeats only when all 24 random bytes do,
//! which is negligible for any number of tokens a server key will see.
//!
//! ## Layout (all integers little-endian, through [`inertia_codec`])
//!
//! ```text
//! public  version u16 | expires_at u64 | nonce [24] | cert_fingerprint [32]
//!         | server_addr_len u8 | server_addr (UTF-8)
//! sealed  sealed_len u16 | ciphertext ‖ tag [16]
//! private client_id u64 | token_id [16] | expires_at u64
//!         | server_addr_len u8 | server_addr | user_data_len u16 | user_data
//! ```

mod replay_guard;

use std::fmt;

use inertia_codec::{ByteReader, ByteWriter, CodecError};
use ring::aead::{self, Aad, LessSafeKey, Nonce, UnboundKey, CHACHA20_POLY1305};
use ring::rand::{SecureRandom, SystemRandom};
use ring::{digest, hkdf};
use thiserror::Error;

use crate::version::PROTOCOL_VERSION;

pub use replay_guard::ReplayGuard;

/// Length of a [`TokenKey`], bytes.
pub const KEY_BYTES: usize = 32;
/// Length of a token's random nonce, bytes.
pub const NONCE_BYTES: usize = 24;
/// Length of a token id, bytes.
pub const TOKEN_ID_BYTES: usize = 16;
/// Longest server address a token may name, bytes of UTF-8.
pub const MAX_SERVER_ADDR_BYTES: usize = 255;
/// Longest user data a token may carry, bytes.
pub const MAX_USER_DATA_BYTES: usize = 256;
/// Length of the authentication tag on the private part, bytes.
pub const TAG_BYTES: usize = 16;

/// Fixed part of the public header: version, expiry, nonce, fingerprint,
/// address length.
const PUBLIC_FIXED: usize = 2 + 8 + NONCE_BYTES + 32 + 1;
/// Fixed part of the private plaintext: client id, token id, expiry, the
/// two length fields.
const PRIVATE_FIXED: usize = 8 + TOKEN_ID_BYTES + 8 + 1 + 2;
/// Longest sealed private part, bytes.
pub const MAX_SEALED_BYTES: usize =
    PRIVATE_FIXED + MAX_SERVER_ADDR_BYTES + MAX_USER_DATA_BYTES + TAG_BYTES;
/// Longest encoded token, bytes: anything longer is refused unread.
pub const MAX_TOKEN_BYTES: usize = PUBLIC_FIXED + MAX_SERVER_ADDR_BYTES + 2 + MAX_SEALED_BYTES;

const SUBKEY_INFO: &[u8] = b"inertia connect token v1";

/// The server's secret for sealing and opening connect tokens: 32 random
/// bytes, shared only with whoever mints tokens. Its `Debug` never shows
/// the bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct TokenKey([u8; KEY_BYTES]);

/// Why a key could not be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum KeyError {
    /// The hex text was not 64 hex digits long.
    #[error("a token key is 64 hex digits, got {len} characters")]
    WrongLength {
        /// Characters given (after trimming whitespace).
        len: usize,
    },
    /// A character that is not a hex digit.
    #[error("a token key is hex, character {at} is not a hex digit")]
    NotHex {
        /// Its index in the trimmed text.
        at: usize,
    },
    /// The system's random source failed.
    #[error("the system random source failed")]
    Random,
}

impl TokenKey {
    /// A fresh key from the system's secure random source.
    pub fn generate() -> Result<Self, KeyError> {
        let mut key = [0u8; KEY_BYTES];
        SystemRandom::new()
            .fill(&mut key)
            .map_err(|_| KeyError::Random)?;
        Ok(Self(key))
    }

    /// A key from its bytes.
    pub fn from_bytes(bytes: [u8; KEY_BYTES]) -> Self {
        Self(bytes)
    }

    /// The key's bytes (keep them secret).
    pub fn as_bytes(&self) -> &[u8; KEY_BYTES] {
        &self.0
    }

    /// A key from 64 hex digits (either case; surrounding whitespace, as
    /// left by a key file's newline, is ignored).
    pub fn from_hex(text: &str) -> Result<Self, KeyError> {
        let text = text.trim();
        if text.len() != 2 * KEY_BYTES {
            return Err(KeyError::WrongLength {
                len: text.chars().count(),
            });
        }
        let digits = text.as_bytes();
        let mut key = [0u8; KEY_BYTES];
        for (i, byte) in key.iter_mut().enumerate() {
            let hi = hex_digit(digits[2 * i]).ok_or(KeyError::NotHex { at: 2 * i })?;
            let lo = hex_digit(digits[2 * i + 1]).ok_or(KeyError::NotHex { at: 2 * i + 1 })?;
            *byte = hi << 4 | lo;
        }
        Ok(Self(key))
    }

    /// The key as 64 lowercase hex digits (keep them secret).
    pub fn to_hex(&self) -> String {
        const DIGITS: &[u8; 16] = b"0123456789abcdef";
        let mut s = String::with_capacity(2 * KEY_BYTES);
        for b in self.0 {
            s.push(DIGITS[usize::from(b >> 4)] as char);
            s.push(DIGITS[usize::from(b & 15)] as char);
        }
        s
    }

    /// The ChaCha20-Poly1305 key for one token's nonce (see the module
    /// notes).
    fn subkey(&self, nonce: &[u8; NONCE_BYTES]) -> LessSafeKey {
        let salt = hkdf::Salt::new(hkdf::HKDF_SHA256, &nonce[12..]);
        let prk = salt.extract(&self.0);
        let okm = prk
            .expand(&[SUBKEY_INFO], &CHACHA20_POLY1305)
            // 32 bytes is far below HKDF-SHA256's 255 × 32 byte limit.
            .expect("HKDF output of one key length");
        LessSafeKey::new(UnboundKey::from(okm))
    }
}

impl fmt::Debug for TokenKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("TokenKey(..)")
    }
}

fn hex_digit(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

/// The SHA-256 of a certificate's DER bytes: what a token tells the client
/// to pin.
pub fn cert_fingerprint(cert_der: &[u8]) -> [u8; 32] {
    let d = digest::digest(&digest::SHA256, cert_der);
    let mut out = [0u8; 32];
    out.copy_from_slice(d.as_ref());
    out
}

/// The part of a token anyone can read. All of it is authenticated as the
/// sealed part's associated data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PublicToken {
    /// The protocol version the token was minted for
    /// ([`PROTOCOL_VERSION`]).
    pub version: u16,
    /// When the token stops being accepted, unix seconds.
    pub expires_at: u64,
    /// Where the client should connect (`host:port`, at most
    /// [`MAX_SERVER_ADDR_BYTES`] bytes).
    pub server_addr: String,
    /// SHA-256 of the server certificate's DER bytes, which the client
    /// must pin.
    pub cert_fingerprint: [u8; 32],
    /// Random bytes that make each token's seal unique.
    pub nonce: [u8; NONCE_BYTES],
}

impl PublicToken {
    fn write(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        w.u16(self.version);
        w.u64(self.expires_at);
        w.bytes(&self.nonce);
        w.bytes(&self.cert_fingerprint);
        // Bounded by mint and by from_bytes.
        w.u8(self.server_addr.len() as u8);
        w.bytes(self.server_addr.as_bytes());
    }

    fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(PUBLIC_FIXED + self.server_addr.len());
        self.write(&mut out);
        out
    }
}

/// A connect token: a public part and a private part sealed under the
/// server's key. Sent to the client as [`ConnectToken::to_bytes`] and
/// passed, unread, to the server in the hello.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConnectToken {
    /// What the client may read.
    pub public: PublicToken,
    /// The private part: ciphertext followed by its 16-byte tag.
    pub sealed: Vec<u8>,
}

/// What a server learns from a token it has opened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OpenedToken {
    /// The client the token was minted for.
    pub client_id: u64,
    /// The token's random id (what the [`ReplayGuard`] remembers).
    pub token_id: [u8; TOKEN_ID_BYTES],
    /// When the token expires, unix seconds.
    pub expires_at: u64,
    /// The server address the token names.
    pub server_addr: String,
    /// The certificate fingerprint the client was told to pin.
    pub cert_fingerprint: [u8; 32],
    /// The game's opaque data (at most [`MAX_USER_DATA_BYTES`]).
    pub user_data: Vec<u8>,
}

/// Why token bytes could not be parsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum TokenFormatError {
    /// More bytes than any token has.
    #[error("token is {len} bytes, the most is {max}")]
    TooLong {
        /// Bytes given.
        len: usize,
        /// [`MAX_TOKEN_BYTES`].
        max: usize,
    },
    /// The bytes ended inside a field.
    #[error("token ends inside {what}")]
    Truncated {
        /// The field.
        what: &'static str,
    },
    /// A length field above its bound.
    #[error("token {what} is {len} bytes, the most is {max}")]
    FieldTooLong {
        /// The field.
        what: &'static str,
        /// Its claimed length, bytes.
        len: usize,
        /// Its bound, bytes.
        max: usize,
    },
    /// A text field that is not UTF-8.
    #[error("token {what} is not UTF-8")]
    NotUtf8 {
        /// The field.
        what: &'static str,
    },
    /// Bytes after the end of the token.
    #[error("{extra} bytes after the end of the token")]
    TrailingBytes {
        /// How many.
        extra: usize,
    },
    /// A token minted for another protocol version.
    #[error("token is for protocol version {token}, this is {ours}")]
    Version {
        /// The token's version.
        token: u16,
        /// Ours.
        ours: u16,
    },
    /// The sealed part, once opened, disagrees with the public part (the
    /// minter holds the key but wrote an inconsistent token).
    #[error("token's sealed part disagrees with its public part")]
    Inconsistent,
}

/// Why a token was refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum TokenError {
    /// The bytes are not a token.
    #[error("malformed token: {0}")]
    Malformed(#[from] TokenFormatError),
    /// The seal does not verify under our key: altered, or minted with
    /// another key.
    #[error("token does not verify under this server's key")]
    Forged,
    /// The token's time has passed; the client needs a fresh one.
    #[error("token expired at {expires_at}, it is now {now} (unix s)")]
    Expired {
        /// Expiry, unix seconds.
        expires_at: u64,
        /// The server's clock, unix seconds.
        now: u64,
    },
    /// The token was minted for another server.
    #[error("token is for server {token}, this is {ours}")]
    WrongServer {
        /// The address the token names.
        token: String,
        /// Ours.
        ours: String,
    },
    /// The token already opened another connection.
    #[error("token already used by connection {first_connection}")]
    Reused {
        /// The connection that presented it first.
        first_connection: u64,
    },
    /// The [`ReplayGuard`] is full of unexpired tokens, so a new one
    /// cannot be remembered; the client should retry later.
    #[error("replay guard full ({capacity} live tokens)")]
    ReplayGuardFull {
        /// The guard's capacity, tokens.
        capacity: usize,
    },
}

/// Why a token could not be minted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum MintError {
    /// The server address is longer than [`MAX_SERVER_ADDR_BYTES`].
    #[error("server address is {len} bytes, the most is {max}")]
    ServerAddrTooLong {
        /// Its length, bytes.
        len: usize,
        /// The bound.
        max: usize,
    },
    /// The user data is longer than [`MAX_USER_DATA_BYTES`].
    #[error("user data is {len} bytes, the most is {max}")]
    UserDataTooLong {
        /// Its length, bytes.
        len: usize,
        /// The bound.
        max: usize,
    },
    /// `now + ttl` does not fit in a u64, or `ttl` is zero.
    #[error("ttl {ttl_secs} s from {now_unix} gives no valid expiry")]
    BadTtl {
        /// The requested lifetime, s.
        ttl_secs: u64,
        /// The clock, unix seconds.
        now_unix: u64,
    },
    /// The system's random source failed.
    #[error("the system random source failed")]
    Random,
}

/// Mints a token for `client_id` to join the server at `server_addr`
/// (whose certificate hashes to `cert_fingerprint`), valid for `ttl_secs`
/// seconds from `now_unix` (unix seconds), carrying `user_data` for the
/// game.
pub fn mint(
    key: &TokenKey,
    client_id: u64,
    server_addr: &str,
    cert_fingerprint: [u8; 32],
    ttl_secs: u64,
    user_data: &[u8],
    now_unix: u64,
) -> Result<ConnectToken, MintError> {
    mint_with(
        &SystemRandom::new(),
        key,
        client_id,
        server_addr,
        cert_fingerprint,
        ttl_secs,
        user_data,
        now_unix,
    )
}

#[allow(clippy::too_many_arguments)]
fn mint_with(
    rng: &dyn SecureRandom,
    key: &TokenKey,
    client_id: u64,
    server_addr: &str,
    cert_fingerprint: [u8; 32],
    ttl_secs: u64,
    user_data: &[u8],
    now_unix: u64,
) -> Result<ConnectToken, MintError> {
    if server_addr.len() > MAX_SERVER_ADDR_BYTES {
        return Err(MintError::ServerAddrTooLong {
            len: server_addr.len(),
            max: MAX_SERVER_ADDR_BYTES,
        });
    }
    if user_data.len() > MAX_USER_DATA_BYTES {
        return Err(MintError::UserDataTooLong {
            len: user_data.len(),
            max: MAX_USER_DATA_BYTES,
        });
    }
    let expires_at = match now_unix.checked_add(ttl_secs) {
        Some(t) if ttl_secs > 0 => t,
        _ => return Err(MintError::BadTtl { ttl_secs, now_unix }),
    };
    let mut nonce = [0u8; NONCE_BYTES];
    let mut token_id = [0u8; TOKEN_ID_BYTES];
    rng.fill(&mut nonce).map_err(|_| MintError::Random)?;
    rng.fill(&mut token_id).map_err(|_| MintError::Random)?;
    let public = PublicToken {
        version: PROTOCOL_VERSION,
        expires_at,
        server_addr: server_addr.to_owned(),
        cert_fingerprint,
        nonce,
    };
    let mut private =
        Vec::with_capacity(PRIVATE_FIXED + server_addr.len() + user_data.len() + TAG_BYTES);
    let mut w = ByteWriter::new(&mut private);
    w.u64(client_id);
    w.bytes(&token_id);
    w.u64(expires_at);
    w.u8(server_addr.len() as u8);
    w.bytes(server_addr.as_bytes());
    w.u16(user_data.len() as u16);
    w.bytes(user_data);
    let aad = public.to_bytes();
    key.subkey(&nonce)
        .seal_in_place_append_tag(aead_nonce(&nonce), Aad::from(&aad[..]), &mut private)
        // Sealing only fails for inputs past ChaCha20's 256 GiB limit.
        .expect("sealing a few hundred bytes");
    Ok(ConnectToken {
        public,
        sealed: private,
    })
}

fn aead_nonce(nonce: &[u8; NONCE_BYTES]) -> Nonce {
    let mut n = [0u8; aead::NONCE_LEN];
    n.copy_from_slice(&nonce[..aead::NONCE_LEN]);
    Nonce::assume_unique_for_key(n)
}

/// Mints tokens for one server: its key, address, certificate and the
/// tokens' lifetime, held together.
#[derive(Debug)]
pub struct TokenIssuer {
    key: TokenKey,
    server_addr: String,
    cert_fingerprint: [u8; 32],
    ttl_secs: u64,
    rng: SystemRandom,
}

impl TokenIssuer {
    /// An issuer for the server at `server_addr` whose certificate hashes
    /// to `cert_fingerprint`; tokens live `ttl_secs` seconds.
    pub fn new(
        key: TokenKey,
        server_addr: impl Into<String>,
        cert_fingerprint: [u8; 32],
        ttl_secs: u64,
    ) -> Self {
        Self {
            key,
            server_addr: server_addr.into(),
            cert_fingerprint,
            ttl_secs,
            rng: SystemRandom::new(),
        }
    }

    /// A token for `client_id` with the game's `user_data`, minted at
    /// `now_unix` (unix seconds).
    pub fn issue(
        &self,
        client_id: u64,
        user_data: &[u8],
        now_unix: u64,
    ) -> Result<ConnectToken, MintError> {
        mint_with(
            &self.rng,
            &self.key,
            client_id,
            &self.server_addr,
            self.cert_fingerprint,
            self.ttl_secs,
            user_data,
            now_unix,
        )
    }
}

/// The bytes ended inside the field `what` (a token has no varints, so
/// every [`CodecError`] is this).
fn ends_inside(what: &'static str) -> impl Fn(CodecError) -> TokenFormatError {
    move |_| TokenFormatError::Truncated { what }
}

/// A length-prefixed field of at most `max` bytes; the prefix is one byte
/// when `wide` is false, two otherwise.
fn field<'a>(
    r: &mut ByteReader<'a>,
    wide: bool,
    max: usize,
    what: &'static str,
) -> Result<&'a [u8], TokenFormatError> {
    let len = if wide {
        usize::from(r.u16().map_err(ends_inside(what))?)
    } else {
        usize::from(r.u8().map_err(ends_inside(what))?)
    };
    if len > max {
        return Err(TokenFormatError::FieldTooLong { what, len, max });
    }
    r.bytes(len).map_err(ends_inside(what))
}

/// A field of UTF-8 text, its length in one byte, at most `max` bytes.
fn text(
    r: &mut ByteReader<'_>,
    max: usize,
    what: &'static str,
) -> Result<String, TokenFormatError> {
    let raw = field(r, false, max, what)?;
    std::str::from_utf8(raw)
        .map(str::to_owned)
        .map_err(|_| TokenFormatError::NotUtf8 { what })
}

/// Refuses bytes after the last field.
fn finish(r: &ByteReader<'_>) -> Result<(), TokenFormatError> {
    match r.remaining() {
        0 => Ok(()),
        extra => Err(TokenFormatError::TrailingBytes { extra }),
    }
}

impl ConnectToken {
    /// The token as bytes (at most [`MAX_TOKEN_BYTES`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(
            PUBLIC_FIXED + self.public.server_addr.len() + 2 + self.sealed.len(),
        );
        self.public.write(&mut out);
        let mut w = ByteWriter::new(&mut out);
        w.u16(self.sealed.len() as u16);
        w.bytes(&self.sealed);
        out
    }

    /// Parses token bytes without opening the sealed part: what a client
    /// does to learn where to connect. Any protocol version is accepted
    /// here; [`open`] refuses versions other than ours.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, TokenFormatError> {
        if bytes.len() > MAX_TOKEN_BYTES {
            return Err(TokenFormatError::TooLong {
                len: bytes.len(),
                max: MAX_TOKEN_BYTES,
            });
        }
        let mut r = ByteReader::new(bytes);
        let version = r.u16().map_err(ends_inside("version"))?;
        let expires_at = r.u64().map_err(ends_inside("expiry"))?;
        let nonce = r.array().map_err(ends_inside("nonce"))?;
        let cert_fingerprint = r.array().map_err(ends_inside("certificate fingerprint"))?;
        let server_addr = text(&mut r, MAX_SERVER_ADDR_BYTES, "server address")?;
        let sealed = field(&mut r, true, MAX_SEALED_BYTES, "sealed part")?;
        finish(&r)?;
        if sealed.len() < PRIVATE_FIXED + TAG_BYTES {
            return Err(TokenFormatError::Truncated {
                what: "sealed part",
            });
        }
        Ok(Self {
            public: PublicToken {
                version,
                expires_at,
                server_addr,
                cert_fingerprint,
                nonce,
            },
            sealed: sealed.to_vec(),
        })
    }

    /// Opens this token with the server's `key`; see [`open`].
    pub fn open(
        &self,
        key: &TokenKey,
        now_unix: u64,
        our_server_addr: &str,
    ) -> Result<OpenedToken, TokenError> {
        let public = &self.public;
        if public.version != PROTOCOL_VERSION {
            return Err(TokenFormatError::Version {
                token: public.version,
                ours: PROTOCOL_VERSION,
            }
            .into());
        }
        let aad = public.to_bytes();
        let mut buf = self.sealed.clone();
        let plain = key
            .subkey(&public.nonce)
            .open_in_place(aead_nonce(&public.nonce), Aad::from(&aad[..]), &mut buf)
            .map_err(|_| TokenError::Forged)?;
        let mut r = ByteReader::new(plain);
        let client_id = r.u64().map_err(ends_inside("client id"))?;
        let token_id = r.array().map_err(ends_inside("token id"))?;
        let expires_at = r.u64().map_err(ends_inside("expiry"))?;
        let server_addr = text(&mut r, MAX_SERVER_ADDR_BYTES, "server address")?;
        let user_data = field(&mut r, true, MAX_USER_DATA_BYTES, "user data")?.to_vec();
        finish(&r)?;
        if expires_at != public.expires_at || server_addr != public.server_addr {
            return Err(TokenFormatError::Inconsistent.into());
        }
        if now_unix >= expires_at {
            return Err(TokenError::Expired {
                expires_at,
                now: now_unix,
            });
        }
        if server_addr != our_server_addr {
            return Err(TokenError::WrongServer {
                token: server_addr,
                ours: our_server_addr.to_owned(),
            });
        }
        Ok(OpenedToken {
            client_id,
            token_id,
            expires_at,
            server_addr,
            cert_fingerprint: public.cert_fingerprint,
            user_data,
        })
    }
}

/// Opens token bytes presented to the server at `our_server_addr`, at
/// `now_unix` (unix seconds): parses them, checks the version, verifies
/// the seal under `key`, then the expiry and the address. Authenticity is
/// checked before anything the token claims, so a forged token is always
/// [`TokenError::Forged`], never a more specific refusal.
///
/// This does not consult a [`ReplayGuard`]; [`verify`] does both.
pub fn open(
    token_bytes: &[u8],
    key: &TokenKey,
    now_unix: u64,
    our_server_addr: &str,
) -> Result<OpenedToken, TokenError> {
    ConnectToken::from_bytes(token_bytes)?.open(key, now_unix, our_server_addr)
}

/// [`open`]s the token, then admits it on `connection` through `guard`.
pub fn verify(
    token_bytes: &[u8],
    key: &TokenKey,
    now_unix: u64,
    our_server_addr: &str,
    connection: u64,
    guard: &mut ReplayGuard,
) -> Result<OpenedToken, TokenError> {
    let opened = open(token_bytes, key, now_unix, our_server_addr)?;
    guard.admit(&opened, connection, now_unix)?;
    Ok(opened)
}

#[cfg(test)]
mod tests;
