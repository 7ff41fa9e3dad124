//! The scene file's types, as serde reads them from RON or JSON.
//!
//! Vectors are `(x, y, z)` tuples in RON and `[x, y, z]` arrays in JSON;
//! enums are written by variant name (`Sphere(radius: 0.5)` in RON,
//! `{"Sphere": {"radius": 0.5}}` in JSON). Units are SI: m, kg, s, N; angles
//! are in degrees where the field name says `_deg`. Unknown fields are
//! refused so a typo does not silently fall back to a default.
//! `docs/scene-format.md` documents every field with examples. One kind
//! of entry a file: `rigid.rs`, `joint.rs`, `particles.rs`, `forces.rs`
//! and `soft.rs`; the file, the world and the bounds here.

use serde::Deserialize;

mod forces;
mod joint;
mod particles;
mod rigid;
mod soft;

pub use forces::*;
pub use joint::*;
pub use particles::*;
pub use rigid::*;
pub use soft::*;

/// A vector, m (or m/s, rad/s, … as the field says).
pub type Vec3 = [f64; 3];

/// A whole scene file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// A name for logs and tools.
    #[serde(default)]
    pub name: String,
    /// World-wide settings.
    #[serde(default)]
    pub world: WorldSettings,
    /// Where avatars appear, m (tried in order; the first free one wins).
    #[serde(default = "default_spawn_points")]
    pub spawn_points: Vec<Vec3>,
    /// Single bodies.
    #[serde(default)]
    pub bodies: Vec<BodySpec>,
    /// Repetitive arrangements of bodies.
    #[serde(default)]
    pub generators: Vec<Generator>,
    /// Humanoid ragdolls (eleven bodies and ten joints each).
    #[serde(default)]
    pub ragdolls: Vec<RagdollSpec>,
    /// Joints between named bodies.
    #[serde(default)]
    pub joints: Vec<JointSpec>,
    /// Mass-spring ropes.
    #[serde(default)]
    pub ropes: Vec<RopeSpec>,
    /// Mass-spring cloth sheets.
    #[serde(default)]
    pub cloths: Vec<ClothSpec>,
    /// Force fields: wind, drag, water, explosions.
    #[serde(default)]
    pub forces: Vec<ForceSpec>,
    /// XPBD soft bodies: inextensible ropes, stiff cloth, jelly solids,
    /// balloons.
    #[serde(default)]
    pub soft_bodies: Vec<SoftBodySpec>,
    /// Position-based fluids, with their emitters.
    #[serde(default)]
    pub fluids: Vec<FluidSpec>,
}

/// `true`, for fields that are on unless a file says otherwise.
fn yes() -> bool {
    true
}

fn default_spawn_points() -> Vec<Vec3> {
    vec![[0.0, 1.0, 0.0]]
}

/// Settings that apply to the whole world.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WorldSettings {
    /// Gravity on bodies and particles, m/s².
    pub gravity: Vec3,
    /// Contact and joint solver substeps per tick (1..=64; default 4).
    pub solver_substeps: u32,
    /// Whether resting bodies may fall asleep.
    pub sleep: bool,
    /// Bodies whose centre of mass leaves this box are removed, m; `None`
    /// keeps everything.
    pub bounds: Option<BoundsSpec>,
}

impl Default for WorldSettings {
    fn default() -> Self {
        Self {
            gravity: [0.0, -9.81, 0.0],
            solver_substeps: 4,
            sleep: true,
            bounds: None,
        }
    }
}

/// An axis-aligned box, m.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsSpec {
    /// Lowest corner, m.
    pub min: Vec3,
    /// Highest corner, m.
    pub max: Vec3,
}
