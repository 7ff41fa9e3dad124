//! The scene file's types, as serde reads them from RON or JSON.
//!
//! Vectors are `(x, y, z)` tuples in RON and `[x, y, z]` arrays in JSON;
//! enums are written by variant name (`Sphere(radius: 0.5)` in RON,
//! `{"Sphere": {"radius": 0.5}}` in JSON). Units are SI: m, kg, s, N; angles
//! are in degrees where the field name says `_deg`. Unknown fields are
//! refused so a typo does not silently fall back to a default.
//! `docs/scene-format.md` documents every field with examples.

use serde::Deserialize;

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

/// A humanoid ragdoll (see `inertia_physics::rigid::ragdoll`).
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

/// A joint between two named bodies.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// First body's name.
    pub a: String,
    /// Second body's name.
    pub b: String,
    /// Where the bodies are joined, world, m (default: midway between
    /// their origins).
    #[serde(default)]
    pub anchor: Option<Vec3>,
    /// What it constrains.
    pub kind: JointKindSpec,
    /// Force above which it breaks, N (default: never).
    #[serde(default)]
    pub break_force: Option<f64>,
}

/// What a joint constrains. Axes are in world coordinates at build time.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum JointKindSpec {
    /// The anchors stay together; rotation is free.
    Ball,
    /// The bodies move as one.
    Fixed,
    /// A hinge about `axis`, with optional angle limits and motor.
    Hinge {
        /// Hinge axis, world.
        axis: Vec3,
        /// Lower and upper angle, degrees.
        #[serde(default)]
        limits_deg: Option<(f64, f64)>,
        /// Target speed (deg/s) and largest torque (N·m).
        #[serde(default)]
        motor: Option<(f64, f64)>,
    },
    /// A ball joint whose swing is limited to a cone about `axis` and whose
    /// twist about it is limited.
    SwingTwist {
        /// Twist axis, world.
        axis: Vec3,
        /// Largest swing, degrees.
        swing_deg: f64,
        /// Largest twist either way, degrees.
        twist_deg: f64,
    },
    /// A slider along `axis` with optional limits (m) and motor.
    Prismatic {
        /// Slide axis, world.
        axis: Vec3,
        /// Lower and upper travel from the anchor, m.
        #[serde(default)]
        limits: Option<(f64, f64)>,
        /// Target speed (m/s) and largest force (N).
        #[serde(default)]
        motor: Option<(f64, f64)>,
    },
    /// The anchors stay between `min` and `max` apart, m.
    Distance {
        /// Smallest distance, m.
        min: f64,
        /// Largest distance, m.
        max: f64,
    },
}

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

fn yes() -> bool {
    true
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
