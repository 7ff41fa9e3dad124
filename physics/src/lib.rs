//! # inertia-physics
//!
//! The Inertia physics engine: particle systems stored as structure-of-arrays,
//! composable force generators, a choice of integrators, mass-spring soft
//! bodies, rigid bodies, XPBD soft bodies and position-based fluids
//! ([`xpbd`]), energy accounting, a state hash and exact save/restore,
//! parallel and bit-deterministic CPU stepping, a walking character's
//! controller ([`character`]), and (feature `gpu`) wgpu
//! compute stepping.
//!
//! No sockets, no async runtime, and no wall clock in the simulation: time is
//! the `dt` the caller passes to [`World::step`]. Units are SI throughout
//! (m, s, kg, N, J).
//!
//! ```
//! use inertia_physics::{World, WorldConfig, SystemDesc, ParticleDesc, UniformGravity, Integrator};
//! use glam::DVec3;
//!
//! let mut world = World::new(WorldConfig::default()).unwrap();
//! let sys = world.add_system(SystemDesc::with_integrator(Integrator::ForwardEuler));
//! world.add_force(sys, UniformGravity { g: 1.0, direction: DVec3::NEG_Y }).unwrap();
//! let p = world
//!     .add_particle(sys, ParticleDesc::at(DVec3::ZERO, 1.0).with_velocity(DVec3::new(2.0, 3.0, 0.0)))
//!     .unwrap();
//! for _ in 0..7 {
//!     world.step(1.0).unwrap();
//! }
//! // The classic lecture table: after 7 s of forward Euler at dt = 1 s the
//! // projectile is back on the ground at x = 14.
//! assert_eq!(world.particle(p).unwrap().position, DVec3::new(14.0, 0.0, 0.0));
//! ```

mod arena;
pub mod character;
pub mod energy;
pub mod error;
pub mod forces;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod handle;
pub mod integrator;
pub mod limits;
mod parallel;
mod particle_contact;
pub mod particle_system;
pub mod profile;
pub mod ragdoll;
pub mod rigid;
pub mod saved_state;
pub mod soft_body;
pub mod spring;
pub mod world;
pub mod xpbd;

pub use energy::Energy;
pub use error::PhysicsError;
pub use forces::{
    Buoyancy, Drag, Explosion, Force, GravityMethod, MutualGravity, UniformGravity, Wind,
};
/// Re-export of the math library used in the public API.
pub use glam;
pub use handle::{
    AttachmentHandle, BodyForceHandle, BodyHandle, FluidHandle, ForceHandle, JointHandle,
    ParticleHandle, SoftBodyHandle, SpringHandle, SystemHandle,
};
pub use integrator::Integrator;
pub use particle_system::{
    Backend, ParticleDesc, ParticleState, ParticleSystem, SystemDesc, MAX_GROUPS,
};
pub use profile::{ProfileTotals, RigidProfile, StepProfile};
pub use saved_state::SavedStateError;
pub use soft_body::{build_cloth, build_rope, Cloth, ClothDesc, Rope, RopeDesc, SpringStiffness};
pub use spring::SpringParams;
pub use world::{QueryIndex, StepReport, ThreadPinning, World, WorldConfig};
pub use xpbd::fluid::{EmitterState, Fluid, FluidDesc, FluidEmitter};
pub use xpbd::soft::{
    EdgeDesc, HingeDesc, Plasticity, PressureDesc, SoftBalloon, SoftBody, SoftBodyDesc, SoftCloth,
    SoftMaterial, SoftRope, SoftSolid, SolidShape, TetDesc, TetherDesc,
};
