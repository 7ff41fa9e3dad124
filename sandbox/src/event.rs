//! What happens in the sandbox that its clients may show: the sandbox
//! rules' messages to every client ([`SandboxEvent`]), reliable, in the
//! order they happened.
//!
//! ## Layout
//!
//! A kind byte, then the kind's fields: ids and client numbers as LEB128
//! varints, the push's impulse as three little-endian `f32` (N·s).
//!
//! ```text
//! 1 Joined     varint client, varint avatar
//! 2 Left       varint client
//! 3 Respawned  varint client, varint avatar
//! 4 Jumped     varint avatar
//! 5 Pushed     varint avatar, varint target, f32 × 3 impulse
//! 6 Removed    varint entity, u8 reason (0 out of bounds, 1 quarantined,
//!              2 despawned)
//! 7 Chat       varint client, varint n, n bytes of UTF-8 (n ≤ MAX_CHAT_BYTES)
//! ```
//!
//! The decoder refuses anything the encoder would not write (an unknown
//! kind or reason, a long varint, an id past 32 bits, text that is not
//! UTF-8 or too long, trailing bytes).

use inertia_codec::{ByteReader, ByteWriter};
use inertia_protocol::message::{GameMessage, MessageDecodeError};
use inertia_protocol::EntityId;

use crate::request::read_text;

/// A client, as the server numbers it.
pub type ClientId = u64;

/// Why an entity left the world without anyone asking for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Removal {
    /// It left the world's bounds.
    OutOfBounds,
    /// Its state went non-finite and it was taken out.
    Quarantined,
    /// An operator or the rules removed it.
    Despawned,
}

/// Something that happened in the sandbox.
#[derive(Debug, Clone, PartialEq)]
pub enum SandboxEvent {
    /// A client joined and got an avatar.
    Joined {
        /// The client.
        client: ClientId,
        /// Its avatar.
        avatar: EntityId,
    },
    /// A client left.
    Left {
        /// The client.
        client: ClientId,
    },
    /// A client's avatar was lost (fell off the world) and made anew.
    Respawned {
        /// The client.
        client: ClientId,
        /// The new avatar.
        avatar: EntityId,
    },
    /// An avatar jumped.
    Jumped {
        /// The avatar.
        avatar: EntityId,
    },
    /// An avatar pushed a body.
    Pushed {
        /// The avatar.
        avatar: EntityId,
        /// What it pushed.
        target: EntityId,
        /// The impulse given, N·s.
        impulse: [f32; 3],
    },
    /// An entity left the world.
    Removed {
        /// The entity (its id is never reused).
        entity: EntityId,
        /// Why.
        reason: Removal,
    },
    /// A client said something ([`SandboxRequest::Chat`](crate::SandboxRequest::Chat)).
    Chat {
        /// Who.
        client: ClientId,
        /// What (at most [`MAX_CHAT_BYTES`](crate::MAX_CHAT_BYTES)).
        text: String,
    },
}

impl SandboxEvent {
    /// A short name for logs and tools (`"jumped"`, `"pushed"`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            SandboxEvent::Joined { .. } => "joined",
            SandboxEvent::Left { .. } => "left",
            SandboxEvent::Respawned { .. } => "respawned",
            SandboxEvent::Jumped { .. } => "jumped",
            SandboxEvent::Pushed { .. } => "pushed",
            SandboxEvent::Removed { .. } => "removed",
            SandboxEvent::Chat { .. } => "chat",
        }
    }
}

impl GameMessage for SandboxEvent {
    fn encode(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter::new(out);
        match self {
            &SandboxEvent::Joined { client, avatar } => {
                w.u8(1);
                w.varint(client);
                w.varint(u64::from(avatar));
            }
            &SandboxEvent::Left { client } => {
                w.u8(2);
                w.varint(client);
            }
            &SandboxEvent::Respawned { client, avatar } => {
                w.u8(3);
                w.varint(client);
                w.varint(u64::from(avatar));
            }
            &SandboxEvent::Jumped { avatar } => {
                w.u8(4);
                w.varint(u64::from(avatar));
            }
            &SandboxEvent::Pushed {
                avatar,
                target,
                impulse,
            } => {
                w.u8(5);
                w.varint(u64::from(avatar));
                w.varint(u64::from(target));
                for x in impulse {
                    w.f32(x);
                }
            }
            &SandboxEvent::Removed { entity, reason } => {
                w.u8(6);
                w.varint(u64::from(entity));
                w.u8(match reason {
                    Removal::OutOfBounds => 0,
                    Removal::Quarantined => 1,
                    Removal::Despawned => 2,
                });
            }
            SandboxEvent::Chat { client, text } => {
                w.u8(7);
                w.varint(*client);
                w.varint(text.len() as u64);
                w.bytes(text.as_bytes());
            }
        }
    }

    fn decode(bytes: &[u8]) -> Result<Self, MessageDecodeError> {
        let mut r = ByteReader::new(bytes);
        let id = |r: &mut ByteReader<'_>| -> Result<EntityId, MessageDecodeError> {
            EntityId::try_from(r.varint()?)
                .map_err(|_| MessageDecodeError::Invalid("an entity id past 32 bits".into()))
        };
        let event = match r.u8()? {
            1 => SandboxEvent::Joined {
                client: r.varint()?,
                avatar: id(&mut r)?,
            },
            2 => SandboxEvent::Left {
                client: r.varint()?,
            },
            3 => SandboxEvent::Respawned {
                client: r.varint()?,
                avatar: id(&mut r)?,
            },
            4 => SandboxEvent::Jumped {
                avatar: id(&mut r)?,
            },
            5 => SandboxEvent::Pushed {
                avatar: id(&mut r)?,
                target: id(&mut r)?,
                impulse: [r.f32()?, r.f32()?, r.f32()?],
            },
            6 => SandboxEvent::Removed {
                entity: id(&mut r)?,
                reason: match r.u8()? {
                    0 => Removal::OutOfBounds,
                    1 => Removal::Quarantined,
                    2 => Removal::Despawned,
                    other => {
                        return Err(MessageDecodeError::Invalid(
                            format!("removal reason {other}").into(),
                        ))
                    }
                },
            },
            7 => SandboxEvent::Chat {
                client: r.varint()?,
                text: read_text(&mut r)?,
            },
            kind => return Err(MessageDecodeError::UnknownKind(u64::from(kind))),
        };
        if !r.is_empty() {
            return Err(MessageDecodeError::Invalid("bytes after the event".into()));
        }
        // Varints spelled longer than the encoder writes them.
        if event.to_bytes() != bytes {
            return Err(MessageDecodeError::Invalid(
                "not the canonical encoding".into(),
            ));
        }
        Ok(event)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all() -> Vec<SandboxEvent> {
        vec![
            SandboxEvent::Joined {
                client: u64::MAX,
                avatar: 7,
            },
            SandboxEvent::Left { client: 0 },
            SandboxEvent::Respawned {
                client: 300,
                avatar: u32::MAX,
            },
            SandboxEvent::Jumped { avatar: 1 },
            SandboxEvent::Pushed {
                avatar: 2,
                target: 128,
                impulse: [1.5, -0.0, 400.0],
            },
            SandboxEvent::Removed {
                entity: 9,
                reason: Removal::Quarantined,
            },
            SandboxEvent::Chat {
                client: 4,
                text: "hello".into(),
            },
        ]
    }

    #[test]
    fn events_round_trip_and_every_truncation_is_refused() {
        for e in all() {
            let bytes = e.to_bytes();
            assert_eq!(SandboxEvent::decode(&bytes), Ok(e.clone()));
            for cut in 0..bytes.len() {
                assert!(
                    SandboxEvent::decode(&bytes[..cut]).is_err(),
                    "{e:?} cut at {cut}"
                );
            }
            let mut longer = bytes.clone();
            longer.push(0);
            assert!(SandboxEvent::decode(&longer).is_err());
        }
    }

    #[test]
    fn what_the_encoder_would_not_write_is_refused() {
        assert_eq!(
            SandboxEvent::decode(&[0]),
            Err(MessageDecodeError::UnknownKind(0))
        );
        assert_eq!(
            SandboxEvent::decode(&[8, 1]),
            Err(MessageDecodeError::UnknownKind(8))
        );
        // Jumped, avatar 1 spelled in two bytes.
        assert!(SandboxEvent::decode(&[4, 0x81, 0x00]).is_err());
        // An avatar past 32 bits.
        assert!(SandboxEvent::decode(&[4, 0x80, 0x80, 0x80, 0x80, 0x10]).is_err());
        // Removed with reason 3.
        assert!(SandboxEvent::decode(&[6, 1, 3]).is_err());
    }
}
