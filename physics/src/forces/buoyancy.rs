//! Buoyancy (Archimedes): a body in a fluid is pushed up by the weight of
//! the fluid it displaces, `F = ρ_f V_sub g`.
//!
//! Each particle is treated as a sphere of its own volume `V` (radius
//! `r = (3V / 4π)^(1/3)`). With its centre at height `y` above the fluid
//! surface, the immersed depth is `h = clamp(r - y, 0, 2r)` and the submerged
//! volume is the spherical cap `π h² (3r - h) / 3`. A sphere of half the
//! fluid's density therefore floats with its centre on the surface.
//!
//! The fluid also resists motion: a linear drag `-k f v`, where `f` is the
//! submerged fraction, so floating bodies settle instead of bobbing forever.

use glam::DVec3;

use crate::error::{direction, finite, non_negative, PhysicsError};

/// A body of fluid below a flat surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Buoyancy {
    /// Height of the surface along `up`, m (the plane `x · up = surface_height`).
    pub surface_height: f64,
    /// Up direction (against gravity); need not be normalised.
    pub up: DVec3,
    /// Fluid density, kg/m³ (water: 1000).
    pub fluid_density: f64,
    /// Gravitational acceleration that makes the displaced fluid weigh, m/s².
    pub gravity: f64,
    /// Viscous drag in the fluid, kg/s, scaled by the submerged fraction.
    pub fluid_drag: f64,
}

impl Default for Buoyancy {
    fn default() -> Self {
        Self {
            surface_height: 0.0,
            up: DVec3::Y,
            fluid_density: 1000.0,
            gravity: 9.81,
            fluid_drag: 0.0,
        }
    }
}

impl Buoyancy {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        finite("fluid surface height", self.surface_height)?;
        direction("buoyancy up direction", self.up)?;
        non_negative("fluid density", self.fluid_density)?;
        non_negative("buoyancy gravity", self.gravity)?;
        non_negative("fluid drag", self.fluid_drag)?;
        Ok(())
    }

    pub(crate) fn compiled(&self) -> Buoyancy {
        Buoyancy {
            up: self.up.normalize(),
            ..*self
        }
    }

    /// Buoyant plus fluid-drag force, N, on a sphere of `volume` m³ at `x`.
    /// `self` must be compiled (unit `up`).
    #[inline]
    pub(crate) fn force(&self, x: DVec3, v: DVec3, volume: f64) -> DVec3 {
        if volume <= 0.0 {
            return DVec3::ZERO;
        }
        let fraction = submerged_fraction(x.dot(self.up) - self.surface_height, volume);
        if fraction <= 0.0 {
            return DVec3::ZERO;
        }
        (self.fluid_density * volume * fraction * self.gravity) * self.up
            - (self.fluid_drag * fraction) * v
    }
}

/// Fraction (0..=1) of a sphere of `volume` whose centre is `height` m above
/// the surface that lies below it.
#[inline]
pub fn submerged_fraction(height: f64, volume: f64) -> f64 {
    let r = (volume * (3.0 / (4.0 * std::f64::consts::PI))).cbrt();
    let h = (r - height).clamp(0.0, 2.0 * r);
    // cap volume / sphere volume = h² (3r - h) / (4 r³)
    h * h * (3.0 * r - h) / (4.0 * r * r * r)
}
