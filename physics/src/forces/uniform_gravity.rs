//! Uniform gravity near the surface of a planet: `F = m g`, the same
//! acceleration for every particle whatever its mass.

use glam::DVec3;

use crate::error::{direction, non_negative, PhysicsError};

/// Constant gravitational acceleration of magnitude `g` along `direction`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformGravity {
    /// Magnitude, m/s² (Earth: 9.81).
    pub g: f64,
    /// Direction the acceleration points (need not be normalised), usually `-Y`.
    pub direction: DVec3,
}

impl Default for UniformGravity {
    fn default() -> Self {
        Self {
            g: 9.81,
            direction: DVec3::NEG_Y,
        }
    }
}

impl UniformGravity {
    /// Earth gravity along `-Y`.
    pub fn earth() -> Self {
        Self::default()
    }

    /// The acceleration vector, m/s².
    pub fn acceleration(&self) -> DVec3 {
        self.g * self.direction.normalize()
    }

    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        non_negative("gravity g", self.g)?;
        direction("gravity direction", self.direction)?;
        Ok(())
    }
}
