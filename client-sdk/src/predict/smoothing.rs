//! The visual offset: how a correction of the prediction is shown.
//!
//! A correction moves the predicted present at once; drawing that would
//! jerk the avatar. The offset takes the jump (drawn = predicted + offset,
//! unchanged at the moment of the correction) and then decays
//! exponentially tick by tick, so the picture slides onto the corrected
//! path. A correction as large as a teleport snaps instead: sliding across
//! metres looks worse than a cut.

use glam::DVec3;

/// A decaying offset between the predicted and the drawn avatar, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisualOffset {
    offset: DVec3,
    /// The factor applied per tick, from the time constant.
    keep: f64,
    snap_distance: f64,
}

/// What folding a correction in did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fold {
    /// The offset took it: the picture did not move.
    Absorbed,
    /// Too large: the offset was dropped and the picture jumped by this
    /// much, m.
    Snapped(f64),
}

impl VisualOffset {
    /// No offset; it decays with time constant `smoothing` (s) in ticks of
    /// `dt` (s), and corrections beyond `snap_distance` (m) snap.
    pub fn new(smoothing: f64, dt: f64, snap_distance: f64) -> Self {
        let keep = if smoothing > 0.0 && dt > 0.0 {
            (-dt / smoothing).exp()
        } else {
            0.0
        };
        Self {
            offset: DVec3::ZERO,
            keep,
            snap_distance,
        }
    }

    /// The offset now, m (drawn − predicted).
    pub fn get(&self) -> DVec3 {
        self.offset
    }

    /// The predicted present moved by `shift` (m) without the avatar
    /// moving in the game: keep the picture where it was, unless that
    /// leaves it further than the snap distance from the prediction.
    pub fn fold(&mut self, shift: DVec3) -> Fold {
        let offset = self.offset - shift;
        if offset.length() > self.snap_distance {
            let jump = offset.length();
            self.offset = DVec3::ZERO;
            Fold::Snapped(jump)
        } else {
            self.offset = offset;
            Fold::Absorbed
        }
    }

    /// One tick passes; returns how far the picture moved off the
    /// predicted motion, m.
    pub fn decay(&mut self) -> f64 {
        let before = self.offset;
        self.offset *= self.keep;
        if self.offset.length_squared() < 1e-12 {
            self.offset = DVec3::ZERO;
        }
        (before - self.offset).length()
    }

    /// Drops the offset (a new avatar, a break in the timeline).
    pub fn clear(&mut self) {
        self.offset = DVec3::ZERO;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_offset_fades_by_the_time_constant_and_a_teleport_snaps() {
        let dt = 1.0 / 60.0;
        let mut o = VisualOffset::new(0.1, dt, 2.0);
        assert_eq!(o.fold(DVec3::X * 0.05), Fold::Absorbed);
        assert_eq!(o.get(), DVec3::X * -0.05);
        let first = o.decay();
        assert!(first < 0.05 * (1.0 - (-dt / 0.1f64).exp()) + 1e-12);
        for _ in 0..5 {
            o.decay();
        }
        // 0.1 s: 1/e left.
        assert!((o.get().length() - 0.05 / std::f64::consts::E).abs() < 1e-6);
        assert!(matches!(o.fold(DVec3::Y * 5.0), Fold::Snapped(j) if j > 4.9));
        assert_eq!(o.get(), DVec3::ZERO);
    }
}
