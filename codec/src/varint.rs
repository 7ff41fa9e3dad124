//! LEB128 varints (see the [crate docs](crate#varints)): the writer, and
//! the reading that [`ByteReader::varint`](crate::ByteReader::varint) does.

use crate::CodecError;

/// The most bytes a varint takes: ⌈64 / 7⌉.
pub const MAX_VARINT_BYTES: usize = 10;

/// Appends `v` as a varint in its minimal form, 1 to
/// [`MAX_VARINT_BYTES`] bytes.
pub fn write_varint(out: &mut Vec<u8>, mut v: u64) {
    loop {
        let byte = (v & 0x7F) as u8;
        v >>= 7;
        if v == 0 {
            out.push(byte);
            return;
        }
        out.push(byte | 0x80);
    }
}

/// Reads a varint off the front of `bytes`: its value and the bytes it
/// took. `at` is where `bytes` starts in the reader's input, for errors.
pub(crate) fn read_varint(bytes: &[u8], at: usize) -> Result<(u64, usize), CodecError> {
    let mut value = 0u64;
    for i in 0..MAX_VARINT_BYTES {
        let Some(&byte) = bytes.get(i) else {
            return Err(CodecError::Truncated {
                at,
                needed: i + 1,
                remaining: bytes.len(),
            });
        };
        let bits = u64::from(byte & 0x7F);
        let shift = 7 * i as u32;
        // The tenth group holds bit 63 alone.
        if shift == 63 && bits > 1 {
            return Err(CodecError::VarintOverflow { at });
        }
        value |= bits << shift;
        if byte & 0x80 == 0 {
            return Ok((value, i + 1));
        }
    }
    Err(CodecError::VarintTooLong { at })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encoded(v: u64) -> Vec<u8> {
        let mut out = Vec::new();
        write_varint(&mut out, v);
        out
    }

    #[test]
    fn edge_values_have_their_known_bytes() {
        assert_eq!(encoded(0), [0x00]);
        assert_eq!(encoded(1), [0x01]);
        assert_eq!(encoded(127), [0x7F]);
        assert_eq!(encoded(128), [0x80, 0x01]);
        assert_eq!(encoded(300), [0xAC, 0x02]);
        assert_eq!(encoded(16_383), [0xFF, 0x7F]);
        assert_eq!(encoded(16_384), [0x80, 0x80, 0x01]);
        assert_eq!(
            encoded(1 << 63),
            [0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x01]
        );
        assert_eq!(
            encoded(u64::MAX),
            [0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01]
        );
    }

    #[test]
    fn values_round_trip_in_their_minimal_length() {
        let mut values = vec![
            0,
            1,
            127,
            128,
            255,
            256,
            16_383,
            16_384,
            u64::MAX - 1,
            u64::MAX,
        ];
        values.extend((0..64).map(|b| 1u64 << b));
        values.extend((1..64).map(|b| (1u64 << b) - 1));
        for v in values {
            let bytes = encoded(v);
            let minimal = (64 - (v | 1).leading_zeros()).div_ceil(7) as usize;
            assert_eq!(bytes.len(), minimal, "{v}");
            assert_eq!(read_varint(&bytes, 0), Ok((v, bytes.len())), "{v}");
        }
    }

    #[test]
    fn every_cut_of_a_varint_is_truncated() {
        let bytes = encoded(u64::MAX);
        for cut in 0..bytes.len() {
            assert_eq!(
                read_varint(&bytes[..cut], 5),
                Err(CodecError::Truncated {
                    at: 5,
                    needed: cut + 1,
                    remaining: cut
                }),
                "cut at {cut}"
            );
        }
    }

    #[test]
    fn past_64_bits_is_refused() {
        // A tenth byte of 2 would be bit 64.
        let mut over = vec![0x80; 9];
        over.push(0x02);
        assert_eq!(
            read_varint(&over, 3),
            Err(CodecError::VarintOverflow { at: 3 })
        );
        let mut over = vec![0xFF; 9];
        over.push(0x7F);
        assert_eq!(
            read_varint(&over, 0),
            Err(CodecError::VarintOverflow { at: 0 })
        );
        // A tenth byte that says more follow, even with bit 63 alone.
        for tenth in [0x80, 0x81] {
            let mut long = vec![0x80; 9];
            long.push(tenth);
            long.push(0x00);
            assert_eq!(
                read_varint(&long, 0),
                Err(CodecError::VarintTooLong { at: 0 })
            );
        }
        assert_eq!(
            read_varint(&[0xFF; 11], 0),
            Err(CodecError::VarintOverflow { at: 0 })
        );
    }

    #[test]
    fn non_minimal_forms_are_read() {
        assert_eq!(read_varint(&[0x80, 0x00], 0), Ok((0, 2)));
        assert_eq!(read_varint(&[0xFF, 0x80, 0x00], 0), Ok((127, 3)));
        let mut zero = vec![0x80; 9];
        zero.push(0x00);
        assert_eq!(read_varint(&zero, 0), Ok((0, 10)));
    }

    #[test]
    fn only_the_varint_is_taken() {
        assert_eq!(read_varint(&[0xAC, 0x02, 0x7F], 0), Ok((300, 2)));
    }
}
