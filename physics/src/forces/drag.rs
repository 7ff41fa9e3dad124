//! Drag (attrition) from a medium at rest: `F = -b v - c |v| v`, with the
//! per-particle coefficients `b` (linear, kg/s: slow motion in a viscous
//! medium, Stokes) and `c` (quadratic, kg/m: fast motion in air,
//! `c = ½ ρ C_d A`). The generator scales both.
//!
//! Terminal speed under gravity `g`: `m g / b` (linear only) and
//! `sqrt(m g / c)` (quadratic only).

use glam::DVec3;

use crate::error::{non_negative, PhysicsError};

/// Enables drag using each particle's own coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drag {
    /// Multiplies every particle's linear coefficient (1 = as set).
    pub linear_scale: f64,
    /// Multiplies every particle's quadratic coefficient (1 = as set).
    pub quadratic_scale: f64,
}

impl Default for Drag {
    fn default() -> Self {
        Self {
            linear_scale: 1.0,
            quadratic_scale: 1.0,
        }
    }
}

impl Drag {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        non_negative("drag linear scale", self.linear_scale)?;
        non_negative("drag quadratic scale", self.quadratic_scale)?;
        Ok(())
    }

    /// Two drag generators acting together: their scales add.
    pub(crate) fn combined(&self, other: &Drag) -> Drag {
        Drag {
            linear_scale: self.linear_scale + other.linear_scale,
            quadratic_scale: self.quadratic_scale + other.quadratic_scale,
        }
    }

    /// Drag force, N, on a particle with velocity `v` and coefficients `b`, `c`.
    #[inline]
    pub(crate) fn force(&self, v: DVec3, b: f64, c: f64) -> DVec3 {
        let speed = v.length();
        -(self.linear_scale * b + self.quadratic_scale * c * speed) * v
    }
}
