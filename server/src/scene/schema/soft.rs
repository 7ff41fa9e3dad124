//! XPBD soft bodies and fluids.

use serde::Deserialize;

use super::*;

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
