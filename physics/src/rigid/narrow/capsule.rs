//! Capsule against capsule: closest points of the two inner segments.
//!
//! When the segments are (nearly) parallel the contact is a line, and the
//! manifold takes the two ends of the overlap, so a capsule lying on
//! another does not rock. Capsule against box and hull goes through the
//! general path in `convex.rs` (GJK/EPA on the segment against the
//! polytope, then the segment clipped against the box face).

use glam::DVec3;

use super::convex::{manifold_from_features, Convex, Core};
use super::sat::closest_segment_segment;
use super::Contact;

fn segment(c: &Convex<'_>) -> (DVec3, DVec3) {
    let h = match c.core {
        Core::Segment(h) => h,
        _ => 0.0,
    };
    (
        c.pose.transform_point(DVec3::new(0.0, -h, 0.0)),
        c.pose.transform_point(DVec3::new(0.0, h, 0.0)),
    )
}

/// Capsule `a` against capsule `b` (common frame).
pub(crate) fn capsule_capsule(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    let (a0, a1) = segment(a);
    let (b0, b1) = segment(b);
    let (p, q) = closest_segment_segment(a0, a1, b0, b1);
    let d = q - p;
    let dist = d.length();
    let radii = a.radius + b.radius;
    let sep = dist - radii;
    if sep.is_nan() || sep > spec {
        return None;
    }
    let n = if dist > 1e-12 * radii {
        d / dist
    } else {
        // Axes meet: the common perpendicular, else away from A's axis
        // towards B's centre, else any perpendicular.
        let da = (a1 - a0).normalize_or(DVec3::Y);
        let db = (b1 - b0).normalize_or(DVec3::Y);
        let towards = b.pose.translation - a.pose.translation;
        let c = da.cross(db);
        let n = if c.length() > 1e-9 {
            c.normalize()
        } else {
            let perp = towards - da * da.dot(towards);
            perp.normalize_or(da.any_orthonormal_vector())
        };
        if n.dot(towards) < 0.0 {
            -n
        } else {
            n
        }
    };
    Some(manifold_from_features(a, b, n, sep, p, q, spec))
}
