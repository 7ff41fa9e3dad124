//! Rigid bodies: shapes, single bodies, generators of many, ragdolls.

use serde::Deserialize;

use super::*;

/// How a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
pub enum BodyKindSpec {
    /// Moved by forces, contacts and joints.
    #[default]
    Dynamic,
    /// Never moves.
    Static,
    /// Moves with the velocity it is given; pushes but is never pushed.
    Kinematic,
}

/// An orientation.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub enum Rotation {
    /// A unit quaternion `(x, y, z, w)` (renormalised when off by < 1e-6).
    Quat([f64; 4]),
    /// Angles about X, then Y, then Z (fixed world axes), degrees.
    Euler(Vec3),
    /// A turn of `deg` degrees about `axis` (need not be unit).
    AxisAngle {
        /// The axis.
        axis: Vec3,
        /// The angle, degrees.
        deg: f64,
    },
}

/// A collision shape in the body's frame (capsules and cylinders along +Y).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeSpec {
    /// A ball.
    Sphere {
        /// Radius, m (> 0).
        radius: f64,
    },
    /// A box.
    Cuboid {
        /// Half the size along x, y, z, m (each > 0).
        half_extents: Vec3,
    },
    /// A cylinder with hemispherical caps, along Y.
    Capsule {
        /// Half the length of the straight part, m (> 0).
        half_height: f64,
        /// Radius, m (> 0).
        radius: f64,
    },
    /// A cylinder along Y.
    Cylinder {
        /// Half the height, m (> 0).
        half_height: f64,
        /// Radius, m (> 0).
        radius: f64,
    },
    /// The convex hull of points, m (at least 4, not all in one plane).
    ConvexHull {
        /// The points, m.
        points: Vec<Vec3>,
    },
    /// Shapes placed in the body's frame (not nested).
    Compound {
        /// The parts.
        parts: Vec<PartSpec>,
    },
    /// A triangle surface for static scenery (no mass).
    TriMesh {
        /// Vertices, m.
        vertices: Vec<Vec3>,
        /// Counter-clockwise triangles (seen from outside) as vertex indices.
        triangles: Vec<[u32; 3]>,
    },
}

/// One part of a compound shape.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartSpec {
    /// Offset in the body's frame, m.
    #[serde(default)]
    pub position: Vec3,
    /// Orientation in the body's frame.
    #[serde(default)]
    pub rotation: Option<Rotation>,
    /// The part's shape (not a compound).
    pub shape: ShapeSpec,
}

/// One rigid body.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name (needed to join it); unnamed bodies get `body#<index>`.
    #[serde(default)]
    pub name: Option<String>,
    /// Dynamic (default), Static or Kinematic.
    #[serde(default)]
    pub kind: BodyKindSpec,
    /// Its shape.
    pub shape: ShapeSpec,
    /// Position of the body's origin, m.
    #[serde(default)]
    pub position: Vec3,
    /// Orientation (default: none).
    #[serde(default)]
    pub rotation: Option<Rotation>,
    /// Initial velocity, m/s.
    #[serde(default)]
    pub velocity: Vec3,
    /// Initial angular velocity, rad/s.
    #[serde(default)]
    pub angular_velocity: Vec3,
    /// Density, kg/m³ (default 1000 when `mass` is not given).
    #[serde(default)]
    pub density: Option<f64>,
    /// Total mass, kg (instead of `density`; the inertia scales with it).
    #[serde(default)]
    pub mass: Option<f64>,
    /// Friction coefficient, static and sliding (default 0.6).
    #[serde(default)]
    pub friction: Option<f64>,
    /// Restitution, 0 (no bounce) to 1 (default 0).
    #[serde(default)]
    pub restitution: Option<f64>,
    /// Linear damping, 1/s (default 0).
    #[serde(default)]
    pub linear_damping: Option<f64>,
    /// Angular damping, 1/s (default 0).
    #[serde(default)]
    pub angular_damping: Option<f64>,
    /// Multiplies gravity (default 1).
    #[serde(default)]
    pub gravity_scale: Option<f64>,
    /// Continuous collision detection for fast, small bodies.
    #[serde(default)]
    pub ccd: bool,
    /// A trigger: reports overlaps, never collides.
    #[serde(default)]
    pub sensor: bool,
    /// RGBA colour (default by kind).
    #[serde(default)]
    pub color: Option<[u8; 4]>,
}

/// Repetitive arrangements, expanded into bodies (and joints) when built.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Generator {
    /// A 2D pyramid of `rows` rows in the XY plane: row `r` (from the
    /// bottom) holds `rows - r` copies of `body`, spaced by the shape's
    /// width plus `gap`; the bottom row rests on `origin` (its centre).
    Pyramid {
        /// Name prefix: bodies are `<name>[<i>]`.
        name: String,
        /// Rows, 1..=100.
        rows: u32,
        /// Centre of the bottom row's underside, m.
        #[serde(default)]
        origin: Vec3,
        /// Extra space between neighbours, m.
        #[serde(default)]
        gap: f64,
        /// The body to copy (its `position` is added to each place).
        body: Box<BodySpec>,
    },
    /// A box grid of `counts` copies of `body`, `spacing` apart, the first at
    /// `origin`.
    Grid {
        /// Name prefix: bodies are `<name>[<i>]`, x fastest then z then y.
        name: String,
        /// Copies along x, y, z (product ≤ 100 000).
        counts: [u32; 3],
        /// Distance between neighbours along x, y, z, m.
        spacing: Vec3,
        /// Position of the first copy, m.
        #[serde(default)]
        origin: Vec3,
        /// The body to copy (its `position` is added to each place).
        body: Box<BodySpec>,
    },
    /// A hanging bridge: `planks` dynamic boards between `start` and `end`
    /// sagging by `sag`, each hinged to the next across the span, the ends
    /// hinged to the named bodies (or left free).
    Bridge {
        /// Name prefix: planks are `<name>[<i>]`.
        name: String,
        /// Where the first plank's hinge is, m.
        start: Vec3,
        /// Where the last plank's hinge is, m.
        end: Vec3,
        /// Number of planks, 1..=1000.
        planks: u32,
        /// Plank width across the span, m.
        width: f64,
        /// Plank thickness, m.
        thickness: f64,
        /// Space between planks, m (less than the span / planks).
        #[serde(default)]
        gap: f64,
        /// How far the middle hangs below the straight line, m.
        #[serde(default)]
        sag: f64,
        /// Plank density, kg/m³ (default 600, wood).
        #[serde(default)]
        density: Option<f64>,
        /// Body the first plank hangs from.
        #[serde(default)]
        start_body: Option<String>,
        /// Body the last plank hangs from.
        #[serde(default)]
        end_body: Option<String>,
        /// Plank colour.
        #[serde(default)]
        color: Option<[u8; 4]>,
    },
}

/// A humanoid ragdoll (see `inertia_physics::ragdoll`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RagdollSpec {
    /// Name prefix: parts are `<name>.pelvis`, `<name>.head`, …
    pub name: String,
    /// Where its feet are, m.
    pub position: Vec3,
    /// Orientation; it stands along +Y facing +Z before turning.
    #[serde(default)]
    pub rotation: Option<Rotation>,
    /// Standing height, m (default 1.8).
    #[serde(default)]
    pub height: Option<f64>,
    /// Total mass, kg (default 75).
    #[serde(default)]
    pub mass: Option<f64>,
    /// Colour of every part.
    #[serde(default)]
    pub color: Option<[u8; 4]>,
}
