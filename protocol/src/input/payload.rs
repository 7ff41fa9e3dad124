//! What a game puts in an input: its own bytes, of a size it declares.
//!
//! The protocol carries an input's sequence, its tick and the view its
//! player saw; everything the player wants (a stick, a yaw and a pitch, a
//! throttle, a weapon, buttons) is the game's, as an [`InputPayload`] of
//! at most [`MAX_INPUT_BYTES`]. A game declares its input as a type that
//! implements [`GameInput`]: the same type in its rules and in its
//! clients, with an encoding of exactly [`GameInput::BYTES`] bytes that
//! the game controls. Its decoder is the validation the rules run before
//! any field is read: bytes it refuses are refused inputs.

use std::borrow::Cow;
use std::fmt;

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use thiserror::Error;

/// The most bytes one input's payload may hold.
pub const MAX_INPUT_BYTES: usize = 64;

/// One input's game-defined bytes (at most [`MAX_INPUT_BYTES`]), inline:
/// an input stays a small `Copy` value.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct InputPayload {
    len: u8,
    bytes: [u8; MAX_INPUT_BYTES],
}

/// A payload longer than [`MAX_INPUT_BYTES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("an input payload of {len} bytes, the most is {max}")]
pub struct PayloadTooLong {
    /// Its length, bytes.
    pub len: usize,
    /// The bound, bytes.
    pub max: usize,
}

impl InputPayload {
    /// No bytes: the input of a game that has none (and every payload's
    /// default).
    pub const EMPTY: InputPayload = InputPayload {
        len: 0,
        bytes: [0; MAX_INPUT_BYTES],
    };

    /// A payload of `bytes`; refused past [`MAX_INPUT_BYTES`].
    pub fn new(bytes: &[u8]) -> Result<Self, PayloadTooLong> {
        if bytes.len() > MAX_INPUT_BYTES {
            return Err(PayloadTooLong {
                len: bytes.len(),
                max: MAX_INPUT_BYTES,
            });
        }
        let mut out = Self::EMPTY;
        out.bytes[..bytes.len()].copy_from_slice(bytes);
        out.len = bytes.len() as u8;
        Ok(out)
    }

    /// Its bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// Its length, bytes.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether it holds no bytes.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl Default for InputPayload {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl fmt::Debug for InputPayload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("InputPayload(")?;
        for b in self.as_bytes() {
            write!(f, "{b:02x}")?;
        }
        f.write_str(")")
    }
}

impl Serialize for InputPayload {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.as_bytes())
    }
}

impl<'de> Deserialize<'de> for InputPayload {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Bytes;
        impl serde::de::Visitor<'_> for Bytes {
            type Value = InputPayload;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "at most {MAX_INPUT_BYTES} bytes")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<InputPayload, E> {
                InputPayload::new(v).map_err(E::custom)
            }
        }
        d.deserialize_bytes(Bytes)
    }
}

/// Why a game's input could not be read from its bytes (the input is then
/// refused, and changes nothing).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum InputDecodeError {
    /// The payload is not the game's input size.
    #[error("an input of {len} bytes, this game's inputs are {expected}")]
    WrongSize {
        /// The payload's length, bytes.
        len: usize,
        /// [`GameInput::BYTES`].
        expected: usize,
    },
    /// The game's decoder refused the bytes, saying why.
    #[error("input refused: {0}")]
    Invalid(Cow<'static, str>),
}

/// A game's input: what one player wants for one tick, shared by the
/// game's rules (which decode it) and its clients (which encode it).
///
/// Encoded in exactly [`GameInput::BYTES`] bytes (at most
/// [`MAX_INPUT_BYTES`]); [`GameInput::decode`] takes untrusted bytes and
/// refuses anything [`GameInput::encode`] would not write, so that what
/// the rules read is always a value the game defines. The SDK predicts
/// with it and the server journals its bytes, so a replay reads exactly
/// what the rules read.
pub trait GameInput: Sized {
    /// Bytes of the encoding, 0 to [`MAX_INPUT_BYTES`].
    const BYTES: usize;

    /// Writes the input into `out`, exactly [`GameInput::BYTES`] long.
    fn encode(&self, out: &mut [u8]);

    /// Reads an input from `bytes`, exactly [`GameInput::BYTES`] long,
    /// refusing any the game does not define.
    fn decode(bytes: &[u8]) -> Result<Self, InputDecodeError>;

    /// The input as a payload.
    fn to_payload(&self) -> InputPayload {
        const {
            assert!(
                Self::BYTES <= MAX_INPUT_BYTES,
                "GameInput::BYTES past MAX_INPUT_BYTES"
            )
        };
        let mut out = InputPayload {
            len: Self::BYTES as u8,
            bytes: [0; MAX_INPUT_BYTES],
        };
        self.encode(&mut out.bytes[..Self::BYTES]);
        out
    }

    /// The input a payload holds; refused when it is not
    /// [`GameInput::BYTES`] long or the game's decoder refuses it.
    fn from_payload(payload: &InputPayload) -> Result<Self, InputDecodeError> {
        if payload.len() != Self::BYTES {
            return Err(InputDecodeError::WrongSize {
                len: payload.len(),
                expected: Self::BYTES,
            });
        }
        Self::decode(payload.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq)]
    struct Throttle(u8);

    impl GameInput for Throttle {
        const BYTES: usize = 1;
        fn encode(&self, out: &mut [u8]) {
            out[0] = self.0;
        }
        fn decode(bytes: &[u8]) -> Result<Self, InputDecodeError> {
            match bytes[0] {
                b @ 0..=100 => Ok(Throttle(b)),
                _ => Err(InputDecodeError::Invalid("throttle past 100 %".into())),
            }
        }
    }

    #[test]
    fn payloads_are_bounded_and_round_trip() {
        assert_eq!(
            InputPayload::new(&[0; MAX_INPUT_BYTES + 1]),
            Err(PayloadTooLong {
                len: MAX_INPUT_BYTES + 1,
                max: MAX_INPUT_BYTES
            })
        );
        let p = InputPayload::new(&[1, 2, 3]).unwrap();
        assert_eq!(p.as_bytes(), &[1, 2, 3]);
        assert_eq!(format!("{p:?}"), "InputPayload(010203)");
        let bytes = postcard::to_allocvec(&p).unwrap();
        assert_eq!(postcard::from_bytes::<InputPayload>(&bytes).unwrap(), p);
        assert!(postcard::from_bytes::<InputPayload>(
            &postcard::to_allocvec(&vec![0u8; 65]).unwrap()
        )
        .is_err());
    }

    #[test]
    fn a_game_input_travels_as_its_bytes_and_is_refused_when_wrong() {
        let p = Throttle(42).to_payload();
        assert_eq!(p.as_bytes(), &[42]);
        assert_eq!(Throttle::from_payload(&p), Ok(Throttle(42)));
        assert_eq!(
            Throttle::from_payload(&InputPayload::new(&[1, 2]).unwrap()),
            Err(InputDecodeError::WrongSize {
                len: 2,
                expected: 1
            })
        );
        assert!(matches!(
            Throttle::from_payload(&InputPayload::new(&[200]).unwrap()),
            Err(InputDecodeError::Invalid(_))
        ));
    }
}
