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

use glam::DVec3;

use super::aabb::Aabb;
use super::contact::ContactError;
use super::narrow::gjk::{self, closest_triangle, GjkResult};
use super::narrow::{collide, to_convex};
use super::pose::Pose;
use super::shape::{HeightField, Shape, TriMesh};

/// A shape cast stops when the gap is below this, m.
pub const CAST_TOLERANCE: f64 = 1e-4;

/// Conservative advancement gives up after this many steps and reports
/// the time reached (which is never past the true time of impact).
const CAST_MAX_ITERATIONS: usize = 256;

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

// ------------------------------------------------------------------ rays

/// The first hit of the ray `origin + t · dir`, `0 <= t <= max_t`, on
/// `shape` placed at `pose` (see the module note for the conventions).
///
/// `None` when the ray misses, or for bad input: a non-finite or zero
/// `dir`, a non-finite `origin`, a negative or NaN `max_t`, or an invalid
/// pose. (The [`World`](crate::World) queries turn bad input into errors.)
pub fn ray_cast_shape(
    shape: &Shape,
    pose: &Pose,
    origin: DVec3,
    dir: DVec3,
    max_t: f64,
) -> Option<RayHit> {
    let len = dir.length();
    if !origin.is_finite()
        || !dir.is_finite()
        || len <= 0.0
        || !len.is_finite()
        || max_t.is_nan()
        || max_t < 0.0
        || !pose.is_valid()
    {
        return None;
    }
    let o = pose.inverse_transform_point(origin);
    let d = pose.inverse_transform_vector(dir / len);
    let (s, n) = ray_local(shape, o, d, max_t * len)?;
    Some(RayHit {
        t: s / len,
        point: origin + dir * (s / len),
        normal: pose.transform_vector(n).normalize_or(-dir / len),
    })
}

/// Ray against a shape in its own frame; `d` is a unit vector and the
/// returned distance and normal are in that frame.
fn ray_local(shape: &Shape, o: DVec3, d: DVec3, max: f64) -> Option<(f64, DVec3)> {
    let hit = match shape {
        Shape::Sphere { radius } => ray_sphere(o, d, DVec3::ZERO, *radius),
        Shape::Cuboid { half_extents } => ray_cuboid(o, d, *half_extents),
        Shape::Capsule {
            half_height,
            radius,
        } => ray_capsule(o, d, *half_height, *radius),
        Shape::Cylinder {
            half_height,
            radius,
        } => ray_cylinder(o, d, *half_height, *radius),
        Shape::ConvexHull(hull) => {
            ray_planes(o, d, hull.faces().iter().map(|f| (f.normal, f.offset)))
        }
        Shape::TriMesh(mesh) => ray_mesh(mesh, o, d, max),
        Shape::HeightField(field) => ray_heightfield(field, o, d, max),
        Shape::Compound(parts) => {
            let mut best: Option<(f64, DVec3)> = None;
            for (p, child) in parts.iter() {
                let co = p.inverse_transform_point(o);
                let cd = p.inverse_transform_vector(d);
                let limit = best.map_or(max, |b| b.0);
                if let Some((t, n)) = ray_local(child, co, cd, limit) {
                    if best.is_none_or(|b| t < b.0) {
                        best = Some((t, p.transform_vector(n)));
                    }
                }
            }
            best
        }
    }?;
    (hit.0 >= 0.0 && hit.0 <= max).then_some(hit)
}

/// Ray against a ball of radius `r` at `c`.
fn ray_sphere(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<(f64, DVec3)> {
    let m = o - c;
    let b = m.dot(d);
    let cc = m.length_squared() - r * r;
    if cc <= 0.0 {
        return Some((0.0, -d));
    }
    if b > 0.0 {
        return None;
    }
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()).max(0.0);
    Some((t, (m + d * t) / r))
}

/// Ray against the box `|x_i| <= h_i` by slabs.
fn ray_cuboid(o: DVec3, d: DVec3, h: DVec3) -> Option<(f64, DVec3)> {
    let mut t_in = f64::NEG_INFINITY;
    let mut t_out = f64::INFINITY;
    let mut normal = -d;
    for i in 0..3 {
        if d[i] == 0.0 {
            if o[i].abs() > h[i] {
                return None;
            }
            continue;
        }
        let (mut t0, mut t1) = ((-h[i] - o[i]) / d[i], (h[i] - o[i]) / d[i]);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if t0 > t_in {
            t_in = t0;
            normal = DVec3::ZERO;
            normal[i] = -d[i].signum();
        }
        t_out = t_out.min(t1);
    }
    if t_in > t_out || t_out < 0.0 {
        return None;
    }
    if t_in <= 0.0 {
        return Some((0.0, -d));
    }
    Some((t_in, normal))
}

/// Ray against the capsule along Y: the first entry into the side cylinder
/// (clipped to the segment) or either end ball.
fn ray_capsule(o: DVec3, d: DVec3, hh: f64, r: f64) -> Option<(f64, DVec3)> {
    let on_axis = DVec3::new(0.0, o.y.clamp(-hh, hh), 0.0);
    if o.distance_squared(on_axis) <= r * r {
        return Some((0.0, -d));
    }
    let mut best: Option<(f64, DVec3)> = None;
    let mut keep = |hit: Option<(f64, DVec3)>| {
        if let Some(h) = hit {
            if best.is_none_or(|b| h.0 < b.0) {
                best = Some(h);
            }
        }
    };
    if let Some((t0, _)) = ray_infinite_cylinder(o, d, r) {
        let p = o + d * t0;
        if t0 >= 0.0 && p.y.abs() <= hh {
            keep(Some((t0, DVec3::new(p.x, 0.0, p.z) / r)));
        }
    }
    keep(ray_sphere(o, d, DVec3::new(0.0, hh, 0.0), r));
    keep(ray_sphere(o, d, DVec3::new(0.0, -hh, 0.0), r));
    best
}

/// Entry and exit of a ray through the infinite cylinder `x² + z² <= r²`;
/// `None` when it misses or runs parallel to the axis (the caller handles
/// that case).
fn ray_infinite_cylinder(o: DVec3, d: DVec3, r: f64) -> Option<(f64, f64)> {
    let a = d.x * d.x + d.z * d.z;
    if a <= 1e-15 {
        return None;
    }
    let b = o.x * d.x + o.z * d.z;
    let c = o.x * o.x + o.z * o.z - r * r;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    Some(((-b - s) / a, (-b + s) / a))
}

/// Ray against the solid cylinder along Y: infinite cylinder ∩ Y slab.
fn ray_cylinder(o: DVec3, d: DVec3, hh: f64, r: f64) -> Option<(f64, DVec3)> {
    let radial2 = o.x * o.x + o.z * o.z;
    if radial2 <= r * r && o.y.abs() <= hh {
        return Some((0.0, -d));
    }
    let (side_in, side_out) = match ray_infinite_cylinder(o, d, r) {
        Some(ts) => ts,
        None if d.x * d.x + d.z * d.z <= 1e-15 && radial2 <= r * r => {
            (f64::NEG_INFINITY, f64::INFINITY)
        }
        None => return None,
    };
    let (cap_in, cap_out) = if d.y == 0.0 {
        if o.y.abs() > hh {
            return None;
        }
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        let (a, b) = ((-hh - o.y) / d.y, (hh - o.y) / d.y);
        (a.min(b), a.max(b))
    };
    let t_in = side_in.max(cap_in);
    let t_out = side_out.min(cap_out);
    if t_in > t_out || t_out < 0.0 || t_in < 0.0 {
        return None;
    }
    let p = o + d * t_in;
    let normal = if side_in >= cap_in {
        DVec3::new(p.x, 0.0, p.z) / r
    } else {
        DVec3::new(0.0, -d.y.signum(), 0.0)
    };
    Some((t_in, normal))
}

/// Ray against the intersection of half-spaces `n · x <= offset`
/// (Cyrus–Beck).
fn ray_planes(
    o: DVec3,
    d: DVec3,
    planes: impl Iterator<Item = (DVec3, f64)>,
) -> Option<(f64, DVec3)> {
    let mut t_in = f64::NEG_INFINITY;
    let mut t_out = f64::INFINITY;
    let mut normal = -d;
    let mut inside = true;
    for (n, offset) in planes {
        let dist = n.dot(o) - offset;
        let denom = n.dot(d);
        inside &= dist <= 0.0;
        if denom == 0.0 {
            if dist > 0.0 {
                return None;
            }
            continue;
        }
        let t = -dist / denom;
        if denom < 0.0 {
            if t > t_in {
                t_in = t;
                normal = n;
            }
        } else {
            t_out = t_out.min(t);
        }
        if t_in > t_out {
            return None;
        }
    }
    if inside {
        return Some((0.0, -d));
    }
    if t_out < 0.0 || t_in < 0.0 {
        return None;
    }
    Some((t_in, normal))
}

/// Möller–Trumbore, two-sided: distance along the unit `d` and the unit
/// normal facing the ray.
fn ray_triangle(o: DVec3, d: DVec3, tri: [DVec3; 3]) -> Option<(f64, DVec3)> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() <= 1e-14 * e1.length_squared().max(e2.length_squared()) {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - tri[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t < 0.0 {
        return None;
    }
    let n = e1.cross(e2).normalize_or_zero();
    Some((t, if n.dot(d) > 0.0 { -n } else { n }))
}

/// Entry and exit of a ray through a box, or `None` if it misses.
fn ray_aabb_interval(o: DVec3, d: DVec3, b: &Aabb) -> Option<(f64, f64)> {
    let mut t_in = f64::NEG_INFINITY;
    let mut t_out = f64::INFINITY;
    for i in 0..3 {
        if d[i] == 0.0 {
            if o[i] < b.min[i] || o[i] > b.max[i] {
                return None;
            }
            continue;
        }
        let (a, c) = ((b.min[i] - o[i]) / d[i], (b.max[i] - o[i]) / d[i]);
        t_in = t_in.max(a.min(c));
        t_out = t_out.min(a.max(c));
    }
    (t_in <= t_out).then_some((t_in, t_out))
}

/// The entry parameter (clamped to 0) of the ray into `aabb` within
/// `[0, max_t]`, or `None`. `dir` need not be normalised; for the
/// prefilter of the world queries.
pub fn ray_aabb(origin: DVec3, dir: DVec3, max_t: f64, aabb: &Aabb) -> Option<f64> {
    let (t_in, t_out) = ray_aabb_interval(origin, dir, aabb)?;
    (t_out >= 0.0 && t_in <= max_t).then_some(t_in.max(0.0))
}

fn ray_mesh(mesh: &TriMesh, o: DVec3, d: DVec3, max: f64) -> Option<(f64, DVec3)> {
    ray_aabb(o, d, max, &mesh.local_aabb().expanded(1e-9))?;
    let v = mesh.vertices();
    let mut best: Option<(f64, DVec3)> = None;
    for t in mesh.triangles() {
        if let Some(hit) = ray_triangle(o, d, t.map(|k| v[k as usize])) {
            if hit.0 <= max && best.is_none_or(|b| hit.0 < b.0) {
                best = Some(hit);
            }
        }
    }
    best
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

fn ray_heightfield(f: &HeightField, o: DVec3, d: DVec3, max: f64) -> Option<(f64, DVec3)> {
    let bounds = f.local_aabb();
    let margin = 1e-9 * (bounds.max - bounds.min).max_element().max(1.0);
    let (t_in, t_out) = ray_aabb_interval(o, d, &bounds.expanded(margin))?;
    let t_start = t_in.max(0.0);
    let t_end = t_out.min(max);
    if t_start > t_end {
        return None;
    }
    let s = f.scale();
    let (rows, cols) = (f.rows(), f.cols());
    let (cw, ch) = (s.x / (cols - 1) as f64, s.z / (rows - 1) as f64);
    // Grid coordinates: x = (c / (cols − 1) − ½) scale.x.
    let p = o + d * t_start;
    let cell_of = |x: f64, size: f64, n: usize| -> usize {
        let g = ((x / size + 0.5) * (n - 1) as f64).floor();
        if g.is_nan() || g <= 0.0 {
            0
        } else {
            (g as usize).min(n - 2)
        }
    };
    let mut c = cell_of(p.x, s.x, cols);
    let mut r = cell_of(p.z, s.z, rows);
    let boundary = |i: usize, step: f64, cell: f64, size: f64| -> f64 {
        let k = if step > 0.0 { i + 1 } else { i };
        k as f64 * cell - 0.5 * size
    };
    let (step_c, step_r) = (d.x.signum(), d.z.signum());
    let mut t_next_c = if d.x == 0.0 {
        f64::INFINITY
    } else {
        (boundary(c, step_c, cw, s.x) - o.x) / d.x
    };
    let mut t_next_r = if d.z == 0.0 {
        f64::INFINITY
    } else {
        (boundary(r, step_r, ch, s.z) - o.z) / d.z
    };
    let dt_c = if d.x == 0.0 {
        f64::INFINITY
    } else {
        cw / d.x.abs()
    };
    let dt_r = if d.z == 0.0 {
        f64::INFINITY
    } else {
        ch / d.z.abs()
    };
    loop {
        let mut best: Option<(f64, DVec3)> = None;
        for tri in cell_triangles(f, r, c)? {
            if let Some(hit) = ray_triangle(o, d, tri) {
                if hit.0 >= t_start && hit.0 <= t_end && best.is_none_or(|b| hit.0 < b.0) {
                    best = Some(hit);
                }
            }
        }
        if best.is_some() {
            return best;
        }
        if t_next_c < t_next_r {
            if t_next_c > t_end {
                return None;
            }
            if step_c > 0.0 && c + 2 < cols {
                c += 1;
            } else if step_c < 0.0 && c > 0 {
                c -= 1;
            } else {
                return None;
            }
            t_next_c += dt_c;
        } else {
            if t_next_r > t_end {
                return None;
            }
            if step_r > 0.0 && r + 2 < rows {
                r += 1;
            } else if step_r < 0.0 && r > 0 {
                r -= 1;
            } else {
                return None;
            }
            t_next_r += dt_r;
        }
    }
}

// ------------------------------------------------------- point projection

/// The nearest point of `shape`'s surface (placed at `pose`) to `point`
/// (m), whether `point` is inside the solid, and the distance between
/// them. See the module note. A hull, mesh or heightfield is scanned face
/// by face or triangle by triangle (linear in its size).
///
/// `None` for a non-finite point or an invalid pose.
pub fn project_point_shape(shape: &Shape, pose: &Pose, point: DVec3) -> Option<PointProjection> {
    if !point.is_finite() || !pose.is_valid() {
        return None;
    }
    let p = pose.inverse_transform_point(point);
    let (q, inside) = project_local(shape, p)?;
    let world = pose.transform_point(q);
    Some(PointProjection {
        point: world,
        inside,
        distance: p.distance(q),
    })
}

/// Nearest surface point in the shape's frame and the inside flag.
fn project_local(shape: &Shape, p: DVec3) -> Option<(DVec3, bool)> {
    Some(match shape {
        Shape::Sphere { radius } => project_ball(p, DVec3::ZERO, *radius),
        Shape::Cuboid { half_extents: h } => {
            let q = p.clamp(-*h, *h);
            if q != p {
                (q, false)
            } else {
                // Inside: push out through the nearest face.
                let depth = *h - p.abs();
                let i = if depth.x <= depth.y && depth.x <= depth.z {
                    0
                } else if depth.y <= depth.z {
                    1
                } else {
                    2
                };
                let mut q = p;
                q[i] = if p[i] >= 0.0 { h[i] } else { -h[i] };
                (q, true)
            }
        }
        Shape::Capsule {
            half_height,
            radius,
        } => project_ball(
            p,
            DVec3::new(0.0, p.y.clamp(-half_height, *half_height), 0.0),
            *radius,
        ),
        Shape::Cylinder {
            half_height: hh,
            radius: r,
        } => {
            let rho = (p.x * p.x + p.z * p.z).sqrt();
            let u = if rho > 0.0 {
                DVec3::new(p.x / rho, 0.0, p.z / rho)
            } else {
                DVec3::X
            };
            if rho > *r || p.y.abs() > *hh {
                (
                    u * rho.min(*r) + DVec3::new(0.0, p.y.clamp(-hh, *hh), 0.0),
                    false,
                )
            } else if r - rho < hh - p.y.abs() {
                (u * *r + DVec3::new(0.0, p.y, 0.0), true)
            } else {
                let y = if p.y >= 0.0 { *hh } else { -hh };
                (DVec3::new(p.x, y, p.z), true)
            }
        }
        Shape::ConvexHull(hull) => {
            let nearest = hull
                .faces()
                .iter()
                .map(|f| (f.distance(p), f.normal))
                .max_by(|a, b| a.0.total_cmp(&b.0))?;
            if nearest.0 <= 0.0 {
                (p - nearest.1 * nearest.0, true)
            } else {
                let v = hull.vertices();
                let tris = hull.triangles().map(|t| t.map(|k| v[k as usize]));
                (closest_on_triangles(p, tris)?, false)
            }
        }
        Shape::TriMesh(mesh) => {
            let v = mesh.vertices();
            let tris = mesh.triangles().iter().map(|t| t.map(|k| v[k as usize]));
            (closest_on_triangles(p, tris)?, false)
        }
        Shape::HeightField(f) => {
            let cells = (0..f.rows() - 1).flat_map(|r| (0..f.cols() - 1).map(move |c| (r, c)));
            let tris = cells.filter_map(|(r, c)| cell_triangles(f, r, c)).flatten();
            (closest_on_triangles(p, tris)?, false)
        }
        Shape::Compound(parts) => {
            // Inside any child means inside the compound; then the nearest
            // surface is taken among the children containing the point
            // (an approximation where children overlap).
            let mut best: Option<(DVec3, bool, f64)> = None;
            for (pose, child) in parts.iter() {
                let (q, inside) = project_local(child, pose.inverse_transform_point(p))?;
                let q = pose.transform_point(q);
                let d = p.distance(q);
                let signed = if inside { -d } else { d };
                let better = match best {
                    None => true,
                    Some((_, b_in, b_d)) => match (inside, b_in) {
                        (true, false) => true,
                        (false, true) => false,
                        (true, true) => d < -b_d,
                        (false, false) => d < b_d,
                    },
                };
                if better {
                    best = Some((q, inside, signed));
                }
            }
            let (q, inside, _) = best?;
            (q, inside)
        }
    })
}

/// Projection onto the ball of radius `r` at `c`.
fn project_ball(p: DVec3, c: DVec3, r: f64) -> (DVec3, bool) {
    let v = p - c;
    let l = v.length();
    let u = if l > 0.0 { v / l } else { DVec3::Y };
    (c + u * r, l <= r)
}

/// The closest point to `p` on any of the triangles.
fn closest_on_triangles(p: DVec3, tris: impl Iterator<Item = [DVec3; 3]>) -> Option<DVec3> {
    let mut best: Option<(f64, DVec3)> = None;
    for t in tris {
        let q = closest_on_triangle(p, t);
        let d = p.distance_squared(q);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, q));
        }
    }
    best.map(|b| b.1)
}

fn closest_on_triangle(p: DVec3, t: [DVec3; 3]) -> DVec3 {
    let (idx, w) = closest_triangle(t[0] - p, t[1] - p, t[2] - p);
    idx.iter().zip(&w).map(|(&k, &l)| t[k] * l).sum()
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

// ------------------------------------------------------------- shape cast

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
        return Err(CastError::NotConvex(kind(shape)));
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
            for r in 0..field.rows() - 1 {
                for c in 0..field.cols() - 1 {
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

fn kind(s: &Shape) -> &'static str {
    match s {
        Shape::Sphere { .. } => "sphere",
        Shape::Cuboid { .. } => "cuboid",
        Shape::Capsule { .. } => "capsule",
        Shape::Cylinder { .. } => "cylinder",
        Shape::ConvexHull(_) => "convex hull",
        Shape::TriMesh(_) => "triangle mesh",
        Shape::HeightField(_) => "heightfield",
        Shape::Compound(_) => "compound",
    }
}
