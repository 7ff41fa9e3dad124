//! Game messages: what a game's clients and server say to each other
//! beside inputs and snapshots (buy, chat, ready, vote; a goal, a kill
//! feed line, a round's result), in the game's own bytes.
//!
//! A message is at most [`MAX_MESSAGE_BYTES`] of the game's bytes, sent
//! one of two ways ([`Delivery`]):
//!
//! - **reliable**: on the control stream, in order with every other
//!   control message (a spawn before the message that names it);
//! - **unreliable**: in a datagram of its own ([`MessageDatagram`]),
//!   lost when the datagram is, never resent, never ahead of a later
//!   snapshot in meaning: for what is stale by the next tick.
//!
//! A game declares its messages as types that implement [`GameMessage`]
//! (typically one enum each way), with an encoding it controls; the
//! decoder is the validation the rules run before any field is read.
//!
//! What a client may send is bounded twice: by size here, and by rate per
//! client ([`MessageLimits`], a token bucket the server's connection
//! keeps, see [`MessageLimiter`]). A message refused either way is
//! counted ([`MessageRefusal`]) and changes nothing else: nothing waits
//! without bound.
//!
//! ## The message datagram
//!
//! ```text
//! tag      8       MESSAGE_DATAGRAM_TAG (0x4D, 'M')
//! bytes    8 × n   the message, the rest of the datagram (n ≤ MAX_MESSAGE_BYTES)
//! ```
//!
//! Both directions use it, beside the input datagram (client to server)
//! and the snapshot datagram (server to client); the first byte tells
//! them apart.

mod limiter;

use std::borrow::Cow;

use thiserror::Error;

pub use limiter::{MessageLimiter, MessageLimits};

/// The most bytes one game message may hold, either way and either
/// delivery: a message and its datagram's tag fit in the smallest
/// datagram QUIC carries (1200-byte packets, less its headers). A game
/// with more to say splits it.
pub const MAX_MESSAGE_BYTES: usize = 1024;

/// The first byte of a message datagram.
pub const MESSAGE_DATAGRAM_TAG: u8 = 0x4D;

/// How a message travels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Delivery {
    /// On the control stream: arrives, once, in order with every other
    /// reliable message and the catalog's spawns and despawns.
    Reliable,
    /// In a datagram of its own: may be lost, and may arrive out of
    /// order with other unreliable messages.
    Unreliable,
}

impl Delivery {
    /// A short label for metrics and logs.
    pub fn label(self) -> &'static str {
        match self {
            Delivery::Reliable => "reliable",
            Delivery::Unreliable => "unreliable",
        }
    }
}

/// Why a game's message could not be read from its bytes (the message is
/// then refused, and changes nothing).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MessageDecodeError {
    /// The bytes end before the message does.
    #[error("the message ends early")]
    Truncated,
    /// The message's kind is not one the game defines.
    #[error("message kind {0} is not one this game defines")]
    UnknownKind(u64),
    /// The game's decoder refused the bytes, saying why.
    #[error("message refused: {0}")]
    Invalid(Cow<'static, str>),
}

impl From<inertia_codec::CodecError> for MessageDecodeError {
    fn from(e: inertia_codec::CodecError) -> Self {
        match e {
            inertia_codec::CodecError::Truncated { .. } => MessageDecodeError::Truncated,
            other => MessageDecodeError::Invalid(other.to_string().into()),
        }
    }
}

/// A game's message: shared by the side that writes it and the side that
/// reads it (for a client's messages, the game's clients and its rules;
/// for the server's, the rules and the clients).
///
/// [`GameMessage::decode`] takes untrusted bytes and refuses anything
/// [`GameMessage::encode`] would not write, so that what the rules read
/// is always a message the game defines. The server journals a client's
/// message's bytes, so a replay reads exactly what the rules read.
pub trait GameMessage: Sized {
    /// Appends the message's bytes to `out` (at most
    /// [`MAX_MESSAGE_BYTES`] in all: a longer message is refused on
    /// sending).
    fn encode(&self, out: &mut Vec<u8>);

    /// Reads a message from `bytes`, refusing any the game does not
    /// define.
    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError>;

    /// The message's bytes.
    fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.encode(&mut out);
        out
    }
}

/// Why a message was not sent or not taken: by its sender's side (too
/// long, not connected), the server's connection (too long, over the
/// rate, malformed), its tick thread (not in the game, a backlog) or the
/// game (undecodable, or refused by its rules). Each is counted where it happens (the
/// server: per client and reason in `/metrics`) and changes nothing
/// else.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MessageRefusal {
    /// More than [`MAX_MESSAGE_BYTES`].
    #[error("a message of {len} bytes, the most is {max}")]
    TooLong {
        /// Its length, bytes.
        len: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// The sender is over its rate ([`MessageLimits`]).
    #[error("over the message rate ({per_second} a second, {bytes_per_second} bytes a second)")]
    RateLimited {
        /// Messages a second allowed, sustained.
        per_second: u32,
        /// Bytes a second allowed, sustained.
        bytes_per_second: u32,
    },
    /// A message datagram that is not one (no tag, or another tag).
    #[error("not a message datagram")]
    Malformed,
    /// The sender is not in the game: its connection is not yet
    /// welcomed or is ending, or (at the server) it has left.
    #[error("not connected")]
    NotConnected,
    /// The server holds as many of the client's messages, waiting for the
    /// next tick, as it keeps.
    #[error("{max} messages of the client wait for the next tick already")]
    Backlog {
        /// The most held per client.
        max: usize,
    },
    /// The game's decoder refused the message.
    #[error(transparent)]
    Undecodable(#[from] MessageDecodeError),
    /// The game's rules refused what the message asks, saying why (a
    /// purchase without the money, a respawn with no room).
    #[error("refused by the rules: {0}")]
    Rules(String),
}

impl MessageRefusal {
    /// A short label for metrics and logs.
    pub fn reason(&self) -> &'static str {
        match self {
            MessageRefusal::TooLong { .. } => "too_long",
            MessageRefusal::RateLimited { .. } => "rate",
            MessageRefusal::Malformed => "malformed",
            MessageRefusal::NotConnected => "not_connected",
            MessageRefusal::Backlog { .. } => "backlog",
            MessageRefusal::Undecodable(_) => "undecodable",
            MessageRefusal::Rules(_) => "rules",
        }
    }
}

/// One message datagram's message (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageDatagram;

impl MessageDatagram {
    /// The datagram carrying `message`; refused past [`MAX_MESSAGE_BYTES`].
    pub fn encode(message: &[u8]) -> Result<Vec<u8>, MessageRefusal> {
        check_len(message)?;
        let mut out = Vec::with_capacity(1 + message.len());
        out.push(MESSAGE_DATAGRAM_TAG);
        out.extend_from_slice(message);
        Ok(out)
    }

    /// The message a datagram carries, from untrusted bytes.
    pub fn decode(datagram: &[u8]) -> Result<&[u8], MessageRefusal> {
        match datagram.split_first() {
            Some((&MESSAGE_DATAGRAM_TAG, message)) => {
                check_len(message)?;
                Ok(message)
            }
            _ => Err(MessageRefusal::Malformed),
        }
    }

    /// Whether `datagram` is a message datagram (by its first byte).
    pub fn is_one(datagram: &[u8]) -> bool {
        datagram.first() == Some(&MESSAGE_DATAGRAM_TAG)
    }
}

/// `Err` when `message` is longer than [`MAX_MESSAGE_BYTES`].
pub fn check_len(message: &[u8]) -> Result<(), MessageRefusal> {
    if message.len() > MAX_MESSAGE_BYTES {
        return Err(MessageRefusal::TooLong {
            len: message.len(),
            max: MAX_MESSAGE_BYTES,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_datagram_round_trips_and_refuses_what_is_not_one() {
        for len in [0, 1, 17, MAX_MESSAGE_BYTES] {
            let message: Vec<u8> = (0..len).map(|i| i as u8).collect();
            let datagram = MessageDatagram::encode(&message).unwrap();
            assert!(MessageDatagram::is_one(&datagram));
            assert_eq!(MessageDatagram::decode(&datagram), Ok(&message[..]));
        }
        let long = vec![0; MAX_MESSAGE_BYTES + 1];
        assert_eq!(
            MessageDatagram::encode(&long),
            Err(MessageRefusal::TooLong {
                len: MAX_MESSAGE_BYTES + 1,
                max: MAX_MESSAGE_BYTES
            })
        );
        let mut datagram = vec![MESSAGE_DATAGRAM_TAG];
        datagram.extend_from_slice(&long);
        assert!(matches!(
            MessageDatagram::decode(&datagram),
            Err(MessageRefusal::TooLong { .. })
        ));
        assert_eq!(MessageDatagram::decode(&[]), Err(MessageRefusal::Malformed));
        assert_eq!(
            MessageDatagram::decode(&[0x49, 1, 2]),
            Err(MessageRefusal::Malformed)
        );
    }
}
