//! [`ByteReader`]: fields off the front of untrusted bytes.

use crate::varint::read_varint;
use crate::CodecError;

/// Reads little-endian fields off the front of a byte slice, in order.
///
/// Every read checks the bytes left first: a read past the end is
/// [`CodecError::Truncated`] and consumes nothing, so the reader's
/// [`position`](Self::position) is still where the field starts.
#[derive(Debug, Clone)]
pub struct ByteReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> ByteReader<'a> {
    /// A reader at the start of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }

    /// Bytes read so far: the offset of the next field.
    pub fn position(&self) -> usize {
        self.at
    }

    /// Bytes left to read.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }

    /// Whether every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.remaining() == 0
    }

    /// The next `n` bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], CodecError> {
        let remaining = self.remaining();
        if n > remaining {
            return Err(CodecError::Truncated {
                at: self.at,
                needed: n,
                remaining,
            });
        }
        let field = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(field)
    }

    /// Every byte left (perhaps none).
    pub fn rest(&mut self) -> &'a [u8] {
        let rest = &self.bytes[self.at..];
        self.at = self.bytes.len();
        rest
    }

    /// The next `N` bytes, as an array.
    pub fn array<const N: usize>(&mut self) -> Result<[u8; N], CodecError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.bytes(N)?);
        Ok(out)
    }

    /// One byte.
    pub fn u8(&mut self) -> Result<u8, CodecError> {
        Ok(self.bytes(1)?[0])
    }

    /// A little-endian `u16` (2 bytes).
    pub fn u16(&mut self) -> Result<u16, CodecError> {
        self.array().map(u16::from_le_bytes)
    }

    /// A little-endian `u32` (4 bytes).
    pub fn u32(&mut self) -> Result<u32, CodecError> {
        self.array().map(u32::from_le_bytes)
    }

    /// A little-endian `u64` (8 bytes).
    pub fn u64(&mut self) -> Result<u64, CodecError> {
        self.array().map(u64::from_le_bytes)
    }

    /// A little-endian two's-complement `i64` (8 bytes).
    pub fn i64(&mut self) -> Result<i64, CodecError> {
        self.array().map(i64::from_le_bytes)
    }

    /// An `f32` from its little-endian bit pattern (4 bytes), NaN payloads
    /// and all; whether it may be NaN or infinite is the format's to say.
    pub fn f32(&mut self) -> Result<f32, CodecError> {
        self.u32().map(f32::from_bits)
    }

    /// An `f64` from its little-endian bit pattern (8 bytes), NaN payloads
    /// and all; whether it may be NaN or infinite is the format's to say.
    pub fn f64(&mut self) -> Result<f64, CodecError> {
        self.u64().map(f64::from_bits)
    }

    /// A [varint](crate#varints), 1 to 10 bytes; non-minimal forms are
    /// read, values past 64 bits refused.
    pub fn varint(&mut self) -> Result<u64, CodecError> {
        let (value, len) = read_varint(&self.bytes[self.at..], self.at)?;
        self.at += len;
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ByteWriter;

    /// One of every field, written by the writer.
    fn sample() -> Vec<u8> {
        let mut out = Vec::new();
        let mut w = ByteWriter::new(&mut out);
        w.u8(0xAB);
        w.u16(0xBEEF);
        w.u32(0xDEAD_BEEF);
        w.u64(u64::MAX - 1);
        w.i64(i64::MIN);
        w.f32(f32::from_bits(0x7FC0_0001));
        w.f64(f64::from_bits(0xFFF8_0000_0000_0042));
        w.varint(300);
        w.bytes(b"abc");
        out
    }

    fn read_sample(r: &mut ByteReader<'_>) -> Result<(), CodecError> {
        assert_eq!(r.u8()?, 0xAB);
        assert_eq!(r.u16()?, 0xBEEF);
        assert_eq!(r.u32()?, 0xDEAD_BEEF);
        assert_eq!(r.u64()?, u64::MAX - 1);
        assert_eq!(r.i64()?, i64::MIN);
        assert_eq!(r.f32()?.to_bits(), 0x7FC0_0001);
        assert_eq!(r.f64()?.to_bits(), 0xFFF8_0000_0000_0042);
        assert_eq!(r.varint()?, 300);
        assert_eq!(r.array::<3>()?, *b"abc");
        Ok(())
    }

    #[test]
    fn every_field_round_trips_little_endian() {
        let bytes = sample();
        assert_eq!(bytes[..3], [0xAB, 0xEF, 0xBE]);
        assert_eq!(bytes[3..7], [0xEF, 0xBE, 0xAD, 0xDE]);
        assert_eq!(bytes.len(), 1 + 2 + 4 + 8 + 8 + 4 + 8 + 2 + 3);
        let mut r = ByteReader::new(&bytes);
        read_sample(&mut r).unwrap();
        assert!(r.is_empty());
        assert_eq!(r.position(), bytes.len());
    }

    #[test]
    fn every_cut_is_truncated_where_the_field_starts() {
        let bytes = sample();
        for cut in 0..bytes.len() {
            let mut r = ByteReader::new(&bytes[..cut]);
            let Err(CodecError::Truncated {
                at,
                needed,
                remaining,
            }) = read_sample(&mut r)
            else {
                panic!("cut at {cut} read in full");
            };
            assert_eq!(
                at,
                r.position(),
                "cut at {cut}: a failed read consumed bytes"
            );
            assert_eq!(at + remaining, cut, "cut at {cut}");
            assert!(needed > remaining, "cut at {cut}");
        }
    }

    #[test]
    fn positions_and_what_is_left() {
        let bytes = [1, 2, 3, 4, 5];
        let mut r = ByteReader::new(&bytes);
        assert_eq!((r.position(), r.remaining(), r.is_empty()), (0, 5, false));
        assert_eq!(r.bytes(2).unwrap(), [1, 2]);
        assert_eq!((r.position(), r.remaining()), (2, 3));
        assert_eq!(
            r.bytes(4),
            Err(CodecError::Truncated {
                at: 2,
                needed: 4,
                remaining: 3
            })
        );
        assert!(r.bytes(usize::MAX).is_err());
        assert_eq!(r.bytes(0).unwrap(), []);
        assert_eq!(r.rest(), [3, 4, 5]);
        assert!(r.is_empty());
        assert_eq!(r.rest(), []);
        assert_eq!(
            r.u8(),
            Err(CodecError::Truncated {
                at: 5,
                needed: 1,
                remaining: 0
            })
        );
    }

    #[test]
    fn a_bad_varint_consumes_nothing() {
        let mut bytes = vec![7];
        bytes.extend_from_slice(&[0xFF; 11]);
        let mut r = ByteReader::new(&bytes);
        assert_eq!(r.u8(), Ok(7));
        assert_eq!(r.varint(), Err(CodecError::VarintOverflow { at: 1 }));
        assert_eq!(r.position(), 1);
        let mut r = ByteReader::new(&[0x80, 0x80]);
        assert_eq!(
            r.varint(),
            Err(CodecError::Truncated {
                at: 0,
                needed: 3,
                remaining: 2
            })
        );
        assert_eq!(r.position(), 0);
    }
}
