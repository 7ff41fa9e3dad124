//! Quantization of what snapshots carry: positions on a grid, orientations
//! as "smallest three" (after Glenn Fiedler's "Snapshot Compression",
//! gafferongames.com, 2015: drop the largest quaternion component, send its
//! index in 2 bits and the other three, each within ±1/√2, in a fixed
//! number of bits; the largest is rebuilt as the positive root).

use crate::bits::{BitError, BitReader, BitWriter};

/// A grid for positions: each axis in `[-bound, bound]` m, in steps of
/// `resolution` m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionGrid {
    /// Grid step, m.
    pub resolution: f64,
    /// Largest coordinate magnitude, m; values beyond are clamped.
    pub bound: f64,
}

impl PositionGrid {
    /// Bits per axis: enough for every step from `-bound` to `bound` (64
    /// for grids too fine to count, which validation then refuses).
    pub fn bits(&self) -> u32 {
        let steps = ((2.0 * self.bound / self.resolution).ceil() as u64).saturating_add(1);
        (64 - (steps - 1).leading_zeros()).max(1)
    }

    /// The grid index of coordinate `x` (clamped to the bound; NaN maps to
    /// the centre).
    pub fn index(&self, x: f64) -> u64 {
        let x = if x.is_nan() {
            0.0
        } else {
            x.clamp(-self.bound, self.bound)
        };
        ((x + self.bound) / self.resolution).round() as u64
    }

    /// The coordinate of grid index `i`, m.
    pub fn coordinate(&self, i: u64) -> f64 {
        i as f64 * self.resolution - self.bound
    }

    /// Writes a position (three axes).
    pub fn write(&self, w: &mut BitWriter, p: [f64; 3]) {
        let bits = self.bits();
        for x in p {
            w.write(self.index(x), bits);
        }
    }

    /// Reads a position written by [`Self::write`].
    pub fn read(&self, r: &mut BitReader<'_>) -> Result<[f64; 3], BitError> {
        let bits = self.bits();
        let max = self.index(self.bound);
        let mut p = [0.0; 3];
        for x in &mut p {
            *x = self.coordinate(r.read_count(bits, max, "position index")?);
        }
        Ok(p)
    }
}

/// Largest magnitude of the three smaller components of a unit quaternion.
const SMALL_BOUND: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Unit quaternion `q` (`[x, y, z, w]`; normalised here, and `-q` is the
/// same rotation) as smallest three with `bits` per component: the index
/// of the dropped (largest) component and the other three as levels
/// `0 ..= 2^bits - 1` spanning `[-1/√2, 1/√2]`, in order. Not finite or
/// zero length is the identity.
pub fn rotation_levels(q: [f64; 4], bits: u32) -> (u8, [u16; 3]) {
    let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    let q = if len > 0.0 && len.is_finite() {
        q.map(|c| c / len)
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let largest = (0..4)
        .max_by(|&a, &b| q[a].abs().total_cmp(&q[b].abs()))
        .unwrap_or(3);
    let sign = if q[largest] < 0.0 { -1.0 } else { 1.0 };
    let levels = ((1u64 << bits) - 1) as f64;
    let mut small = [0u16; 3];
    let others = (0..4).filter(|&i| i != largest);
    for (level, i) in small.iter_mut().zip(others) {
        let unit =
            ((q[i] * sign).clamp(-SMALL_BOUND, SMALL_BOUND) + SMALL_BOUND) / (2.0 * SMALL_BOUND);
        *level = (unit * levels).round() as u16;
    }
    (largest as u8, small)
}

/// The unit quaternion (largest component positive) that
/// [`rotation_levels`] levels stand for; levels above `2^bits - 1` are
/// taken as the top level.
pub fn rotation_from_levels(largest: u8, small: [u16; 3], bits: u32) -> [f64; 4] {
    let largest = usize::from(largest & 3);
    let levels = ((1u64 << bits) - 1) as f64;
    let mut q = [0.0; 4];
    let mut sum = 0.0;
    let others = (0..4).filter(|&i| i != largest);
    for (&level, i) in small.iter().zip(others) {
        let unit = (f64::from(level) / levels).min(1.0);
        q[i] = unit * 2.0 * SMALL_BOUND - SMALL_BOUND;
        sum += q[i] * q[i];
    }
    q[largest] = (1.0 - sum).max(0.0).sqrt();
    let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    q.map(|c| c / len)
}

/// Writes unit quaternion `q` as [`rotation_levels`] gives it: the
/// dropped index in 2 bits, then the three levels, `bits` each.
pub fn write_rotation(w: &mut BitWriter, q: [f64; 4], bits: u32) {
    let (largest, small) = rotation_levels(q, bits);
    w.write(u64::from(largest), 2);
    for level in small {
        w.write(u64::from(level), bits);
    }
}

/// Reads a quaternion written by [`write_rotation`] (unit, largest
/// component positive).
pub fn read_rotation(r: &mut BitReader<'_>, bits: u32) -> Result<[f64; 4], BitError> {
    let largest = r.read(2)? as u8;
    let mut small = [0u16; 3];
    for level in &mut small {
        *level = r.read(bits)? as u16;
    }
    Ok(rotation_from_levels(largest, small, bits))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn next(state: &mut crate::rng::SplitMix) -> f64 {
        state.uniform()
    }

    #[test]
    fn positions_come_back_within_half_a_step() {
        let grid = PositionGrid {
            resolution: 0.001,
            bound: 512.0,
        };
        assert_eq!(grid.bits(), 20);
        let mut s = crate::rng::SplitMix(5);
        let points: Vec<[f64; 3]> = (0..1000)
            .map(|_| [0, 1, 2].map(|_| (next(&mut s) * 2.0 - 1.0) * 600.0))
            .collect();
        let mut w = BitWriter::new();
        for p in &points {
            grid.write(&mut w, *p);
        }
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        for p in &points {
            let q = grid.read(&mut r).unwrap();
            for (a, b) in p.iter().zip(q) {
                let expected = a.clamp(-512.0, 512.0);
                assert!(
                    (expected - b).abs() <= 0.0005 + 1e-9,
                    "{a} came back as {b}"
                );
            }
        }
    }

    #[test]
    fn rotations_come_back_within_the_stated_angle() {
        // 9 bits a component (Fiedler's choice): a step of √2/511 ≈ 0.0028
        // per component; with the largest component rebuilt from the other
        // three the rotation comes back within half a degree (0.48° worst
        // over these 10 000).
        let bits = 9;
        let mut s = crate::rng::SplitMix(9);
        let mut worst: f64 = 0.0;
        for _ in 0..10_000 {
            let q = [0, 1, 2, 3].map(|_| next(&mut s) * 2.0 - 1.0);
            let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
            let q = q.map(|c| c / len);
            let mut w = BitWriter::new();
            write_rotation(&mut w, q, bits);
            assert_eq!(w.bit_len(), 2 + 3 * bits as usize);
            let bytes = w.finish();
            let back = read_rotation(&mut BitReader::new(&bytes), bits).unwrap();
            let dot: f64 = q.iter().zip(back).map(|(a, b)| a * b).sum::<f64>().abs();
            let angle = 2.0 * dot.min(1.0).acos();
            worst = worst.max(angle.to_degrees());
        }
        assert!(worst < 0.5, "worst rotation error {worst} degrees");
    }

    #[test]
    fn grids_too_fine_to_count_do_not_overflow() {
        for (resolution, bound) in [(1e-300, 1e300), (f64::MIN_POSITIVE, 1.0), (1.0, f64::MAX)] {
            assert_eq!(PositionGrid { resolution, bound }.bits(), 64);
        }
        let nan = PositionGrid {
            resolution: f64::NAN,
            bound: 1.0,
        };
        assert_eq!(nan.bits(), 1);
    }

    #[test]
    fn out_of_grid_indices_are_refused() {
        let grid = PositionGrid {
            resolution: 0.25,
            bound: 1.0,
        };
        // 9 steps need 4 bits; index 15 is not on the grid.
        let mut w = BitWriter::new();
        w.write(15, 4);
        w.write(0, 8);
        let bytes = w.finish();
        assert!(matches!(
            grid.read(&mut BitReader::new(&bytes)),
            Err(BitError::TooLarge { .. })
        ));
    }
}
