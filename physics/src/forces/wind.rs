//! Wind: dynamic pressure of moving air on the area a particle exposes along
//! the wind direction.
//!
//! With wind velocity `w` (direction `ŵ`), the air meets a particle moving at
//! `v` with relative speed `s = max(0, (w - v) · ŵ)` and pushes it along `ŵ`
//! with `F = ½ ρ C s² A ŵ` (`ρ` air density, `C` pressure coefficient, `A`
//! the particle's exposed area). A particle already moving with the wind
//! feels nothing, so a light particle accelerates up to wind speed and stops
//! there.

use glam::DVec3;

use crate::error::{finite3, non_negative, PhysicsError};

/// A uniform wind field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wind {
    /// Wind velocity, m/s.
    pub velocity: DVec3,
    /// Air density, kg/m³ (sea level: 1.225).
    pub air_density: f64,
    /// Pressure coefficient `C` (a flat plate facing the wind: about 1.2).
    pub pressure_coefficient: f64,
}

impl Default for Wind {
    fn default() -> Self {
        Self {
            velocity: DVec3::new(5.0, 0.0, 0.0),
            air_density: 1.225,
            pressure_coefficient: 1.0,
        }
    }
}

impl Wind {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        finite3("wind velocity", self.velocity)?;
        non_negative("air density", self.air_density)?;
        non_negative("wind pressure coefficient", self.pressure_coefficient)?;
        Ok(())
    }

    /// Precomputed `(ŵ, |w|, ½ ρ C)`.
    pub(crate) fn compiled(&self) -> CompiledWind {
        let speed = self.velocity.length();
        let dir = if speed > 0.0 {
            self.velocity / speed
        } else {
            DVec3::ZERO
        };
        CompiledWind {
            dir,
            speed,
            half_rho_c: 0.5 * self.air_density * self.pressure_coefficient,
        }
    }
}

/// A wind with its invariants precomputed once per step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CompiledWind {
    pub(crate) dir: DVec3,
    pub(crate) speed: f64,
    pub(crate) half_rho_c: f64,
}

impl CompiledWind {
    /// Wind force, N, on a particle moving at `v` exposing `area` m².
    #[inline]
    pub(crate) fn force(&self, v: DVec3, area: f64) -> DVec3 {
        let s = (self.speed - v.dot(self.dir)).max(0.0);
        (self.half_rho_c * s * s * area) * self.dir
    }
}
