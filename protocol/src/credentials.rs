//! The dev-mode credentials file, `<data-dir>/dev-credentials.json`.
//!
//! With no key configured, the server makes a connect-token key, a
//! self-signed certificate and an admin token, binds loopback only, and
//! writes them here (mode 0600) so that the SDK examples and tools can mint
//! connect tokens and pin the certificate without any set-up. The file is a
//! development convenience: whoever can read it can join the server and
//! administer it.

use serde::{Deserialize, Serialize};

use crate::token::{mint, ConnectToken, MintError, TokenKey};

/// The default path of the dev credentials file, relative to the working
/// directory (the server's default data directory is `./inertia-data`).
pub const DEV_CREDENTIALS_PATH: &str = "inertia-data/dev-credentials.json";

/// The contents of the dev credentials file. Every byte string is lowercase
/// hex.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DevCredentials {
    /// The address the server listens on (a loopback address), as
    /// `ip:port`.
    pub server_addr: String,
    /// SHA-256 of the server certificate's DER, which clients pin (hex, 64
    /// characters).
    pub cert_fingerprint: String,
    /// The key connect tokens are sealed with (hex, 64 characters).
    pub token_key: String,
    /// The admin credential (hex).
    pub admin_token: String,
    /// The protocol version the server speaks.
    pub protocol_version: u16,
}

/// Why a credentials field could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("dev credentials field `{field}`: {why}")]
pub struct CredentialsFieldError {
    /// The field.
    pub field: &'static str,
    /// What is wrong with it.
    pub why: String,
}

impl DevCredentials {
    /// The certificate fingerprint as bytes.
    pub fn fingerprint(&self) -> Result<[u8; 32], CredentialsFieldError> {
        hex32("cert_fingerprint", &self.cert_fingerprint)
    }

    /// The token key as bytes.
    pub fn token_key_bytes(&self) -> Result<[u8; 32], CredentialsFieldError> {
        hex32("token_key", &self.token_key)
    }

    /// A connect token for `client_id`, valid for `ttl_secs` from
    /// `now_unix` (s), sealed with this file's key for its server and
    /// certificate: what dev tools, and a dev server's page, join with.
    pub fn mint_token(
        &self,
        client_id: u64,
        ttl_secs: u64,
        now_unix: u64,
    ) -> Result<ConnectToken, DevTokenError> {
        let key = TokenKey::from_bytes(self.token_key_bytes()?);
        let token = mint(
            &key,
            client_id,
            &self.server_addr,
            self.fingerprint()?,
            ttl_secs,
            b"",
            now_unix,
        )?;
        Ok(token)
    }
}

/// Why a token could not be minted from dev credentials.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DevTokenError {
    /// A field of the file is not valid.
    #[error(transparent)]
    Field(#[from] CredentialsFieldError),
    /// The token could not be sealed.
    #[error("minting a token: {0}")]
    Mint(#[from] MintError),
}

/// Lowercase hex of `bytes`.
pub fn to_hex(bytes: &[u8]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut s = String::with_capacity(bytes.len() * 2);
    for b in bytes {
        s.push(DIGITS[usize::from(b >> 4)] as char);
        s.push(DIGITS[usize::from(b & 15)] as char);
    }
    s
}

/// Parses exactly 32 bytes of hex (upper or lower case).
pub fn hex32(field: &'static str, text: &str) -> Result<[u8; 32], CredentialsFieldError> {
    let err = |why: String| CredentialsFieldError { field, why };
    let text = text.trim();
    if text.len() != 64 {
        return Err(err(format!(
            "expected 64 hex digits, got {} characters",
            text.len()
        )));
    }
    let mut out = [0u8; 32];
    for (i, pair) in text.as_bytes().chunks(2).enumerate() {
        let digit = |c: u8| (c as char).to_digit(16);
        match (digit(pair[0]), digit(pair[1])) {
            (Some(h), Some(l)) => out[i] = (h * 16 + l) as u8,
            _ => return Err(err(format!("not a hex digit at position {}", 2 * i))),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_round_trip_and_errors() {
        let bytes: [u8; 32] = std::array::from_fn(|i| (i * 37) as u8);
        assert_eq!(hex32("k", &to_hex(&bytes)).unwrap(), bytes);
        assert_eq!(hex32("k", &to_hex(&bytes).to_uppercase()).unwrap(), bytes);
        assert!(hex32("k", "abc").is_err());
        let mut bad = to_hex(&bytes);
        bad.replace_range(10..11, "g");
        let e = hex32("token_key", &bad).unwrap_err();
        assert_eq!(e.field, "token_key");
        assert!(e.why.contains("position 10"), "{e}");
    }
}
