//! Why a game connection ends, and the QUIC application close codes that
//! say it on their own.

use serde::{Deserialize, Serialize};

use super::{truncate_utf8, MAX_REASON_BYTES};

/// The QUIC application close codes of a game connection; the reason
/// text beside them is for people, the code is what a client maps to a
/// [`DisconnectReason`] ([`DisconnectReason::from_close`]).
pub mod close_code {
    /// A normal goodbye.
    pub const GOODBYE: u32 = 0;
    /// The hello was refused.
    pub const REFUSED: u32 = 1;
    /// The peer broke the protocol on its control stream.
    pub const PROTOCOL: u32 = 2;
    /// The server is shutting down.
    pub const SHUTDOWN: u32 = 3;
    /// An operator kicked the client.
    pub const KICKED: u32 = 4;
    /// The simulation failed; the server is about to restart. The reason
    /// text is `simulation stopped: <what failed>`.
    pub const SIMULATION_STOPPED: u32 = 5;
    /// Nothing was heard from the client for too long.
    pub const TIMEOUT: u32 = 6;
    /// The match is over (its time is up, or the game rules ended it);
    /// the reason text says why.
    pub const MATCH_OVER: u32 = 7;
}

/// The prefix of the reason text of a [`close_code::SIMULATION_STOPPED`]
/// close, before what failed.
pub const SIMULATION_STOPPED_PREFIX: &str = "simulation stopped: ";

impl DisconnectReason {
    /// Why the server closed a game connection with application close
    /// `code` and `reason` text (untrusted: cut to [`MAX_REASON_BYTES`]).
    /// A code this protocol does not define reads as a kick, with the
    /// text as its reason.
    pub fn from_close(code: u64, reason: &[u8]) -> DisconnectReason {
        let mut text = String::from_utf8_lossy(reason).into_owned();
        truncate_utf8(&mut text, MAX_REASON_BYTES);
        match u32::try_from(code) {
            Ok(close_code::SIMULATION_STOPPED) => DisconnectReason::SimulationStopped {
                reason: text
                    .strip_prefix(SIMULATION_STOPPED_PREFIX)
                    .unwrap_or(&text)
                    .to_string(),
            },
            Ok(close_code::SHUTDOWN) => DisconnectReason::ServerShutdown,
            Ok(close_code::PROTOCOL) => DisconnectReason::ProtocolError { what: text },
            Ok(close_code::GOODBYE) => DisconnectReason::ClientLeft,
            Ok(close_code::TIMEOUT) => DisconnectReason::Timeout,
            Ok(close_code::MATCH_OVER) => DisconnectReason::MatchOver { reason: text },
            _ => DisconnectReason::Kicked { reason: text },
        }
    }

    /// The application close code and reason text that say this reason
    /// on their own, for a client that sees the close before the goodbye
    /// (a close discards what is still in flight): the inverse of
    /// [`DisconnectReason::from_close`]. The text is at most
    /// [`MAX_REASON_BYTES`] plus the simulation-stopped prefix.
    pub fn to_close(&self) -> (u32, String) {
        let mut text = match self {
            DisconnectReason::ServerShutdown => "server shutting down".to_string(),
            DisconnectReason::Kicked { reason } => reason.clone(),
            DisconnectReason::Timeout => "timed out".to_string(),
            DisconnectReason::ClientLeft => "goodbye".to_string(),
            DisconnectReason::ProtocolError { what } => what.clone(),
            DisconnectReason::SimulationStopped { reason } => reason.clone(),
            DisconnectReason::MatchOver { reason } => reason.clone(),
        };
        truncate_utf8(&mut text, MAX_REASON_BYTES);
        match self {
            DisconnectReason::ServerShutdown => (close_code::SHUTDOWN, text),
            DisconnectReason::Kicked { .. } => (close_code::KICKED, text),
            DisconnectReason::Timeout => (close_code::TIMEOUT, text),
            DisconnectReason::ClientLeft => (close_code::GOODBYE, text),
            DisconnectReason::ProtocolError { .. } => (close_code::PROTOCOL, text),
            DisconnectReason::MatchOver { .. } => (close_code::MATCH_OVER, text),
            DisconnectReason::SimulationStopped { .. } => (
                close_code::SIMULATION_STOPPED,
                format!("{SIMULATION_STOPPED_PREFIX}{text}"),
            ),
        }
    }
}

/// Why a connection ended.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum DisconnectReason {
    /// The server is stopping.
    ServerShutdown,
    /// An operator or the game removed the client.
    Kicked {
        /// Why, for the player (at most [`MAX_REASON_BYTES`]).
        reason: String,
    },
    /// Nothing was heard from the peer for too long.
    Timeout,
    /// The client said goodbye.
    ClientLeft,
    /// The peer broke the protocol.
    ProtocolError {
        /// What it did (at most [`MAX_REASON_BYTES`]).
        what: String,
    },
    /// The server's simulation failed and stopped; the server restarts
    /// (and resumes from its recording), so reconnecting later works.
    SimulationStopped {
        /// What failed, for logs (at most [`MAX_REASON_BYTES`]).
        reason: String,
    },
    /// The match is over: its time is up, or the game rules ended it. The
    /// server drains and stops (under Agones, its game server is deleted).
    MatchOver {
        /// Why, for the player (at most [`MAX_REASON_BYTES`]).
        reason: String,
    },
}
