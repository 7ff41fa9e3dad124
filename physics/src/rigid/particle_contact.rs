//! Particles colliding with rigid bodies.
//!
//! A particle system with a collision radius (see
//! [`SystemDesc::collision_radius`](crate::SystemDesc::collision_radius))
//! is kept out of every rigid body's shape after each step: a particle that
//! ends a step closer than its radius to a surface (or inside a solid
//! shape) is moved out along the surface normal to exactly one radius away,
//! loses the part of its velocity that points into the surface, and its
//! sliding velocity is reduced by Coulomb friction (`μ` times the removed
//! normal speed). This is the position projection that cloth and rope
//! solvers in games use; it is one-way: bodies do not feel the particles
//! (two-way coupling would go through the contact solver).
//!
//! Each particle is handled on its own against the bodies in handle order,
//! so the pass is parallel and deterministic. Bodies are found with a
//! bounding-box test per particle, which is fine for the few bodies cloth
//! and ropes drape over; a broad-phase query would serve crowds.

use crate::arena::Arena;
use crate::parallel::{par_map_chunks3, CHUNK};
use crate::particle_system::ParticleSystem;
use crate::rigid::body::RigidBody;
use crate::rigid::query::project_point_shape;

/// Pushes the particles of `sys` out of every body. Returns how many were
/// moved.
pub(crate) fn resolve(sys: &mut ParticleSystem, bodies: &Arena<RigidBody>) -> usize {
    let radius = sys.collision_radius;
    if radius <= 0.0 || bodies.len() == 0 || sys.is_empty() {
        return 0;
    }
    let friction = sys.collision_friction;
    let targets: Vec<_> = bodies
        .iter()
        .filter(|(_, _, b)| !b.sensor)
        .filter_map(|(_, _, b)| {
            let shape = b.shape.as_ref()?;
            let pose = b.pose();
            Some((shape, pose, shape.aabb(&pose).expanded(radius), b))
        })
        .collect();
    let ParticleSystem {
        position,
        velocity,
        flags,
        ..
    } = sys;
    let moved = par_map_chunks3(position, velocity, flags, CHUNK, |_, xs, vs, fs| {
        let mut moved = 0;
        for k in 0..xs.len() {
            if fs[k] != 0 {
                continue;
            }
            for (shape, pose, aabb, body) in &targets {
                let x = xs[k];
                if !aabb.contains_point(x) {
                    continue;
                }
                let Some(p) = project_point_shape(shape, pose, x) else {
                    continue;
                };
                if !p.inside && p.distance >= radius {
                    continue;
                }
                // Outward normal: from the surface point to the particle,
                // flipped when the particle is inside.
                let to = x - p.point;
                let len = to.length();
                let normal = if len > 1e-12 {
                    if p.inside {
                        -to / len
                    } else {
                        to / len
                    }
                } else {
                    continue;
                };
                let target = p.point + normal * radius;
                if !target.is_finite() {
                    continue;
                }
                xs[k] = target;
                // Velocity relative to the surface the particle touches.
                let surface_v = body.velocity_at(p.point);
                let rel = vs[k] - surface_v;
                let vn = rel.dot(normal);
                if vn < 0.0 {
                    let tangential = rel - normal * vn;
                    let t_len = tangential.length();
                    let keep = if t_len > 0.0 {
                        (1.0 - friction * -vn / t_len).max(0.0)
                    } else {
                        0.0
                    };
                    vs[k] = surface_v + tangential * keep;
                }
                moved += 1;
            }
        }
        moved
    });
    moved.iter().sum()
}
