//! The replay guard: each connect token opens one connection.

use std::collections::{BTreeSet, HashMap};

use super::{OpenedToken, TokenError, TOKEN_ID_BYTES};

/// Remembers which connection first used each token, until the token
/// expires, so a token copied off the wire cannot open a second
/// connection. Bounded: when full of unexpired tokens it refuses new ones
/// ([`TokenError::ReplayGuardFull`]) rather than grow.
#[derive(Debug, Clone)]
pub struct ReplayGuard {
    capacity: usize,
    /// Token id → (first connection, expiry in unix seconds).
    seen: HashMap<[u8; TOKEN_ID_BYTES], (u64, u64)>,
    /// The same entries ordered by expiry, so expired ones leave first.
    by_expiry: BTreeSet<(u64, [u8; TOKEN_ID_BYTES])>,
}

impl ReplayGuard {
    /// A guard remembering at most `capacity` live tokens. Size it for the
    /// joins expected within one token lifetime (for example 1000 joins a
    /// minute with 60 s tokens needs 1000).
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity,
            seen: HashMap::new(),
            by_expiry: BTreeSet::new(),
        }
    }

    /// The most tokens remembered at once.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Tokens remembered now (expired ones may linger until the next
    /// [`Self::admit`] or [`Self::purge_expired`]).
    pub fn len(&self) -> usize {
        self.seen.len()
    }

    /// True when nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.seen.is_empty()
    }

    /// Forgets tokens whose expiry is at or before `now_unix` (unix
    /// seconds): they could not be opened again anyway.
    pub fn purge_expired(&mut self, now_unix: u64) {
        while let Some(&(expires_at, id)) = self.by_expiry.first() {
            if expires_at > now_unix {
                break;
            }
            self.by_expiry.pop_first();
            self.seen.remove(&id);
        }
    }

    /// Admits an opened token on `connection` at `now_unix` (unix
    /// seconds). The first presentation is remembered; presenting it again
    /// on the same connection is fine; on any other connection it is
    /// [`TokenError::Reused`]. Fails with [`TokenError::Expired`] for a
    /// token past its expiry and [`TokenError::ReplayGuardFull`] when no
    /// room is left.
    pub fn admit(
        &mut self,
        token: &OpenedToken,
        connection: u64,
        now_unix: u64,
    ) -> Result<(), TokenError> {
        if now_unix >= token.expires_at {
            return Err(TokenError::Expired {
                expires_at: token.expires_at,
                now: now_unix,
            });
        }
        self.purge_expired(now_unix);
        if let Some(&(first, _)) = self.seen.get(&token.token_id) {
            return if first == connection {
                Ok(())
            } else {
                Err(TokenError::Reused {
                    first_connection: first,
                })
            };
        }
        if self.seen.len() >= self.capacity {
            return Err(TokenError::ReplayGuardFull {
                capacity: self.capacity,
            });
        }
        self.seen
            .insert(token.token_id, (connection, token.expires_at));
        self.by_expiry.insert((token.expires_at, token.token_id));
        Ok(())
    }
}
