//! Free motion of rigid bodies: gravity, damping, scripted forces and
//! torques, and the rotation of a spinning body — everything a body does
//! between contacts and joints.
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

use crate::rigid::body::{BodyKind, RigidBody};

/// Advances one body by `dt` seconds under uniform `gravity` (m/s², before
/// the body's gravity scale). Returns false, leaving the body untouched, if
/// the result would not be finite.
pub(crate) fn integrate(
    body: &mut RigidBody,
    gravity: DVec3,
    force: DVec3,
    torque: DVec3,
    dt: f64,
) -> bool {
    match body.kind {
        BodyKind::Static => true,
        BodyKind::Kinematic => {
            let com = body.com + body.linvel * dt;
            let rotation = rotate_by(body.rotation, body.angvel, dt);
            if !(com.is_finite() && rotation.is_finite()) {
                return false;
            }
            body.com = com;
            body.rotation = rotation;
            true
        }
        BodyKind::Dynamic => {
            if body.sleeping || body.quarantined {
                return true;
            }
            let (com, linvel, rotation, angvel) = dynamic_step(body, gravity, force, torque, dt);
            if !(com.is_finite()
                && linvel.is_finite()
                && rotation.is_finite()
                && angvel.is_finite())
            {
                return false;
            }
            body.com = com;
            body.linvel = linvel;
            body.rotation = rotation;
            body.angvel = angvel;
            true
        }
    }
}

/// The new `(com, linear velocity, rotation, angular velocity)` of a dynamic
/// body under `gravity` (before its scale) and an external `force` (N, at the
/// centre of mass) and `torque` (N·m), both on top of its scripted control.
fn dynamic_step(
    b: &RigidBody,
    gravity: DVec3,
    force: DVec3,
    torque: DVec3,
    dt: f64,
) -> (DVec3, DVec3, DQuat, DVec3) {
    // Linear: symplectic Euler with implicit damping.
    let accel = gravity * b.gravity_scale + (b.control_force + force) * b.inv_mass;
    let linvel = (b.linvel + accel * dt) / (1.0 + dt * b.linear_damping);
    let com = b.com + linvel * dt;

    // Angular: torque kick on the body-frame momentum, then the free rotation.
    let inertia = b.inv_principal_inertia.recip();
    let q = b.principal_rotation();
    let pi = inertia * (q.inverse() * b.angvel) + q.inverse() * ((b.control_torque + torque) * dt);
    let (q, pi) = free_rotation(q, pi, b.inv_principal_inertia, dt);
    let angvel = (q * (b.inv_principal_inertia * pi)) / (1.0 + dt * b.angular_damping);
    let rotation = (q * b.principal.inverse()).normalize();
    (com, linvel, rotation, angvel)
}

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

/// `q` turned by the world angular velocity `omega` for `dt`.
fn rotate_by(q: DQuat, omega: DVec3, dt: f64) -> DQuat {
    let angle = omega.length() * dt;
    if angle == 0.0 {
        return q;
    }
    (DQuat::from_axis_angle(omega.normalize(), angle) * q).normalize()
}
