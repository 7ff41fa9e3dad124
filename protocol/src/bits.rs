//! Our own bit packer: values of any width from 1 to 64 bits, written
//! back to back with no padding, least significant bit first.
//!
//! Snapshots spend their bits where they matter (a changed-flag is one
//! bit, a quantized coordinate as many as its range needs), so the packer
//! works at bit granularity. The reader takes untrusted bytes: every read
//! past the end, every count above its stated bound and every value outside
//! its stated range is a typed [`BitError`], never a panic, and nothing is
//! ever allocated from a length the bytes claim.

use thiserror::Error;

/// Why a read failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum BitError {
    /// The bytes ended before the value did.
    #[error("read past the end: wanted {wanted} bits, {left} left")]
    Truncated {
        /// Bits the read needed.
        wanted: u32,
        /// Bits that were left.
        left: usize,
    },
    /// A count or length above the bound the caller allows.
    #[error("{what}: {value} is above the limit {max}")]
    TooLarge {
        /// What was being read.
        what: &'static str,
        /// The value read.
        value: u64,
        /// The largest value allowed.
        max: u64,
    },
}

/// Packs values of 1 to 64 bits into 64-bit words, least significant bit
/// first: what [`BitWriter`] writes as bytes, and what a recorded
/// snapshot delta keeps as words.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct WordPacker {
    /// Bits not yet handed out as a word, least significant first.
    scratch: u128,
    /// How many bits `scratch` holds (< 64 between calls).
    pending: u32,
}

impl WordPacker {
    /// Adds the low `bits` bits of `value` (1 to 64; higher bits are
    /// ignored); a word when one is full.
    #[inline]
    pub(crate) fn put(&mut self, value: u64, bits: u32) -> Option<u64> {
        let masked = if bits >= 64 {
            value
        } else {
            value & ((1u64 << bits) - 1)
        };
        self.scratch |= u128::from(masked) << self.pending;
        self.pending += bits;
        (self.pending >= 64).then(|| {
            let word = self.scratch as u64;
            self.scratch >>= 64;
            self.pending -= 64;
            word
        })
    }

    /// The bits of a partial word still held (fewer than 64), and how many.
    pub(crate) fn rest(&self) -> (u64, u32) {
        (self.scratch as u64, self.pending)
    }
}

/// Writes values bit by bit into a growing byte buffer.
#[derive(Debug, Default, Clone)]
pub struct BitWriter {
    bytes: Vec<u8>,
    /// Bits not yet flushed to `bytes` (eight bytes at a time).
    packer: WordPacker,
}

impl BitWriter {
    /// An empty writer.
    pub fn new() -> Self {
        Self::default()
    }

    /// A writer whose buffer has room for `bytes` bytes before it grows.
    pub fn with_capacity(bytes: usize) -> Self {
        Self {
            bytes: Vec::with_capacity(bytes),
            ..Self::default()
        }
    }

    /// Writes the low `bits` bits of `value` (1 to 64; higher bits of
    /// `value` are ignored).
    ///
    /// # Panics
    /// If `bits` is 0 or above 64: a bug in the caller, not bad input.
    pub fn write(&mut self, value: u64, bits: u32) {
        assert!((1..=64).contains(&bits), "bit width {bits} outside 1..=64");
        if let Some(word) = self.packer.put(value, bits) {
            self.bytes.extend_from_slice(&word.to_le_bytes());
        }
    }

    /// Writes one bit.
    pub fn write_bool(&mut self, value: bool) {
        self.write(u64::from(value), 1);
    }

    /// Writes a signed value in `bits` bits, two's complement (it must fit:
    /// `-2^(bits-1) <= value < 2^(bits-1)`; callers clamp first).
    pub fn write_signed(&mut self, value: i64, bits: u32) {
        self.write(value as u64, bits);
    }

    /// Bits written so far.
    pub fn bit_len(&self) -> usize {
        self.bytes.len() * 8 + self.packer.rest().1 as usize
    }

    /// The bytes, the last one padded with zero bits.
    pub fn finish(mut self) -> Vec<u8> {
        let (word, bits) = self.packer.rest();
        let tail = bits.div_ceil(8) as usize;
        self.bytes.extend_from_slice(&word.to_le_bytes()[..tail]);
        self.bytes
    }
}

/// Reads values written by [`BitWriter`] from untrusted bytes.
#[derive(Debug, Clone)]
pub struct BitReader<'a> {
    bytes: &'a [u8],
    /// Position in bits.
    at: usize,
}

impl<'a> BitReader<'a> {
    /// A reader at the start of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }

    /// Bits left to read (including the padding of the last byte).
    pub fn bits_left(&self) -> usize {
        self.bytes.len() * 8 - self.at
    }

    /// Reads `bits` bits (1 to 64) as an unsigned value.
    ///
    /// # Panics
    /// If `bits` is 0 or above 64: a bug in the caller, not bad input.
    pub fn read(&mut self, bits: u32) -> Result<u64, BitError> {
        assert!((1..=64).contains(&bits), "bit width {bits} outside 1..=64");
        let left = self.bits_left();
        if (bits as usize) > left {
            return Err(BitError::Truncated { wanted: bits, left });
        }
        let mut value = 0u64;
        let mut got = 0u32;
        while got < bits {
            let byte = self.bytes[self.at / 8];
            let offset = (self.at % 8) as u32;
            let take = (8 - offset).min(bits - got);
            let part = (u64::from(byte) >> offset) & ((1u64 << take) - 1);
            value |= part << got;
            got += take;
            self.at += take as usize;
        }
        Ok(value)
    }

    /// Reads one bit.
    pub fn read_bool(&mut self) -> Result<bool, BitError> {
        Ok(self.read(1)? == 1)
    }

    /// Reads a two's-complement value of `bits` bits.
    pub fn read_signed(&mut self, bits: u32) -> Result<i64, BitError> {
        let raw = self.read(bits)?;
        if bits == 64 {
            return Ok(raw as i64);
        }
        let sign = 1u64 << (bits - 1);
        Ok(((raw ^ sign).wrapping_sub(sign)) as i64)
    }

    /// Reads a count of `bits` bits and refuses it above `max` (so a
    /// decoder never sizes anything from an unchecked number).
    pub fn read_count(&mut self, bits: u32, max: u64, what: &'static str) -> Result<u64, BitError> {
        let value = self.read(bits)?;
        if value > max {
            return Err(BitError::TooLarge { what, value, max });
        }
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn next(state: &mut crate::rng::SplitMix) -> u64 {
        state.next_u64()
    }

    #[test]
    fn random_widths_round_trip() {
        let mut s = crate::rng::SplitMix(1);
        for _ in 0..200 {
            let n = (next(&mut s) % 100) as usize;
            let values: Vec<(u64, u32)> = (0..n)
                .map(|_| {
                    let bits = (next(&mut s) % 64) as u32 + 1;
                    let v = next(&mut s);
                    let v = if bits == 64 { v } else { v & ((1 << bits) - 1) };
                    (v, bits)
                })
                .collect();
            let mut w = BitWriter::new();
            for &(v, bits) in &values {
                w.write(v, bits);
            }
            let total: usize = values.iter().map(|&(_, b)| b as usize).sum();
            assert_eq!(w.bit_len(), total);
            let bytes = w.finish();
            assert_eq!(bytes.len(), total.div_ceil(8));
            let mut r = BitReader::new(&bytes);
            for &(v, bits) in &values {
                assert_eq!(r.read(bits).unwrap(), v);
            }
            assert!(r.bits_left() < 8);
        }
    }

    #[test]
    fn signed_values_round_trip_at_their_extremes() {
        let mut w = BitWriter::new();
        let cases = [
            (-1i64, 1u32),
            (0, 1),
            (-128, 8),
            (127, 8),
            (-3, 3),
            (i64::MIN, 64),
            (i64::MAX, 64),
        ];
        for &(v, bits) in &cases {
            w.write_signed(v, bits);
        }
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        for &(v, bits) in &cases {
            assert_eq!(r.read_signed(bits).unwrap(), v, "{v} in {bits} bits");
        }
    }

    #[test]
    fn every_truncation_is_a_typed_error() {
        let mut w = BitWriter::new();
        for k in 0..20u64 {
            w.write(k * 977, 17);
        }
        let bytes = w.finish();
        for cut in 0..bytes.len() {
            let mut r = BitReader::new(&bytes[..cut]);
            let mut failed = false;
            for _ in 0..20 {
                match r.read(17) {
                    Ok(_) => {}
                    Err(BitError::Truncated { wanted: 17, .. }) => {
                        failed = true;
                        break;
                    }
                    Err(e) => panic!("unexpected {e}"),
                }
            }
            assert!(failed, "cut at {cut} bytes read 20 values");
        }
    }

    #[test]
    fn counts_above_their_bound_are_refused() {
        let mut w = BitWriter::new();
        w.write(1000, 16);
        let bytes = w.finish();
        let err = BitReader::new(&bytes)
            .read_count(16, 999, "entities")
            .unwrap_err();
        assert_eq!(
            err,
            BitError::TooLarge {
                what: "entities",
                value: 1000,
                max: 999
            }
        );
        assert_eq!(
            BitReader::new(&bytes).read_count(16, 1000, "entities"),
            Ok(1000)
        );
    }
}
