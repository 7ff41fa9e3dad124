//! The rotation of a spinning rigid body between contacts and joints (the
//! substep loop in [`pipeline`](super::pipeline) calls it for every
//! dynamic body).
//!
//! # Rotation: why a splitting method
//!
//! A torque-free body keeps its angular momentum `L` (world) but not its
//! angular velocity: `ω = I_w⁻¹ L` changes as the body turns, which is what
//! makes a box spun about its intermediate axis tumble (the tennis-racket or
//! Dzhanibekov effect). The textbook explicit update
//! `ω += dt I⁻¹ (τ - ω × Iω)` gains energy and spins up; implicit
//! gyroscopic solvers (one Newton step, as in Box2D/Jolt) are stable but
//! bleed angular momentum.
//!
//! We integrate the body-frame angular momentum `π` and the orientation
//! together with the symplectic splitting of Dullweber, Leimkuhler and
//! McLachlan ("Symplectic splitting methods for rigid body molecular
//! dynamics", J. Chem. Phys. 107, 1997; McLachlan 1993). The free-body
//! energy `Σ π_i² / 2I_i` splits into three terms, one per principal axis,
//! and each is solved exactly: the body turns about axis `i` by
//! `θ = π_i dt / I_i` while `π` turns the other way. Composed symmetrically,
//! `R₁(dt/2) R₂(dt/2) R₃(dt) R₂(dt/2) R₁(dt/2)`, the step is second order,
//! time-reversible and symplectic; `L = R π` is conserved to rounding
//! (every sub-rotation moves `R` and `π` by inverse rotations), and the
//! energy error stays bounded.

use glam::{DQuat, DVec3};

/// The splitting step for the free rigid body: `q` takes principal-frame
/// vectors to the world, `pi` is the angular momentum in the principal
/// frame, `inv_inertia` the inverse principal moments.
pub(crate) fn free_rotation(
    mut q: DQuat,
    mut pi: DVec3,
    inv_inertia: DVec3,
    dt: f64,
) -> (DQuat, DVec3) {
    const AXES: [DVec3; 3] = [DVec3::X, DVec3::Y, DVec3::Z];
    for (axis, h) in [(0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)] {
        let theta = pi[axis] * inv_inertia[axis] * h * dt;
        let turn = DQuat::from_axis_angle(AXES[axis], theta);
        q *= turn;
        pi = turn.inverse() * pi;
    }
    (q.normalize(), pi)
}
