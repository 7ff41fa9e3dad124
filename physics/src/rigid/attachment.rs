//! Springs between a particle and a point on a rigid body: ropes and cloth
//! hang from bodies and pull on them.
//!
//! Each attachment is a damped Hooke spring (the particle engine's
//! [`SpringParams`]) between the particle and an anchor in the body's frame.
//! Its force is evaluated once at the start of a step from both states; the
//! particle receives it with its other interaction forces (for every
//! substep of its system), the body receives the opposite force at the
//! anchor (with the torque it makes) through the rigid step. The coupling is
//! explicit, so a very stiff attachment on a light particle needs the
//! particle system's substeps like any stiff spring.

use glam::DVec3;

use crate::handle::{BodyHandle, ParticleHandle};
use crate::spring::{spring_force, SpringParams};

/// A spring from a particle to a point on a body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attachment {
    /// The particle.
    pub particle: ParticleHandle,
    /// The body.
    pub body: BodyHandle,
    /// Anchor in the body's frame, m.
    pub anchor: DVec3,
    /// Rest length, stiffness and damping.
    pub params: SpringParams,
}

impl Attachment {
    /// Force on the particle, N, given the particle's position and velocity
    /// and the anchor's world position and velocity.
    pub(crate) fn force(&self, x: DVec3, v: DVec3, anchor: DVec3, anchor_v: DVec3) -> DVec3 {
        spring_force(x - anchor, v - anchor_v, &self.params)
    }
}
