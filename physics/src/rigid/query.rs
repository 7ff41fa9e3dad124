//! Geometric queries against one shape: ray casts, point projection,
//! overlap tests and linear shape casts.
//!
//! # Design note
//!
//! **Frames.** Every query maps its input into the shape's frame once
//! (`pose⁻¹`), answers there with the shape's own closed form, and maps
//! the answer back. Capsules and cylinders then always stand along +Y and
//! boxes are axis-aligned, so the formulas stay the textbook ones
//! (Ericson, *Real-Time Collision Detection*, 2005, §5.1 closest points
//! and §5.3 ray tests).
//!
//! **Rays.** `t` is measured along `dir` as given: the hit point is
//! `origin + t · dir`, so `t` is in metres when `dir` is a unit vector.
//! Internally the direction is normalised and the distance divided back.
//! - sphere: the quadratic; cuboid: slabs (Kay & Kajiya), which also
//!   handle axis-parallel rays (a zero component is a slab that is either
//!   always or never crossed);
//! - capsule: the union of a clipped infinite cylinder and two balls, the
//!   first entry into any of them;
//! - cylinder: the intersection of an infinite cylinder and a Y slab, the
//!   last entry and the first exit;
//! - convex hull: Cyrus–Beck clipping against the face planes;
//! - triangle mesh: Möller–Trumbore on every triangle once the ray meets
//!   the mesh's local box (a BVH is future work);
//! - heightfield: a 2D DDA (Amanatides & Woo) over the grid cells the ray
//!   crosses in X–Z, two triangles per cell, stopping at the first cell
//!   with a hit (cells are visited in order of `t`);
//! - compound: the nearest child hit.
//!
//! **Starting inside.** Solid (convex) shapes report a ray whose origin is
//! inside or on them as a hit at `t = 0`, at the origin, with normal
//! `−dir`: the ray is already blocked (the convention of Box2D and
//! Rapier's solid casts). Triangle meshes and heightfields are surfaces
//! with no inside: they report the first triangle crossed at `t ≥ 0`,
//! from either side, with the normal turned to face the ray.
//!
//! **Point projection** gives the nearest point of the shape's *surface*,
//! whether the query point lies inside the solid, and the distance to that
//! surface point (the penetration depth when inside). Surfaces are never
//! "inside". Primitives use closed forms; a hull uses its nearest face plane
//! when inside (exact for convex polytopes) and the closest point on its
//! triangles when outside; meshes and heightfields scan their triangles.
//!
//! **Overlap** is [`collide`] with no speculative margin: a manifold with
//! any point means the shapes touch or overlap. Compounds are split into
//! their children.
//!
//! **Shape casts** move a convex shape along a line and find the first
//! time it touches a target by conservative advancement (Mirtich 1996):
//! GJK gives the gap `d` and the separating normal `n`; the shape cannot
//! touch before it has closed `d` along `n`, so `t += d / (dir · n)`. The
//! cast stops when the gap is below [`CAST_TOLERANCE`], and reports no hit
//! when `dir · n <= 0` (moving apart: the separating plane stays between
//! them) or the time passes `max_t`.

mod cast;
mod project;
mod ray;

use glam::DVec3;

use super::contact::ContactError;
use super::narrow::collide;
use super::pose::Pose;
use super::shape::{HeightField, Shape};

pub use cast::{cast_shape, CastError, CAST_TOLERANCE};
pub use project::project_point_shape;
pub use ray::{ray_aabb, ray_cast_shape};

/// Where a ray first meets a shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Ray parameter of the hit, in units of `|dir|` (m for a unit `dir`);
    /// the hit point is `origin + t · dir`.
    pub t: f64,
    /// The hit point, m, world (or the pose's parent frame).
    pub point: DVec3,
    /// Unit surface normal at the hit, facing the ray (`−dir` when the ray
    /// starts inside a solid shape).
    pub normal: DVec3,
}

/// The nearest point of a shape's surface to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointProjection {
    /// The nearest point on the shape's surface, m.
    pub point: DVec3,
    /// True when the query point lies inside (or on) the solid shape;
    /// always false for triangle meshes and heightfields.
    pub inside: bool,
    /// Distance from the query point to `point`, m (>= 0; the depth when
    /// `inside`).
    pub distance: f64,
}

impl PointProjection {
    /// Signed distance to the surface, m: negative inside.
    #[inline]
    pub fn signed_distance(&self) -> f64 {
        if self.inside {
            -self.distance
        } else {
            self.distance
        }
    }
}

/// The two triangles of heightfield cell `(r, c)`, as the narrow phase
/// splits them.
fn cell_triangles(f: &HeightField, r: usize, c: usize) -> Option<[[DVec3; 3]; 2]> {
    let v00 = f.vertex(r, c)?;
    let v01 = f.vertex(r, c + 1)?;
    let v10 = f.vertex(r + 1, c)?;
    let v11 = f.vertex(r + 1, c + 1)?;
    Some([[v00, v10, v01], [v01, v10, v11]])
}

// ---------------------------------------------------------------- overlap

/// True when `a` at `pose_a` and `b` at `pose_b` touch or overlap.
/// Compounds are tested child by child.
///
/// # Errors
/// As [`collide`]: a bad pose, or a mesh or heightfield against a mesh or
/// heightfield ([`ContactError::Unsupported`]).
pub fn overlap(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose) -> Result<bool, ContactError> {
    if let Shape::Compound(parts) = a {
        for (p, child) in parts.iter() {
            if overlap(child, &pose_a.mul(p), b, pose_b)? {
                return Ok(true);
            }
        }
        return Ok(false);
    }
    if let Shape::Compound(parts) = b {
        for (p, child) in parts.iter() {
            if overlap(a, pose_a, child, &pose_b.mul(p))? {
                return Ok(true);
            }
        }
        return Ok(false);
    }
    Ok(!collide(a, pose_a, b, pose_b, 0.0)?.is_empty())
}
