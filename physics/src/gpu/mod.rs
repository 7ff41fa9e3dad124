//! GPU stepping of particle systems, soft bodies and fluids through wgpu
//! compute (feature `gpu`). Soft bodies are in `gpu/soft.rs`, fluids in
//! `gpu/fluid.rs` (the rigid bodies both meet, and push back, in
//! `gpu/bodies.rs`); the note below is about particle systems.
//!
//! # Design note
//!
//! **Problem.** A particle system of 10⁵–10⁶ particles spends its step
//! streaming memory (field forces, integration) or in O(N²) arithmetic
//! (exact mutual gravity); both map well onto a GPU. The CPU engine is f64,
//! structure-of-arrays and bit-deterministic; the GPU path must keep as much
//! of that as a GPU allows, move state to and from the CPU on demand, and
//! never panic on bad input.
//!
//! **Precision.** WGSL has no f64, so GPU state is f32 (about 7 significant
//! digits). The CPU arrays stay the f64 *mirror*: the upload converts (and
//! refuses values outside the f32 range), downloads and readback steps
//! convert back. A system moved to the GPU and straight back is unchanged
//! (the mirror is not overwritten until the GPU has stepped). How far a GPU
//! run may drift from the CPU run is stated in [`GPU_TOLERANCE`] and
//! asserted by `physics/tests/gpu_*.rs`.
//!
//! **Layout.** One buffer of 32-byte bodies (position, flags, velocity: the
//! only thing a step writes and a readback copies), one of 32-byte constant
//! properties, the springs and their CSR adjacency as compiled by
//! `SpringTopology`, the control forces, and one force scratch buffer. See
//! `gpu/buffers.rs` for the table. The force generators go into a uniform block
//! rewritten every step, because `World::set_force` may change them between
//! steps; at most `MAX_FIELD_FORCES` winds/buoyancies/explosions and
//! `MAX_MUTUAL_GRAVITY` mutual gravities fit (more is refused with
//! [`PhysicsError::Gpu`](crate::PhysicsError::Gpu)).
//!
//! **Passes.** A step is cut into the same substeps as on the CPU (stiff
//! springs, `ParticleSystem::substeps_for`); each substep is one submission
//! of three dispatches (`inertia-shaders` has the WGSL):
//! 1. *springs* — one invocation per spring writes that spring's force to
//!    its own slot;
//! 2. *interactions* — one invocation per particle gathers its springs'
//!    forces over the CSR adjacency in adjacency order, then adds exact
//!    mutual gravity, tiled through workgroup memory, summing partners in
//!    index order like the CPU;
//! 3. *integrate* — one invocation per particle adds the field forces
//!    (gravity, drag, wind, buoyancy, explosions, control; the CPU's
//!    formulas and order), integrates (forward or symplectic Euler), keeps
//!    pinned and quarantined particles still, and quarantines a particle
//!    whose new state is not finite (last finite position, zero velocity).
//!
//! **Determinism.** Every invocation writes only its own slots and every
//! sum runs in a fixed order, so no pass uses atomics and a run repeats bit
//! for bit on the same device and driver. Energy after a readback step is
//! summed on the CPU, in index order, from the f64 mirror.
//!
//! **Options considered.** Scattering spring forces to both ends needs
//! float atomics (non-deterministic order, and not in core WGSL); the
//! gather over the CPU's CSR adjacency costs one extra pass and none of
//! that. Barnes–Hut needs a tree build per step (sort, reductions) and is
//! refused; exact tiled N-body is the GPU's strength up to ~10⁵ particles.
//! Leapfrog, Verlet and RK4 need several force evaluations (or history) per
//! step and are refused; forward and symplectic Euler are what large
//! particle effects use.
//!
//! **Adapters.** Vulkan and GL (`WGPU_BACKEND` overrides), real GPUs first,
//! Mesa lavapipe/llvmpipe last, so CI machines without a GPU run the same
//! shaders on the CPU. [`GpuContext::description`] says which one ran.

pub(crate) mod bodies;
mod buffers;
mod context;
pub(crate) mod fluid;
mod grid;
mod layout;
mod on_gpu;
mod params;
mod program;
mod self_collision;
pub(crate) mod soft;
mod system;
mod tolerance;

pub use bodies::MAX_GPU_BODIES;
pub use context::GpuContext;
pub use fluid::{FLUID_GPU_MEDIAN_TOLERANCE, FLUID_GPU_TOLERANCE};
pub use soft::SOFT_GPU_TOLERANCE;
pub use tolerance::{GpuTolerance, GPU_TOLERANCE};

pub(crate) use on_gpu::OnGpu;
pub(crate) use system::{download, step_system, upload};
