//! Explosions: a spherical shock front that leaves `center` at `start_time`
//! and expands at a finite `front_speed`. While the front (a shell
//! `front_thickness` thick) sweeps over a particle it pushes it radially
//! outwards with pressure `P(r) = peak_pressure · (reference_radius / r)²`
//! (spherical spreading, capped inside the reference radius) on the
//! particle's exposed area. Nothing is pushed beyond `max_radius`; once the
//! front has passed it the explosion is spent and removes itself.
//!
//! The push is integrated exactly over the step: a particle at distance `r`
//! is inside the shell during `[t0 + r/c, t0 + (r + w)/c]`; the force applied
//! in a step is scaled by the fraction of the step that overlaps that
//! interval. So every particle the front passes gets the same impulse,
//! `P(r) A w / c`, whatever `dt` is and however fast the front moves.

use glam::DVec3;

use crate::error::{finite, finite3, non_negative, positive, PhysicsError};

/// A one-shot radial blast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Explosion {
    /// Where it goes off, m.
    pub center: DVec3,
    /// Simulation time it goes off, s.
    pub start_time: f64,
    /// Speed of the shock front, m/s (> 0).
    pub front_speed: f64,
    /// Thickness of the pushing shell, m (> 0).
    pub front_thickness: f64,
    /// Overpressure at `reference_radius`, Pa.
    pub peak_pressure: f64,
    /// Radius where the overpressure is `peak_pressure`, m (> 0).
    pub reference_radius: f64,
    /// Nothing beyond this distance is pushed, m (> 0).
    pub max_radius: f64,
}

impl Default for Explosion {
    fn default() -> Self {
        Self {
            center: DVec3::ZERO,
            start_time: 0.0,
            front_speed: 340.0,
            front_thickness: 1.0,
            peak_pressure: 1.0e5,
            reference_radius: 1.0,
            max_radius: 50.0,
        }
    }
}

impl Explosion {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        finite3("explosion center", self.center)?;
        finite("explosion start time", self.start_time)?;
        positive("explosion front speed", self.front_speed)?;
        positive("explosion front thickness", self.front_thickness)?;
        non_negative("explosion peak pressure", self.peak_pressure)?;
        positive("explosion reference radius", self.reference_radius)?;
        positive("explosion max radius", self.max_radius)?;
        Ok(())
    }

    /// Whether the front has passed `max_radius` by time `t`, s.
    pub fn is_spent(&self, t: f64) -> bool {
        (t - self.start_time) * self.front_speed > self.max_radius + self.front_thickness
    }

    /// Mean force, N, over the step `[t, t + dt]` on a particle at `x` exposing `area` m².
    #[inline]
    pub(crate) fn force(&self, x: DVec3, area: f64, t: f64, dt: f64) -> DVec3 {
        if area <= 0.0 {
            return DVec3::ZERO;
        }
        let d = x - self.center;
        let r = d.length();
        if r > self.max_radius || r <= 0.0 {
            return DVec3::ZERO;
        }
        let enter = self.start_time + r / self.front_speed;
        let leave = self.start_time + (r + self.front_thickness) / self.front_speed;
        let overlap = (leave.min(t + dt) - enter.max(t)).max(0.0);
        if overlap <= 0.0 {
            return DVec3::ZERO;
        }
        let rr = r.max(self.reference_radius);
        let pressure = self.peak_pressure * (self.reference_radius / rr).powi(2);
        (pressure * area * overlap / (dt * r)) * d
    }

    /// The impulse, N·s, the whole passage of the front gives a particle at
    /// distance `r` m exposing `area` m² (for checks and tuning).
    pub fn impulse_at(&self, r: f64, area: f64) -> f64 {
        if r > self.max_radius || r <= 0.0 {
            return 0.0;
        }
        let rr = r.max(self.reference_radius);
        self.peak_pressure * (self.reference_radius / rr).powi(2) * area * self.front_thickness
            / self.front_speed
    }
}
