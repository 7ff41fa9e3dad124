//! Soft bodies and fluids as clients see them: one entity described as a
//! [`ShapeDesc::PointSet`] (how many points, how to draw them), whose
//! points travel in snapshots as the entities just after it. Point `i` of
//! the set with id `s` is entity `s + 1 + i`: an ordinary entity state
//! with an identity rotation, so the snapshot codec quantizes, delta-codes,
//! budgets and culls each point like any body, and a resting cloth costs
//! nothing once sent.
//!
//! A description stays within the protocol's bounds: a body of more
//! points than a set holds streams its first
//! [`ShapeDesc::MAX_SET_POINTS`]; triangles (or lines) past what a spawn
//! holds, or using a point past that cut, are left out and the client
//! draws the points alone.

use inertia_physics::glam::{DVec3, Vec3};
use inertia_physics::xpbd::fluid::Fluid;
use inertia_physics::xpbd::soft::SoftBody;
use inertia_protocol::{EntityDesc, EntityKind, EntityState, ShapeDesc};

/// Drawing radius of a soft body's points when it does not collide, m.
pub const DEFAULT_POINT_RADIUS: f32 = 0.02;

/// The description of a soft body: its points, its surface triangles
/// (cloth, a solid's hull) or, when it has none (a rope), its edges as
/// lines. Placed at its centre of mass; `id` is set by the table.
pub fn soft_body_desc(body: &SoftBody, name: String, color: [u8; 4]) -> EntityDesc {
    let points = points_streamed(body.len());
    let radius = match body.material().collision_radius as f32 {
        r if r > 0.0 => r,
        _ => DEFAULT_POINT_RADIUS,
    };
    let inside = |i: &u32| *i < points;
    let mut triangles: Vec<[u32; 3]> = body
        .triangles()
        .iter()
        .filter(|t| t.iter().all(inside))
        .copied()
        .collect();
    if triangles.len() > ShapeDesc::MAX_SET_TRIANGLES {
        triangles.clear();
    }
    let mut lines: Vec<[u32; 2]> = Vec::new();
    if body.triangles().is_empty() {
        lines = body
            .edges()
            .map(|(edge, ..)| edge)
            .filter(|e| e.iter().all(inside))
            .collect();
        if lines.len() > ShapeDesc::MAX_SET_LINES {
            lines.clear();
        }
    }
    EntityDesc {
        id: 0,
        kind: EntityKind::SoftBody,
        shape: ShapeDesc::PointSet {
            points,
            radius,
            triangles,
            lines,
        },
        color,
        owner: None,
        name,
        position: body.centre_of_mass().to_array(),
        rotation: [0.0, 0.0, 0.0, 1.0],
    }
}

/// The description of a fluid: as many points as it may ever hold (its
/// capacity, up to a set's), each drawn as a ball of half the particle
/// spacing. Placed at the centre of its particles; `id` is set by the
/// table.
pub fn fluid_desc(fluid: &Fluid, name: String, color: [u8; 4]) -> EntityDesc {
    let x = fluid.positions();
    let centre = if x.is_empty() {
        DVec3::ZERO
    } else {
        x.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / x.len() as f64
    };
    EntityDesc {
        id: 0,
        kind: EntityKind::Fluid,
        shape: ShapeDesc::PointSet {
            points: points_streamed(fluid.max_particles().max(1)),
            radius: 0.5 * fluid.spacing(),
            triangles: Vec::new(),
            lines: Vec::new(),
        },
        color,
        owner: None,
        name,
        position: centre.to_array(),
        rotation: [0.0, 0.0, 0.0, 1.0],
    }
}

/// The points of a set a body of `n` points streams.
fn points_streamed(n: usize) -> u32 {
    u32::try_from(n)
        .unwrap_or(u32::MAX)
        .clamp(1, ShapeDesc::MAX_SET_POINTS)
}

/// Appends the state of every point the set `desc` streams and the body
/// has (`positions` m and `velocities` m/s, by point), in id order.
pub fn push_points(
    desc: &EntityDesc,
    positions: &[Vec3],
    velocities: &[Vec3],
    out: &mut Vec<EntityState>,
) {
    let ShapeDesc::PointSet { points, .. } = desc.shape else {
        return;
    };
    let n = positions.len().min(velocities.len()).min(points as usize);
    out.extend((0..n).map(|i| EntityState {
        id: desc.id + 1 + i as u32,
        position: positions[i].as_dvec3(),
        rotation: inertia_physics::glam::DQuat::IDENTITY,
        linear_velocity: velocities[i].as_dvec3(),
        angular_velocity: DVec3::ZERO,
        asleep: false,
    }));
}
