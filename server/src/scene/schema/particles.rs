//! Ropes and cloths: what is made of particles and springs.

use serde::Deserialize;

use super::*;

/// A rope: a chain of particles joined by springs.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RopeSpec {
    /// Name (particles are streamed as `<name>[<i>]`).
    pub name: String,
    /// First end, m.
    pub start: Vec3,
    /// Other end, m.
    pub end: Vec3,
    /// Segments (particles = segments + 1), 1..=1000.
    pub segments: u32,
    /// Total mass, kg (default 1).
    #[serde(default)]
    pub mass: Option<f64>,
    /// Segment spring stiffness, N/m (default 2000).
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// Segment spring damping, N·s/m (default 2).
    #[serde(default)]
    pub damping: Option<f64>,
    /// Pin the first particle in place (default true).
    #[serde(default = "yes")]
    pub pin_start: bool,
    /// Pin the last particle in place.
    #[serde(default)]
    pub pin_end: bool,
    /// Hang the first particle from this body instead of pinning it.
    #[serde(default)]
    pub attach_start: Option<String>,
    /// Hang the last particle from this body.
    #[serde(default)]
    pub attach_end: Option<String>,
    /// Radius with which the particles collide with bodies and are drawn, m
    /// (default 0.05).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Colour.
    #[serde(default)]
    pub color: Option<[u8; 4]>,
}

/// A rectangular cloth sheet of `nu × nv` particles.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClothSpec {
    /// Name (particles are streamed as `<name>[<i>]`, row-major).
    pub name: String,
    /// Corner particle (0, 0), m.
    pub origin: Vec3,
    /// Direction of the rows (default +X).
    #[serde(default)]
    pub u_axis: Option<Vec3>,
    /// Direction of the columns (default −Y: a hanging sheet).
    #[serde(default)]
    pub v_axis: Option<Vec3>,
    /// Extent along `u_axis`, m.
    pub width: f64,
    /// Extent along `v_axis`, m.
    pub height: f64,
    /// Particles along u, 2..=128.
    pub nu: u32,
    /// Particles along v, 2..=128.
    pub nv: u32,
    /// Total mass, kg (default 1).
    #[serde(default)]
    pub mass: Option<f64>,
    /// Stiffness of the grid-edge springs, N/m (default 300; shear springs
    /// get 40 % of it and bend springs 10 %).
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// Linear drag per particle, kg/s (default 0.002).
    #[serde(default)]
    pub drag: Option<f64>,
    /// Grid coordinates `(u, v)` pinned in place.
    #[serde(default)]
    pub pinned: Vec<(u32, u32)>,
    /// Radius with which the particles collide with bodies and are drawn, m
    /// (default 0.04; 0 = no collision).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Colour.
    #[serde(default)]
    pub color: Option<[u8; 4]>,
}
