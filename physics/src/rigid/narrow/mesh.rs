//! Convex shapes against triangle meshes and heightfields.
//!
//! The convex shape's bounds in the surface's frame (grown by the
//! speculative distance) pick the candidate triangles: every mesh triangle
//! whose box overlaps them (a linear scan; a BVH is future work), or the
//! heightfield cells under them (two triangles per cell, found by index).
//! Each triangle is a two-sided polytope collided by [`super::sat`] (or
//! GJK/EPA for rounded and curved shapes). One manifold comes back: the
//! normal of the deepest triangle, with the points of every triangle whose
//! normal agrees with it to within about 18°, reduced to four.
//!
//! Heightfield triangles are one-sided (terrain is solid below; see
//! `front_side`); mesh triangles are two-sided, since a mesh need not
//! be closed.
//!
//! Known limit: no internal-edge handling yet, so a box sliding across a
//! flat mesh can catch on the shared edges of its triangles.

use glam::DVec3;

use super::convex::{manifold_from_features, mix, Convex, Core};
use super::{convex_pair, reduce, Contact};
use crate::rigid::aabb::Aabb;
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;

/// Least `cos` between a triangle's normal and the chosen one to merge.
const MERGE_COS: f64 = 0.95;

/// Contact of `surface` (mesh or heightfield, frame = common frame) as A
/// against the convex `b` placed in that frame. `None` if `surface` is not
/// a mesh or heightfield.
pub(crate) fn surface_convex(surface: &Shape, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    let bounds = convex_bounds(b).expanded(spec);
    let one_sided = matches!(surface, Shape::HeightField(_));
    let mut parts: Vec<Contact> = Vec::new();
    let mut collide_tri = |index: u32, tri: [DVec3; 3]| {
        let lo = tri[0].min(tri[1]).min(tri[2]);
        let hi = tri[0].max(tri[1]).max(tri[2]);
        if !bounds.intersects(&Aabb::new(lo, hi)) {
            return;
        }
        let a = Convex {
            core: Core::Triangle(tri),
            radius: 0.0,
            pose: Pose::IDENTITY,
        };
        let mut c = if one_sided {
            front_side(&a, tri, b, spec)
        } else {
            convex_pair(&a, b, spec, &mut None)
        };
        if c.points.is_empty() {
            return;
        }
        for p in &mut c.points {
            p.3 = mix(index, p.3);
        }
        parts.push(c);
    };
    match surface {
        Shape::TriMesh(m) => {
            let v = m.vertices();
            for (i, t) in m.triangles().iter().enumerate() {
                collide_tri(i as u32, t.map(|k| v[k as usize]));
            }
        }
        Shape::HeightField(f) => {
            let (rows, cols) = (f.rows(), f.cols());
            let s = f.scale();
            let cell = |x: f64, n: usize, size: f64| (x / size + 0.5) * (n - 1) as f64;
            let clamp = |x: f64, n: usize| -> usize {
                if x.is_nan() || x <= 0.0 {
                    0
                } else {
                    (x as usize).min(n - 2)
                }
            };
            let c0 = clamp(cell(bounds.min.x, cols, s.x).floor(), cols);
            let c1 = clamp(cell(bounds.max.x, cols, s.x).floor(), cols);
            let r0 = clamp(cell(bounds.min.z, rows, s.z).floor(), rows);
            let r1 = clamp(cell(bounds.max.z, rows, s.z).floor(), rows);
            for r in r0..=r1 {
                for c in c0..=c1 {
                    let (Some(v00), Some(v01), Some(v10), Some(v11)) = (
                        f.vertex(r, c),
                        f.vertex(r, c + 1),
                        f.vertex(r + 1, c),
                        f.vertex(r + 1, c + 1),
                    ) else {
                        continue;
                    };
                    let id = 2 * (r * (cols - 1) + c) as u32;
                    collide_tri(id, [v00, v10, v01]);
                    collide_tri(id + 1, [v01, v10, v11]);
                }
            }
        }
        _ => return None,
    }
    let deepest = parts
        .iter()
        .enumerate()
        .min_by(|x, y| {
            let sx = x.1.points.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
            let sy = y.1.points.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
            sx.total_cmp(&sy)
        })
        .map(|(i, _)| i);
    let Some(k) = deepest else {
        return Some(Contact::default());
    };
    let normal = parts[k].normal;
    let mut out = Contact {
        normal,
        points: Vec::new(),
    };
    for c in &parts {
        if c.normal.dot(normal) >= MERGE_COS {
            // Re-measure along the common normal, keeping the point on the
            // convex shape; the surface's point moves by a sliver of the
            // tangential difference, which a static surface does not feel.
            out.points.extend(c.points.iter().map(|&(p, q, _, id)| {
                let sep = (q - p).dot(normal);
                (q - normal * sep, q, sep, id)
            }));
        }
    }
    out.points.retain(|p| p.2 <= spec);
    Some(reduce(out))
}

/// A heightfield triangle is one-sided: terrain is solid below. A shape
/// whose centre is above the triangle's plane, or whose centre is not over
/// the triangle, collides normally; one whose centre has sunk below the
/// triangle (over it, under its plane) is pushed back up along the
/// triangle's normal instead of out through the bottom. (Testing "over the
/// triangle" keeps a steep neighbour's extended plane from grabbing a
/// shape resting at its foot.)
fn front_side(a: &Convex<'_>, tri: [DVec3; 3], b: &Convex<'_>, spec: f64) -> Contact {
    let front = (tri[1] - tri[0])
        .cross(tri[2] - tri[0])
        .normalize_or(DVec3::Y);
    let offset = front.dot(tri[0]);
    let centre = b.pose.translation;
    if front.dot(centre) >= offset || !over_triangle(tri, DVec3::Y, centre) {
        return convex_pair(a, b, spec, &mut None);
    }
    let q = b.core_support(-front);
    let gap = front.dot(q) - offset;
    let sep = gap - b.radius;
    if sep.is_nan() || sep > spec {
        return Contact::default();
    }
    manifold_from_features(a, b, front, sep, q - front * gap, q, spec)
}

/// True when `p` projected along `n` falls inside the triangle (edges
/// included; the triangle counter-clockwise seen from `+n`). Heightfields
/// project straight down (their +Y), which is what "over the terrain" means.
fn over_triangle(tri: [DVec3; 3], n: DVec3, p: DVec3) -> bool {
    (0..3).all(|i| {
        let (u, v) = (tri[i], tri[(i + 1) % 3]);
        (v - u).cross(p - u).dot(n) >= 0.0
    })
}

/// Bounds of a convex shape placed in the common frame, m.
fn convex_bounds(b: &Convex<'_>) -> Aabb {
    let mut lo = DVec3::ZERO;
    let mut hi = DVec3::ZERO;
    for i in 0..3 {
        let mut e = DVec3::ZERO;
        e[i] = 1.0;
        hi[i] = b.core_support(e)[i] + b.radius;
        lo[i] = b.core_support(-e)[i] - b.radius;
    }
    Aabb::new(lo, hi)
}
