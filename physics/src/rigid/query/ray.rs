//! Ray casts against each shape kind (see the note in the parent module).

use glam::DVec3;

use super::{cell_triangles, RayHit};
use crate::rigid::aabb::Aabb;
use crate::rigid::pose::Pose;
use crate::rigid::shape::{HeightField, Shape, TriMesh};

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
