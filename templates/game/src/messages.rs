//! What players and rules say to each other beside inputs. A kind byte,
//! then its fields; a line of chat is its length (one byte, at most
//! [`MAX_LINE`]) and its UTF-8.

use inertia_codec::{ByteReader, ByteWriter};
use inertia_protocol::message::{GameMessage, MessageDecodeError};

/// The longest chat line, bytes.
pub const MAX_LINE: usize = 100;

/// What a player asks of the rules.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ask {
    /// I am ready: the round starts once every player is.
    Ready,
    /// Say this to everyone.
    Say(String),
}

/// What the rules tell the players.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Tell {
    /// A round started.
    Started,
    /// `client` took an orb and holds `orbs`.
    Collected {
        /// Who.
        client: u64,
        /// How many it holds now.
        orbs: u8,
    },
    /// `client` said `text`.
    Said {
        /// Who.
        client: u64,
        /// What.
        text: String,
    },
    /// The round is over: `client` won.
    Won {
        /// Who.
        client: u64,
    },
}

fn put_line(w: &mut ByteWriter<'_>, text: &str) {
    w.u8(text.len() as u8);
    w.bytes(text.as_bytes());
}

fn line(r: &mut ByteReader<'_>) -> Result<String, MessageDecodeError> {
    let n = usize::from(r.u8()?);
    if n > MAX_LINE {
        return Err(MessageDecodeError::Invalid("a line past 100 bytes".into()));
    }
    String::from_utf8(r.bytes(n)?.to_vec())
        .map_err(|_| MessageDecodeError::Invalid("a line that is not UTF-8".into()))
}

fn done<T>(r: &ByteReader<'_>, value: T) -> Result<T, MessageDecodeError> {
    if r.is_empty() {
        Ok(value)
    } else {
        Err(MessageDecodeError::Invalid(
            "bytes after the message".into(),
        ))
    }
}

impl GameMessage for Ask {
    /// A line past [`MAX_LINE`] is cut to it (at a character boundary).
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        match self {
            Ask::Ready => w.u8(1),
            Ask::Say(text) => {
                w.u8(2);
                let mut end = text.len().min(MAX_LINE);
                while !text.is_char_boundary(end) {
                    end -= 1;
                }
                put_line(&mut w, &text[..end]);
            }
        }
    }

    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError> {
        let mut r = ByteReader::new(bytes);
        let ask = match r.u8()? {
            1 => Ask::Ready,
            2 => Ask::Say(line(&mut r)?),
            kind => return Err(MessageDecodeError::UnknownKind(u64::from(kind))),
        };
        done(&r, ask)
    }
}

impl GameMessage for Tell {
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        match self {
            Tell::Started => w.u8(1),
            Tell::Collected { client, orbs } => {
                w.u8(2);
                w.u64(*client);
                w.u8(*orbs);
            }
            Tell::Said { client, text } => {
                w.u8(3);
                w.u64(*client);
                put_line(&mut w, text);
            }
            Tell::Won { client } => {
                w.u8(4);
                w.u64(*client);
            }
        }
    }

    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError> {
        let mut r = ByteReader::new(bytes);
        let tell = match r.u8()? {
            1 => Tell::Started,
            2 => Tell::Collected {
                client: r.u64()?,
                orbs: r.u8()?,
            },
            3 => Tell::Said {
                client: r.u64()?,
                text: line(&mut r)?,
            },
            4 => Tell::Won { client: r.u64()? },
            kind => return Err(MessageDecodeError::UnknownKind(u64::from(kind))),
        };
        done(&r, tell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_round_trip_and_bad_bytes_are_refused() {
        for ask in [Ask::Ready, Ask::Say("gl hf".into())] {
            assert_eq!(Ask::decode(&ask.to_bytes()), Ok(ask));
        }
        for tell in [
            Tell::Started,
            Tell::Collected { client: 7, orbs: 3 },
            Tell::Said {
                client: 8,
                text: "gg".into(),
            },
            Tell::Won { client: 7 },
        ] {
            assert_eq!(Tell::decode(&tell.to_bytes()), Ok(tell));
        }
        assert!(Ask::decode(&[9]).is_err());
        assert!(Ask::decode(&[1, 0]).is_err());
        assert!(Ask::decode(&[2, 101]).is_err());
        assert_eq!(
            Ask::decode(&Ask::Say("é".repeat(80)).to_bytes()),
            Ok(Ask::Say("é".repeat(50)))
        );
    }
}
