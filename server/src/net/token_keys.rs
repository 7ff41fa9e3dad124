//! The keys connect tokens are opened with: the current one, and after a
//! rotation the one before it for a grace period, so that tokens a game
//! backend minted just before the rotation still admit their players
//! (sans-IO: the caller gives the time); and [`ConnectTokens`], all a
//! game connection's hello is checked against.

use std::sync::{Mutex, RwLock};

use inertia_protocol::token::{ReplayGuard, TokenKey};

/// How many tokens the replay guard remembers at once.
pub const REPLAY_GUARD_CAPACITY: usize = 65_536;

/// What a connect token is opened and checked with.
#[derive(Debug)]
pub struct ConnectTokens {
    /// The keys tokens are opened with, rotated by
    /// [`crate::secrets::Secrets::reload`].
    pub keys: RwLock<TokenKeys>,
    /// The address tokens must name (the server's public `ip:port`).
    pub public_addr: String,
    /// Tokens already used, by connection.
    pub guard: Mutex<ReplayGuard>,
}

impl ConnectTokens {
    /// Tokens opened with `key` that name `public_addr`.
    pub fn new(key: TokenKey, public_addr: String) -> Self {
        Self {
            keys: RwLock::new(TokenKeys::new(key)),
            public_addr,
            guard: Mutex::new(ReplayGuard::new(REPLAY_GUARD_CAPACITY)),
        }
    }
}

/// How long a replaced token key still opens tokens, s: longer than a
/// connect token lives (a backend mints them for the next minute or two).
pub const TOKEN_KEY_GRACE_SECS: u64 = 300;

/// The current key and the retired one with the unix time it is accepted
/// until.
#[derive(Debug, Clone)]
pub struct TokenKeys {
    current: TokenKey,
    retired: Option<(TokenKey, u64)>,
    grace_secs: u64,
}

impl TokenKeys {
    /// Only `key`, a replaced key kept [`TOKEN_KEY_GRACE_SECS`].
    pub fn new(key: TokenKey) -> TokenKeys {
        TokenKeys::with_grace(key, TOKEN_KEY_GRACE_SECS)
    }

    /// Only `key`, a replaced key kept `grace_secs`.
    pub fn with_grace(key: TokenKey, grace_secs: u64) -> TokenKeys {
        TokenKeys {
            current: key,
            retired: None,
            grace_secs,
        }
    }

    /// Makes `key` current at `now_unix`; the key it replaces opens tokens
    /// for the grace period more. Returns false (and changes nothing) when
    /// `key` is already current.
    pub fn rotate(&mut self, key: TokenKey, now_unix: u64) -> bool {
        if key == self.current {
            return false;
        }
        let old = std::mem::replace(&mut self.current, key);
        self.retired = Some((old, now_unix.saturating_add(self.grace_secs)));
        true
    }

    /// The keys that open tokens at `now_unix`: the current one first.
    pub fn at(&self, now_unix: u64) -> impl Iterator<Item = &TokenKey> {
        let retired = self
            .retired
            .as_ref()
            .filter(|(_, until)| now_unix < *until)
            .map(|(k, _)| k);
        std::iter::once(&self.current).chain(retired)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_replaced_key_opens_tokens_for_the_grace_period_only() {
        let (a, b, c) = (
            TokenKey::from_bytes([1; 32]),
            TokenKey::from_bytes([2; 32]),
            TokenKey::from_bytes([3; 32]),
        );
        let mut keys = TokenKeys::with_grace(a.clone(), 60);
        assert_eq!(keys.at(1000).collect::<Vec<_>>(), [&a]);
        assert!(!keys.rotate(a.clone(), 1000), "the same key is no rotation");
        assert!(keys.rotate(b.clone(), 1000));
        assert_eq!(keys.at(1059).collect::<Vec<_>>(), [&b, &a]);
        assert_eq!(keys.at(1060).collect::<Vec<_>>(), [&b]);
        // A second rotation retires the second key; the first is gone.
        assert!(keys.rotate(c.clone(), 1010));
        assert_eq!(keys.at(1011).collect::<Vec<_>>(), [&c, &b]);
    }
}
