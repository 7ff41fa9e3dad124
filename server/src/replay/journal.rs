//! The journal: everything that changed a simulation between two ticks, in
//! the order it was applied — joins, leaves, accepted inputs and messages,
//! and live edits. Re-simulating a recording applies the journal of tick T (what
//! happened while the world stood at T) and then steps to T + 1; with the
//! same state and the same journal the step is the same, bit for bit.
//!
//! # Encoding
//!
//! A journal payload is a varint count followed by the entries, each a tag
//! byte and its fields. Varints are LEB128 (7 bits a byte, least
//! significant first, at most 10 bytes); `zigzag` maps signed to unsigned;
//! fixed-width fields are little-endian (all [`inertia_codec`]).
//!
//! ```text
//! 1 Join      varint client
//! 2 Leave     varint client
//! 5 Edit      varint length n, n bytes: the WorldEdit (postcard)
//! 8 Input     varint client, varint sequence, varint zigzag(input tick −
//!             journal tick), varint view: the view offset in the wire's
//!             1/16 tick steps, varint n, n bytes: the game's payload
//!             (inputs whose view the wire could carry)
//! 9 RawInput  varint client, varint sequence, u64 tick, f32 view behind,
//!             ticks, varint n, n bytes: the payload (anything else,
//!             exactly)
//! 10 Message  varint client, u8 delivery (0 reliable, 1 unreliable),
//!             varint n, n bytes: the message (n ≤ MAX_MESSAGE_BYTES)
//! ```
//!
//! An input takes its payload and about 7 bytes this way; a message its
//! bytes and about 4.
//!
//! Tags 3, 4, 6 and 7 were written before games defined their inputs,
//! when every input was the sandbox's; they are still read, as the
//! sandbox's input ([`SandboxInput`]), and no longer written:
//!
//! ```text
//! 3 Input     varint client, varint sequence, varint zigzag(input tick −
//!             journal tick), 5 bytes: the SandboxInput's bytes
//! 4 RawInput  varint client, varint sequence, u64 tick, f32 movement x,
//!             f32 movement z, f32 yaw, u8 buttons (read as the
//!             SandboxInput the wire would have made of them)
//! 6 Input     as 3, then varint view in 1/16 tick steps
//! 7 RawInput  as 4, then f32 view behind, ticks
//! ```
//!
//! Tags 3 and 4 were written before inputs carried the tick their player
//! saw ([`PlayerInput::view_behind`]): they are read with a view of 0 (the
//! world as it is).

use inertia_codec::{unzigzag, zigzag, ByteReader, ByteWriter, CodecError};
use inertia_protocol::admin::SpawnDesc;
use inertia_protocol::input::{
    pack_view_behind, unpack_view_behind, GameInput, InputPayload, MAX_INPUT_BYTES,
};
use inertia_protocol::message::{Delivery, MAX_MESSAGE_BYTES};
use inertia_protocol::{EntityId, PlayerInput};
use inertia_sandbox::{SandboxInput, SANDBOX_INPUT_BYTES};
use serde::{Deserialize, Serialize};

use crate::rules::ClientId;

/// Most entries one journal payload may hold.
pub const MAX_JOURNAL_ENTRIES: u64 = 1 << 20;
/// Largest encoded edit, bytes.
pub const MAX_EDIT_BYTES: u64 = 1 << 20;

/// One change applied to a simulation between ticks.
#[derive(Debug, Clone, PartialEq)]
pub enum JournalEntry {
    /// A client joined (the rules made its avatar).
    Join(ClientId),
    /// A client left.
    Leave(ClientId),
    /// The rules accepted an input from a client.
    Input(ClientId, PlayerInput),
    /// The rules took a message from a client: how it came, and its bytes.
    Message(ClientId, Delivery, Vec<u8>),
    /// An operator edited the world.
    Edit(Box<WorldEdit>),
}

/// An operator's live edit of the world, as replay applies it again.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum WorldEdit {
    /// Remove an entity.
    Despawn {
        /// The entity.
        id: EntityId,
    },
    /// Push an entity's body.
    Impulse {
        /// The entity.
        id: EntityId,
        /// The impulse asked for, N·s (the rules' limits apply again).
        impulse: [f64; 3],
        /// Where it acts, m; `None` the centre of mass.
        point: Option<[f64; 3]>,
    },
    /// Add a body.
    Spawn {
        /// What was added.
        desc: SpawnDesc,
    },
}

/// Why a journal payload was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("journal: {0}")]
pub struct JournalError(pub String);

fn err(what: impl Into<String>) -> JournalError {
    JournalError(what.into())
}

/// The payload ends early or holds a varint past 64 bits.
impl From<CodecError> for JournalError {
    fn from(e: CodecError) -> Self {
        err(e.to_string())
    }
}

/// Encodes the entries applied while the world stood at `tick`.
pub fn encode(tick: u64, entries: &[JournalEntry]) -> Vec<u8> {
    let mut out = Vec::with_capacity(2 + entries.len() * 12);
    let mut w = ByteWriter::new(&mut out);
    w.varint(entries.len() as u64);
    for e in entries {
        match e {
            JournalEntry::Join(c) => {
                w.u8(1);
                w.varint(*c);
            }
            JournalEntry::Leave(c) => {
                w.u8(2);
                w.varint(*c);
            }
            JournalEntry::Input(c, input) => {
                match pack_view_behind(input) {
                    Some(view) => {
                        w.u8(8);
                        w.varint(*c);
                        w.varint(u64::from(input.sequence));
                        w.varint(zigzag(input.tick.wrapping_sub(tick) as i64));
                        w.varint(u64::from(view));
                    }
                    None => {
                        w.u8(9);
                        w.varint(*c);
                        w.varint(u64::from(input.sequence));
                        w.u64(input.tick);
                        w.f32(input.view_behind);
                    }
                }
                w.varint(input.payload.len() as u64);
                w.bytes(input.payload.as_bytes());
            }
            JournalEntry::Message(c, delivery, bytes) => {
                w.u8(10);
                w.varint(*c);
                w.u8(match delivery {
                    Delivery::Reliable => 0,
                    Delivery::Unreliable => 1,
                });
                w.varint(bytes.len() as u64);
                w.bytes(bytes);
            }
            JournalEntry::Edit(edit) => {
                w.u8(5);
                let bytes = postcard::to_allocvec(edit).unwrap_or_default();
                w.varint(bytes.len() as u64);
                w.bytes(&bytes);
            }
        }
    }
    out
}

/// A varint that must fit 32 bits (a sequence number).
fn u32_varint(r: &mut ByteReader<'_>) -> Result<u32, JournalError> {
    u32::try_from(r.varint()?).map_err(|_| err("a sequence number passes 32 bits"))
}

/// A view offset in the wire's 1/16 tick steps, within its cap.
fn view(r: &mut ByteReader<'_>, client: ClientId) -> Result<f32, JournalError> {
    let steps = u16::try_from(r.varint()?)
        .map_err(|_| err(format!("view of client {client} past its cap")))?;
    unpack_view_behind(steps).map_err(|e| err(format!("input of client {client}: {e}")))
}

/// A length-prefixed payload of at most [`MAX_INPUT_BYTES`].
fn payload(r: &mut ByteReader<'_>, client: ClientId) -> Result<InputPayload, JournalError> {
    let n = r.varint()?;
    if n > MAX_INPUT_BYTES as u64 {
        return Err(err(format!("an input of client {client} of {n} bytes")));
    }
    let bytes = r.bytes(n as usize)?;
    Ok(InputPayload::new(bytes).expect("length checked"))
}

/// Decodes a journal payload written for `tick`. Counts and lengths are
/// bounded; trailing bytes are refused.
pub fn decode(tick: u64, bytes: &[u8]) -> Result<Vec<JournalEntry>, JournalError> {
    let mut r = ByteReader::new(bytes);
    let count = r.varint()?;
    if count > MAX_JOURNAL_ENTRIES || count > bytes.len() as u64 {
        return Err(err(format!("{count} entries cannot fit")));
    }
    let mut out = Vec::with_capacity(count as usize);
    for _ in 0..count {
        let entry = match r.u8()? {
            1 => JournalEntry::Join(r.varint()?),
            2 => JournalEntry::Leave(r.varint()?),
            tag @ (3 | 4 | 6 | 7 | 8 | 9) => {
                let client = r.varint()?;
                let sequence = u32_varint(&mut r)?;
                // Inputs that came over the wire keep their tick relative
                // to the journal's; the others write it out.
                let input_tick = match tag {
                    3 | 6 | 8 => tick.wrapping_add(unzigzag(r.varint()?) as u64),
                    _ => r.u64()?,
                };
                let (payload, view_behind) = match tag {
                    8 => {
                        let view_behind = view(&mut r, client)?;
                        (payload(&mut r, client)?, view_behind)
                    }
                    9 => {
                        let view_behind = r.f32()?;
                        (payload(&mut r, client)?, view_behind)
                    }
                    // The sandbox's input, as the wire packed it then.
                    3 | 6 => {
                        let body = r.array::<SANDBOX_INPUT_BYTES>()?;
                        let payload = InputPayload::new(&body).expect("5 bytes fit");
                        let view_behind = if tag == 6 { view(&mut r, client)? } else { 0.0 };
                        (payload, view_behind)
                    }
                    // The sandbox's input written out: as the wire would
                    // have packed it.
                    _ => {
                        let sandbox = SandboxInput {
                            movement: [r.f32()?, r.f32()?],
                            yaw: r.f32()?,
                            buttons: r.u8()?,
                        };
                        let view_behind = if tag == 7 { r.f32()? } else { 0.0 };
                        (sandbox.to_payload(), view_behind)
                    }
                };
                JournalEntry::Input(
                    client,
                    PlayerInput {
                        sequence,
                        tick: input_tick,
                        payload,
                        view_behind,
                    },
                )
            }
            5 => {
                let n = r.varint()?;
                if n > MAX_EDIT_BYTES {
                    return Err(err(format!("an edit of {n} bytes is too large")));
                }
                let bytes = r.bytes(n as usize)?;
                let edit: WorldEdit =
                    postcard::from_bytes(bytes).map_err(|e| err(format!("edit: {e}")))?;
                JournalEntry::Edit(Box::new(edit))
            }
            10 => {
                let client = r.varint()?;
                let delivery = match r.u8()? {
                    0 => Delivery::Reliable,
                    1 => Delivery::Unreliable,
                    d => return Err(err(format!("message delivery {d}"))),
                };
                let n = r.varint()?;
                if n > MAX_MESSAGE_BYTES as u64 {
                    return Err(err(format!("a message of client {client} of {n} bytes")));
                }
                JournalEntry::Message(client, delivery, r.bytes(n as usize)?.to_vec())
            }
            tag => return Err(err(format!("unknown entry tag {tag}"))),
        };
        out.push(entry);
    }
    if !r.is_empty() {
        return Err(err(format!("{} trailing bytes", r.remaining())));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_protocol::admin::MassSpec;
    use inertia_protocol::input::quantize_input;
    use inertia_protocol::{EntityKind, ShapeDesc};

    fn input(seq: u32, tick: u64, mx: f32, yaw: f32, buttons: u8) -> PlayerInput {
        PlayerInput {
            sequence: seq,
            tick,
            payload: SandboxInput {
                movement: [mx, -0.25],
                yaw,
                buttons,
            }
            .to_payload(),
            view_behind: 4.25,
        }
    }

    #[test]
    fn entries_round_trip_bit_for_bit() {
        let wire = quantize_input(&input(70_000, 995, 0.5, 1.0, 1));
        let odd = PlayerInput {
            payload: InputPayload::new(&[0xff; MAX_INPUT_BYTES]).unwrap(),
            ..input(3, 1_000_000, f32::NAN, -7.0, 0xFF)
        };
        let odd_view = PlayerInput {
            view_behind: f32::NAN,
            ..input(4, 1_000_000, 0.0, 0.0, 0)
        };
        let entries = vec![
            JournalEntry::Join(7),
            JournalEntry::Input(7, wire),
            JournalEntry::Input(u64::MAX, odd),
            JournalEntry::Input(2, odd_view),
            JournalEntry::Edit(Box::new(WorldEdit::Impulse {
                id: 4,
                impulse: [1.0, 2.0, -3.5],
                point: None,
            })),
            JournalEntry::Edit(Box::new(WorldEdit::Spawn {
                desc: SpawnDesc {
                    kind: EntityKind::Dynamic,
                    shape: ShapeDesc::Sphere { radius: 0.5 },
                    mass: MassSpec::Mass(3.0),
                    position: [0.0, 5.0, 0.0],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                    velocity: [0.0; 3],
                    angular_velocity: [0.0; 3],
                    color: [1, 2, 3, 4],
                    name: "crate".into(),
                },
            })),
            JournalEntry::Message(7, Delivery::Reliable, b"buy rifle".to_vec()),
            JournalEntry::Message(2, Delivery::Unreliable, vec![0; MAX_MESSAGE_BYTES]),
            JournalEntry::Message(3, Delivery::Reliable, vec![]),
            JournalEntry::Leave(7),
        ];
        let bytes = encode(1000, &entries);
        let back = decode(1000, &bytes).unwrap();
        assert_eq!(back.len(), entries.len());
        // Compare inputs by bits (NaN != NaN).
        for (a, b) in entries.iter().zip(&back) {
            match (a, b) {
                (JournalEntry::Input(ca, ia), JournalEntry::Input(cb, ib)) => {
                    assert_eq!(ca, cb);
                    assert_eq!(ia.sequence, ib.sequence);
                    assert_eq!(ia.tick, ib.tick);
                    assert_eq!(ia.payload, ib.payload);
                    assert_eq!(ia.view_behind.to_bits(), ib.view_behind.to_bits());
                }
                _ => assert_eq!(a, b),
            }
        }
        // A wire input is compact: the count, the tag, the client, a
        // three-byte sequence, the tick step, the view, the length and its
        // payload.
        let one = encode(1000, &[JournalEntry::Input(7, wire)]);
        assert_eq!(one.len(), 1 + 1 + 1 + 3 + 1 + 1 + 1 + 5);
        // A payload past the bound is refused.
        let mut long = encode(1000, &[JournalEntry::Input(7, wire)]);
        let at = long.len() - 6;
        assert_eq!(long[at], 5, "the payload's length");
        long[at] = 65;
        assert!(decode(1000, &long).is_err());
        assert_eq!(wire.view_behind, 4.25);
        // A message: the count, the tag, the client, the delivery, the
        // length and its bytes; one past the bound, or of a delivery that
        // is none, is refused.
        let one = encode(
            1000,
            &[JournalEntry::Message(7, Delivery::Reliable, b"gg".to_vec())],
        );
        assert_eq!(one, [1, 10, 7, 0, 2, b'g', b'g']);
        let mut odd = one.clone();
        odd[3] = 2;
        assert!(decode(1000, &odd).is_err());
        let too_long = JournalEntry::Message(7, Delivery::Reliable, vec![1; MAX_MESSAGE_BYTES + 1]);
        assert!(decode(1000, &encode(1000, &[too_long])).is_err());
    }

    #[test]
    fn inputs_written_before_views_still_load() {
        // Tag 3: client 7, sequence 5, tick step 0, a packed body: the
        // sandbox's input bytes, as the wire packed them then.
        let sandbox = input(5, 1000, 0.5, 1.0, 1);
        let body = sandbox.payload;
        let mut bytes = vec![1, 3, 7, 5, 0];
        bytes.extend_from_slice(body.as_bytes());
        let back = decode(1000, &bytes).unwrap();
        let JournalEntry::Input(7, i) = back[0] else {
            panic!("{back:?}");
        };
        assert_eq!((i.sequence, i.tick, i.view_behind), (5, 1000, 0.0));
        assert_eq!(i.payload, body);
        // Tag 4: the input written out, without a view: read as the
        // sandbox input the wire would have made of it.
        let mut bytes = vec![1, 4, 7, 5];
        bytes.extend_from_slice(&1000u64.to_le_bytes());
        for f in [0.5f32, -0.25, 1.0] {
            bytes.extend_from_slice(&f.to_le_bytes());
        }
        bytes.push(1);
        let back = decode(1000, &bytes).unwrap();
        assert!(
            matches!(back[0], JournalEntry::Input(7, i) if i.view_behind == 0.0 && i.payload == body)
        );
        // A packed view past the cap is refused.
        let mut bytes = vec![1, 6, 7, 5, 0];
        bytes.extend_from_slice(body.as_bytes());
        bytes.extend_from_slice(&[0x80, 0x20]); // 4096 steps
        assert!(decode(1000, &bytes).is_err());
    }

    #[test]
    fn garbage_is_refused_without_panic() {
        let good = encode(5, &[JournalEntry::Join(1), JournalEntry::Leave(1)]);
        for cut in 0..good.len() {
            assert!(decode(5, &good[..cut]).is_err(), "cut at {cut}");
        }
        let mut extra = good.clone();
        extra.push(0);
        assert!(decode(5, &extra).is_err());
        assert!(decode(5, &[0xFF; 11]).is_err());
        assert!(decode(5, &[1, 9]).is_err());
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..2000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let bytes: Vec<u8> = (0..(x % 40)).map(|i| (x >> (i % 8 * 8)) as u8).collect();
            let _ = decode(x, &bytes);
        }
    }
}
