//! Nearest surface points (see the note in the parent module).

use glam::DVec3;

use super::{cell_triangles, PointProjection};
use crate::rigid::narrow::gjk::closest_triangle;
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;

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
    closest_triangle(t[0] - p, t[1] - p, t[2] - p).point(&t)
}
