//! The narrow phase: contact manifolds between pairs of shapes.
//!
//! # Design note
//!
//! **Problem.** The broad phase hands us pairs whose boxes overlap; the
//! solver wants, per pair, one normal and a few points with separations,
//! stable from frame to frame so that warm starting and resting stacks
//! work, and including pairs that are still apart but will touch within
//! the step (speculative contacts, Catto's "speculative contacts" in
//! Box2D: a point with a positive separation only pushes once the gap has
//! closed, so fast bodies do not tunnel and nothing pops).
//!
//! **One frame.** Everything is computed in A's shape frame: B is placed by
//! `pose_a⁻¹ · pose_b`. Results are then independent of where the pair sits
//! in the world (and of the world's magnitude), and the points come out in
//! the shape-local frames the solver stores.
//!
//! **Core + radius.** A sphere is a point swept by a ball, a capsule a
//! segment swept by a ball; other shapes have radius 0 (Box2D's and
//! Bullet's "margin" idea). Distances are computed between the cores and
//! the radii subtracted, so curved shapes are handled exactly instead of
//! through slowly converging support iterations.
//!
//! **Algorithms, by pair.**
//! - *Fast paths* (closed forms, `sphere.rs`, `capsule.rs`): sphere–sphere,
//!   sphere–capsule, sphere–box, sphere–cylinder, capsule–capsule (segment
//!   closest points; two points when the capsules lie side by side).
//! - *Box–box* (`box_box.rs`): the same separating axis test, clipping,
//!   tie rules, points and ids as for polytopes below, worked out on the
//!   boxes' axes (15 axes, clipping on the stack, no allocation but the
//!   result), GJK only for separated pairs whose SAT gap is not the
//!   distance. When an edge axis wins, the cross product is the normal
//!   (where the polytope path runs EPA); faces within 26° of it are
//!   clipped as the polytope path's features are, else one point, the
//!   closest points of the two edges.
//! - *Polytopes* (hulls, mesh triangles, boxes against those; `sat.rs`):
//!   the separating axis test over face normals and edge-pair cross
//!   products, then the reference face's side planes clip the incident
//!   face (Sutherland–Hodgman), as in Gottschalk's OBB tree work (1996),
//!   Catto's Box2D/Box3D manifolds and Dirk Gregorius's GDC 2013/2015 talks ("The
//!   separating axis test between convex polyhedra", "Robust contact
//!   creation for physics simulations"). Edge pairs are pruned with
//!   Gregorius's Gauss-map (Minkowski face) test. Face axes win near-ties
//!   so a box resting on a box keeps its four corners. When an edge axis
//!   wins, EPA on the two polytopes (exact for them) gives the normal and
//!   the one point. Separated pairs are measured with GJK to get the exact
//!   gap for speculative points.
//! - *Everything else* (`convex.rs`: capsule–box, capsule–hull, anything
//!   with a cylinder): GJK (Gilbert, Johnson & Keerthi 1988, with van den
//!   Bergen's termination and Ericson's sub-simplex selection, [`gjk`])
//!   between the cores gives the normal and the gap; when the cores
//!   overlap, EPA (van den Bergen 2001, [`epa`]) gives the depth and
//!   direction. A manifold is then built from each shape's supporting
//!   feature along the normal (a polygon face, a segment, or a point; a
//!   cylinder's cap is an 8-point rim polygon): the incident feature is
//!   clipped against the reference polygon or segment, as Jolt does for
//!   its convex pairs. EPA converges exactly on polytope cores; on a
//!   cylinder's curved side it stops at a tolerance (points within about
//!   1 % of the radius in the random-pair test).
//! - *Meshes and heightfields* (`mesh.rs`): the triangles under the convex
//!   shape's bounds, each collided as a polytope (two-sided for meshes,
//!   one-sided for heightfields, which push sunk shapes up); the deepest
//!   triangle's normal wins and points from triangles facing within about
//!   18° of it are merged, re-measured along that normal.
//!
//! **Manifolds.** At most [`MAX_POINTS`] points: when clipping gives more
//! (hull faces, cylinder caps, several triangles), four are kept: the
//! deepest, the one farthest from it, the one making the largest triangle
//! with those two, and the one adding the most area on the other side
//! (Gregorius's reduction), a near tie going to the point clipped first
//! (`tie_margin`), so that a resting pair keeps its points. The last
//! three are looked for first among the points within `SUPPORT_BAND` of
//! the deepest, which bear the load, so that a tilted box keeps them
//! rather than points hovering on its high side. Feature ids
//! hash the reference and incident face indices and, per point, the
//! incident vertex or the incident edge and reference side plane that cut
//! it, so they stay put while the same features touch. Ids are per
//! ordered pair: swapping A and B gives the same geometry but may give
//! other ids.
//!
//! **Robustness.** Bad poses and unsupported pairs give a [`ContactError`];
//! degenerate input (coincident centres, exactly touching shapes) picks a
//! deterministic normal instead of dividing by zero; nothing panics.

mod box_box;
mod capsule;
mod convex;
pub mod epa;
pub mod gjk;
mod mesh;
mod sat;
mod sphere;

use glam::DVec3;

use super::contact::{ContactError, ContactPoint, Manifold, MAX_POINTS};
use super::pose::Pose;
use super::shape::Shape;
use convex::{Convex, Core};

pub use gjk::GjkResult;

/// An axis along which two convex shapes were found farther apart than the
/// speculative distance: a unit vector in the common (A's shape) frame,
/// from A towards B, with `min(B·n) − max(A·n)` beyond it. Projecting the
/// two shapes on it again (two support queries) shows whether they still
/// are, long before GJK or the separating-axis test would; `None` where
/// the test that found them apart gives no such axis (an edge pair of the
/// separating-axis test, or shapes with their own closed form).
pub(crate) type Apart = Option<DVec3>;

/// Relative margin by which a cached axis must show a pair apart before
/// the full test is skipped: it covers the rounding of the two support
/// queries, so that a skipped test could never have found a contact.
const APART_MARGIN: f64 = 1e-9;

/// Whether `a` and `b` are still farther apart than `spec` along `axis`
/// (see [`Apart`]).
fn still_apart(a: &Convex<'_>, b: &Convex<'_>, axis: DVec3, spec: f64) -> bool {
    let top_a = a.core_support(axis).dot(axis) + a.radius;
    let bottom_b = b.core_support(-axis).dot(axis) - b.radius;
    let slack = APART_MARGIN * (a.size() + b.size() + top_a.abs() + spec);
    bottom_b - top_a > spec + slack
}

/// A manifold under construction, in the common (A's shape) frame: the
/// normal A→B and points `(on A, on B, separation, id)`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Contact {
    pub normal: DVec3,
    pub points: Vec<(DVec3, DVec3, f64, u32)>,
}

impl Contact {
    fn flipped(self) -> Contact {
        Contact {
            normal: -self.normal,
            points: self
                .points
                .into_iter()
                .map(|(p, q, s, id)| (q, p, s, id))
                .collect(),
        }
    }
}

/// Contacts between shape `a` at `pose_a` and shape `b` at `pose_b`
/// (poses in the world), including points separated by up to
/// `speculative` m.
///
/// Returns a manifold whose normal (world) points from A to B, with points
/// in each shape's local frame; empty when the shapes are farther apart
/// than `speculative`.
///
/// # Errors
/// [`ContactError::BadPose`] for a non-finite pose or a non-unit rotation,
/// [`ContactError::BadSpeculative`] for a negative or non-finite
/// `speculative`, [`ContactError::Compound`] when either shape is a
/// compound (collide its children), and [`ContactError::Unsupported`] for
/// mesh or heightfield against mesh or heightfield.
pub fn collide(
    a: &Shape,
    pose_a: &Pose,
    b: &Shape,
    pose_b: &Pose,
    speculative: f64,
) -> Result<Manifold, ContactError> {
    collide_apart(a, pose_a, b, pose_b, speculative, &mut None)
}

/// [`collide`] for a pair of shapes that may have been found apart before
/// along `apart` (in A's shape frame). When that axis still shows them
/// farther apart than `speculative`, the manifold is empty at the cost of
/// two support queries, and `apart` stays; otherwise the shapes are
/// collided, and `apart` becomes the axis that showed them apart, if they
/// are and one did. The manifold is always the one [`collide`] returns:
/// the axis only ever skips a test whose answer is "apart" (the margin
/// [`APART_MARGIN`] covers rounding), so nothing found depends on it.
pub(crate) fn collide_apart(
    a: &Shape,
    pose_a: &Pose,
    b: &Shape,
    pose_b: &Pose,
    speculative: f64,
    apart: &mut Apart,
) -> Result<Manifold, ContactError> {
    if !pose_a.is_valid() {
        return Err(ContactError::BadPose { which: "a" });
    }
    if !pose_b.is_valid() {
        return Err(ContactError::BadPose { which: "b" });
    }
    if speculative.is_nan() || speculative < 0.0 || !speculative.is_finite() {
        return Err(ContactError::BadSpeculative(speculative));
    }
    if matches!(a, Shape::Compound(_)) || matches!(b, Shape::Compound(_)) {
        return Err(ContactError::Compound);
    }
    let rel = pose_a.inverse().mul(pose_b);
    let contact = match (a.is_convex(), b.is_convex()) {
        (true, true) => {
            let (Some(ca), Some(cb)) = (to_convex(a, Pose::IDENTITY), to_convex(b, rel)) else {
                return Err(unsupported(a, b));
            };
            if let Some(axis) = *apart {
                if still_apart(&ca, &cb, axis, speculative) {
                    return Ok(Manifold::empty());
                }
            }
            *apart = None;
            convex_pair(&ca, &cb, speculative, apart)
        }
        (false, true) => {
            *apart = None;
            let Some(cb) = to_convex(b, rel) else {
                return Err(unsupported(a, b));
            };
            mesh::surface_convex(a, &cb, speculative).ok_or_else(|| unsupported(a, b))?
        }
        (true, false) => {
            *apart = None;
            // Collide in B's frame with B as the surface, then flip.
            let Some(ca) = to_convex(a, rel.inverse()) else {
                return Err(unsupported(a, b));
            };
            let c = mesh::surface_convex(b, &ca, speculative).ok_or_else(|| unsupported(a, b))?;
            // Points are in B's frame; re-express "on A" in A's frame below.
            let m = to_manifold(&c.flipped(), &rel.inverse(), pose_b, true);
            return Ok(m);
        }
        (false, false) => return Err(unsupported(a, b)),
    };
    Ok(to_manifold(&contact, &rel, pose_a, false))
}

/// Converts a common-frame contact to a manifold. `rel` maps the second
/// shape's frame into the common frame; `frame` places the common frame in
/// the world. With `swapped`, the common frame is B's: the first points of
/// each pair are on A (expressed through `rel`), the second on B.
fn to_manifold(c: &Contact, rel: &Pose, frame: &Pose, swapped: bool) -> Manifold {
    let normal = frame.transform_vector(c.normal).normalize_or_zero();
    let points = c
        .points
        .iter()
        .filter(|(p, q, s, _)| p.is_finite() && q.is_finite() && s.is_finite())
        .map(|&(p, q, s, id)| {
            if swapped {
                ContactPoint {
                    local_a: rel.inverse_transform_point(p),
                    local_b: q,
                    separation: s,
                    id,
                }
            } else {
                ContactPoint {
                    local_a: p,
                    local_b: rel.inverse_transform_point(q),
                    separation: s,
                    id,
                }
            }
        })
        .collect::<Vec<_>>();
    if points.is_empty() {
        return Manifold::empty();
    }
    Manifold { normal, points }
}

fn unsupported(a: &Shape, b: &Shape) -> ContactError {
    ContactError::Unsupported {
        a: a.kind_name(),
        b: b.kind_name(),
    }
}

/// The core-and-radius view of a convex shape placed at `pose`.
pub(crate) fn to_convex(s: &Shape, pose: Pose) -> Option<Convex<'_>> {
    let (core, radius) = match s {
        Shape::Sphere { radius } => (Core::Point, *radius),
        Shape::Capsule {
            half_height,
            radius,
        } => (Core::Segment(*half_height), *radius),
        Shape::Cuboid { half_extents } => (Core::Cuboid(*half_extents), 0.0),
        Shape::Cylinder {
            half_height,
            radius,
        } => (Core::Cylinder(*half_height, *radius), 0.0),
        Shape::ConvexHull(h) => (Core::Hull(h), 0.0),
        _ => return None,
    };
    Some(Convex { core, radius, pose })
}

/// Dispatch between two convex shapes in the common frame; where they are
/// farther apart than `spec`, the contact has no points and `apart` may
/// hold the axis that showed it.
pub(crate) fn convex_pair(a: &Convex<'_>, b: &Convex<'_>, spec: f64, apart: &mut Apart) -> Contact {
    use Core::*;
    let flip = |c: Option<Contact>| c.map(Contact::flipped);
    let c = match (a.core, b.core) {
        (Point, Point) => sphere::sphere_sphere(a, b, spec),
        (Point, Segment(_)) => sphere::sphere_capsule(a, b, spec),
        (Segment(_), Point) => flip(sphere::sphere_capsule(b, a, spec)),
        (Point, Cuboid(_)) => sphere::sphere_box(a, b, spec),
        (Cuboid(_), Point) => flip(sphere::sphere_box(b, a, spec)),
        (Point, Cylinder(..)) => sphere::sphere_cylinder(a, b, spec),
        (Cylinder(..), Point) => flip(sphere::sphere_cylinder(b, a, spec)),
        (Segment(_), Segment(_)) => capsule::capsule_capsule(a, b, spec),
        (Cuboid(_), Cuboid(_)) if a.radius == 0.0 && b.radius == 0.0 => {
            box_box::box_box(a, b, spec)
        }
        (Cuboid(_) | Hull(_) | Triangle(_), Cuboid(_) | Hull(_) | Triangle(_)) => {
            sat::polytope_polytope(a, b, spec, apart)
        }
        _ => convex::convex_convex(a, b, spec, apart),
    };
    c.unwrap_or_default()
}

/// Distance between two convex shapes by GJK on their cores (radii
/// subtracted), m: `Some(d >= 0)` when apart, `Some(0)` when touching or
/// overlapping, `None` for non-convex shapes or bad poses. Also returns
/// the closest points (world, m) when apart.
pub fn distance(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose) -> Option<(f64, DVec3, DVec3)> {
    if !pose_a.is_valid() || !pose_b.is_valid() {
        return None;
    }
    let ca = to_convex(a, *pose_a)?;
    let cb = to_convex(b, *pose_b)?;
    let scale = ca.size().max(cb.size()).max(1e-12);
    let sa = |d: DVec3| ca.core_support(d);
    let sb = |d: DVec3| cb.core_support(d);
    match gjk::gjk(&sa, &sb, pose_b.translation - pose_a.translation, scale) {
        GjkResult::Separated {
            distance,
            point_a,
            point_b,
        } => {
            let n = (point_b - point_a) / distance;
            let d = distance - ca.radius - cb.radius;
            if d <= 0.0 {
                return Some((0.0, point_a + n * ca.radius, point_b - n * cb.radius));
            }
            Some((d, point_a + n * ca.radius, point_b - n * cb.radius))
        }
        GjkResult::Overlapping(_) => Some((0.0, pose_a.translation, pose_b.translation)),
    }
}

/// Penetration depth (m, >= 0) and unit direction A→B of two overlapping
/// convex shapes, by GJK then EPA on the full shapes; `None` when apart,
/// for non-convex shapes, or bad poses.
pub fn penetration(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose) -> Option<(f64, DVec3)> {
    let m = collide(a, pose_a, b, pose_b, 0.0).ok()?;
    let s = m.min_separation()?;
    (s <= 0.0).then_some((-s, m.normal))
}

/// The length below which two candidates for the same role in a contact
/// (reference face, deepest point) count as tied, m: half a millimetre, as
/// Box2D's polygon collider takes a tenth of its 5 mm linear slop, or a
/// thousandth of `scale` (the shapes' size) for shapes under half a metre.
/// A tie goes to the candidate that comes first in a fixed order, so two
/// nearly equal ones do not swap from one step to the next while a body
/// rests: a swap changes the manifold's points (and their ids) and jolts
/// the bodies resting there.
pub(crate) fn tie_margin(scale: f64) -> f64 {
    (1e-3 * scale).min(5e-4)
}

/// How much farther apart an edge-pair axis must hold the shapes than the
/// best face axis to give the contact, m, when the best face axis
/// separates them by `face` m: five tie margins (2.5 mm for shapes of half
/// a metre and more) and a thousandth of `face`. A box resting tilted on
/// another's face has an edge-pair axis within a fraction of a millimetre
/// of the face axis; taking whichever was ahead by a hair swapped the
/// four-point face manifold for another every few steps. The same axis
/// bias as Gregorius's SAT (qu3e: faces win unless an edge is ahead by
/// half a linear slop).
pub(crate) fn edge_margin(scale: f64, face: f64) -> f64 {
    5.0 * tie_margin(scale) + 1e-3 * face.abs()
}

/// The first of `0..len` (skipping `skip`) whose `score` is within
/// `margin` of the largest: near ties go to the earlier candidate.
fn first_near_best(
    len: usize,
    skip: &[usize],
    score: impl Fn(usize) -> f64,
    margin: impl Fn(f64) -> f64,
) -> Option<usize> {
    first_near_best_of(|i| !skip.contains(&i), len, score, margin)
}

/// [`first_near_best`] among the candidates `0..len` that `take` accepts.
fn first_near_best_of(
    take: impl Fn(usize) -> bool,
    len: usize,
    score: impl Fn(usize) -> f64,
    margin: impl Fn(f64) -> f64,
) -> Option<usize> {
    let candidates = || (0..len).filter(|&i| take(i));
    let best = candidates().map(&score).fold(f64::NEG_INFINITY, f64::max);
    candidates().find(|&i| score(i) >= best - margin(best))
}

/// How far above the deepest point of a manifold a point may lie and
/// still count as bearing load when four points are kept from more, m.
/// The spread picks look among these supporting points first: a box
/// tilted on another's face rests on its low side, and a pick by area
/// alone kept points hovering millimetres above on the high side instead
/// of a loaded one, so the box dipped and was pushed back every time its
/// shapes were collided again (a rocking that never let a heap sleep).
const SUPPORT_BAND: f64 = 0.002;

/// Of the picks a spread score gives, a supporting point's (see
/// [`SUPPORT_BAND`]) is taken while its score is at least this fraction of
/// the best over all points; below it the supporting points lie too close
/// together (one point, a short line) and the best of all is taken.
const SUPPORT_SPREAD: f64 = 0.1;

/// A feature id from the reference side (0 = A, 1 = B), the reference and
/// incident face indices and two per-point keys.
pub(crate) fn pack_id(ref_side: u32, ref_face: u32, inc_face: u32, k0: u32, k1: u32) -> u32 {
    use convex::mix;
    mix(mix(mix(ref_side, ref_face), mix(inc_face, k0)), k1)
}

/// Keeps at most [`MAX_POINTS`] points, well spread (see the note).
pub(crate) fn reduce(mut c: Contact) -> Contact {
    let kept = reduce_in_place(c.normal, &mut c.points);
    c.points.truncate(kept);
    c
}

/// [`reduce`] without allocating: the points kept are moved to the front
/// of `pts`, in their original order, and their count is returned.
pub(crate) fn reduce_in_place(n: DVec3, pts: &mut [(DVec3, DVec3, f64, u32)]) -> usize {
    // Drop duplicates (same point twice from clipping), keeping the deeper.
    let scale = pts
        .iter()
        .map(|p| p.0.abs().max_element())
        .fold(1e-9, f64::max);
    let mut len = 0;
    for i in 0..pts.len() {
        let p = pts[i];
        if let Some(q) = pts[..len]
            .iter_mut()
            .find(|q| q.0.distance_squared(p.0) <= (1e-9 * scale).powi(2))
        {
            if p.2 < q.2 {
                *q = p;
            }
        } else {
            pts[len] = p;
            len += 1;
        }
    }
    if len <= MAX_POINTS {
        return len;
    }
    let pts = &mut pts[..len];
    let proj = |p: DVec3| p - n * n.dot(p);
    // Each pick takes the first point (in clipping order, which follows
    // the features) within a margin of the best score: the deepest within
    // a tie margin, the others within a hundredth of the best distance or
    // area. A resting pair's picks then stay put, where taking the best by
    // a hair swapped them whenever two near-equal points traded places.
    let tie = tie_margin(scale);
    let relative = |best: f64| 1e-2 * best.abs();
    let i0 = first_near_best(len, &[], |i| -pts[i].2, |_| tie).unwrap_or(0);
    let p0 = proj(pts[i0].0);
    let supporting = |i: usize| pts[i].2 <= pts[i0].2 + SUPPORT_BAND;
    // The best supporting point for a spread score, or the best of all
    // where no supporting point comes close (see `SUPPORT_SPREAD`).
    let spread = |skip: &[usize], score: &dyn Fn(usize) -> f64| {
        let all = first_near_best(len, skip, score, relative)?;
        let held = first_near_best_of(
            |i| !skip.contains(&i) && supporting(i),
            len,
            score,
            relative,
        );
        Some(match held {
            Some(i) if score(i) > 0.0 && score(i) >= SUPPORT_SPREAD * score(all) => i,
            _ => all,
        })
    };
    let i1 = spread(&[], &|i| proj(pts[i].0).distance_squared(p0)).unwrap_or(0);
    let p1 = proj(pts[i1].0);
    let area = |a: DVec3, b: DVec3, q: DVec3| (b - a).cross(q - a).dot(n);
    let i2 = spread(&[], &|i| area(p0, p1, proj(pts[i].0)).abs()).unwrap_or(0);
    let p2 = proj(pts[i2].0);
    let orient = area(p0, p1, p2).signum();
    // The fourth: the point farthest outside the triangle (most negative
    // signed area against one of its edges).
    let outside = |q: DVec3| {
        let q = proj(q);
        (orient * area(p0, p1, q))
            .min(orient * area(p1, p2, q))
            .min(orient * area(p2, p0, q))
    };
    let i3 = spread(&[i0, i1, i2], &|i| -outside(pts[i].0));
    let mut keep = [i0, i1, i2, i3.unwrap_or(i2)];
    keep.sort_unstable();
    let mut kept = 0;
    for k in 0..keep.len() {
        if kept > 0 && keep[k] == keep[kept - 1] {
            continue;
        }
        keep[kept] = keep[k];
        // Indices are increasing, so the slot written is never one still
        // to be read.
        pts[kept] = pts[keep[k]];
        kept += 1;
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair found apart keeps the axis that showed it; colliding the
    /// pair again a little later with that axis gives exactly the manifold
    /// colliding it afresh gives, whether the axis still shows it apart
    /// (and the test is skipped) or not. Hulls, boxes, cylinders, capsules
    /// and spheres in every pairing, near the speculative distance.
    #[test]
    fn issue_13_a_cached_separating_axis_changes_no_manifold() {
        let mut rng = box_box::tests::Rng(13);
        let points: Vec<DVec3> = (0..24).map(|_| rng.in_cube(0.5)).collect();
        let shapes = [
            Shape::convex_hull(&points).unwrap(),
            Shape::Cuboid {
                half_extents: DVec3::new(0.5, 0.3, 0.4),
            },
            Shape::Cylinder {
                half_height: 0.4,
                radius: 0.3,
            },
            Shape::Capsule {
                half_height: 0.3,
                radius: 0.2,
            },
            Shape::Sphere { radius: 0.4 },
        ];
        let (mut skipped, mut apart_found, mut touching) = (0, 0, 0);
        for case in 0..4000 {
            let a = &shapes[case % shapes.len()];
            let b = &shapes[(case / shapes.len()) % shapes.len()];
            let pose_a = Pose::new(rng.in_cube(0.2), rng.rotation());
            let pose_b = Pose::new(rng.unit() * rng.range(0.6, 1.6), rng.rotation());
            let spec = rng.range(0.0, 0.1);
            let mut apart = None;
            let first = collide_apart(a, &pose_a, b, &pose_b, spec, &mut apart).unwrap();
            assert_eq!(first, collide(a, &pose_a, b, &pose_b, spec).unwrap());
            let Some(axis) = apart else {
                continue;
            };
            apart_found += 1;
            assert!(first.is_empty(), "found apart, yet with points");
            // B drifts and turns a little; the axis is asked again.
            let drift = Pose::new(
                rng.in_cube(0.05),
                rng.rotation().slerp(glam::DQuat::IDENTITY, 0.97),
            );
            let later = pose_b.mul(&drift);
            let again = collide_apart(a, &pose_a, b, &later, spec, &mut apart).unwrap();
            assert_eq!(
                again,
                collide(a, &pose_a, b, &later, spec).unwrap(),
                "case {case}"
            );
            if apart == Some(axis) {
                skipped += 1;
                assert!(again.is_empty());
            }
            if !again.is_empty() {
                touching += 1;
            }
        }
        assert!(apart_found > 500, "{apart_found} pairs found apart");
        assert!(skipped > 200, "the axis skipped only {skipped} tests");
        assert!(touching > 20, "only {touching} pairs came to touch");
    }

    /// A box tilted on another's face bears on its low side: of six
    /// clipped points, three lie within a millimetre of the deepest and
    /// three hover 4 mm above. Picking by spread alone kept two hovering
    /// points and dropped a loaded one, so the box dipped there until its
    /// shapes were collided again and it was pushed back, for ever.
    #[test]
    fn issue_13_a_tilted_box_keeps_its_loaded_points() {
        let point = |x: f64, z: f64, separation: f64, id: u32| {
            let p = DVec3::new(x, 0.0, z);
            (p, p + DVec3::Y * separation, separation, id)
        };
        let mut pts = [
            point(0.25, -0.25, -0.0004, 0),
            point(0.0, -0.25, -0.0006, 1),
            point(-0.24, -0.08, 0.0008, 2),
            point(0.15, 0.25, 0.004, 3),
            point(0.01, 0.25, 0.004, 4),
            point(0.25, 0.18, 0.004, 5),
        ];
        let kept = reduce_in_place(DVec3::Y, &mut pts);
        let ids: Vec<u32> = pts[..kept].iter().map(|p| p.3).collect();
        assert_eq!(kept, MAX_POINTS);
        for loaded in [0, 1, 2] {
            assert!(
                ids.contains(&loaded),
                "loaded point {loaded} dropped: kept {ids:?}"
            );
        }
        // The fourth still spreads the manifold over the high side, where
        // the box would land if it tipped.
        assert!(ids.iter().any(|id| *id >= 3), "kept {ids:?}");
    }
}
