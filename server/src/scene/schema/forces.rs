//! Force fields and the water regions.

use serde::Deserialize;

use super::*;

/// What a force field acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
pub enum Target {
    /// Bodies and particles.
    #[default]
    All,
    /// Rigid bodies only.
    Bodies,
    /// Particles (ropes, cloth) only.
    Particles,
}

/// A force field.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ForceSpec {
    /// A uniform wind pushing on the area things show it.
    Wind {
        /// Wind velocity, m/s.
        velocity: Vec3,
        /// Air density, kg/m³ (default 1.225).
        #[serde(default)]
        air_density: Option<f64>,
        /// Pressure coefficient (default 1).
        #[serde(default)]
        pressure_coefficient: Option<f64>,
        /// What it acts on (default All).
        #[serde(default)]
        applies_to: Target,
    },
    /// Drag with each body's or particle's own coefficients, scaled.
    Drag {
        /// Scale of the linear coefficients (default 1).
        #[serde(default)]
        linear_scale: Option<f64>,
        /// Scale of the quadratic coefficients (default 1).
        #[serde(default)]
        quadratic_scale: Option<f64>,
        /// What it acts on (default All).
        #[serde(default)]
        applies_to: Target,
    },
    /// Water below `surface_height`: buoyancy of the submerged volume and
    /// fluid drag. The field covers the whole world below the surface, so
    /// put the surface below the ground and the water in a pit; `region`
    /// is the visible pool (a sensor body drawn as water).
    Water {
        /// Height of the surface, m.
        surface_height: f64,
        /// Fluid density, kg/m³ (default 1000).
        #[serde(default)]
        density: Option<f64>,
        /// Viscous drag in the fluid, kg/s per unit submerged fraction
        /// (default 500).
        #[serde(default)]
        drag: Option<f64>,
        /// The pool to draw: centre and half extents, m.
        #[serde(default)]
        region: Option<RegionSpec>,
        /// What it acts on (default All).
        #[serde(default)]
        applies_to: Target,
    },
    /// A one-shot blast.
    Explosion {
        /// Where it goes off, m.
        center: Vec3,
        /// When, s of simulation time.
        at: f64,
        /// Overpressure at 1 m, Pa (default 20 000).
        #[serde(default)]
        peak_pressure: Option<f64>,
        /// Nothing beyond this is pushed, m (default 10).
        #[serde(default)]
        max_radius: Option<f64>,
        /// What it acts on (default All).
        #[serde(default)]
        applies_to: Target,
    },
}

/// A box region: centre and half extents, m.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Centre, m.
    pub center: Vec3,
    /// Half the size along x, y, z, m.
    pub half_extents: Vec3,
}
