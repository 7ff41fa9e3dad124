//! What a sandbox player may ask of the rules beside its input: the
//! sandbox clients' messages to the server ([`SandboxRequest`]).
//!
//! ## Layout
//!
//! A kind byte, then the kind's fields:
//!
//! ```text
//! 1 Chat     varint n, n bytes of UTF-8 (n ≤ MAX_CHAT_BYTES)
//! 2 Respawn
//! ```
//!
//! The decoder refuses anything the encoder would not write (an unknown
//! kind, text that is not UTF-8 or too long, a long varint, trailing
//! bytes).

use inertia_codec::{ByteReader, ByteWriter};
use inertia_protocol::message::{GameMessage, MessageDecodeError};

/// The longest chat line, bytes of UTF-8.
pub const MAX_CHAT_BYTES: usize = 200;

/// A sandbox player's request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SandboxRequest {
    /// Say something to everyone (at most [`MAX_CHAT_BYTES`]; the rules
    /// tell every client [`SandboxEvent::Chat`](crate::SandboxEvent::Chat)).
    Chat {
        /// The line.
        text: String,
    },
    /// Put my avatar back at a spawn point (the rules tell every client
    /// [`SandboxEvent::Respawned`](crate::SandboxEvent::Respawned)).
    Respawn,
}

impl GameMessage for SandboxRequest {
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        match self {
            SandboxRequest::Chat { text } => {
                w.u8(1);
                w.varint(text.len() as u64);
                w.bytes(text.as_bytes());
            }
            SandboxRequest::Respawn => w.u8(2),
        }
    }

    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError> {
        let mut r = ByteReader::new(bytes);
        let request = match r.u8()? {
            1 => SandboxRequest::Chat {
                text: read_text(&mut r)?,
            },
            2 => SandboxRequest::Respawn,
            kind => return Err(MessageDecodeError::UnknownKind(u64::from(kind))),
        };
        if !r.is_empty() {
            return Err(MessageDecodeError::Invalid(
                "bytes after the request".into(),
            ));
        }
        if request.to_bytes() != bytes {
            return Err(MessageDecodeError::Invalid(
                "not the canonical encoding".into(),
            ));
        }
        Ok(request)
    }
}

/// A length-prefixed chat line: UTF-8, at most [`MAX_CHAT_BYTES`].
pub(crate) fn read_text(r: &mut ByteReader<'_>) -> Result<String, MessageDecodeError> {
    let n = r.varint()?;
    if n > MAX_CHAT_BYTES as u64 {
        return Err(MessageDecodeError::Invalid(
            format!("a chat line of {n} bytes, the most is {MAX_CHAT_BYTES}").into(),
        ));
    }
    let bytes = r.bytes(n as usize)?;
    String::from_utf8(bytes.to_vec())
        .map_err(|_| MessageDecodeError::Invalid("a chat line that is not UTF-8".into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_round_trip_and_what_the_encoder_would_not_write_is_refused() {
        for r in [
            SandboxRequest::Chat {
                text: "gg — well played".into(),
            },
            SandboxRequest::Chat {
                text: "x".repeat(MAX_CHAT_BYTES),
            },
            SandboxRequest::Chat {
                text: String::new(),
            },
            SandboxRequest::Respawn,
        ] {
            let bytes = r.to_bytes();
            assert_eq!(SandboxRequest::decode(&bytes), Ok(r));
            for cut in 0..bytes.len() {
                assert!(SandboxRequest::decode(&bytes[..cut]).is_err());
            }
        }
        let long = SandboxRequest::Chat {
            text: "x".repeat(MAX_CHAT_BYTES + 1),
        };
        assert!(SandboxRequest::decode(&long.to_bytes()).is_err());
        assert!(
            SandboxRequest::decode(&[1, 2, 0xff, 0xfe]).is_err(),
            "not UTF-8"
        );
        assert!(SandboxRequest::decode(&[2, 0]).is_err(), "trailing");
        assert_eq!(
            SandboxRequest::decode(&[9]),
            Err(MessageDecodeError::UnknownKind(9))
        );
    }
}
