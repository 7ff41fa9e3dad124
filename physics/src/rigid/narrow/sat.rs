//! Separating-axis test between two polytopes (boxes, hulls, triangles),
//! then a manifold: the reference face's side planes clip the most
//! anti-parallel face of the other shape (face contact), or the closest
//! points of the two best edges (edge contact).
//!
//! Axes tried: every face normal of A, every face normal of B, and the
//! cross products of edge pairs. For closed polytopes (boxes, hulls) only
//! the edge pairs whose Gauss-map arcs cross are tried (they build a face
//! of the Minkowski difference, Gregorius GDC 2013), each measured from
//! its two edges; for triangles (whose Gauss map is degenerate) every pair
//! is tried and measured by projecting both shapes, valid for any axis. Face
//! axes win ties (within a tolerance) because face contacts give the
//! stable multi-point manifolds a resting stack needs; A's faces win ties
//! against B's for determinism.

use glam::DVec3;

use super::convex::{
    convex_convex, convex_convex_from, gjk_start, manifold_from_features, Convex, Feature, Polytope,
};
use super::gjk::{gjk, gjk_or_axis, GjkResult};
use super::{pack_id, Contact};

/// Vertices of a polytope mapped into the common frame.
fn world_verts(p: &Polytope<'_>) -> Vec<DVec3> {
    p.verts.iter().map(|&v| p.pose.transform_point(v)).collect()
}

fn max_dot(v: &[DVec3], d: DVec3) -> f64 {
    v.iter().map(|p| p.dot(d)).fold(f64::NEG_INFINITY, f64::max)
}

fn min_dot(v: &[DVec3], d: DVec3) -> f64 {
    v.iter().map(|p| p.dot(d)).fold(f64::INFINITY, f64::min)
}

/// Edge pairs above which two polytopes go to GJK/EPA instead of the
/// separating-axis test (boxes have 12 edges: 144 pairs; a 32-point hull
/// about 90: 8100).
const MAX_EDGE_PAIRS: usize = 1024;

#[derive(Debug, Clone, Copy)]
enum Axis {
    FaceA(usize),
    FaceB(usize),
    Edge,
}

/// Contact between two polytope shapes (`a`, `b` with radius 0) in the
/// common frame; `None` when farther apart than `spec`, with `apart` set
/// to the axis that showed it where there is one (see [`super::Apart`]).
pub(crate) fn polytope_polytope(
    a: &Convex<'_>,
    b: &Convex<'_>,
    spec: f64,
    apart: &mut super::Apart,
) -> Option<Contact> {
    let scale = a.size().max(b.size()).max(1e-12);
    // Most pairs the broad phase hands over are apart: for hulls, GJK (a
    // few support queries) settles that before the separating-axis test
    // (every face against every vertex). Its answer is reused below.
    let sa = |d: DVec3| a.core_support(d);
    let sb = |d: DVec3| b.core_support(d);
    let early = if matches!(a.core, super::convex::Core::Hull(_))
        || matches!(b.core, super::convex::Core::Hull(_))
    {
        match gjk_or_axis(&sa, &sb, gjk_start(a, b), scale, spec) {
            Err(axis) => {
                *apart = Some(axis);
                return None;
            }
            Ok(GjkResult::Separated {
                distance,
                point_a,
                point_b,
            }) if distance > spec => {
                *apart = Some((point_b - point_a) / distance);
                return None;
            }
            Ok(r) => Some(r),
        }
    } else {
        None
    };
    // GJK/EPA and the features along its normal, from the answer above
    // when there is one (polytopes have no radius, so it is the answer
    // `convex_convex` would find).
    let general = |early: Option<GjkResult>, apart: &mut super::Apart| match early {
        Some(found) if a.radius + b.radius == 0.0 => convex_convex_from(a, b, spec, scale, found),
        _ => convex_convex(a, b, spec, apart),
    };
    let pa = a.polytope()?;
    let pb = b.polytope()?;
    if pa.edges.len() * pb.edges.len() > MAX_EDGE_PAIRS {
        // Many-sided hulls: the edge-pair test would dominate; GJK/EPA and
        // the features along its normal give the manifold instead (as
        // Rapier does for every convex pair).
        return general(early, apart);
    }
    let va = world_verts(&pa);
    let vb = world_verts(&pb);

    let mut best_face = (f64::NEG_INFINITY, Axis::FaceA(0));
    for (i, f) in pa.faces.iter().enumerate() {
        let n = pa.pose.transform_vector(f.normal);
        let s = min_dot(&vb, n) - (f.offset + n.dot(pa.pose.translation));
        if s > best_face.0 {
            best_face = (s, Axis::FaceA(i));
        }
    }
    // A's faces win ties with B's.
    let face_tol = super::tie_margin(scale);
    for (i, f) in pb.faces.iter().enumerate() {
        let n = pb.pose.transform_vector(f.normal);
        let s = min_dot(&va, n) - (f.offset + n.dot(pb.pose.translation));
        if s > best_face.0 + face_tol {
            best_face = (s, Axis::FaceB(i));
        }
    }
    let mut best = best_face;
    if best.0 <= spec {
        let edge_tol = super::edge_margin(scale, best_face.0);
        let edge = match (edge_adjacency(&pa), edge_adjacency(&pb)) {
            (Some(ja), Some(jb)) => gauss_map_edges(&pa, &pb, &va, &vb, &ja, &jb),
            _ => projected_edges(&pa, &pb, &va, &vb),
        };
        if edge > best.0 + edge_tol && edge > best_face.0 + edge_tol {
            best = (edge, Axis::Edge);
        }
    }
    let (sat_sep, axis) = best;
    if sat_sep.is_nan() || sat_sep > spec {
        // A face's normal (outward from A, or B's turned) separates them.
        *apart = match axis {
            Axis::FaceA(i) => Some(pa.pose.transform_vector(pa.faces[i].normal)),
            Axis::FaceB(i) => Some(-pb.pose.transform_vector(pb.faces[i].normal)),
            Axis::Edge => None,
        };
        return None;
    }
    if sat_sep > 0.0 {
        // Separated: GJK gives the exact distance and direction. If it
        // agrees with a face axis, clip that face; otherwise one point.
        let result = early
            .clone()
            .unwrap_or_else(|| gjk(&sa, &sb, gjk_start(a, b), scale));
        if let GjkResult::Separated {
            distance,
            point_a,
            point_b,
        } = result
        {
            let n = (point_b - point_a) / distance;
            if distance > spec {
                *apart = Some(n);
                return None;
            }
            if (distance - sat_sep).abs() > 1e-6 * scale || matches!(axis, Axis::Edge) {
                return Some(manifold_from_features(
                    a, b, n, distance, point_a, point_b, spec,
                ));
            }
        }
    }
    match axis {
        Axis::FaceA(i) => face_contact(&pa, &pb, i, sat_sep, spec, 0),
        Axis::FaceB(i) => face_contact(&pb, &pa, i, sat_sep, spec, 1).map(|c| Contact {
            normal: -c.normal,
            points: c
                .points
                .into_iter()
                .map(|(p, q, s, id)| (q, p, s, id))
                .collect(),
        }),
        // Edge against edge: EPA on the polytopes is exact and gives the
        // witness points of the two edges.
        Axis::Edge => return general(early, apart),
    }
    .map(super::reduce)
}

/// Best edge-pair separation by projecting both shapes on every
/// cross product (any axis is a valid test; used for triangles, whose
/// Gauss map is degenerate).
fn projected_edges(pa: &Polytope<'_>, pb: &Polytope<'_>, va: &[DVec3], vb: &[DVec3]) -> f64 {
    let mut best = f64::NEG_INFINITY;
    for ea in pa.edges.iter() {
        let da = va[ea[1] as usize] - va[ea[0] as usize];
        for eb in pb.edges.iter() {
            let db = vb[eb[1] as usize] - vb[eb[0] as usize];
            let c = da.cross(db);
            let l = c.length();
            if l <= 1e-6 * da.length() * db.length() {
                continue;
            }
            // Either sign of the axis is a valid test; take the better.
            let n = c / l;
            let forward = min_dot(vb, n) - max_dot(va, n);
            let backward = min_dot(va, n) - max_dot(vb, n);
            best = best.max(forward).max(backward);
        }
    }
    best
}

/// An edge `[v0, v1]` with the faces on its two sides.
type AdjacentEdge = (u32, u32, usize, usize);

/// Each edge of a closed polytope with its two faces, from the face loops;
/// `None` when the faces do not pair up (a triangle's two sides).
fn edge_adjacency<'p>(p: &'p Polytope<'_>) -> Option<std::borrow::Cow<'p, [AdjacentEdge]>> {
    if let Some(cached) = p.edge_faces {
        return (!cached.is_empty()).then_some(std::borrow::Cow::Borrowed(cached));
    }
    edge_adjacency_of(p).map(std::borrow::Cow::Owned)
}

/// [`edge_adjacency`] computed from the faces.
fn edge_adjacency_of(p: &Polytope<'_>) -> Option<Vec<AdjacentEdge>> {
    let mut half: Vec<(u32, u32, usize)> = Vec::with_capacity(p.edges.len() * 2);
    for (fi, f) in p.faces.iter().enumerate() {
        let k = f.vertices.len();
        for i in 0..k {
            let (u, v) = (f.vertices[i], f.vertices[(i + 1) % k]);
            half.push((u.min(v), u.max(v), fi));
        }
    }
    half.sort_unstable();
    if half.len() % 2 != 0 {
        return None;
    }
    let mut out = Vec::with_capacity(half.len() / 2);
    for pair in half.chunks(2) {
        if pair[0].0 != pair[1].0 || pair[0].1 != pair[1].1 || pair[0].2 == pair[1].2 {
            return None;
        }
        out.push((pair[0].0, pair[0].1, pair[0].2, pair[1].2));
    }
    Some(out)
}

/// Best edge-pair separation over the pairs whose arcs cross on the Gauss
/// map, i.e. that build a face of the Minkowski difference (Gregorius,
/// GDC 2013); only those can realise the separation, and each is measured
/// from its two edges directly, without projecting the whole shapes.
fn gauss_map_edges(
    pa: &Polytope<'_>,
    pb: &Polytope<'_>,
    va: &[DVec3],
    vb: &[DVec3],
    ja: &[AdjacentEdge],
    jb: &[AdjacentEdge],
) -> f64 {
    let na: Vec<DVec3> = pa
        .faces
        .iter()
        .map(|f| pa.pose.transform_vector(f.normal))
        .collect();
    let nb: Vec<DVec3> = pb
        .faces
        .iter()
        .map(|f| -pb.pose.transform_vector(f.normal))
        .collect();
    let centroid = va.iter().copied().sum::<DVec3>() / va.len().max(1) as f64;
    let mut best = f64::NEG_INFINITY;
    for &(a0, a1, fa0, fa1) in ja {
        let (a, b) = (na[fa0], na[fa1]);
        let bxa = b.cross(a);
        let pa0 = va[a0 as usize];
        let ea = va[a1 as usize] - pa0;
        for &(b0, b1, fb0, fb1) in jb {
            let (c, d) = (nb[fb0], nb[fb1]);
            let dxc = d.cross(c);
            let cba = c.dot(bxa);
            let dba = d.dot(bxa);
            let adc = a.dot(dxc);
            let bdc = b.dot(dxc);
            if !(cba * dba < 0.0 && adc * bdc < 0.0 && cba * bdc > 0.0) {
                continue;
            }
            let pb0 = vb[b0 as usize];
            let eb = vb[b1 as usize] - pb0;
            let axis = ea.cross(eb);
            let l = axis.length();
            if l <= 1e-6 * ea.length() * eb.length() {
                continue;
            }
            let mut n = axis / l;
            if n.dot(pa0 - centroid) < 0.0 {
                n = -n;
            }
            best = best.max(n.dot(pb0 - pa0));
        }
    }
    best
}

/// Face `fi` of `rf` is the reference; the face of `inc` most anti-parallel
/// to it is clipped against its side planes.
fn face_contact(
    rf: &Polytope<'_>,
    inc: &Polytope<'_>,
    fi: usize,
    sat_sep: f64,
    spec: f64,
    ref_side: u32,
) -> Option<Contact> {
    let face = &rf.faces[fi];
    let n = rf.pose.transform_vector(face.normal);
    let ref_feature = Feature {
        pts: face
            .vertices
            .iter()
            .map(|&v| rf.pose.transform_point(rf.verts[v as usize]))
            .collect(),
        ids: face.vertices.iter().map(|&v| v + 1).collect(),
        face: fi as u32,
        plane: Some(n),
    };
    let local_n = inc.pose.inverse_transform_vector(-n);
    let ii = inc.best_face_local(local_n);
    let iface = &inc.faces[ii];
    let inc_feature = Feature {
        pts: iface
            .vertices
            .iter()
            .map(|&v| inc.pose.transform_point(inc.verts[v as usize]))
            .collect(),
        ids: iface.vertices.iter().map(|&v| v + 1).collect(),
        face: ii as u32,
        plane: Some(-n),
    };
    let c = super::convex::clip_features(&ref_feature, &inc_feature, n, 0.0, 0.0, spec, ref_side);
    match c {
        Some(c) if !c.points.is_empty() => Some(c),
        _ => {
            // Clipping lost every point (rounding at a touching corner):
            // the deepest incident vertex alone.
            let (k, q) = inc_feature
                .pts
                .iter()
                .enumerate()
                .min_by(|x, y| x.1.dot(n).total_cmp(&y.1.dot(n)))?;
            let p = q - n * sat_sep;
            Some(Contact {
                normal: n,
                points: vec![(
                    p,
                    *q,
                    sat_sep,
                    pack_id(ref_side, fi as u32, ii as u32, inc_feature.ids[k], 0),
                )],
            })
        }
    }
}

/// Closest points between segments `p0p1` and `q0q1` (Ericson §5.1.9).
pub(crate) fn closest_segment_segment(
    p0: DVec3,
    p1: DVec3,
    q0: DVec3,
    q1: DVec3,
) -> (DVec3, DVec3) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let tiny = 1e-300;
    let (s, t);
    if a <= tiny && e <= tiny {
        return (p0, q0);
    }
    if a <= tiny {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(r);
        if e <= tiny {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > 1e-12 * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                // Parallel: the middle of the overlap keeps the point stable.
                let t0 = (-c / a).clamp(0.0, 1.0);
                let t1 = ((b - c) / a).clamp(0.0, 1.0);
                0.5 * (t0 + t1)
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    (p0 + d1 * s, q0 + d2 * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rigid::narrow::to_convex;
    use crate::rigid::pose::Pose;
    use crate::rigid::shape::Shape;
    use glam::DQuat;

    /// Best face separation of the pair (both directions).
    fn face_sep(pa: &Polytope<'_>, pb: &Polytope<'_>, va: &[DVec3], vb: &[DVec3]) -> f64 {
        let mut best = f64::NEG_INFINITY;
        for (p, v) in [(pa, vb), (pb, va)] {
            for f in p.faces.iter() {
                let n = p.pose.transform_vector(f.normal);
                best = best.max(min_dot(v, n) - (f.offset + n.dot(p.pose.translation)));
            }
        }
        best
    }

    /// For overlapping shapes, the SAT maximum over faces and Gauss-map
    /// edge pairs equals the one over faces and all edge pairs: pruning
    /// loses no axis that matters.
    #[test]
    fn gauss_map_pruning_keeps_the_sat_maximum() {
        let mut seed = 5u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let box_shape = Shape::cuboid(DVec3::new(0.5, 0.3, 0.2)).unwrap();
        let mut edge_wins = 0;
        for round in 0..300 {
            let cloud: Vec<DVec3> = (0..12)
                .map(|_| DVec3::new(next(), next(), next()) * 0.5)
                .collect();
            let hull = Shape::convex_hull(&cloud).unwrap();
            let other = if round % 2 == 0 { &hull } else { &box_shape };
            let q = DQuat::from_xyzw(next(), next(), next(), next() + 1.5).normalize();
            let pose = Pose::new(DVec3::new(next(), next(), next()) * 0.5, q);
            let a = to_convex(&hull, Pose::IDENTITY).unwrap();
            let b = to_convex(other, pose).unwrap();
            let (pa, pb) = (a.polytope().unwrap(), b.polytope().unwrap());
            let (va, vb) = (world_verts(&pa), world_verts(&pb));
            let ja = edge_adjacency(&pa).unwrap();
            let jb = edge_adjacency(&pb).unwrap();
            let faces = face_sep(&pa, &pb, &va, &vb);
            let gauss = gauss_map_edges(&pa, &pb, &va, &vb, &ja, &jb);
            let all = projected_edges(&pa, &pb, &va, &vb);
            assert!(
                gauss <= all + 1e-12,
                "a Gauss-map axis beat its own projection"
            );
            if faces.max(all) > 0.0 {
                // Apart, the closest features may be vertex–vertex, whose
                // axis is neither kind; SAT is exact only for overlap.
                continue;
            }
            assert!(
                (faces.max(gauss) - faces.max(all)).abs() < 1e-9,
                "round {round}: faces {faces}, gauss {gauss}, all {all}"
            );
            if gauss > faces {
                edge_wins += 1;
            }
        }
        assert!(edge_wins > 10, "{edge_wins}");
    }
}
