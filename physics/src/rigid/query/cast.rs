//! Linear shape casts by conservative advancement (see the note in the
//! parent module).

use glam::DVec3;

use super::cell_triangles;
use crate::rigid::aabb::Aabb;
use crate::rigid::narrow::gjk::{self, GjkResult};
use crate::rigid::narrow::to_convex;
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;

/// A shape cast stops when the gap is below this, m.
pub const CAST_TOLERANCE: f64 = 1e-4;

/// Conservative advancement gives up after this many steps and reports
/// the time reached (which is never past the true time of impact).
const CAST_MAX_ITERATIONS: usize = 256;

/// Why a shape cast could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CastError {
    /// The moving shape must be convex (sphere, cuboid, capsule, cylinder
    /// or hull); cast each child of a compound instead.
    #[error("the cast shape must be convex, got a {0}")]
    NotConvex(&'static str),
    /// A pose is not finite or its rotation is not unit.
    #[error("pose of the {0} shape is not finite or its rotation is not unit")]
    BadPose(&'static str),
}

/// The first time `t` in `[0, max_t]` at which the convex `shape`, moved
/// from `pose` to `pose + t · dir` without turning, touches `target` at
/// `target_pose` (to [`CAST_TOLERANCE`]); `t` is in units of `|dir|`.
/// Shapes already touching give `t = 0`. Compound targets are cast
/// child by child; triangle meshes and heightfields triangle by triangle
/// (those whose box meets the swept box).
///
/// `None` for a miss, a zero or non-finite `dir` or a bad `max_t`.
///
/// # Errors
/// [`CastError::NotConvex`] for a non-convex moving shape,
/// [`CastError::BadPose`] for a bad pose.
pub fn cast_shape(
    shape: &Shape,
    pose: &Pose,
    dir: DVec3,
    max_t: f64,
    target: &Shape,
    target_pose: &Pose,
) -> Result<Option<f64>, CastError> {
    if !pose.is_valid() {
        return Err(CastError::BadPose("cast"));
    }
    if !target_pose.is_valid() {
        return Err(CastError::BadPose("target"));
    }
    let Some(mover) = to_convex(shape, *pose) else {
        return Err(CastError::NotConvex(shape.kind_name()));
    };
    let len = dir.length();
    if len <= 0.0 || !len.is_finite() || max_t.is_nan() || max_t < 0.0 {
        return Ok(None);
    }
    let unit = dir / len;
    let max = max_t * len;
    let start = shape.aabb(pose);
    let end = shape.aabb(&Pose::new(pose.translation + dir * max_t, pose.rotation));
    let swept = start.union(&end).expanded(CAST_TOLERANCE);
    let sa = |d: DVec3| mover.core_support(d);
    let mut best: Option<f64> = None;
    let mut visit = |sb: &dyn Fn(DVec3) -> DVec3, rb: f64, scale: f64, centre: DVec3| {
        let limit = best.unwrap_or(max);
        if let Some(t) = advance(&sa, mover.radius, sb, rb, unit, limit, scale, centre) {
            if best.is_none_or(|b| t < b) {
                best = Some(t);
            }
        }
    };
    each_convex_leaf(target, *target_pose, &swept, &mut visit);
    Ok(best.map(|t| t / len))
}

/// A support function: the farthest point (m) along a direction.
type Support<'s> = &'s dyn Fn(DVec3) -> DVec3;

/// Receives a convex piece: support of its core, radius (m), size (m) and
/// a point inside it.
type LeafVisitor<'v> = dyn FnMut(Support<'_>, f64, f64, DVec3) + 'v;

/// Calls `f(support, radius, size, centre)` for every convex piece of
/// `shape` at `pose` whose box meets `bounds`: the shape itself, the
/// children of a compound, the triangles of a mesh or heightfield.
fn each_convex_leaf(shape: &Shape, pose: Pose, bounds: &Aabb, f: &mut LeafVisitor<'_>) {
    match shape {
        Shape::Compound(parts) => {
            for (p, child) in parts.iter() {
                each_convex_leaf(child, pose.mul(p), bounds, f);
            }
        }
        Shape::TriMesh(mesh) => {
            let v = mesh.vertices();
            for t in mesh.triangles() {
                triangle_leaf(t.map(|k| pose.transform_point(v[k as usize])), bounds, f);
            }
        }
        Shape::HeightField(field) => {
            // Only the cells under the bounds (mapped into the field's frame).
            let corners: Vec<DVec3> = (0..8)
                .map(|k| {
                    let pick = |bit: usize, i: usize| {
                        if k & bit != 0 {
                            bounds.max[i]
                        } else {
                            bounds.min[i]
                        }
                    };
                    pose.inverse_transform_point(DVec3::new(pick(1, 0), pick(2, 1), pick(4, 2)))
                })
                .collect();
            let Some(local) = Aabb::from_points(&corners) else {
                return;
            };
            let s = field.scale();
            let cells = |lo: f64, hi: f64, size: f64, n: usize| {
                let g = |x: f64| (x / size + 0.5) * (n - 1) as f64;
                let clamp = |x: f64| x.clamp(0.0, (n - 2) as f64) as usize;
                if g(hi) < 0.0 || g(lo) > (n - 1) as f64 {
                    return None;
                }
                Some(clamp(g(lo).floor())..=clamp(g(hi).floor()))
            };
            let (Some(rows), Some(cols)) = (
                cells(local.min.z, local.max.z, s.z, field.rows()),
                cells(local.min.x, local.max.x, s.x, field.cols()),
            ) else {
                return;
            };
            for r in rows {
                for c in cols.clone() {
                    for tri in cell_triangles(field, r, c).into_iter().flatten() {
                        triangle_leaf(tri.map(|v| pose.transform_point(v)), bounds, f);
                    }
                }
            }
        }
        s => {
            if !s.aabb(&pose).intersects(bounds) {
                return;
            }
            if let Some(cv) = to_convex(s, pose) {
                let sb = |d: DVec3| cv.core_support(d);
                f(&sb, cv.radius, cv.size(), pose.translation);
            }
        }
    }
}

fn triangle_leaf(t: [DVec3; 3], bounds: &Aabb, f: &mut LeafVisitor<'_>) {
    let b = Aabb::new(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
    if !b.intersects(bounds) {
        return;
    }
    let centre = (t[0] + t[1] + t[2]) / 3.0;
    let size = (b.max - b.min).max_element();
    let sb = |d: DVec3| {
        let mut best = t[0];
        for &v in &t[1..] {
            if v.dot(d) > best.dot(d) {
                best = v;
            }
        }
        best
    };
    f(&sb, 0.0, size, centre);
}

/// Conservative advancement of core `sa` (radius `ra`) along the unit `u`
/// towards core `sb` (radius `rb`): the distance travelled at first touch,
/// or `None` if it does not happen within `max` m.
#[allow(clippy::too_many_arguments)]
fn advance(
    sa: &dyn Fn(DVec3) -> DVec3,
    ra: f64,
    sb: &dyn Fn(DVec3) -> DVec3,
    rb: f64,
    u: DVec3,
    max: f64,
    size: f64,
    centre: DVec3,
) -> Option<f64> {
    let mut s = 0.0;
    let scale = size.max(1e-9);
    for _ in 0..CAST_MAX_ITERATIONS {
        let moved = |d: DVec3| sa(d) + u * s;
        let init = centre - moved(DVec3::X);
        let (gap, n) = match gjk::gjk(&moved, &sb, init, scale) {
            GjkResult::Separated {
                distance,
                point_a,
                point_b,
            } => (distance - ra - rb, (point_b - point_a) / distance),
            GjkResult::Overlapping(_) => return Some(s),
        };
        if gap < CAST_TOLERANCE {
            return Some(s);
        }
        let closing = u.dot(n);
        if closing <= 0.0 {
            return None;
        }
        s += gap / closing;
        if s > max {
            return None;
        }
    }
    Some(s)
}
