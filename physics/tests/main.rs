//! The engine's integration tests: the public API of `inertia-physics`
//! against analytic results, conservation laws, determinism, robustness
//! and (feature `gpu`) the GPU backends.
//!
//! One test binary for the crate (each links the whole crate and its
//! dependencies, so one binary builds in a fraction of the time of one per
//! file): every file of this folder is a module here, and so are the
//! helpers they share. One file's tests:
//! `cargo test -p inertia-physics --test integration <file>::`.

mod common;
// Its `gpu_or_skip!` is used by name in the GPU tests below.
#[cfg(feature = "gpu")]
#[macro_use]
mod gpu_support;

mod analytic;
mod barnes_hut;
mod convergence;
mod determinism;
mod energy;
mod forces;
mod gpu_agreement;
mod gpu_backend;
mod issue_11_saved_state_bounds;
mod issue_13_saved_contacts;
mod issue_13_stability;
mod issue_16_fluid;
mod issue_16_gpu_fluid;
mod issue_16_gpu_soft;
mod issue_16_soft;
mod projectile;
mod rigid_ballistic;
mod rigid_broad_phase;
mod rigid_builders;
mod rigid_contacts;
mod rigid_determinism;
mod rigid_forces;
mod rigid_joints;
mod rigid_motion;
mod rigid_prismatic;
mod rigid_queries;
mod rigid_recycling;
mod rigid_shapes;
mod rigid_solver;
mod robustness;
mod world_api;
