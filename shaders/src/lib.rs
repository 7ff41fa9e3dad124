//! # inertia-shaders
//!
//! Inertia's WGSL shaders (the engine's compute passes and the viewer's
//! drawing), kept as real `.wgsl` files under `wgsl/`
//! (so editors and `naga` can read them) and exported here as source strings.
//! `tests/validate.rs` parses and validates every one with naga and checks
//! that the layouts they declare match the byte sizes in [`layout`], which
//! the engine's `#[repr(C)]` mirrors assert at compile time.
//!
//! The GPU particle step (`inertia-physics`, feature `gpu`) runs three passes
//! per step, each one invocation per item and each writing only its own
//! slots, so no pass needs atomics and every sum has a fixed order:
//!
//! 1. [`PARTICLE_SPRINGS`]: one force per spring;
//! 2. [`PARTICLE_INTERACTIONS`]: per particle, gather its spring forces over
//!    the CSR adjacency and add tiled exact mutual gravity;
//! 3. [`PARTICLE_INTEGRATE`]: per particle, field forces plus interactions,
//!    forward or symplectic Euler, pinning and quarantine.

/// Pass 1 of a GPU particle step: damped Hooke force of every spring.
pub const PARTICLE_SPRINGS: &str = include_str!("../wgsl/particle_springs.wgsl");

/// Pass 2 of a GPU particle step: spring gather and tiled exact N-body gravity.
pub const PARTICLE_INTERACTIONS: &str = include_str!("../wgsl/particle_interactions.wgsl");

/// Pass 3 of a GPU particle step: field forces and Euler integration.
pub const PARTICLE_INTEGRATE: &str = include_str!("../wgsl/particle_integrate.wgsl");

/// Rigid bodies as particles see them on the GPU: their shapes along
/// their path over the step, the surface nearest a point, and the pushes
/// particles give the dynamic ones, summed per body in a fixed order
/// (`reduce_chunks`, `reduce_bodies`) and moving them (`take_pushes`,
/// `advance_bodies`). Not a shader of its own: the head of [`XPBD_SOFT`]
/// and [`PBF`].
pub const BODIES: &str = include_str!("../wgsl/bodies.wgsl");

/// XPBD soft bodies on the GPU: `predict`, `finish` (velocities, fused
/// with the next substep's prediction) and `project` (one colour of one
/// constraint kind: distance, bending, volume, tether), dispatched colour
/// by colour; `find_contacts` and `collide` against rigid bodies
/// ([`BODIES`] first).
pub const XPBD_SOFT: &str = concat!(
    include_str!("../wgsl/bodies.wgsl"),
    include_str!("../wgsl/xpbd_soft.wgsl")
);

/// The neighbour grid by a counting sort (`count`, `scan`, `scatter`,
/// `sort_cells`) and the walk over a particle's neighbours. Not a shader
/// of its own: the head of [`PBF`] and [`XPBD_SELF_COLLISION`].
pub const GRID: &str = include_str!("../wgsl/grid.wgsl");

/// Position-based fluids on the GPU: the neighbour grid ([`GRID`]), the
/// walls near each particle (`find_walls`), the substeps (`predict`,
/// `densities`, `corrections`, `collide`) and the velocity passes after
/// them (`vorticity`, `confine`, `xsph`, `take_velocities`) ([`BODIES`]
/// and [`GRID`] first).
pub const PBF: &str = concat!(
    include_str!("../wgsl/bodies.wgsl"),
    include_str!("../wgsl/grid.wgsl"),
    include_str!("../wgsl/pbf.wgsl")
);

/// Cloth self-collision on the GPU: its candidates on the neighbour grid
/// once a step ([`GRID`] first), and each substep a Jacobi pass (`keep`,
/// `self_collide`).
pub const XPBD_SELF_COLLISION: &str = concat!(
    include_str!("../wgsl/grid.wgsl"),
    include_str!("../wgsl/xpbd_self_collision.wgsl")
);

/// The viewer's scene shader (`inertia-viewer`): lit, instanced meshes
/// (`vs_main`, `fs_main`) and static scenery with a metre grid
/// (`fs_gridded`).
pub const VIEWER_SCENE: &str = include_str!("../wgsl/viewer_scene.wgsl");

/// Every drawing (vertex and fragment) shader as `(file name, source)`.
pub const DRAWING: &[(&str, &str)] = &[("viewer_scene.wgsl", VIEWER_SCENE)];

/// Every compute shader as `(file name, source)`, for validation and tooling.
pub const ALL: &[(&str, &str)] = &[
    ("particle_springs.wgsl", PARTICLE_SPRINGS),
    ("particle_interactions.wgsl", PARTICLE_INTERACTIONS),
    ("particle_integrate.wgsl", PARTICLE_INTEGRATE),
    ("xpbd_soft.wgsl", XPBD_SOFT),
    ("xpbd_self_collision.wgsl", XPBD_SELF_COLLISION),
    ("pbf.wgsl", PBF),
];

/// Sizes and limits of the data the particle shaders share with the engine.
/// The shaders declare the same numbers; `tests/validate.rs` checks them
/// against naga's layout of each struct.
pub mod layout {
    /// Invocations per workgroup of every particle pass (and the N-body tile
    /// length). 64 is a multiple of every vendor's SIMD width (32 or 64).
    pub const WORKGROUP_SIZE: u32 = 64;
    /// Most field-force records (winds + buoyancies + explosions) one system
    /// may carry in a step: they live in the uniform block, 48 bytes each.
    pub const MAX_FIELD_FORCES: usize = 64;
    /// Most mutual-gravity generators one system may carry.
    pub const MAX_MUTUAL_GRAVITY: usize = 4;
    /// `struct Body`: position (m), flags, velocity (m/s), padding.
    pub const BODY_BYTES: usize = 32;
    /// `struct Props`: per-particle constants.
    pub const PROPS_BYTES: usize = 32;
    /// `struct Spring`: endpoints, rest length, stiffness, damping.
    pub const SPRING_BYTES: usize = 20;
    /// `struct FieldForce`: three `vec4<f32>`.
    pub const FIELD_FORCE_BYTES: usize = 48;
    /// `struct Params` of `xpbd_soft.wgsl`: one dispatch's uniform slot.
    pub const SOFT_PARAMS_BYTES: usize = 128;
    /// `struct Distance` of `xpbd_soft.wgsl`.
    pub const SOFT_DISTANCE_BYTES: usize = 16;
    /// `struct Quad` of `xpbd_soft.wgsl` (hinges and tetrahedra).
    pub const SOFT_QUAD_BYTES: usize = 32;
    /// `struct SelfParams` of `xpbd_self_collision.wgsl`.
    pub const SELF_PARAMS_BYTES: usize = 32;
    /// `struct Tether` of `xpbd_soft.wgsl`.
    pub const SOFT_TETHER_BYTES: usize = 16;
    /// `struct Attachment` of `xpbd_soft.wgsl`: a particle held to a rigid
    /// body.
    pub const SOFT_ATTACHMENT_BYTES: usize = 32;
    /// Triangles, and particles, whose pressure sums one invocation of
    /// `shell_sums` takes (`SHELL_CHUNK` of `xpbd_soft.wgsl`).
    pub const SHELL_CHUNK: usize = 256;
    /// `struct FluidParams` of `pbf.wgsl`: one step's uniform block (the
    /// wall table's 2 × 64 entries included).
    pub const FLUID_PARAMS_BYTES: usize = 144 + 2 * 64 * 4;
    /// `struct Shape` of `bodies.wgsl`: a rigid body particles meet.
    pub const SHAPE_BYTES: usize = 272;
    /// `struct Push` of `bodies.wgsl`: a positional impulse and its moment.
    pub const PUSH_BYTES: usize = 32;
    /// `struct Motion` of `bodies.wgsl`: what a soft body's stage did to a
    /// rigid body.
    pub const MOTION_BYTES: usize = 80;
    /// Particles whose pushes one invocation of `reduce_chunks` sums
    /// (`PUSH_CHUNK` of `bodies.wgsl`).
    pub const PUSH_CHUNK: usize = 1024;
    /// Bodies a particle keeps over a step (`BODY_SLOTS` of
    /// `bodies.wgsl`): a fluid particle's planes, a soft body's contacts.
    pub const BODY_SLOTS: usize = 4;
    /// `struct Plane` of `pbf.wgsl`: a wall near a particle.
    pub const FLUID_PLANE_BYTES: usize = 32;
    /// `struct Slot` of `pbf.wgsl`: a slot of the neighbour grid.
    pub const FLUID_SLOT_BYTES: usize = 16;
    /// Invocations of the fluid's one-workgroup prefix sum (`SCAN_SIZE`).
    pub const FLUID_SCAN_SIZE: u32 = 256;
    /// `struct Params`: the per-step uniform block.
    pub const PARAMS_BYTES: usize =
        96 + 16 * MAX_MUTUAL_GRAVITY + FIELD_FORCE_BYTES * MAX_FIELD_FORCES;
}
