//! Zigzag: signed integers as unsigned ones whose size follows the
//! magnitude (0, −1, 1, −2, 2, … become 0, 1, 2, 3, 4, …), so a small
//! negative number takes a short varint instead of ten bytes.

/// Maps `v` to an unsigned value: `2v` for `v ≥ 0`, `−2v − 1` below.
pub fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// The inverse of [`zigzag`]; every `u64` maps to one `i64`.
pub fn unzigzag(v: u64) -> i64 {
    ((v >> 1) as i64) ^ -((v & 1) as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_magnitudes_map_to_small_values() {
        let pairs = [
            (0i64, 0u64),
            (-1, 1),
            (1, 2),
            (-2, 3),
            (2, 4),
            (-64, 127),
            (64, 128),
        ];
        for (signed, unsigned) in pairs {
            assert_eq!(zigzag(signed), unsigned, "{signed}");
            assert_eq!(unzigzag(unsigned), signed, "{unsigned}");
        }
    }

    #[test]
    fn the_extremes_round_trip() {
        assert_eq!(zigzag(i64::MAX), u64::MAX - 1);
        assert_eq!(zigzag(i64::MIN), u64::MAX);
        for v in [i64::MIN, i64::MIN + 1, -1, 0, 1, i64::MAX - 1, i64::MAX] {
            assert_eq!(unzigzag(zigzag(v)), v, "{v}");
        }
        for u in [0, 1, u64::MAX - 1, u64::MAX] {
            assert_eq!(zigzag(unzigzag(u)), u, "{u}");
        }
    }
}
