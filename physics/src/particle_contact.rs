//! Particles colliding with rigid bodies.
//!
//! A particle system with a collision radius (see
//! [`SystemDesc::collision_radius`](crate::SystemDesc::collision_radius))
//! is kept out of every rigid body's shape after each step: a particle that
//! ends a step closer than its radius to a surface (or inside a solid
//! shape) is moved out along the surface normal to exactly one radius away
//! (the position projection that cloth and rope solvers in games use).
//!
//! The collision is **two-way**. If the particle is approaching the surface,
//! a normal impulse stops the approach, computed with the effective mass of
//! the pair (`1 / (1/m_p + 1/M + (r × n) · I⁻¹ (r × n))`), so a heavy
//! particle moves a light body and a light particle barely moves a heavy
//! one; a friction impulse, at most `μ` times the normal one, acts against
//! the sliding. The particle takes the impulse and the body the opposite
//! one at the contact point, so linear momentum is conserved exactly and
//! a particle resting on a body weighs on it (`m g` on average). Static and
//! kinematic bodies take nothing; a sleeping body that is pushed wakes.
//!
//! Each particle is handled on its own against the bodies in handle order,
//! against the bodies' velocities at the end of the rigid step, so the pass
//! is parallel; the impulses on bodies are summed in particle order, so the
//! result is deterministic. Bodies are found with a bounding-box test per
//! particle, which is fine for the few bodies cloth and ropes drape over; a
//! broad-phase query would serve crowds.

use glam::DVec3;

use crate::arena::Arena;
use crate::parallel::{par_map_chunks4, CHUNK};
use crate::particle_system::ParticleSystem;
use crate::rigid::body::RigidBody;
use crate::rigid::query::project_point_shape;
use crate::xpbd::coupling::CouplingBody;

/// An impulse a particle gave a body: the body's key, the point (m) and
/// the impulse (N·s).
type BodyImpulse = ((u32, u32), DVec3, DVec3);

/// Pushes the particles of `sys` out of every body, exchanging impulses
/// with the bodies. Returns how many particles were moved.
pub(crate) fn resolve(sys: &mut ParticleSystem, bodies: &mut Arena<RigidBody>) -> usize {
    let radius = sys.collision_radius;
    if radius <= 0.0 || bodies.len() == 0 || sys.is_empty() {
        return 0;
    }
    let friction = sys.collision_friction;
    let targets: Vec<CouplingBody<'_>> = bodies
        .iter()
        .filter_map(|(index, generation, b)| CouplingBody::of((index, generation), b, radius))
        .collect();
    let ParticleSystem {
        position,
        velocity,
        inv_mass,
        flags,
        ..
    } = sys;
    let results = par_map_chunks4(
        position,
        velocity,
        inv_mass,
        flags,
        CHUNK,
        |_, xs, vs, ws, fs| {
            let mut moved = 0;
            let mut impulses: Vec<BodyImpulse> = Vec::new();
            for k in 0..xs.len() {
                if fs[k] != 0 {
                    continue;
                }
                for t in &targets {
                    let x = xs[k];
                    if !t.aabb.contains_point(x) {
                        continue;
                    }
                    let Some(p) = project_point_shape(t.shape, &t.pose, x) else {
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
                    moved += 1;
                    let w = ws[k];
                    // Velocity relative to the surface the particle touches.
                    let rel = vs[k] - t.velocity_at(p.point);
                    let vn = rel.dot(normal);
                    if vn >= 0.0 {
                        continue;
                    }
                    let kn = w + t.inv_mass_along(p.point, normal);
                    if kn <= 0.0 {
                        continue;
                    }
                    let jn = -vn / kn;
                    let tangential = rel - normal * vn;
                    let t_len = tangential.length();
                    let mut j = normal * jn;
                    if t_len > 1e-12 && friction > 0.0 {
                        let dir = tangential / t_len;
                        let kt = w + t.inv_mass_along(p.point, dir);
                        let jt = (t_len / kt).min(friction * jn);
                        j -= dir * jt;
                    }
                    // A particle of infinite mass (pinned) is skipped above by
                    // its flag; w > 0 here.
                    vs[k] += j * w;
                    if t.movable() {
                        impulses.push((t.key, p.point, -j));
                    }
                }
            }
            (moved, impulses)
        },
    );
    let mut moved = 0;
    for (m, impulses) in results {
        moved += m;
        for ((index, generation), point, j) in impulses {
            if let Some(b) = bodies.get_mut(index, generation) {
                if b.sleeping {
                    b.wake();
                }
                b.linvel += j * b.inv_mass;
                b.angvel += b.inverse_inertia_world() * (point - b.com).cross(j);
            }
        }
    }
    moved
}
