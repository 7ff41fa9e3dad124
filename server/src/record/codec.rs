//! The [`Record`] type and its payload encoding (the bytes inside a frame;
//! see the layout in the [module docs](super)).
//!
//! Payloads are written field by field ([`inertia_codec`]), little-endian,
//! fixed-width, rather than by a generic serializer: the layout is then
//! documented byte by byte, stays put when a derive changes, and a float's
//! exact bit pattern (NaN included) is what comes back — replays compare
//! state hashes bit for bit.

use inertia_codec::{ByteReader, ByteWriter};

use super::error::{Corruption, RecordError};
use super::MAX_RECORD_BYTES;

/// An input as the recordings of the first builds kept it, before the
/// journal ([`Record::Journal`]) and before games defined their inputs:
/// the sandbox's fields, written out. Read from old recordings only.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LegacyInput {
    /// The client's input sequence number.
    pub sequence: u32,
    /// The tick it was meant for.
    pub tick: u64,
    /// Movement in the horizontal plane (x, z).
    pub movement: [f32; 2],
    /// Facing angle about +Y, rad.
    pub yaw: f32,
    /// Held buttons.
    pub buttons: u8,
    /// How far behind `tick` the player's view was, ticks.
    pub view_behind: f32,
}

/// Bytes of one `(client, LegacyInput)` entry in an `Inputs` payload
/// (kind 7, with the view offset).
pub(crate) const INPUT_ENTRY_BYTES: usize = 8 + 4 + 8 + 4 + 4 + 4 + 1 + 4;
/// Bytes of one entry of the older `Inputs` payload (kind 3, no view).
const INPUT_ENTRY_BYTES_V1: usize = INPUT_ENTRY_BYTES - 4;

/// One entry of a recording. Every record belongs to a tick; within a
/// recording, ticks never decrease.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// The server started (or resumed) recording: the tick rate and scene
    /// the following ticks run with.
    SessionStart {
        /// The tick recording starts at.
        tick: u64,
        /// Simulation ticks per second of simulation time, Hz.
        tick_hz: u32,
        /// The scene's name or path, UTF-8.
        scene: String,
    },
    /// The world's full saved state at `tick` (opaque here: the physics
    /// crate's save bytes). Seeking restores the keyframe at or before the
    /// target and re-simulates the recorded inputs.
    Keyframe {
        /// The tick the state belongs to.
        tick: u64,
        /// The saved state, bytes.
        state: Vec<u8>,
    },
    /// Every player input applied at `tick`, in the order applied, as the
    /// first builds recorded them (read only; the journal holds inputs
    /// now).
    Inputs {
        /// The tick the inputs were applied at.
        tick: u64,
        /// `(client id, input)` pairs.
        inputs: Vec<(u64, LegacyInput)>,
    },
    /// The 64-bit state hash after `tick`, for checking a replay.
    TickHash {
        /// The tick hashed.
        tick: u64,
        /// The state hash.
        hash: u64,
    },
    /// What changed the simulation while the world stood at `tick` —
    /// joins, leaves, inputs and live edits, in the order applied (opaque
    /// here: [`crate::replay::journal`] encodes it). Several may share a
    /// tick; they follow each other.
    Journal {
        /// The tick the world stood at.
        tick: u64,
        /// The encoded entries.
        entries: Vec<u8>,
    },
    /// An administrator changed the world at `tick` (opaque here).
    AdminEdit {
        /// The tick the edit was applied at.
        tick: u64,
        /// Who made it (the admin credential's name), UTF-8.
        who: String,
        /// The edit, encoded by its owner.
        what: Vec<u8>,
    },
}

/// The kind byte that starts every frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum RecordKind {
    /// [`Record::SessionStart`].
    SessionStart = 1,
    /// [`Record::Keyframe`].
    Keyframe = 2,
    /// [`Record::Inputs`] as written before inputs carried a view
    /// offset (read only: decoded with a view of 0).
    Inputs = 3,
    /// [`Record::TickHash`].
    TickHash = 4,
    /// [`Record::AdminEdit`].
    AdminEdit = 5,
    /// [`Record::Journal`].
    Journal = 6,
    /// [`Record::Inputs`], with each input's view offset.
    InputsWithView = 7,
}

impl RecordKind {
    /// The kind a frame's first byte names, if any.
    pub fn from_byte(byte: u8) -> Option<Self> {
        Some(match byte {
            1 => Self::SessionStart,
            2 => Self::Keyframe,
            3 => Self::Inputs,
            4 => Self::TickHash,
            5 => Self::AdminEdit,
            6 => Self::Journal,
            7 => Self::InputsWithView,
            _ => return None,
        })
    }
}

impl Record {
    /// The tick this record belongs to.
    pub fn tick(&self) -> u64 {
        match self {
            Self::SessionStart { tick, .. }
            | Self::Keyframe { tick, .. }
            | Self::Inputs { tick, .. }
            | Self::TickHash { tick, .. }
            | Self::Journal { tick, .. }
            | Self::AdminEdit { tick, .. } => *tick,
        }
    }

    /// Which kind of record this is.
    pub fn kind(&self) -> RecordKind {
        match self {
            Self::SessionStart { .. } => RecordKind::SessionStart,
            Self::Keyframe { .. } => RecordKind::Keyframe,
            Self::Inputs { .. } => RecordKind::InputsWithView,
            Self::TickHash { .. } => RecordKind::TickHash,
            Self::AdminEdit { .. } => RecordKind::AdminEdit,
            Self::Journal { .. } => RecordKind::Journal,
        }
    }

    /// The payload's size, bytes (without the 9 bytes of framing). Computed
    /// in `u64` so an absurd record cannot overflow before it is refused.
    pub fn payload_len(&self) -> u64 {
        let n = |len: usize| len as u64;
        8 + match self {
            Self::SessionStart { scene, .. } => 4 + 4 + n(scene.len()),
            Self::Keyframe { state, .. } => n(state.len()),
            Self::Inputs { inputs, .. } => 4 + n(inputs.len()) * n(INPUT_ENTRY_BYTES),
            Self::TickHash { .. } => 8,
            Self::Journal { entries, .. } => n(entries.len()),
            Self::AdminEdit { who, what, .. } => 4 + n(who.len()) + n(what.len()),
        }
    }

    /// Appends the payload to `out`, or refuses a record over
    /// [`MAX_RECORD_BYTES`] without writing anything.
    pub(crate) fn encode_payload(&self, out: &mut Vec<u8>) -> Result<(), RecordError> {
        let len = self.payload_len();
        if len > u64::from(MAX_RECORD_BYTES) {
            return Err(RecordError::TooLarge {
                len,
                max: u64::from(MAX_RECORD_BYTES),
            });
        }
        out.reserve(len as usize);
        let mut w = ByteWriter::new(out);
        w.u64(self.tick());
        // Lengths below fit in u32: each is part of a payload ≤ MAX_RECORD_BYTES.
        match self {
            Self::SessionStart { tick_hz, scene, .. } => {
                w.u32(*tick_hz);
                w.u32(scene.len() as u32);
                w.bytes(scene.as_bytes());
            }
            Self::Keyframe { state, .. } => w.bytes(state),
            Self::Inputs { inputs, .. } => {
                w.u32(inputs.len() as u32);
                for (client, input) in inputs {
                    // Destructured so a new field fails to compile here
                    // instead of silently not being recorded.
                    let LegacyInput {
                        sequence,
                        tick,
                        movement,
                        yaw,
                        buttons,
                        view_behind,
                    } = *input;
                    w.u64(*client);
                    w.u32(sequence);
                    w.u64(tick);
                    w.f32(movement[0]);
                    w.f32(movement[1]);
                    w.f32(yaw);
                    w.u8(buttons);
                    w.f32(view_behind);
                }
            }
            Self::TickHash { hash, .. } => w.u64(*hash),
            Self::Journal { entries, .. } => w.bytes(entries),
            Self::AdminEdit { who, what, .. } => {
                w.u32(who.len() as u32);
                w.bytes(who.as_bytes());
                w.bytes(what);
            }
        }
        Ok(())
    }

    /// Decodes a payload of the given kind. Untrusted bytes: every length is
    /// checked against what is left, trailing bytes are refused, nothing
    /// panics.
    pub(crate) fn decode(kind: RecordKind, payload: &[u8]) -> Result<Self, Corruption> {
        let mut r = ByteReader::new(payload);
        let tick = r.u64()?;
        let record = match kind {
            RecordKind::SessionStart => {
                let tick_hz = r.u32()?;
                let len = r.u32()?;
                let scene = string(&mut r, len)?;
                Self::SessionStart {
                    tick,
                    tick_hz,
                    scene,
                }
            }
            RecordKind::Keyframe => Self::Keyframe {
                tick,
                state: r.rest().to_vec(),
            },
            RecordKind::Inputs | RecordKind::InputsWithView => {
                let with_view = kind == RecordKind::InputsWithView;
                let entry = if with_view {
                    INPUT_ENTRY_BYTES
                } else {
                    INPUT_ENTRY_BYTES_V1
                };
                let count = r.u32()? as usize;
                if r.remaining() / entry != count || r.remaining() % entry != 0 {
                    return Err(Corruption::BadPayload("input count does not match length"));
                }
                let mut inputs = Vec::with_capacity(count);
                for _ in 0..count {
                    let client = r.u64()?;
                    let input = LegacyInput {
                        sequence: r.u32()?,
                        tick: r.u64()?,
                        movement: [r.f32()?, r.f32()?],
                        yaw: r.f32()?,
                        buttons: r.u8()?,
                        view_behind: if with_view { r.f32()? } else { 0.0 },
                    };
                    inputs.push((client, input));
                }
                Self::Inputs { tick, inputs }
            }
            RecordKind::TickHash => Self::TickHash {
                tick,
                hash: r.u64()?,
            },
            RecordKind::Journal => Self::Journal {
                tick,
                entries: r.rest().to_vec(),
            },
            RecordKind::AdminEdit => {
                let len = r.u32()?;
                let who = string(&mut r, len)?;
                Self::AdminEdit {
                    tick,
                    who,
                    what: r.rest().to_vec(),
                }
            }
        };
        if r.is_empty() {
            Ok(record)
        } else {
            Err(Corruption::BadPayload("trailing bytes"))
        }
    }
}

/// `len` bytes of UTF-8 text.
fn string(r: &mut ByteReader<'_>, len: u32) -> Result<String, Corruption> {
    let bytes = r.bytes(len as usize)?;
    String::from_utf8(bytes.to_vec()).map_err(|_| Corruption::BadPayload("string is not UTF-8"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(seed: u32) -> LegacyInput {
        LegacyInput {
            sequence: seed,
            tick: u64::from(seed) * 3 + 1,
            movement: [seed as f32 * 0.25 - 1.0, -0.5],
            yaw: f32::from_bits(0x7FC0_0001), // a NaN with a payload
            buttons: seed as u8,
            view_behind: seed as f32 * 0.0625,
        }
    }

    fn round_trip(record: &Record) -> Record {
        let mut bytes = Vec::new();
        record.encode_payload(&mut bytes).unwrap();
        assert_eq!(bytes.len() as u64, record.payload_len());
        Record::decode(record.kind(), &bytes).unwrap()
    }

    #[test]
    fn every_kind_round_trips() {
        let records = [
            Record::SessionStart {
                tick: 7,
                tick_hz: 60,
                scene: "démo".into(),
            },
            Record::Keyframe {
                tick: 8,
                state: vec![1, 2, 3],
            },
            Record::Keyframe {
                tick: 8,
                state: vec![],
            },
            Record::Inputs {
                tick: 9,
                inputs: vec![(1, input(1)), (u64::MAX, input(2))],
            },
            Record::Inputs {
                tick: 9,
                inputs: vec![],
            },
            Record::TickHash {
                tick: u64::MAX,
                hash: 0xDEAD_BEEF,
            },
            Record::AdminEdit {
                tick: 10,
                who: "ops".into(),
                what: vec![9; 100],
            },
        ];
        for record in &records {
            let back = round_trip(record);
            // NaN yaw: compare the encodings, which hold the bit patterns.
            let (mut a, mut b) = (Vec::new(), Vec::new());
            record.encode_payload(&mut a).unwrap();
            back.encode_payload(&mut b).unwrap();
            assert_eq!(a, b);
            assert_eq!(back.tick(), record.tick());
            assert_eq!(back.kind(), record.kind());
        }
    }

    #[test]
    fn too_large_is_refused_without_writing() {
        let record = Record::Keyframe {
            tick: 1,
            state: vec![0; MAX_RECORD_BYTES as usize],
        };
        let mut out = Vec::new();
        assert!(matches!(
            record.encode_payload(&mut out),
            Err(RecordError::TooLarge { .. })
        ));
        assert!(out.is_empty());
    }

    #[test]
    fn malformed_payloads_are_refused() {
        let kinds = [
            RecordKind::SessionStart,
            RecordKind::Inputs,
            RecordKind::TickHash,
            RecordKind::AdminEdit,
        ];
        for kind in kinds {
            assert!(Record::decode(kind, &[0; 7]).is_err());
        }
        // A count claiming more inputs than the bytes hold.
        let mut p = 5u64.to_le_bytes().to_vec();
        p.extend_from_slice(&u32::MAX.to_le_bytes());
        assert!(Record::decode(RecordKind::Inputs, &p).is_err());
        // A string that is not UTF-8.
        let mut p = 5u64.to_le_bytes().to_vec();
        p.extend_from_slice(&2u32.to_le_bytes());
        p.extend_from_slice(&[0xFF, 0xFE]);
        assert!(Record::decode(RecordKind::AdminEdit, &p).is_err());
        // Inputs of the older kind (no view) still load, with a view of 0.
        let mut old = 9u64.to_le_bytes().to_vec();
        old.extend_from_slice(&1u32.to_le_bytes());
        old.extend_from_slice(&7u64.to_le_bytes());
        old.extend_from_slice(&3u32.to_le_bytes());
        old.extend_from_slice(&4u64.to_le_bytes());
        for f in [0.5f32, -1.0, 2.0] {
            old.extend_from_slice(&f.to_bits().to_le_bytes());
        }
        old.push(1);
        let Ok(Record::Inputs { tick: 9, inputs }) = Record::decode(RecordKind::Inputs, &old)
        else {
            panic!("an older inputs record is refused");
        };
        assert_eq!(
            inputs,
            vec![(
                7,
                LegacyInput {
                    sequence: 3,
                    tick: 4,
                    movement: [0.5, -1.0],
                    yaw: 2.0,
                    buttons: 1,
                    view_behind: 0.0,
                }
            )]
        );
        // ... and read as the new kind they are refused (wrong length).
        assert!(Record::decode(RecordKind::InputsWithView, &old).is_err());
        // Trailing bytes after a tick hash.
        assert!(Record::decode(RecordKind::TickHash, &[0; 17]).is_err());
    }
}
