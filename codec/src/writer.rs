//! [`ByteWriter`]: fields appended to a byte vector.

use crate::varint::write_varint;

/// Appends little-endian fields to a `Vec<u8>`, the inverse of
/// [`ByteReader`](crate::ByteReader): what one writes, the other reads
/// back, bit for bit.
#[derive(Debug)]
pub struct ByteWriter<'a> {
    out: &'a mut Vec<u8>,
}

impl<'a> ByteWriter<'a> {
    /// A writer appending to `out` (whatever it holds stays in front).
    pub fn new(out: &'a mut Vec<u8>) -> Self {
        Self { out }
    }

    /// One byte.
    pub fn u8(&mut self, v: u8) {
        self.out.push(v);
    }

    /// A `u16`, little-endian (2 bytes).
    pub fn u16(&mut self, v: u16) {
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    /// A `u32`, little-endian (4 bytes).
    pub fn u32(&mut self, v: u32) {
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    /// A `u64`, little-endian (8 bytes).
    pub fn u64(&mut self, v: u64) {
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    /// An `i64`, little-endian two's complement (8 bytes).
    pub fn i64(&mut self, v: i64) {
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    /// An `f32`'s bit pattern, little-endian (4 bytes).
    pub fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }

    /// An `f64`'s bit pattern, little-endian (8 bytes).
    pub fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }

    /// A [varint](crate#varints) in its minimal form, 1 to 10 bytes.
    pub fn varint(&mut self, v: u64) {
        write_varint(self.out, v);
    }

    /// Bytes as they are (no length: the format writes one if it needs it).
    pub fn bytes(&mut self, bytes: &[u8]) {
        self.out.extend_from_slice(bytes);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_append_after_what_is_there() {
        let mut out = vec![9];
        let mut w = ByteWriter::new(&mut out);
        w.u16(0x0102);
        w.i64(-2);
        w.f32(-0.0);
        w.varint(128);
        assert_eq!(
            out,
            [
                9, 0x02, 0x01, 0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0x80, 0x80,
                0x01
            ]
        );
    }
}
