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
    /// XPBD soft bodies: inextensible ropes, stiff cloth, jelly solids,
    /// balloons.
    #[serde(default)]
    pub soft_bodies: Vec<SoftBodySpec>,
    /// Position-based fluids, with their emitters.
    #[serde(default)]
    pub fluids: Vec<FluidSpec>,
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

/// A soft body on XPBD small steps: particles held by compliant
/// constraints (see `inertia_physics::xpbd::soft`). Unlike `ropes` and
/// `cloths` (mass-spring), it takes any stiffness at any tick rate, down
/// to an inextensible rope.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftBodySpec {
    /// Name, unique among soft bodies and fluids.
    pub name: String,
    /// What it is, with the compliances of its constraints.
    pub shape: SoftShapeSpec,
    /// Total mass, kg (> 0; default 1 for a rope, a cloth or a balloon; a
    /// solid weighs `density` times its volume unless this is given).
    #[serde(default)]
    pub mass: Option<f64>,
    /// Density, kg/m³, of a solid (`Box`, `Sphere`, `Mesh`) only (> 0;
    /// default 1000 when `mass` is not given).
    #[serde(default)]
    pub density: Option<f64>,
    /// Substeps per tick, 1..=64 (default 10; stiffer or heavier-loaded
    /// bodies want more).
    #[serde(default)]
    pub substeps: Option<u32>,
    /// Velocity damping, 1/s (>= 0; default 0.1).
    #[serde(default)]
    pub damping: Option<f64>,
    /// Multiplies the world's gravity (default 1).
    #[serde(default)]
    pub gravity_scale: Option<f64>,
    /// Radius of each particle against rigid bodies, m (>= 0; default 0:
    /// it passes through bodies).
    #[serde(default)]
    pub collision_radius: Option<f64>,
    /// Coulomb friction against rigid bodies (>= 0; default 0.3; a pair
    /// takes the larger of this and the body's).
    #[serde(default)]
    pub friction: Option<f64>,
    /// Particles keep `2 × collision_radius` apart from particles they are
    /// not joined to (cloth that folds onto itself).
    #[serde(default)]
    pub self_collision: bool,
    /// Plastic flow: past a yield strain it keeps part of its deformation
    /// (default: none, elastic).
    #[serde(default)]
    pub plasticity: Option<PlasticitySpec>,
    /// A constraint stretched past this strain breaks (tearing), > 0
    /// (default: never).
    #[serde(default)]
    pub tear_strain: Option<f64>,
    /// Initial velocity of every particle, m/s.
    #[serde(default)]
    pub velocity: Vec3,
    /// Particles pinned in place, beside the shape's own pins.
    #[serde(default)]
    pub pinned: Vec<ParticleSpec>,
    /// Particles held to points of named bodies.
    #[serde(default)]
    pub attach: Vec<SoftAttachSpec>,
    /// How clients draw its surface, rope or points (default coral).
    #[serde(default)]
    pub color: Option<[u8; 4]>,
}

/// What a soft body is. Compliance is the inverse of stiffness: 0 is
/// rigid (inextensible), larger is softer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum SoftShapeSpec {
    /// A chain of `segments + 1` particles from `start` to `end`.
    Rope {
        /// First particle, m.
        start: Vec3,
        /// Last particle, m.
        end: Vec3,
        /// Segments, 1..=10 000.
        segments: u32,
        /// How far the middle hangs below the straight line, m (a
        /// parabola; default 0). The rope is as long as the curve.
        #[serde(default)]
        sag: f64,
        /// Compliance of each segment, m/N (>= 0; default 0: inextensible).
        #[serde(default)]
        compliance: Option<f64>,
        /// Pin the first particle in place (default true).
        #[serde(default = "yes")]
        pin_start: bool,
        /// Pin the last particle in place.
        #[serde(default)]
        pin_end: bool,
        /// Tether every particle to the pinned end(s) at its distance as
        /// built, so no load stretches it away from its pins (default true).
        #[serde(default = "yes")]
        tethers: bool,
    },
    /// A sheet of `nu × nv` particles, triangulated, with bending across
    /// its inner edges. Particle `(u, v)` is index `v × nu + u`.
    Cloth {
        /// Particle (0, 0), m.
        origin: Vec3,
        /// Direction of the rows (default +X).
        #[serde(default)]
        u_axis: Option<Vec3>,
        /// Direction of the columns (default −Y: a hanging sheet).
        #[serde(default)]
        v_axis: Option<Vec3>,
        /// Extent along `u_axis`, m (> 0).
        width: f64,
        /// Extent along `v_axis`, m (> 0).
        height: f64,
        /// Particles along u, 2..=256.
        nu: u32,
        /// Particles along v, 2..=256.
        nv: u32,
        /// Grid coordinates `(u, v)` pinned in place.
        #[serde(default)]
        pinned: Vec<(u32, u32)>,
        /// Tether every free particle to its nearest pin, so the sheet
        /// cannot stretch away from its pins (default false).
        #[serde(default)]
        tethers: bool,
        /// Compliance of the grid lines, m/N (>= 0; default 0:
        /// inextensible).
        #[serde(default)]
        stretch_compliance: Option<f64>,
        /// Compliance of the diagonals, m/N (>= 0; default 1e-6).
        #[serde(default)]
        shear_compliance: Option<f64>,
        /// Compliance of the bending hinges, rad/(N·m) (>= 0; default 1).
        #[serde(default)]
        bend_compliance: Option<f64>,
    },
    /// A solid box filled with tetrahedra on a grid of cubes of side `cell`.
    Box {
        /// Centre, m.
        center: Vec3,
        /// Half the size along its x, y, z, m (each > 0).
        half_extents: Vec3,
        /// Orientation (default: none).
        #[serde(default)]
        rotation: Option<Rotation>,
        /// Side of the grid's cubes, m (> 0; at most 20 000 cubes).
        cell: f64,
        /// Compliance of the edges, m/N (>= 0; default 1e-6).
        #[serde(default)]
        edge_compliance: Option<f64>,
        /// Compliance of the volumes, 1/Pa (>= 0; default 0:
        /// incompressible).
        #[serde(default)]
        volume_compliance: Option<f64>,
    },
    /// A solid ball filled with tetrahedra on a grid of cubes of side
    /// `cell`, its surface moved onto the sphere.
    Sphere {
        /// Centre, m.
        center: Vec3,
        /// Radius, m (> 0).
        radius: f64,
        /// Side of the grid's cubes, m (> 0; at most 20 000 cubes).
        cell: f64,
        /// Compliance of the edges, m/N (>= 0; default 1e-6).
        #[serde(default)]
        edge_compliance: Option<f64>,
        /// Compliance of the volumes, 1/Pa (>= 0; default 0).
        #[serde(default)]
        volume_compliance: Option<f64>,
    },
    /// The inside of a closed triangle mesh, filled with tetrahedra on a
    /// grid of cubes of side `cell`.
    Mesh {
        /// Where the mesh's origin goes, m.
        #[serde(default)]
        position: Vec3,
        /// Orientation (default: none).
        #[serde(default)]
        rotation: Option<Rotation>,
        /// Vertices in the mesh's frame, m (at least 4).
        vertices: Vec<Vec3>,
        /// Triangles as vertex indices (at least 4; closed; any winding).
        triangles: Vec<[u32; 3]>,
        /// Side of the grid's cubes, m (> 0; at most 20 000 cubes).
        cell: f64,
        /// Compliance of the edges, m/N (>= 0; default 1e-6).
        #[serde(default)]
        edge_compliance: Option<f64>,
        /// Compliance of the volumes, 1/Pa (>= 0; default 0).
        #[serde(default)]
        volume_compliance: Option<f64>,
    },
    /// An inflated shell: a subdivided icosahedron whose enclosed volume
    /// is kept at `pressure` times its rest volume.
    Balloon {
        /// Centre, m.
        center: Vec3,
        /// Radius, m (> 0).
        radius: f64,
        /// Times each triangle is cut in four, 0..=6 (default 3: 642
        /// particles).
        #[serde(default)]
        subdivisions: Option<u32>,
        /// Compliance of the edges, m/N (>= 0; default 1e-4).
        #[serde(default)]
        stretch_compliance: Option<f64>,
        /// Compliance of the bending hinges, rad/(N·m) (>= 0; default 10).
        #[serde(default)]
        bend_compliance: Option<f64>,
        /// Volume kept over rest volume (> 0; default 1; above 1: inflated).
        #[serde(default)]
        pressure: Option<f64>,
        /// Compliance of the volume, 1/Pa (>= 0; default 0).
        #[serde(default)]
        pressure_compliance: Option<f64>,
    },
}

/// Plastic flow of a soft body's distance constraints.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlasticitySpec {
    /// Strain (length over rest length, minus one) past which the rest
    /// length flows, > 0.
    pub yield_strain: f64,
    /// How fast the strain past the yield flows into the rest length, 1/s
    /// (>= 0).
    pub creep: f64,
    /// Largest permanent strain, > 0.
    pub max_strain: f64,
}

/// Which particles of a soft body an entry means.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ParticleSpec {
    /// One particle by index (a rope's from `start`; a cloth's `v × nu +
    /// u`; a solid's or balloon's in build order).
    Index(u32),
    /// A rope's first particle.
    Start,
    /// A rope's last particle.
    End,
    /// A cloth's particle `(u, v)`.
    Grid(u32, u32),
    /// Every particle inside this box, world, m, as built (at least one).
    InBox {
        /// Lowest corner, m.
        min: Vec3,
        /// Highest corner, m.
        max: Vec3,
    },
}

/// Soft-body particles held to a named body (both ways: the body is
/// pulled too).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoftAttachSpec {
    /// Which particles.
    pub particles: ParticleSpec,
    /// The body's name.
    pub body: String,
    /// The point of the body they are held to, world, m, as built
    /// (default: where each particle is; only for a single particle).
    #[serde(default)]
    pub point: Option<Vec3>,
    /// Compliance of the hold, m/N (>= 0; default 0: rigid).
    #[serde(default)]
    pub compliance: Option<f64>,
}

/// A position-based fluid: particles `spacing` apart, each standing for a
/// cube of fluid `spacing` on a side. Its walls and floating things are
/// the scene's rigid bodies.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidSpec {
    /// Name, unique among soft bodies and fluids.
    pub name: String,
    /// Distance between neighbouring particles at rest, m (> 0).
    pub spacing: f64,
    /// Boxes filled with fluid at rest when the scene starts (they must
    /// not overlap).
    #[serde(default)]
    pub blocks: Vec<FluidBlockSpec>,
    /// Density at rest, kg/m³ (> 0; default 1000, water).
    #[serde(default)]
    pub rest_density: Option<f64>,
    /// Kernel (smoothing) radius, m, above `spacing` and at most 4 times
    /// it (default 2 × spacing).
    #[serde(default)]
    pub kernel_radius: Option<f64>,
    /// XSPH viscosity, 0..=1 (default 0.01).
    #[serde(default)]
    pub viscosity: Option<f64>,
    /// Vorticity confinement, m/s (>= 0; default 0, off).
    #[serde(default)]
    pub vorticity: Option<f64>,
    /// Substeps per tick, 1..=64 (default 4).
    #[serde(default)]
    pub substeps: Option<u32>,
    /// Coulomb friction of the particles on bodies (>= 0; default 0).
    #[serde(default)]
    pub friction: Option<f64>,
    /// How far particles are kept from bodies, m (>= 0, at most the kernel
    /// radius; default spacing / 2).
    #[serde(default)]
    pub collision_radius: Option<f64>,
    /// Multiplies the world's gravity (default 1).
    #[serde(default)]
    pub gravity_scale: Option<f64>,
    /// Most particles the fluid may hold, 1..=1 000 000 (default: the
    /// blocks' particles plus every emitter's `limit`; required when an
    /// emitter has no limit).
    #[serde(default)]
    pub max_particles: Option<u32>,
    /// Spouts that add particles over time.
    #[serde(default)]
    pub emitters: Vec<FluidEmitterSpec>,
    /// How clients draw its particles (default see-through blue).
    #[serde(default)]
    pub color: Option<[u8; 4]>,
}

/// An axis-aligned box of fluid at rest: particles on a cubic lattice
/// `spacing` apart, the outer ones half a spacing in from the faces.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidBlockSpec {
    /// Lowest corner, m.
    pub min: Vec3,
    /// Highest corner, m (at least one spacing above `min` on every axis).
    pub max: Vec3,
}

/// A spout: it fires a shot of particles every `interval` seconds of
/// simulation time from `start` until `stop`, each shot a disc of
/// particles `spacing` apart across the nozzle, moving at `velocity`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidEmitterSpec {
    /// Centre of the nozzle, m.
    pub position: Vec3,
    /// Velocity of the particles let out, m/s (not zero: it is also the
    /// nozzle's axis).
    pub velocity: Vec3,
    /// Radius of the nozzle, m (>= 0; default 0: one particle a shot).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Time between shots, s (> 0, at least spacing / speed so shots do
    /// not overlap; default spacing / speed: a continuous jet).
    #[serde(default)]
    pub interval: Option<f64>,
    /// When the first shot is due, s of simulation time (>= 0; default 0).
    #[serde(default)]
    pub start: Option<f64>,
    /// No shot after this time, s (>= `start`; default: never).
    #[serde(default)]
    pub stop: Option<f64>,
    /// Most particles it adds in all (> 0; default: until the fluid's cap).
    #[serde(default)]
    pub limit: Option<u32>,
}
