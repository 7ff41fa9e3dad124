//! The byte codec under Inertia's byte-level binary formats: a
//! [`ByteReader`] that takes fields off the front of untrusted bytes, a
//! [`ByteWriter`] that appends them, LEB128 [varints](#varints) and
//! [`zigzag()`] for signed values, and one error, [`CodecError`].
//!
//! Every integer and float is little-endian, floats by their bit pattern
//! (a NaN's payload comes back as it went). No format in the workspace is
//! big-endian, so there are no big-endian reads.
//!
//! What uses it:
//!
//! - the engine's saved world state (`inertia_physics::snapshot`);
//! - connect tokens (`inertia_protocol::token`);
//! - recordings' record payloads, the journal, saved simulation states and
//!   the lag-compensation pose window (`inertia_server`).
//!
//! The one zigzag also serves the input datagram's bit-packed varints
//! (`inertia_protocol::input`), whose varint is bit-level and canonical,
//! a different code from the byte-level one here.
//!
//! A reader never panics on short or hostile input: every read checks what
//! is left and says [`CodecError::Truncated`] with where and how much, and
//! a failed read consumes nothing. What a field means, its bounds and the
//! format's own errors stay with the format; each maps [`CodecError`] into
//! its own error type.
//!
//! ```
//! use inertia_codec::{zigzag, unzigzag, ByteReader, ByteWriter, CodecError};
//!
//! let mut bytes = Vec::new();
//! let mut w = ByteWriter::new(&mut bytes);
//! w.u32(7);
//! w.varint(zigzag(-3));
//! assert_eq!(bytes, [7, 0, 0, 0, 5]);
//!
//! let mut r = ByteReader::new(&bytes);
//! assert_eq!(r.u32(), Ok(7));
//! assert_eq!(r.varint().map(unzigzag), Ok(-3));
//! assert!(r.is_empty());
//! assert_eq!(
//!     r.u64(),
//!     Err(CodecError::Truncated { at: 5, needed: 8, remaining: 0 })
//! );
//! ```
//!
//! ## Varints
//!
//! LEB128: an unsigned 64-bit value in groups of 7 bits, least significant
//! first, each in a byte whose high bit says whether another follows. A
//! value below 128 takes one byte, `u64::MAX` ten ([`MAX_VARINT_BYTES`]).
//! [`write_varint`] always writes the minimal form. [`ByteReader::varint`]
//! refuses what cannot be a `u64` — a tenth byte with value bits past the
//! 64th ([`CodecError::VarintOverflow`]) or one that says more follow
//! ([`CodecError::VarintTooLong`]) — and accepts non-minimal forms (`80 00`
//! reads as 0), as the journal, the first format to use this code, always
//! has. A format that must be canonical checks the length it read.
//!
//! A signed value goes through [`zigzag()`] first, so that a small negative
//! number takes a short varint.

mod error;
mod reader;
mod varint;
mod writer;
mod zigzag;

pub use error::CodecError;
pub use reader::ByteReader;
pub use varint::{write_varint, MAX_VARINT_BYTES};
pub use writer::ByteWriter;
pub use zigzag::{unzigzag, zigzag};
