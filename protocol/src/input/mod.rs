//! The client's datagram: its newest inputs and which snapshots it has
//! received. Sent unreliably every tick, so each datagram repeats the last
//! few inputs ([`MAX_REDUNDANT_INPUTS`]): an input is lost only when every
//! datagram that carried it is. The server's [`InputBuffer`] removes the
//! copies and hands each input on exactly once, in order.
//!
//! What the player wants is the game's: each input carries a payload of
//! the game's bytes ([`InputPayload`], see [`GameInput`]), the same size
//! in every input of a datagram.
//!
//! ## Layout (bit-packed with [`BitWriter`], least significant bit first)
//!
//! ```text
//! tag          8  INPUT_DATAGRAM_TAG (0x49, 'I')
//! has_ack      1
//!   ack       16  newest snapshot sequence received     (if has_ack)
//!   ack_bits  32  bit i: snapshot ack-1-i received       (if has_ack)
//! count        4  inputs, 0 to MAX_REDUNDANT_INPUTS
//! size         7  bytes of every input's payload, 0 to MAX_INPUT_BYTES (64)
//! newest input:
//!   sequence  32
//!   tick      varint
//!   payload   8 × size
//!   view      varint  how far behind `tick` the player's view was, in
//!                 1/16 tick, 0 to MAX_VIEW_BEHIND_STEPS (4095)
//! each older input (sequence and tick relative to the one before it):
//!   seq_step   1  1: sequence is one less; 0: varint (difference − 2)
//!   tick_step  1  1: tick is one less; 0: zigzag varint of the difference
//!   same       1  1: the payload of the input before it; 0: its own,
//!                 8 × size bits
//!   view      varint
//! ```
//!
//! A player holds the same stick for many ticks, so most redundant inputs
//! cost a bit for their payload.
//!
//! `view` carries [`PlayerInput::view_behind`]: the player's render tick
//! was `tick − view / 16`. Eight ticks or less behind take one group (8
//! bits), up to the cap two (16). The cap, 4095/16 ≈ 256 ticks (4.3 s at
//! 60 Hz), is far past any rewind a server grants; a server caps the
//! rewind itself (see the server's lag compensation).
//!
//! A varint is groups of 7 value bits, least significant first, each after
//! a bit saying whether another group follows. The signed tick step is
//! zigzagged first ([`inertia_codec::zigzag()`]). The encoding is canonical:
//! the decoder refuses anything the encoder would not have written
//! (non-minimal varints, a step spelled long, nonzero padding, trailing
//! bytes), so `encode(decode(bytes)) == bytes` for every accepted datagram.

mod buffer;
mod payload;
mod player_input;

use inertia_codec::{unzigzag, zigzag};
use thiserror::Error;

use crate::bits::{BitError, BitReader, BitWriter};

pub use buffer::{InputBuffer, InputBufferStats, INPUT_WINDOW};
pub use payload::{GameInput, InputDecodeError, InputPayload, PayloadTooLong, MAX_INPUT_BYTES};
pub use player_input::PlayerInput;

/// The first byte of every input datagram.
pub const INPUT_DATAGRAM_TAG: u8 = 0x49;
/// The most inputs one datagram carries (the newest and its predecessors).
pub const MAX_REDUNDANT_INPUTS: usize = 8;
/// Bits of the payload size field.
const SIZE_BITS: u32 = 7;
const VARINT64_BITS: usize = 10 * 8;
const VARINT32_BITS: usize = 5 * 8;
/// Bits of a payload at its largest.
const PAYLOAD_BITS: usize = 8 * MAX_INPUT_BYTES;
/// Steps of [`PlayerInput::view_behind`] per tick: it travels in 1/16 tick.
pub const VIEW_STEPS_PER_TICK: u32 = 16;
/// The most steps (1/16 tick each) of [`PlayerInput::view_behind`] on the
/// wire.
pub const MAX_VIEW_BEHIND_STEPS: u32 = 4095;
/// The most [`PlayerInput::view_behind`] the wire carries, ticks
/// (4095/16); more is sent as this.
pub const MAX_VIEW_BEHIND: f32 = MAX_VIEW_BEHIND_STEPS as f32 / VIEW_STEPS_PER_TICK as f32;
/// Value bits of the view varint: [`MAX_VIEW_BEHIND_STEPS`] fits in 12.
const VIEW_VALUE_BITS: u32 = 12;
/// Bits of the view varint at its longest: two groups.
const VIEW_BITS: usize = 2 * 8;
/// The longest input datagram, bytes; longer ones are refused unread.
pub const MAX_INPUT_DATAGRAM_BYTES: usize = (8
    + 1
    + 16
    + 32
    + 4
    + SIZE_BITS as usize
    + (32 + VARINT64_BITS + PAYLOAD_BITS + VIEW_BITS)
    + (MAX_REDUNDANT_INPUTS - 1)
        * (1 + VARINT32_BITS + 1 + VARINT64_BITS + 1 + PAYLOAD_BITS + VIEW_BITS))
    .div_ceil(8);

/// What a client sends every tick.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct InputDatagram {
    /// The newest snapshot sequence received, if any yet.
    pub ack: Option<u16>,
    /// Bit `i` set: snapshot `ack - 1 - i` (wrapping) was received too.
    /// Must be 0 when `ack` is `None`.
    pub ack_bits: u32,
    /// The newest inputs, newest first, at most [`MAX_REDUNDANT_INPUTS`],
    /// with distinct sequences and payloads of one size. The view offset
    /// travels quantized (see [`quantize_input`]); payloads as they are.
    pub inputs: Vec<PlayerInput>,
}

/// Why an input datagram could not be encoded or decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum InputError {
    /// The bits ran out or a count passed its bound.
    #[error("input datagram: {0}")]
    Bits(#[from] BitError),
    /// Longer than [`MAX_INPUT_DATAGRAM_BYTES`].
    #[error("input datagram of {len} bytes, the most is {max}")]
    TooLong {
        /// Its length, bytes.
        len: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// The first byte is not [`INPUT_DATAGRAM_TAG`].
    #[error("datagram tag {tag:#04x} is not an input datagram")]
    UnknownTag {
        /// The tag found.
        tag: u8,
    },
    /// A replay datagram (its tag) that is not a whole acknowledgement
    /// ([`crate::replay::ReplayDatagram::decode_ack`]).
    #[error("a replay datagram that is not an acknowledgement")]
    ReplayAck,
    /// More than [`MAX_REDUNDANT_INPUTS`] inputs.
    #[error("{count} inputs, the most is {max}")]
    TooManyInputs {
        /// Inputs given.
        count: usize,
        /// The bound.
        max: usize,
    },
    /// Two inputs in a row with the same sequence.
    #[error("input {index} repeats the sequence of the one before")]
    RepeatedSequence {
        /// The input's position in the datagram.
        index: usize,
    },
    /// An input whose payload is not the size of the newest one's.
    #[error("input {index}'s payload is {len} bytes, the newest one's {size}")]
    MixedPayloadSizes {
        /// The input's position in the datagram.
        index: usize,
        /// Its payload's length, bytes.
        len: usize,
        /// The newest input's, bytes.
        size: usize,
    },
    /// Payloads of another size than the game's
    /// ([`ServerConnectionConfig::input_bytes`](crate::connection::ServerConnectionConfig::input_bytes)).
    #[error("inputs of {size} bytes, this game's are {expected}")]
    WrongPayloadSize {
        /// The size sent, bytes.
        size: usize,
        /// The game's, bytes.
        expected: usize,
    },
    /// A payload size past [`MAX_INPUT_BYTES`].
    #[error("payloads of {size} bytes, the most is {max}")]
    PayloadTooLong {
        /// The size read, bytes.
        size: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// `ack_bits` without an `ack`.
    #[error("ack bits without an ack")]
    AckBitsWithoutAck,
    /// Bits the encoder would never write: a non-minimal or overlong
    /// varint, a long form where the short one applies, nonzero padding,
    /// trailing bytes.
    #[error("input datagram is not in canonical form: {what}")]
    NotCanonical {
        /// What was wrong.
        what: &'static str,
    },
}

/// Writes `v` as a varint (see the module notes).
///
/// Not the byte-level LEB128 [varint](inertia_codec#varints): this one is
/// bit-packed in the middle of a datagram, not byte-aligned; each group's
/// flag comes before its 7 value bits rather than as the high bit of a
/// byte; and its reader refuses non-minimal forms and bounds the value
/// bits per field (a 32-bit step, the 12-bit view), which the datagram's
/// canonical form needs. Only the zigzag is shared.
fn write_varint(w: &mut BitWriter, mut v: u64) {
    loop {
        let group = v & 0x7F;
        v >>= 7;
        w.write_bool(v != 0);
        w.write(group, 7);
        if v == 0 {
            return;
        }
    }
}

/// Reads a varint of at most `max_bits` value bits, refusing non-minimal
/// forms.
fn read_varint(r: &mut BitReader<'_>, max_bits: u32) -> Result<u64, InputError> {
    let mut value = 0u64;
    let mut shift = 0u32;
    loop {
        let more = r.read_bool()?;
        let group = r.read(7)?;
        if shift > 0 && group == 0 && !more {
            return Err(InputError::NotCanonical {
                what: "varint with a zero last group",
            });
        }
        if shift + 7 > max_bits && group >> (max_bits - shift) != 0 {
            return Err(InputError::NotCanonical {
                what: "varint too large",
            });
        }
        value |= group << shift;
        shift += 7;
        if !more {
            return Ok(value);
        }
        if shift >= max_bits {
            return Err(InputError::NotCanonical {
                what: "varint too long",
            });
        }
    }
}

/// The wire's steps for a view offset: NaN, negative and zero as 0 (no
/// rewind), rounded to 1/16 tick, at most [`MAX_VIEW_BEHIND_STEPS`].
fn view_index(behind: f32) -> u64 {
    if behind.is_nan() || behind <= 0.0 {
        return 0;
    }
    let steps = (f64::from(behind) * f64::from(VIEW_STEPS_PER_TICK)).round();
    steps.min(f64::from(MAX_VIEW_BEHIND_STEPS)) as u64
}

fn view_value(i: u64) -> f32 {
    // Exact: i < 2¹² and 16 is a power of two.
    i as f32 / VIEW_STEPS_PER_TICK as f32
}

/// [`PlayerInput::view_behind`] as the wire's steps of 1/16 tick, when
/// that loses nothing: `None` unless it is already quantized (a multiple
/// of 1/16 in `0..=MAX_VIEW_BEHIND`). For stores that keep inputs
/// compactly.
pub fn pack_view_behind(input: &PlayerInput) -> Option<u16> {
    let i = view_index(input.view_behind);
    (view_value(i).to_bits() == input.view_behind.to_bits()).then_some(i as u16)
}

/// The view offset [`pack_view_behind`] packed, ticks; steps past
/// [`MAX_VIEW_BEHIND_STEPS`] are refused.
pub fn unpack_view_behind(steps: u16) -> Result<f32, InputError> {
    if u32::from(steps) > MAX_VIEW_BEHIND_STEPS {
        return Err(InputError::NotCanonical {
            what: "view offset past its cap",
        });
    }
    Ok(view_value(u64::from(steps)))
}

/// An input as it arrives after the trip: its view offset in steps of
/// 1/16 tick within `0..=MAX_VIEW_BEHIND` (NaN and negative as 0); its
/// payload, sequence and tick as they are. Quantizing twice changes
/// nothing.
pub fn quantize_input(input: &PlayerInput) -> PlayerInput {
    PlayerInput {
        view_behind: view_value(view_index(input.view_behind)),
        ..*input
    }
}

fn write_payload(w: &mut BitWriter, payload: &InputPayload) {
    for b in payload.as_bytes() {
        w.write(u64::from(*b), 8);
    }
}

fn read_payload(r: &mut BitReader<'_>, size: usize) -> Result<InputPayload, InputError> {
    let mut bytes = [0u8; MAX_INPUT_BYTES];
    for b in &mut bytes[..size] {
        *b = r.read(8)? as u8;
    }
    Ok(InputPayload::new(&bytes[..size]).expect("size checked against MAX_INPUT_BYTES"))
}

impl InputDatagram {
    /// The datagram's bytes (at most [`MAX_INPUT_DATAGRAM_BYTES`]).
    /// Refuses more than [`MAX_REDUNDANT_INPUTS`] inputs, two inputs in a
    /// row with one sequence, payloads of different sizes, and `ack_bits`
    /// without an `ack`.
    pub fn encode(&self) -> Result<Vec<u8>, InputError> {
        if self.inputs.len() > MAX_REDUNDANT_INPUTS {
            return Err(InputError::TooManyInputs {
                count: self.inputs.len(),
                max: MAX_REDUNDANT_INPUTS,
            });
        }
        let mut w = BitWriter::new();
        w.write(u64::from(INPUT_DATAGRAM_TAG), 8);
        match self.ack {
            Some(ack) => {
                w.write_bool(true);
                w.write(u64::from(ack), 16);
                w.write(u64::from(self.ack_bits), 32);
            }
            None if self.ack_bits != 0 => return Err(InputError::AckBitsWithoutAck),
            None => w.write_bool(false),
        }
        w.write(self.inputs.len() as u64, 4);
        let size = self.inputs.first().map_or(0, |i| i.payload.len());
        w.write(size as u64, SIZE_BITS);
        let mut prev: Option<&PlayerInput> = None;
        for (index, input) in self.inputs.iter().enumerate() {
            if input.payload.len() != size {
                return Err(InputError::MixedPayloadSizes {
                    index,
                    len: input.payload.len(),
                    size,
                });
            }
            match prev {
                None => {
                    w.write(u64::from(input.sequence), 32);
                    write_varint(&mut w, input.tick);
                    write_payload(&mut w, &input.payload);
                }
                Some(p) => {
                    let step = p.sequence.wrapping_sub(input.sequence);
                    match step {
                        0 => return Err(InputError::RepeatedSequence { index }),
                        1 => w.write_bool(true),
                        _ => {
                            w.write_bool(false);
                            write_varint(&mut w, u64::from(step - 2));
                        }
                    }
                    let tick_step = input.tick.wrapping_sub(p.tick) as i64;
                    if tick_step == -1 {
                        w.write_bool(true);
                    } else {
                        w.write_bool(false);
                        write_varint(&mut w, zigzag(tick_step));
                    }
                    let same = input.payload == p.payload;
                    w.write_bool(same);
                    if !same {
                        write_payload(&mut w, &input.payload);
                    }
                }
            }
            write_varint(&mut w, view_index(input.view_behind));
            prev = Some(input);
        }
        Ok(w.finish())
    }

    /// Reads a datagram from untrusted bytes: every count is bounded,
    /// every field checked, and anything but a canonical datagram is a
    /// typed error, never a panic. Payloads come back as bytes, for the
    /// game to decode ([`GameInput::from_payload`]).
    pub fn decode(bytes: &[u8]) -> Result<Self, InputError> {
        if bytes.len() > MAX_INPUT_DATAGRAM_BYTES {
            return Err(InputError::TooLong {
                len: bytes.len(),
                max: MAX_INPUT_DATAGRAM_BYTES,
            });
        }
        let mut r = BitReader::new(bytes);
        let tag = r.read(8)? as u8;
        if tag != INPUT_DATAGRAM_TAG {
            return Err(InputError::UnknownTag { tag });
        }
        let (ack, ack_bits) = if r.read_bool()? {
            (Some(r.read(16)? as u16), r.read(32)? as u32)
        } else {
            (None, 0)
        };
        let count = r.read_count(4, MAX_REDUNDANT_INPUTS as u64, "inputs")? as usize;
        let size = r.read(SIZE_BITS)? as usize;
        if size > MAX_INPUT_BYTES {
            return Err(InputError::PayloadTooLong {
                size,
                max: MAX_INPUT_BYTES,
            });
        }
        if count == 0 && size != 0 {
            return Err(InputError::NotCanonical {
                what: "a payload size without inputs",
            });
        }
        let mut inputs: Vec<PlayerInput> = Vec::with_capacity(count);
        for _ in 0..count {
            let (sequence, tick, payload) = match inputs.last() {
                None => {
                    let sequence = r.read(32)? as u32;
                    let tick = read_varint(&mut r, 64)?;
                    (sequence, tick, read_payload(&mut r, size)?)
                }
                Some(p) => {
                    let sequence = if r.read_bool()? {
                        p.sequence.wrapping_sub(1)
                    } else {
                        // The long form covers steps 2 to u32::MAX.
                        let step = read_varint(&mut r, 32)?;
                        let step = u32::try_from(step)
                            .ok()
                            .and_then(|s| s.checked_add(2))
                            .ok_or(InputError::NotCanonical {
                                what: "sequence step too large",
                            })?;
                        p.sequence.wrapping_sub(step)
                    };
                    let tick = if r.read_bool()? {
                        p.tick.wrapping_sub(1)
                    } else {
                        let step = unzigzag(read_varint(&mut r, 64)?);
                        if step == -1 {
                            return Err(InputError::NotCanonical {
                                what: "tick step of -1 in the long form",
                            });
                        }
                        p.tick.wrapping_add(step as u64)
                    };
                    let payload = if r.read_bool()? {
                        p.payload
                    } else {
                        let own = read_payload(&mut r, size)?;
                        if own == p.payload {
                            return Err(InputError::NotCanonical {
                                what: "a repeated payload spelled out",
                            });
                        }
                        own
                    };
                    (sequence, tick, payload)
                }
            };
            let view_behind = view_value(read_varint(&mut r, VIEW_VALUE_BITS)?);
            inputs.push(PlayerInput {
                sequence,
                tick,
                payload,
                view_behind,
            });
        }
        let left = r.bits_left();
        if left >= 8 {
            return Err(InputError::NotCanonical {
                what: "trailing bytes",
            });
        }
        if left > 0 && r.read(left as u32)? != 0 {
            return Err(InputError::NotCanonical {
                what: "nonzero padding",
            });
        }
        Ok(Self {
            ack,
            ack_bits,
            inputs,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5-byte payload that changes every fourth sequence.
    fn payload(sequence: u32) -> InputPayload {
        let k = (sequence / 4) as u8;
        InputPayload::new(&[0x80, 0x7f, k, 0x10, 0x01]).unwrap()
    }

    fn input(sequence: u32, tick: u64) -> PlayerInput {
        PlayerInput {
            sequence,
            tick,
            payload: payload(sequence),
            view_behind: 9.5,
        }
    }

    fn datagram(newest: u32, n: u32) -> InputDatagram {
        InputDatagram {
            ack: Some(9),
            ack_bits: 0b101,
            inputs: (0..n)
                .map(|k| input(newest.wrapping_sub(k), u64::from(5000 - k)))
                .collect(),
        }
    }

    #[test]
    fn datagrams_round_trip_and_stay_small() {
        let d = datagram(u32::MAX - 2, 8);
        let bytes = d.encode().unwrap();
        assert_eq!(bytes[0], INPUT_DATAGRAM_TAG);
        let expected = InputDatagram {
            inputs: d.inputs.iter().map(quantize_input).collect(),
            ..d.clone()
        };
        assert_eq!(InputDatagram::decode(&bytes).unwrap(), expected);
        // Tag, acks, count, size, a full newest input, seven short ones
        // of which the payload changes in two (sequences u32::MAX - 2 down
        // to u32::MAX - 9 cross two multiples of 4); each input's view
        // (9.5 ticks: 152 steps) in two varint groups.
        let changes: usize = d
            .inputs
            .windows(2)
            .filter(|w| w[0].payload != w[1].payload)
            .count();
        assert_eq!(changes, 2);
        assert_eq!(
            bytes.len(),
            (8 + 49 + 4 + 7 + 32 + 16 + 40 + 16 + 7 * (3 + 16usize) + changes * 40).div_ceil(8)
        );
        assert!(bytes.len() <= MAX_INPUT_DATAGRAM_BYTES);
    }

    #[test]
    fn payloads_travel_as_they_are_and_repeats_cost_a_bit() {
        let same = |n: u32| InputDatagram {
            ack: None,
            ack_bits: 0,
            inputs: (0..n)
                .map(|k| PlayerInput {
                    payload: payload(0),
                    ..input(100 - k, u64::from(100 - k))
                })
                .collect(),
        };
        let one = same(1).encode().unwrap().len();
        let eight = same(8).encode().unwrap().len();
        // Each repeat: two step bits, the same-payload bit, a one-group
        // view of 9.5 ticks (16 bits).
        assert!(eight * 8 - one * 8 <= 7 * 19 + 7, "{one} {eight}");
        for d in [same(8), datagram(77, 8)] {
            let bytes = d.encode().unwrap();
            let back = InputDatagram::decode(&bytes).unwrap();
            assert_eq!(
                back.inputs.iter().map(|i| i.payload).collect::<Vec<_>>(),
                d.inputs.iter().map(|i| i.payload).collect::<Vec<_>>()
            );
            assert_eq!(back.encode().unwrap(), bytes, "canonical");
        }
        // A game without input bytes sends none.
        let empty = InputDatagram {
            ack: None,
            ack_bits: 0,
            inputs: vec![PlayerInput {
                payload: InputPayload::EMPTY,
                ..input(1, 1)
            }],
        };
        let back = InputDatagram::decode(&empty.encode().unwrap()).unwrap();
        assert!(back.inputs[0].payload.is_empty());
        // The largest payloads fit the bound.
        let big = InputDatagram {
            ack: Some(1),
            ack_bits: u32::MAX,
            inputs: (0..MAX_REDUNDANT_INPUTS as u32)
                .map(|k| PlayerInput {
                    payload: InputPayload::new(&[k as u8; MAX_INPUT_BYTES]).unwrap(),
                    ..input(u32::MAX - k, u64::MAX - u64::from(k) * 1000)
                })
                .collect(),
        };
        let bytes = big.encode().unwrap();
        assert!(bytes.len() <= MAX_INPUT_DATAGRAM_BYTES, "{}", bytes.len());
        assert_eq!(
            InputDatagram::decode(&bytes).unwrap().inputs.len(),
            MAX_REDUNDANT_INPUTS
        );
    }

    #[test]
    fn view_offsets_travel_in_sixteenths_within_the_cap() {
        let with = |view_behind| PlayerInput {
            view_behind,
            ..input(1, 1000)
        };
        let trip = |view_behind| {
            let d = InputDatagram {
                ack: None,
                ack_bits: 0,
                inputs: vec![with(view_behind)],
            };
            let bytes = d.encode().unwrap();
            let back = InputDatagram::decode(&bytes).unwrap();
            assert_eq!(back.encode().unwrap(), bytes, "canonical");
            assert_eq!(back.inputs[0], quantize_input(&with(view_behind)));
            back.inputs[0].view_behind
        };
        assert_eq!(trip(0.0), 0.0);
        assert_eq!(trip(7.9375), 7.9375);
        assert_eq!(trip(6.03), 6.0);
        assert_eq!(trip(6.04), 6.0625);
        // Not finite or ahead of the tick: no rewind; too far: the cap.
        assert_eq!(trip(f32::NAN), 0.0);
        assert_eq!(trip(-3.0), 0.0);
        assert_eq!(trip(f32::NEG_INFINITY), 0.0);
        assert_eq!(trip(1e9), MAX_VIEW_BEHIND);
        assert_eq!(trip(f32::INFINITY), MAX_VIEW_BEHIND);
        assert_eq!(with(2.5).view_tick(), 997.5);
        // A view varint past the cap is refused: 4096 steps.
        let mut w = BitWriter::new();
        w.write(u64::from(INPUT_DATAGRAM_TAG), 8);
        w.write_bool(false);
        w.write(1, 4);
        w.write(1, 32);
        w.write(5, SIZE_BITS);
        write_varint(&mut w, 1000);
        write_payload(&mut w, &payload(1));
        write_varint(&mut w, 4096);
        assert!(matches!(
            InputDatagram::decode(&w.finish()),
            Err(InputError::NotCanonical { .. })
        ));
        // Stores pack only what is already quantized.
        assert_eq!(pack_view_behind(&with(2.5)), Some(40));
        assert_eq!(pack_view_behind(&with(2.51)), None);
        assert_eq!(pack_view_behind(&with(-0.0)), None);
        assert_eq!(unpack_view_behind(40), Ok(2.5));
        assert!(unpack_view_behind(4096).is_err());
    }

    #[test]
    fn odd_steps_round_trip() {
        let d = InputDatagram {
            ack: None,
            ack_bits: 0,
            inputs: vec![input(5, 0), input(2, u64::MAX), input(u32::MAX - 100, 7)],
        };
        let back = InputDatagram::decode(&d.encode().unwrap()).unwrap();
        let seqs: Vec<_> = back.inputs.iter().map(|i| (i.sequence, i.tick)).collect();
        assert_eq!(seqs, vec![(5, 0), (2, u64::MAX), (u32::MAX - 100, 7)]);
    }

    #[test]
    fn bad_datagrams_are_typed_errors() {
        let bytes = datagram(10, 2).encode().unwrap();
        let mut b = bytes.clone();
        b[0] = 0x53;
        assert_eq!(
            InputDatagram::decode(&b),
            Err(InputError::UnknownTag { tag: 0x53 })
        );
        let mut b = bytes.clone();
        b.push(0);
        assert!(matches!(
            InputDatagram::decode(&b),
            Err(InputError::NotCanonical { .. })
        ));
        for cut in 0..bytes.len() {
            assert!(InputDatagram::decode(&bytes[..cut]).is_err());
        }
        let mut d = datagram(10, 2);
        d.inputs[1].payload = InputPayload::new(&[1]).unwrap();
        assert_eq!(
            d.encode(),
            Err(InputError::MixedPayloadSizes {
                index: 1,
                len: 1,
                size: 5
            })
        );
        // A size past the bound, and a repeat spelled out.
        let mut w = BitWriter::new();
        w.write(u64::from(INPUT_DATAGRAM_TAG), 8);
        w.write_bool(false);
        w.write(1, 4);
        w.write(65, SIZE_BITS);
        assert_eq!(
            InputDatagram::decode(&w.finish()),
            Err(InputError::PayloadTooLong { size: 65, max: 64 })
        );
        let mut w = BitWriter::new();
        w.write(u64::from(INPUT_DATAGRAM_TAG), 8);
        w.write_bool(false);
        w.write(2, 4);
        w.write(1, SIZE_BITS);
        w.write(9, 32);
        write_varint(&mut w, 50);
        w.write(0xab, 8);
        write_varint(&mut w, 0);
        w.write_bool(true);
        w.write_bool(true);
        w.write_bool(false);
        w.write(0xab, 8);
        write_varint(&mut w, 0);
        assert_eq!(
            InputDatagram::decode(&w.finish()),
            Err(InputError::NotCanonical {
                what: "a repeated payload spelled out"
            })
        );
        let mut d = datagram(10, 2);
        d.inputs[1].sequence = 10;
        assert_eq!(d.encode(), Err(InputError::RepeatedSequence { index: 1 }));
        assert!(matches!(
            datagram(10, 9).encode(),
            Err(InputError::TooManyInputs { count: 9, .. })
        ));
        let d = InputDatagram {
            ack: None,
            ack_bits: 1,
            inputs: vec![],
        };
        assert_eq!(d.encode(), Err(InputError::AckBitsWithoutAck));
    }

    #[test]
    fn buffer_yields_each_sequence_once_in_order() {
        let mut b = InputBuffer::new(32);
        let mut out = Vec::new();
        // Datagrams for sequences 100..=130, each carrying the last 8;
        // some lost, some duplicated, some reordered.
        let mut sends: Vec<InputDatagram> = (100..=130)
            .filter(|s| s % 5 != 0)
            .map(|s| datagram(s, 8))
            .collect();
        sends.swap(3, 4);
        let dup = sends[7].clone();
        sends.insert(9, dup);
        for (i, d) in sends.iter().enumerate() {
            b.push_datagram(d);
            if i % 2 == 0 {
                out.extend(b.pop());
            }
        }
        while let Some(i) = b.pop() {
            out.push(i);
        }
        let seqs: Vec<u32> = out.iter().map(|i| i.sequence).collect();
        assert_eq!(seqs, (94..=129).collect::<Vec<_>>());
        assert_eq!(b.stats().skipped, 0);
        assert!(b.stats().duplicates > 0);
    }

    #[test]
    fn buffer_drops_old_skips_gaps_and_stays_bounded() {
        let mut b = InputBuffer::new(4);
        b.push(input(10, 0));
        assert_eq!(b.pop().map(|i| i.sequence), Some(10));
        b.push(input(9, 0));
        b.push(input(10, 0));
        assert_eq!(b.stats().too_old, 2);
        for s in [14, 13, 12, 15, 16] {
            b.push(input(s, 0));
        }
        assert_eq!(b.len(), 4);
        assert_eq!(b.stats().overflowed, 1);
        // An older input evicts the newest waiting one.
        b.push(input(11, 0));
        assert_eq!(b.stats().overflowed, 2);
        let seqs: Vec<u32> = std::iter::from_fn(|| b.pop()).map(|i| i.sequence).collect();
        assert_eq!(seqs, vec![11, 12, 13, 14]);
        assert_eq!(b.next_sequence(), Some(15));
        b.push(input(15 + INPUT_WINDOW, 0));
        assert_eq!(b.stats().too_far, 1);
        assert!(b.is_empty());
    }

    #[test]
    fn buffer_follows_the_sequence_through_wraparound() {
        let mut b = InputBuffer::new(16);
        let mut seqs = Vec::new();
        for s in 0..20u32 {
            b.push_datagram(&datagram((u32::MAX - 10).wrapping_add(s), 3));
            seqs.extend(b.pop().map(|i| i.sequence));
        }
        let expected: Vec<u32> = (0..20u32)
            .map(|k| (u32::MAX - 12).wrapping_add(k))
            .collect();
        assert_eq!(seqs, expected);
    }
}
