//! The server's answer to a hello, without I/O: the version, then the
//! connect token, then the replay guard; a refusal says which failed.

use serde::{Deserialize, Serialize};

use crate::token::{self, OpenedToken, ReplayGuard, TokenError, TokenKey};

use super::{ClientControl, PROTOCOL_VERSION};

/// Why a hello was refused.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// Client and server speak different protocol versions.
    VersionMismatch {
        /// The server's version.
        server: u16,
        /// The client's version.
        client: u16,
    },
    /// The connect token was refused.
    Token(TokenRefusal),
    /// No room for another client; try later or elsewhere.
    ServerFull,
    /// The server is shutting down.
    ShuttingDown,
    /// The first message was not a well-formed hello.
    Malformed,
    /// A connection with this client id is already in the game.
    AlreadyConnected,
    /// The server's simulation is too busy to take the join now; retry in
    /// a moment.
    Busy,
    /// The server's simulation has stopped (it is about to restart).
    SimulationStopped,
    /// The game's rules refused the join, for their own reason (at most
    /// [`MAX_REASON_BYTES`]).
    Rejected {
        /// Why, for the player.
        reason: String,
    },
}

/// Why a connect token was refused, as told to the client: the
/// [`TokenError`] without anything the client should not learn.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum TokenRefusal {
    /// The bytes are not a token of this protocol version.
    Malformed,
    /// The token does not verify under the server's key.
    Forged,
    /// The token has expired; fetch a new one.
    Expired {
        /// Its expiry, unix seconds.
        expires_at: u64,
        /// The server's clock, unix seconds.
        now: u64,
    },
    /// The token is for another server.
    WrongServer {
        /// The address in the token (at most [`MAX_REASON_BYTES`]).
        token: String,
        /// This server's address (at most [`MAX_REASON_BYTES`]).
        ours: String,
    },
    /// The token already opened another connection.
    Reused,
}

impl From<TokenError> for Refusal {
    fn from(e: TokenError) -> Self {
        match e {
            TokenError::Malformed(_) => Refusal::Token(TokenRefusal::Malformed),
            TokenError::Forged => Refusal::Token(TokenRefusal::Forged),
            TokenError::Expired { expires_at, now } => {
                Refusal::Token(TokenRefusal::Expired { expires_at, now })
            }
            TokenError::WrongServer { token, ours } => {
                Refusal::Token(TokenRefusal::WrongServer { token, ours })
            }
            TokenError::Reused { .. } => Refusal::Token(TokenRefusal::Reused),
            TokenError::ReplayGuardFull { .. } => Refusal::ServerFull,
        }
    }
}

/// Answers a client's first message, without I/O: checks the protocol
/// version first (so an old client learns it is old, whatever its token),
/// then opens the connect token with `key` at `now_unix` (unix seconds)
/// for the server at `our_addr`, and admits it on `connection_id` through
/// `guard`. On success the server sends [`ServerControl::Welcome`]; on
/// failure, [`ServerControl::Refused`] with the refusal.
pub fn handshake(
    hello: &ClientControl,
    now_unix: u64,
    key: &TokenKey,
    our_addr: &str,
    connection_id: u64,
    guard: &mut ReplayGuard,
) -> Result<OpenedToken, Refusal> {
    let ClientControl::Hello { version, token } = hello else {
        return Err(Refusal::Malformed);
    };
    if *version != PROTOCOL_VERSION {
        return Err(Refusal::VersionMismatch {
            server: PROTOCOL_VERSION,
            client: *version,
        });
    }
    Ok(token::verify(
        token,
        key,
        now_unix,
        our_addr,
        connection_id,
        guard,
    )?)
}
