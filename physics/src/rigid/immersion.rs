//! How much of a shape lies below a plane (buoyancy) and how much area it
//! shows to a direction (wind, blasts).
//!
//! Both work on a closed triangulated surface of the shape in its local
//! frame ([`surface`]): exact for boxes and hulls, a 24-sided tessellation
//! for capsules and cylinders, and closed forms for spheres.
//!
//! **Submerged volume.** Every surface triangle is clipped to the part below
//! the plane, and each clipped piece forms a tetrahedron with a reference
//! point *on* the plane. Summing signed volumes and volume-weighted
//! centroids gives the submerged volume and its centroid (the centre of
//! buoyancy): the cap where the plane cuts the body is never built, because
//! its tetrahedra, with their apex on the plane, have zero volume. (This is
//! the divergence-theorem construction also used by Catto's and Gaul's
//! buoyancy write-ups.)
//!
//! **Projected area.** For a closed convex surface, the area seen along `d`
//! is half of `Σ |n·d| A` over the triangles (Cauchy's projection formula).
//! The centre of pressure is taken as the area-weighted centroid of the
//! triangles facing `d`, so wind on a long body produces a torque.

use std::f64::consts::PI;

use glam::DVec3;

use crate::rigid::shape::Shape;

/// Sides of the polygon that stands in for a circle in capsules and cylinders.
const ROUND_SEGMENTS: usize = 24;

/// A closed triangulated surface, local frame, counter-clockwise from outside.
pub(crate) fn surface(shape: &Shape) -> Vec<[DVec3; 3]> {
    let mut tris = Vec::new();
    append_surface(shape, &crate::rigid::pose::Pose::IDENTITY, &mut tris);
    tris
}

fn append_surface(shape: &Shape, pose: &crate::rigid::pose::Pose, out: &mut Vec<[DVec3; 3]>) {
    let mut push = |a: DVec3, b: DVec3, c: DVec3| {
        out.push([
            pose.transform_point(a),
            pose.transform_point(b),
            pose.transform_point(c),
        ]);
    };
    match shape {
        Shape::Sphere { radius } => {
            // An icosphere-like UV sphere; only used where a sphere is part of
            // a compound (single spheres take the closed forms).
            uv_sphere(DVec3::ZERO, *radius, &mut push);
        }
        Shape::Cuboid { half_extents: h } => {
            let c = |x: f64, y: f64, z: f64| DVec3::new(x * h.x, y * h.y, z * h.z);
            let quads = [
                [
                    c(1., -1., -1.),
                    c(1., 1., -1.),
                    c(1., 1., 1.),
                    c(1., -1., 1.),
                ],
                [
                    c(-1., -1., -1.),
                    c(-1., -1., 1.),
                    c(-1., 1., 1.),
                    c(-1., 1., -1.),
                ],
                [
                    c(-1., 1., -1.),
                    c(-1., 1., 1.),
                    c(1., 1., 1.),
                    c(1., 1., -1.),
                ],
                [
                    c(-1., -1., -1.),
                    c(1., -1., -1.),
                    c(1., -1., 1.),
                    c(-1., -1., 1.),
                ],
                [
                    c(-1., -1., 1.),
                    c(1., -1., 1.),
                    c(1., 1., 1.),
                    c(-1., 1., 1.),
                ],
                [
                    c(-1., -1., -1.),
                    c(-1., 1., -1.),
                    c(1., 1., -1.),
                    c(1., -1., -1.),
                ],
            ];
            for q in quads {
                push(q[0], q[1], q[2]);
                push(q[0], q[2], q[3]);
            }
        }
        Shape::ConvexHull(hull) => {
            let v = hull.vertices();
            for [a, b, c] in hull.triangles() {
                push(v[a as usize], v[b as usize], v[c as usize]);
            }
        }
        Shape::Cylinder {
            half_height,
            radius,
        } => {
            let ring = |y: f64| -> Vec<DVec3> {
                (0..ROUND_SEGMENTS)
                    .map(|k| {
                        let a = 2.0 * PI * k as f64 / ROUND_SEGMENTS as f64;
                        DVec3::new(radius * a.cos(), y, -radius * a.sin())
                    })
                    .collect()
            };
            let (top, bottom) = (ring(*half_height), ring(-half_height));
            for k in 0..ROUND_SEGMENTS {
                let n = (k + 1) % ROUND_SEGMENTS;
                push(bottom[k], bottom[n], top[n]);
                push(bottom[k], top[n], top[k]);
                push(DVec3::Y * *half_height, top[k], top[n]);
                push(DVec3::NEG_Y * *half_height, bottom[n], bottom[k]);
            }
        }
        Shape::Capsule {
            half_height,
            radius,
        } => {
            capsule(*half_height, *radius, &mut push);
        }
        Shape::Compound(parts) => {
            for (p, child) in parts.iter() {
                append_surface(child, &pose.mul(p), out);
            }
        }
        // Open or unbounded surfaces have no inside: no buoyancy, no area.
        Shape::TriMesh(_) | Shape::HeightField(_) => {}
    }
}

/// Latitude-longitude sphere of `ROUND_SEGMENTS` meridians.
fn uv_sphere(center: DVec3, r: f64, push: &mut impl FnMut(DVec3, DVec3, DVec3)) {
    let rings = ROUND_SEGMENTS / 2;
    let p = |i: usize, j: usize| {
        let theta = PI * i as f64 / rings as f64;
        let phi = 2.0 * PI * j as f64 / ROUND_SEGMENTS as f64;
        center
            + r * DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            )
    };
    for i in 0..rings {
        for j in 0..ROUND_SEGMENTS {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            if i != 0 {
                push(a, b, d);
            }
            if i + 1 != rings {
                push(b, c, d);
            }
        }
    }
}

/// A capsule: two tessellated hemispheres joined by a cylindrical band.
fn capsule(hh: f64, r: f64, push: &mut impl FnMut(DVec3, DVec3, DVec3)) {
    let rings = ROUND_SEGMENTS / 2; // latitude bands over the whole sphere
                                    // Point on latitude `i` (0 = top pole), meridian `j`, on the upper or
                                    // lower hemisphere (the equator exists on both).
    let p = |i: usize, j: usize, lower: bool| {
        let theta = PI * i as f64 / rings as f64;
        let phi = 2.0 * PI * j as f64 / ROUND_SEGMENTS as f64;
        let y = if lower { -hh } else { hh };
        DVec3::new(
            r * theta.sin() * phi.cos(),
            y + r * theta.cos(),
            -r * theta.sin() * phi.sin(),
        )
    };
    for i in 0..rings {
        let lower = i >= rings / 2;
        for j in 0..ROUND_SEGMENTS {
            let (a, b, c, d) = (
                p(i, j, lower),
                p(i + 1, j, lower),
                p(i + 1, j + 1, lower),
                p(i, j + 1, lower),
            );
            if i != 0 {
                push(a, b, d);
            }
            if i + 1 != rings {
                push(b, c, d);
            }
            if i + 1 == rings / 2 {
                // The band from the upper equator down to the lower one.
                let (e, f) = (p(i + 1, j, true), p(i + 1, j + 1, true));
                let (g, k) = (p(i + 1, j, false), p(i + 1, j + 1, false));
                push(e, k, g);
                push(e, f, k);
            }
        }
    }
}

/// Volume (m³) and centroid (local frame) of the part of `shape` below the
/// plane `{x : n · x = d}` (`n` unit, local frame, pointing out of the fluid).
pub(crate) fn submerged(shape: &Shape, surface: &[[DVec3; 3]], n: DVec3, d: f64) -> (f64, DVec3) {
    if let Shape::Sphere { radius } = shape {
        return sphere_cap(*radius, n, d);
    }
    let origin = n * d; // a point on the plane
    let (mut vol, mut moment) = (0.0, DVec3::ZERO);
    let mut add = |a: DVec3, b: DVec3, c: DVec3| {
        let v = (a - origin).dot((b - origin).cross(c - origin)) / 6.0;
        vol += v;
        moment += v * (origin + a + b + c) / 4.0;
    };
    for tri in surface {
        let h = tri.map(|p| n.dot(p) - d);
        let below: Vec<usize> = (0..3).filter(|&i| h[i] <= 0.0).collect();
        match below.len() {
            3 => add(tri[0], tri[1], tri[2]),
            0 => {}
            _ => {
                // Clip the triangle against the plane; keep the part below,
                // walking the triangle's vertices in order to keep winding.
                let mut poly: Vec<DVec3> = Vec::with_capacity(4);
                for i in 0..3 {
                    let j = (i + 1) % 3;
                    if h[i] <= 0.0 {
                        poly.push(tri[i]);
                    }
                    if (h[i] <= 0.0) != (h[j] <= 0.0) {
                        let t = h[i] / (h[i] - h[j]);
                        poly.push(tri[i] + (tri[j] - tri[i]) * t);
                    }
                }
                for k in 1..poly.len().saturating_sub(1) {
                    add(poly[0], poly[k], poly[k + 1]);
                }
            }
        }
    }
    if vol <= 0.0 {
        (0.0, DVec3::ZERO)
    } else {
        (vol, moment / vol)
    }
}

/// Closed form for a sphere at the origin: the spherical cap below the plane.
fn sphere_cap(r: f64, n: DVec3, d: f64) -> (f64, DVec3) {
    // Depth of the cap: the plane is at signed height d above the centre.
    let h = (r + d).clamp(0.0, 2.0 * r);
    if h <= 0.0 {
        return (0.0, DVec3::ZERO);
    }
    let vol = PI * h * h * (3.0 * r - h) / 3.0;
    // Centroid of a cap of height h, measured from the centre towards -n.
    let z = 3.0 * (2.0 * r - h).powi(2) / (4.0 * (3.0 * r - h));
    (vol, -n * z)
}

/// Area (m²) the shape shows to direction `dir` (unit, local frame) and the
/// centre of pressure (local frame): the area-weighted centroid of the
/// triangles facing against `dir`.
pub(crate) fn projected_area(shape: &Shape, surface: &[[DVec3; 3]], dir: DVec3) -> (f64, DVec3) {
    if let Shape::Sphere { radius } = shape {
        return (PI * radius * radius, DVec3::ZERO);
    }
    let (mut area, mut moment) = (0.0, DVec3::ZERO);
    for [a, b, c] in surface {
        let n2 = (*b - *a).cross(*c - *a); // twice the area, along the normal
        let facing = -n2.dot(dir) * 0.5;
        if facing > 0.0 {
            area += facing;
            moment += facing * (*a + *b + *c) / 3.0;
        }
    }
    if area <= 0.0 {
        (0.0, DVec3::ZERO)
    } else {
        (area, moment / area)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-12)
    }

    #[test]
    fn fully_submerged_volume_is_the_shape_volume() {
        let shapes = [
            Shape::cuboid(DVec3::new(0.5, 1.0, 1.5)).unwrap(),
            Shape::convex_hull(&[
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::Z,
                DVec3::new(0.7, 0.7, 0.7),
            ])
            .unwrap(),
        ];
        for s in &shapes {
            let (v, c) = submerged(s, &surface(s), DVec3::Y, 100.0);
            assert!(close(v, s.volume().unwrap(), 1e-12), "{v}");
            let com = s.mass_properties(1.0).unwrap().center_of_mass;
            assert!((c - com).length() < 1e-12, "{c} vs {com}");
        }
        // Tessellated round shapes: within the tessellation error (24 sides: ~1.1%).
        for s in [
            Shape::cylinder(1.0, 0.5).unwrap(),
            Shape::capsule(1.0, 0.5).unwrap(),
        ] {
            let (v, c) = submerged(&s, &surface(&s), DVec3::Y, 100.0);
            assert!(
                close(v, s.volume().unwrap(), 0.03),
                "{s:?}: {v} vs {}",
                s.volume().unwrap()
            );
            assert!(c.length() < 1e-9, "{c}");
        }
    }

    #[test]
    fn a_box_cut_by_a_tilted_plane() {
        let s = Shape::cuboid(DVec3::splat(1.0)).unwrap(); // the cube [-1, 1]³
        let tris = surface(&s);
        for depth in [-0.75, -0.2, 0.0, 0.4, 0.9] {
            // Horizontal plane: the slab below y = depth.
            let (v, c) = submerged(&s, &tris, DVec3::Y, depth);
            assert!(close(v, 4.0 * (depth + 1.0), 1e-12), "{v}");
            assert!((c - DVec3::new(0.0, (depth - 1.0) / 2.0, 0.0)).length() < 1e-12);
        }
        // A plane through the centre at any tilt cuts the cube in half.
        let n = DQuat::from_rotation_z(0.3) * DQuat::from_rotation_x(0.2) * DVec3::Y;
        let (v, _) = submerged(&s, &tris, n, 0.0);
        assert!(close(v, 4.0, 1e-12), "{v}");
    }

    #[test]
    fn sphere_caps() {
        let s = Shape::sphere(2.0).unwrap();
        let full = 4.0 / 3.0 * PI * 8.0;
        assert!(close(
            submerged(&s, &[], DVec3::Y, 0.0).0,
            full / 2.0,
            1e-12
        ));
        assert!(close(submerged(&s, &[], DVec3::Y, 5.0).0, full, 1e-12));
        assert_eq!(submerged(&s, &[], DVec3::Y, -3.0).0, 0.0);
        let (_, c) = submerged(&s, &[], DVec3::Y, 0.0);
        assert!(
            (c.y + 3.0 * 2.0 / 8.0).abs() < 1e-12,
            "half ball centroid {c}"
        );
    }

    #[test]
    fn projected_areas() {
        let s = Shape::cuboid(DVec3::new(0.5, 1.0, 1.5)).unwrap(); // 1 × 2 × 3
        let tris = surface(&s);
        assert!(close(projected_area(&s, &tris, DVec3::X).0, 6.0, 1e-12));
        assert!(close(projected_area(&s, &tris, DVec3::NEG_Y).0, 3.0, 1e-12));
        let d = DVec3::new(1.0, 1.0, 0.0).normalize();
        assert!(close(
            projected_area(&s, &tris, d).0,
            (6.0 + 3.0) / 2f64.sqrt(),
            1e-12
        ));
        // Wind along +X meets the face at x = -0.5: centre of pressure there.
        let (_, cp) = projected_area(&s, &tris, DVec3::X);
        assert!((cp - DVec3::new(-0.5, 0.0, 0.0)).length() < 1e-12, "{cp}");
        let c = Shape::cylinder(1.0, 0.5).unwrap();
        let a = projected_area(&c, &surface(&c), DVec3::Y).0;
        assert!(close(a, PI * 0.25, 0.03), "{a}");
    }
}
