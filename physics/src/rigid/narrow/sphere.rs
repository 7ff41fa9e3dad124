//! Closed forms for spheres: against a sphere, a capsule and a box.
//!
//! A sphere is its centre swept by its radius, so each pair reduces to a
//! point against the other core: another point, a segment (closest point
//! on the segment) or a box (clamp to the box; inside, the nearest face).

use glam::DVec3;

use super::convex::{Convex, Core};
use super::Contact;

/// Sphere `a` against sphere `b` (common frame).
pub(crate) fn sphere_sphere(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    let ca = a.pose.translation;
    let cb = b.pose.translation;
    point_point(ca, a.radius, cb, b.radius, spec, 0)
}

/// Two points swept by radii: one contact along the line of centres
/// (+Y for coincident centres).
fn point_point(ca: DVec3, ra: f64, cb: DVec3, rb: f64, spec: f64, id: u32) -> Option<Contact> {
    let d = cb - ca;
    let dist = d.length();
    let sep = dist - ra - rb;
    if sep.is_nan() || sep > spec {
        return None;
    }
    let n = if dist > 1e-12 * (ra + rb) {
        d / dist
    } else {
        DVec3::Y
    };
    Some(Contact {
        normal: n,
        points: vec![(ca + n * ra, cb - n * rb, sep, id)],
    })
}

/// Sphere `a` against capsule `b`: the closest point of the capsule's
/// segment to the sphere's centre.
pub(crate) fn sphere_capsule(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    let Core::Segment(h) = b.core else {
        return None;
    };
    let ca = a.pose.translation;
    let b0 = b.pose.transform_point(DVec3::new(0.0, -h, 0.0));
    let b1 = b.pose.transform_point(DVec3::new(0.0, h, 0.0));
    let axis = b1 - b0;
    let t = ((ca - b0).dot(axis) / axis.length_squared()).clamp(0.0, 1.0);
    let t = if t.is_finite() { t } else { 0.5 };
    let c = b0 + axis * t;
    let id = if t <= 0.0 {
        1
    } else if t >= 1.0 {
        2
    } else {
        3
    };
    let d = c - ca;
    if d.length() <= 1e-12 * (a.radius + b.radius) {
        // Centre on the axis: push out sideways, deterministically.
        let n = axis.normalize_or(DVec3::Y).any_orthonormal_vector();
        let sep = -a.radius - b.radius;
        if sep.is_nan() || sep > spec {
            return None;
        }
        return Some(Contact {
            normal: n,
            points: vec![(ca + n * a.radius, c - n * b.radius, sep, id)],
        });
    }
    point_point(ca, a.radius, c, b.radius, spec, id)
}

/// Sphere `a` against box `b`: clamp the centre into the box; from inside,
/// leave through the nearest face.
pub(crate) fn sphere_box(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    let Core::Cuboid(h) = b.core else {
        return None;
    };
    let ca = a.pose.translation;
    let l = b.pose.inverse_transform_point(ca);
    let c = l.clamp(-h, h);
    let (outward_local, box_local, sep, id) = if c != l {
        let d = l - c;
        let dist = d.length();
        // Region id: per axis 0 inside, 1 above, 2 below.
        let code = |i: usize| {
            if l[i] > h[i] {
                1
            } else if l[i] < -h[i] {
                2
            } else {
                0
            }
        };
        let id = 1 + code(0) + 3 * code(1) + 9 * code(2);
        (d / dist, c, dist - a.radius, id)
    } else {
        // Inside: the face with the least depth (first on ties).
        let depth = h - l.abs();
        let mut i = 0;
        for k in 1..3 {
            if depth[k] < depth[i] {
                i = k;
            }
        }
        let s = if l[i] >= 0.0 { 1.0 } else { -1.0 };
        let mut e = DVec3::ZERO;
        e[i] = s;
        let mut p = l;
        p[i] = s * h[i];
        (
            e,
            p,
            -depth[i] - a.radius,
            100 + 2 * i as u32 + u32::from(s < 0.0),
        )
    };
    if (sep.is_nan() || sep > spec) || !outward_local.is_finite() {
        return None;
    }
    let n = -b.pose.transform_vector(outward_local);
    Some(Contact {
        normal: n,
        points: vec![(
            ca + n * a.radius,
            b.pose.transform_point(box_local),
            sep,
            id,
        )],
    })
}

/// Sphere `a` against cylinder `b`: the closest point of the solid
/// cylinder to the centre; from inside, leave through the nearer of the
/// side and the cap.
pub(crate) fn sphere_cylinder(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    let Core::Cylinder(hh, r) = b.core else {
        return None;
    };
    let ca = a.pose.translation;
    let l = b.pose.inverse_transform_point(ca);
    let radial = DVec3::new(l.x, 0.0, l.z);
    let rho = radial.length();
    let dir = if rho > 1e-12 * r {
        radial / rho
    } else {
        DVec3::X
    };
    let (outward, c, sep, id) = if rho > r || l.y.abs() > hh {
        let c = dir * rho.min(r) + DVec3::Y * l.y.clamp(-hh, hh);
        let d = l - c;
        let dist = d.length();
        let id = 1 + u32::from(rho > r) + 2 * (u32::from(l.y > hh) + 2 * u32::from(l.y < -hh));
        (d / dist, c, dist - a.radius, id)
    } else {
        let side = r - rho;
        let cap = hh - l.y.abs();
        if side < cap {
            (dir, dir * r + DVec3::Y * l.y, -side - a.radius, 20)
        } else {
            let s = if l.y >= 0.0 { 1.0 } else { -1.0 };
            (
                DVec3::Y * s,
                DVec3::new(l.x, s * hh, l.z),
                -cap - a.radius,
                21 + u32::from(s < 0.0),
            )
        }
    };
    if (sep.is_nan() || sep > spec) || !outward.is_finite() {
        return None;
    }
    let n = -b.pose.transform_vector(outward);
    Some(Contact {
        normal: n,
        points: vec![(ca + n * a.radius, b.pose.transform_point(c), sep, id)],
    })
}
