//! Box–box contact: the separating axis test over the 15 axes of two
//! boxes (3 + 3 face normals, 9 edge cross products; Gottschalk 1996,
//! ODE's `dBoxBox`), then a face manifold by clipping or one edge–edge
//! point.
//!
//! It gives what the generic polytope path (`sat.rs`, then `convex.rs`)
//! gives for two boxes: the same tie rules (A's faces win exact ties, B's
//! faces must beat A's by [`super::tie_margin`], edges must beat faces by
//! [`super::edge_margin`]), the same clipping, point
//! keys and reduction, so the same points and feature ids, which stay put
//! while a box rests. It works on the boxes' axes directly: no vertex
//! lists, no edge adjacency, no heap until the result is built, and GJK
//! only where the generic path's answer needs it.
//!
//! - *Face axis*: the incident face (the other box's face most
//!   anti-parallel to the reference face) is clipped against the
//!   reference face's side planes (Sutherland–Hodgman).
//! - *Edge axis*: the normal is the cross product itself (the generic
//!   path gets it from EPA, exact on polytopes, so they agree to
//!   rounding). When a face of either box lies within about 26° of it
//!   (cosine ≥ 0.9, the generic path's rule) that face is the reference
//!   and the other box's best face is clipped against it along the edge
//!   normal: a box resting on an edge or a slightly tilted face keeps
//!   several points. Otherwise one point, the closest points of the two
//!   edges.
//! - *Apart*: the SAT gap only bounds the distance. It is the distance
//!   when a clipped point lies at it over the reference face (to
//!   `1e-6 · scale`, the generic path's tolerance), or when the closest
//!   points of the edges' lines lie on both edges; otherwise GJK measures
//!   the gap and the manifold is built from the features along its
//!   direction, as in the generic path.
//!
//! The one difference from the generic path: an edge–edge contact that
//! ends as one point takes its id from the two edges' corners (the
//! generic path hashes the best faces along the normal), so it stays put
//! while the same edges touch.

use glam::{DMat3, DVec3};

use super::convex::{convex_convex, manifold_from_features, mix, Convex, Core};
use super::gjk::{gjk, GjkResult};
use super::sat::closest_segment_segment;
use super::{pack_id, reduce_in_place, Contact};
use crate::rigid::pose::Pose;

/// A contact point under construction: on A, on B, separation, id.
type Point = (DVec3, DVec3, f64, u32);

/// Room for a clipped polygon: a quad gains at most one point per side
/// plane (8 in all); twice that leaves a margin for rounding, and a point
/// that would not fit is dropped rather than allocated.
const CAP: usize = 16;

/// Face `f` of a box: outward normal `+axis` for even `f`, `-axis` for odd,
/// with `axis = f / 2`; corners counter-clockwise seen from outside. Corner
/// `v` has bit `k` set when its coordinate `k` is `+h_k` (the numbering of
/// the generic path's box topology, so ids agree).
const QUADS: [[u32; 4]; 6] = [
    [1, 3, 7, 5],
    [0, 4, 6, 2],
    [2, 6, 7, 3],
    [0, 1, 5, 4],
    [4, 5, 7, 6],
    [0, 2, 3, 1],
];

/// Least cosine between a face's normal and an edge–edge normal for that
/// face to be clipped against (about 26°, as in the generic path).
const FACE_ALIGNED: f64 = 0.9;

/// The face index given to edge–edge ids (faces are 0..6).
const EDGE_FEATURE: u32 = 6;

/// Added to `|a_i · b_j|` in the edge axes' projected radii, so that
/// nearly parallel edges (a small cross product amplifies rounding) never
/// show a false gap.
const EDGE_EPS: f64 = 1e-12;

/// A box placed in the common frame.
#[derive(Debug, Clone, Copy)]
struct Obb {
    centre: DVec3,
    axes: [DVec3; 3],
    half: [f64; 3],
}

impl Obb {
    fn new(half: DVec3, pose: &Pose) -> Obb {
        let m = DMat3::from_quat(pose.rotation);
        Obb {
            centre: pose.translation,
            axes: [m.x_axis, m.y_axis, m.z_axis],
            half: half.to_array(),
        }
    }

    /// Corner `v` (see [`QUADS`]) in the common frame.
    fn corner(&self, v: u32) -> DVec3 {
        let s = |k: usize| {
            if v & (1 << k) != 0 {
                self.half[k]
            } else {
                -self.half[k]
            }
        };
        self.centre + self.axes[0] * s(0) + self.axes[1] * s(1) + self.axes[2] * s(2)
    }

    /// Outward unit normal of face `f`.
    fn normal(&self, f: usize) -> DVec3 {
        if f % 2 == 0 {
            self.axes[f / 2]
        } else {
            -self.axes[f / 2]
        }
    }

    /// The first face whose normal is closest to the direction `dir`
    /// (later faces must beat it by `1e-12`, as in the generic path).
    fn best_face(&self, dir: DVec3) -> usize {
        let local = self.axes.map(|x| x.dot(dir));
        let mut best = 0;
        let mut best_dot = f64::NEG_INFINITY;
        for f in 0..6 {
            let dot = if f % 2 == 0 {
                local[f / 2]
            } else {
                -local[f / 2]
            };
            if dot > best_dot + 1e-12 {
                best_dot = dot;
                best = f;
            }
        }
        best
    }
}

/// The winning axis of the separating axis test.
#[derive(Debug, Clone, Copy)]
enum Axis {
    /// Face `face` (0..6) of A (`side` 0) or B (`side` 1).
    Face { side: u32, face: usize },
    /// `a_i × b_j`, unit, oriented from A to B.
    Edge { i: usize, j: usize, normal: DVec3 },
}

/// How [`box_box`] found its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// Not boxes, or farther apart than `spec` by SAT.
    Apart,
    /// Face axis: the incident face clipped.
    Face,
    /// Edge axis with a face within 26°: faces clipped along it.
    EdgeFaces,
    /// Edge axis: one point.
    Edge,
    /// Apart, SAT gap not the distance: GJK as in the generic path.
    Gjk,
}

/// Points of a manifold under construction, on the stack.
type Buf = [Point; CAP];

/// Contact between two boxes (`Core::Cuboid`, radius 0) in the common
/// frame, normal from A to B; `None` when farther apart than `spec`, or
/// when either core is not a box.
pub(crate) fn box_box(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> Option<Contact> {
    routed(a, b, spec).0
}

fn routed(a: &Convex<'_>, b: &Convex<'_>, spec: f64) -> (Option<Contact>, Route) {
    let (Core::Cuboid(ha), Core::Cuboid(hb)) = (a.core, b.core) else {
        return (None, Route::Apart);
    };
    let ba = Obb::new(ha, &a.pose);
    let bb = Obb::new(hb, &b.pose);
    let scale = a.size().max(b.size()).max(1e-12);
    let d = bb.centre - ba.centre;
    // r[i][j] = a_i · b_j; the centre offset in A's and in B's axes.
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = ba.axes[i].dot(bb.axes[j]);
        }
    }
    let da = ba.axes.map(|x| x.dot(d));
    let db = bb.axes.map(|x| x.dot(d));
    let (ha, hb) = (ba.half, bb.half);

    // Face axes. A's face along +a_i faces B when d · a_i >= 0 (the +
    // face wins an exact tie, as in the generic path's face order).
    let mut best = (f64::NEG_INFINITY, Axis::Face { side: 0, face: 0 });
    for i in 0..3 {
        let rb = r[i][0].abs() * hb[0] + r[i][1].abs() * hb[1] + r[i][2].abs() * hb[2];
        let s = da[i].abs() - ha[i] - rb;
        if s > best.0 {
            let face = 2 * i + usize::from(da[i] < 0.0);
            best = (s, Axis::Face { side: 0, face });
        }
    }
    // A's faces win ties with B's.
    let face_tol = super::tie_margin(scale);
    for j in 0..3 {
        let ra = r[0][j].abs() * ha[0] + r[1][j].abs() * ha[1] + r[2][j].abs() * ha[2];
        let s = db[j].abs() - hb[j] - ra;
        if s > best.0 + face_tol {
            // B's face along +b_j faces A when d · b_j <= 0.
            let face = 2 * j + usize::from(db[j] > 0.0);
            best = (s, Axis::Face { side: 1, face });
        }
    }

    // Edge axes, only when the faces leave the pair within reach.
    if best.0 <= spec {
        let edge_tol = super::edge_margin(scale, best.0);
        if let Some((s, axis)) = best_edge(&ba, &bb, &r, d) {
            if s > best.0 + edge_tol {
                best = (s, axis);
            }
        }
    }
    let (sat_sep, axis) = best;
    if !sat_sep.is_finite() || sat_sep > spec {
        return (None, Route::Apart);
    }
    let mut buf = [(DVec3::ZERO, DVec3::ZERO, 0.0, 0u32); CAP];
    match axis {
        Axis::Face { side, face } => {
            let (rf, inc) = if side == 0 { (&ba, &bb) } else { (&bb, &ba) };
            let n = rf.normal(face);
            let inc_face = inc.best_face(-n);
            let (len, min_dist) = clip_faces(rf, face, inc, inc_face, n, side, spec, &mut buf);
            // Apart, the SAT gap is the distance when a clipped point lies
            // at it over the reference face; otherwise GJK decides.
            let exact = min_dist - sat_sep <= 1e-6 * scale && min_dist <= spec;
            if sat_sep > 0.0 && !exact {
                if let Some(c) = separated_face(a, b, sat_sep, spec, scale) {
                    return (c, Route::Gjk);
                }
            }
            let len = if len > 0 {
                len
            } else {
                // Clipping lost every point (rounding at a touching
                // corner): the deepest incident vertex alone.
                let (q, key) = QUADS[inc_face]
                    .map(|v| (inc.corner(v), v + 1))
                    .into_iter()
                    .min_by(|x, y| x.0.dot(n).total_cmp(&y.0.dot(n)))
                    .unwrap_or((inc.centre, 0));
                let id = pack_id(side, face as u32, inc_face as u32, key, 0);
                buf[0] = (q - n * sat_sep, q, sat_sep, id);
                1
            };
            let normal = if side == 0 { n } else { -n };
            (Some(finish(normal, &mut buf[..len], side)), Route::Face)
        }
        Axis::Edge { i, j, normal: n } => {
            let point = || edge_contact(&ba, &bb, i, j, n);
            if sat_sep > 0.0 {
                let w = point();
                let w = w.1 - w.0;
                if (w - n * w.dot(n)).length() > 1e-9 * scale {
                    // Apart, and the closest points of the edges' lines
                    // lie off the edges: a vertex is nearest and the axis
                    // only bounds the gap. GJK, as in the generic path.
                    return (convex_convex(a, b, spec, &mut None), Route::Gjk);
                }
            }
            // A face within 26° of the normal: clip, as the generic
            // path's features do.
            let (fa, fb) = (ba.best_face(n), bb.best_face(-n));
            let align_a = ba.normal(fa).dot(n);
            let align_b = -bb.normal(fb).dot(n);
            let (len, side) = if align_a >= FACE_ALIGNED && align_a + 1e-9 >= align_b {
                (clip_faces(&ba, fa, &bb, fb, n, 0, spec, &mut buf).0, 0)
            } else if align_b >= FACE_ALIGNED {
                (clip_faces(&bb, fb, &ba, fa, -n, 1, spec, &mut buf).0, 1)
            } else {
                (0, 0)
            };
            if len == 0 {
                let c = Contact {
                    normal: n,
                    points: vec![point()],
                };
                return (Some(c), Route::Edge);
            }
            (Some(finish(n, &mut buf[..len], side)), Route::EdgeFaces)
        }
    }
}

/// The contact from clipped points (on the reference box first): points
/// put in (on A, on B) order, then reduced as the generic path does.
fn finish(normal: DVec3, pts: &mut [Point], ref_side: u32) -> Contact {
    if ref_side == 1 {
        for p in pts.iter_mut() {
            *p = (p.1, p.0, p.2, p.3);
        }
    }
    let kept = reduce_in_place(normal, pts);
    Contact {
        normal,
        points: pts[..kept].to_vec(),
    }
}

/// A separated pair whose best axis is a face but whose SAT gap may not
/// be the distance: the generic path's rule. GJK measures the gap; beyond
/// `spec` there is no contact; if it differs from the SAT gap by more than
/// `1e-6 · scale`, the manifold is built from the features along GJK's
/// direction. `None` when the face contact stands.
fn separated_face(
    a: &Convex<'_>,
    b: &Convex<'_>,
    sat_sep: f64,
    spec: f64,
    scale: f64,
) -> Option<Option<Contact>> {
    let sa = |v: DVec3| a.core_support(v);
    let sb = |v: DVec3| b.core_support(v);
    let GjkResult::Separated {
        distance,
        point_a,
        point_b,
    } = gjk(&sa, &sb, a.pose.translation - b.pose.translation, scale)
    else {
        return None;
    };
    if distance > spec {
        return Some(None);
    }
    if (distance - sat_sep).abs() <= 1e-6 * scale {
        return None;
    }
    let n = (point_b - point_a) / distance;
    Some(Some(manifold_from_features(
        a, b, n, distance, point_a, point_b, spec,
    )))
}

/// The best of the 9 edge axes `a_i × b_j` (skipping nearly parallel
/// edges): its separation and axis, oriented from A to B. Every such axis
/// is supported by an edge of each box, so projecting the boxes measures
/// the same pairs as the generic path's Gauss-map test.
fn best_edge(ba: &Obb, bb: &Obb, r: &[[f64; 3]; 3], d: DVec3) -> Option<(f64, Axis)> {
    let (ha, hb) = (ba.half, bb.half);
    let mut best: Option<(f64, Axis)> = None;
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let l = ba.axes[i].cross(bb.axes[j]);
            let len = l.length();
            if len <= 1e-6 {
                continue;
            }
            let ra = ha[i1] * (r[i2][j].abs() + EDGE_EPS) + ha[i2] * (r[i1][j].abs() + EDGE_EPS);
            let rb = hb[j1] * (r[i][j2].abs() + EDGE_EPS) + hb[j2] * (r[i][j1].abs() + EDGE_EPS);
            let dl = d.dot(l);
            let s = (dl.abs() - ra - rb) / len;
            if best.is_none_or(|(b, _)| s > b) {
                let normal = if dl < 0.0 { -l / len } else { l / len };
                best = Some((s, Axis::Edge { i, j, normal }));
            }
        }
    }
    best
}

/// The point of an edge–edge contact: the closest points of A's edge
/// along `a_i` that supports `n` and B's edge along `b_j` that supports
/// `-n`, their separation along `n`, and an id from the four corners.
fn edge_contact(ba: &Obb, bb: &Obb, i: usize, j: usize, n: DVec3) -> Point {
    let mut va = 0u32;
    let mut vb = 0u32;
    for k in 0..3 {
        if k != i && n.dot(ba.axes[k]) >= 0.0 {
            va |= 1 << k;
        }
        if k != j && n.dot(bb.axes[k]) < 0.0 {
            vb |= 1 << k;
        }
    }
    let (va1, vb1) = (va | (1 << i), vb | (1 << j));
    let (p, q) =
        closest_segment_segment(ba.corner(va), ba.corner(va1), bb.corner(vb), bb.corner(vb1));
    let id = pack_id(
        0,
        EDGE_FEATURE,
        EDGE_FEATURE,
        (va + 1) | ((va1 + 1) << 8),
        (vb + 1) | ((vb1 + 1) << 8),
    );
    (p, q, (q - p).dot(n), id)
}

/// Face `fi` of `rf` is the reference, face `ii` of `inc` the incident
/// face, `n` the contact normal (from `rf` towards `inc`, within 26° of
/// the reference face's normal): the incident face is clipped against the
/// reference face's side planes (Sutherland–Hodgman), as the generic
/// path's `clip_features` does. Writes the points within `spec` (on the
/// reference box, on the incident box, separation, id) into `out`; returns
/// their number and the least separation over the clipped polygon (`+∞`
/// when clipping left nothing).
#[allow(clippy::too_many_arguments)]
fn clip_faces(
    rf: &Obb,
    fi: usize,
    inc: &Obb,
    ii: usize,
    n: DVec3,
    ref_side: u32,
    spec: f64,
    out: &mut Buf,
) -> (usize, f64) {
    let m = rf.normal(fi);
    let mn = m.dot(n);
    if mn <= 0.0 {
        return (0, f64::INFINITY);
    }
    let ref_pts = QUADS[fi].map(|v| rf.corner(v));
    let mut buf_a = [(DVec3::ZERO, 0u32); CAP];
    let mut buf_b = [(DVec3::ZERO, 0u32); CAP];
    for (slot, v) in buf_a.iter_mut().zip(QUADS[ii]) {
        *slot = (inc.corner(v), v + 1);
    }
    let (mut src, mut dst) = (&mut buf_a, &mut buf_b);
    let mut len = 4;
    for j in 0..4 {
        let v0 = ref_pts[j];
        let v1 = ref_pts[(j + 1) % 4];
        let side = (v1 - v0).cross(n);
        if side.length_squared() == 0.0 {
            continue;
        }
        len = clip_by_plane(&src[..len], side, side.dot(v0), j as u32, dst);
        std::mem::swap(&mut src, &mut dst);
        if len == 0 {
            return (0, f64::INFINITY);
        }
    }
    let origin = ref_pts[0];
    let mut count = 0;
    let mut min_dist = f64::INFINITY;
    for &(q, key) in &src[..len] {
        let dist = (q - origin).dot(m) / mn;
        min_dist = min_dist.min(dist);
        if dist <= spec {
            let id = pack_id(ref_side, fi as u32, ii as u32, key, 0);
            out[count] = (q - n * dist, q, dist, id);
            count += 1;
        }
    }
    (count, min_dist)
}

/// Sutherland–Hodgman against the half space `side · x <= offset`, into
/// `out`; returns the number of points. A cut point's key mixes the keys
/// of the edge it cuts and the plane index; 1 point is kept or not, and 2
/// points are a segment, walked once (the rules of the generic path).
fn clip_by_plane(
    poly: &[(DVec3, u32)],
    side: DVec3,
    offset: f64,
    plane: u32,
    out: &mut [(DVec3, u32); CAP],
) -> usize {
    let mut n = 0;
    let mut push = |x: (DVec3, u32)| {
        if n < CAP {
            out[n] = x;
            n += 1;
        }
    };
    let len = poly.len();
    if len == 0 {
        return 0;
    }
    if len == 1 {
        if side.dot(poly[0].0) <= offset {
            push(poly[0]);
        }
        return n;
    }
    let edges = if len == 2 { 1 } else { len };
    for i in 0..edges {
        let (p, kp) = poly[i];
        let (q, kq) = poly[(i + 1) % len];
        let dp = side.dot(p) - offset;
        let dq = side.dot(q) - offset;
        if dp <= 0.0 {
            push((p, kp));
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            let t = dp / (dp - dq);
            let key = mix(mix(kp.min(kq), kp.max(kq)), 0x100 + plane);
            push((p + (q - p) * t, key));
        }
        if len == 2 && dq <= 0.0 {
            push((q, kq));
        }
    }
    n
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::rigid::narrow::collide;
    use crate::rigid::narrow::sat::polytope_polytope;
    use crate::rigid::shape::Shape;
    use glam::DQuat;

    /// splitmix64, as in the integration tests' generator.
    pub(in crate::rigid::narrow) struct Rng(pub u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        pub(in crate::rigid::narrow) fn f64(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        pub(in crate::rigid::narrow) fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.f64()
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next_u64() % n
        }
        pub(in crate::rigid::narrow) fn in_cube(&mut self, h: f64) -> DVec3 {
            DVec3::new(self.range(-h, h), self.range(-h, h), self.range(-h, h))
        }
        pub(in crate::rigid::narrow) fn unit(&mut self) -> DVec3 {
            loop {
                let v = self.in_cube(1.0);
                let l = v.length();
                if l > 1e-3 && l <= 1.0 {
                    return v / l;
                }
            }
        }
        pub(in crate::rigid::narrow) fn rotation(&mut self) -> DQuat {
            loop {
                let q = DQuat::from_xyzw(
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                );
                let l = q.length();
                if l > 1e-3 && l <= 1.0 {
                    return q / l;
                }
            }
        }
        /// One of the box's 24 symmetries (quarter turns), as a rotation.
        fn quarter_turns(&mut self) -> DQuat {
            let turn = |k: u64| k as f64 * std::f64::consts::FRAC_PI_2;
            DQuat::from_rotation_x(turn(self.below(4)))
                * DQuat::from_rotation_y(turn(self.below(4)))
                * DQuat::from_rotation_z(turn(self.below(4)))
        }
        fn half_extents(&mut self) -> DVec3 {
            DVec3::new(
                self.range(0.1, 2.0),
                self.range(0.1, 2.0),
                self.range(0.1, 2.0),
            )
        }
    }

    fn cuboid(h: DVec3, pose: Pose) -> Convex<'static> {
        Convex {
            core: Core::Cuboid(h),
            radius: 0.0,
            pose,
        }
    }

    /// Half width of a box's projection on the unit `u`.
    fn width(b: &Obb, u: DVec3) -> f64 {
        (0..3).map(|k| b.half[k] * b.axes[k].dot(u).abs()).sum()
    }

    fn obb(c: &Convex<'_>) -> Obb {
        let Core::Cuboid(h) = c.core else {
            unreachable!()
        };
        Obb::new(h, &c.pose)
    }

    /// Signed distance between two boxes: the true gap when apart (GJK),
    /// minus the penetration depth (the best of the 15 SAT axes, exact
    /// for overlapping boxes) otherwise.
    fn signed_distance(a: &Convex<'_>, b: &Convex<'_>) -> f64 {
        let (oa, ob) = (obb(a), obb(b));
        let d = ob.centre - oa.centre;
        let mut axes: Vec<DVec3> = oa.axes.iter().chain(ob.axes.iter()).copied().collect();
        for x in oa.axes {
            for y in ob.axes {
                let c = x.cross(y);
                if c.length() > 1e-6 {
                    axes.push(c.normalize());
                }
            }
        }
        let sat = axes
            .iter()
            .map(|&u| d.dot(u).abs() - width(&oa, u) - width(&ob, u))
            .fold(f64::NEG_INFINITY, f64::max);
        if sat <= 0.0 {
            return sat;
        }
        let sa = |v: DVec3| a.core_support(v);
        let sb = |v: DVec3| b.core_support(v);
        match gjk(&sa, &sb, -d, a.size().max(b.size())) {
            GjkResult::Separated { distance, .. } => distance,
            GjkResult::Overlapping(_) => 0.0,
        }
    }

    /// A random pair: box B moved out from A's centre along a direction
    /// until the boxes overlap, touch or are apart by the gap drawn (up to
    /// 1.5 `spec`). Boxes are centrally symmetric, so the signed distance
    /// grows along the way and bisection finds the place.
    fn random_pair(rng: &mut Rng, spec: f64) -> (Convex<'static>, Convex<'static>) {
        let pose_a = if rng.below(4) == 0 {
            Pose::new(rng.in_cube(5.0), rng.rotation())
        } else {
            Pose::IDENTITY
        };
        let (ha, hb) = (rng.half_extents(), rng.half_extents());
        let rot_a = pose_a.rotation;
        let rot_b = rot_a
            * match rng.below(4) {
                0 => rng.rotation(),
                1 => rng.quarter_turns(),
                _ => {
                    let tilt = DQuat::from_axis_angle(rng.unit(), rng.range(0.0, 2e-3));
                    rng.quarter_turns() * tilt
                }
            };
        let u = if rng.below(2) == 0 {
            rng.unit()
        } else {
            // Mostly along one of A's face normals: face contacts.
            let k = rng.below(3) as usize;
            let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
            let axis = DVec3::AXES[k] * sign + rng.in_cube(0.3);
            (rot_a * axis).normalize()
        };
        let gap = match rng.below(8) {
            0 => 0.0,
            1 => rng.range(0.0, 1.5 * spec),
            _ => rng.range(-0.3 * ha.min_element().min(hb.min_element()), 1.5 * spec),
        };
        let place = |t: f64| {
            (
                cuboid(ha, pose_a),
                cuboid(hb, Pose::new(pose_a.translation + u * t, rot_b)),
            )
        };
        let (mut lo, mut hi) = (0.0, 2.0 * (ha.length() + hb.length()) + 2.0 * spec);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            let (a, b) = place(mid);
            if signed_distance(&a, &b) < gap {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        place(0.5 * (lo + hi))
    }

    fn non_empty(c: Option<Contact>) -> Option<Contact> {
        c.filter(|c| !c.points.is_empty())
    }

    fn min_sep(c: &Contact) -> f64 {
        c.points.iter().map(|p| p.2).fold(f64::INFINITY, f64::min)
    }

    /// `box_box` against the generic polytope path over 6000 random pairs
    /// (three `spec`s): same emptiness (but within `1e-6 · scale` of
    /// `spec`, where the two paths' tolerances meet), same normal (`1e-6`),
    /// same number of points, each within `1e-9 · scale` of one of the
    /// generic path's with the same separation and id (only single
    /// edge–edge points have other ids: they name the two edges). Allowed,
    /// and counted: a point at `spec` to rounding kept by one path only,
    /// and, touching across an edge, an EPA normal a hair off the SAT axis.
    #[test]
    fn matches_the_generic_path_on_random_pairs() {
        let mut routes = std::collections::BTreeMap::<String, usize>::new();
        let mut band = 0;
        let mut ambiguous = 0;
        for (k, spec) in [1e-3, 0.02, 0.1].into_iter().enumerate() {
            let mut rng = Rng(7 + k as u64);
            for round in 0..2000 {
                let (a, b) = random_pair(&mut rng, spec);
                let scale = a.size().max(b.size());
                let g = non_empty(polytope_polytope(&a, &b, spec, &mut None));
                let (f, route) = routed(&a, &b, spec);
                let f = non_empty(f);
                *routes.entry(format!("{route:?}")).or_default() += 1;
                let what = format!("spec {spec}, round {round}, {route:?}\n{a:?}\n{b:?}");
                let (g, f) = match (g, f) {
                    (None, None) => continue,
                    (Some(c), None) | (None, Some(c)) => {
                        assert!(min_sep(&c) > spec - 1e-6 * scale, "{what}\n{c:?}");
                        band += 1;
                        continue;
                    }
                    (Some(g), Some(f)) => (g, f),
                };
                let detail = format!("{what}\ngeneric {g:?}\nbox_box {f:?}");
                if (g.normal - f.normal).length() > 1e-6 {
                    // Touching across an edge, many directions measure
                    // nearly the same gap and EPA stops within its
                    // tolerance: accept a normal a hair away along which
                    // the boxes' projections are at least as far apart
                    // (the SAT axis is the best one).
                    let gap = |n: DVec3| {
                        let (oa, ob) = (obb(&a), obb(&b));
                        (ob.centre - oa.centre).dot(n) - width(&oa, n) - width(&ob, n)
                    };
                    assert!(route != Route::Face, "normal: {detail}");
                    assert!((g.normal - f.normal).length() <= 1e-4, "normal: {detail}");
                    assert!(
                        gap(f.normal) >= gap(g.normal) - 1e-9 * scale,
                        "normal: {detail}"
                    );
                    ambiguous += 1;
                    continue;
                }
                // A point at `spec` (to rounding) may be kept by one path
                // and not the other, and with it the rest of the manifold
                // may change (for instance when the other path is left
                // with no point and falls back on the deepest vertex).
                let at_spec =
                    |c: &Contact| c.points.iter().any(|p| (p.2 - spec).abs() <= 1e-9 * scale);
                if at_spec(&g) || at_spec(&f) {
                    band += 1;
                    continue;
                }
                assert!(
                    (min_sep(&g) - min_sep(&f)).abs() <= 1e-9 * scale,
                    "separation: {detail}"
                );
                assert_eq!(g.points.len(), f.points.len(), "count: {detail}");
                for p in &f.points {
                    assert!(
                        g.points.iter().any(|q| p.0.distance(q.0) <= 1e-9 * scale
                            && p.1.distance(q.1) <= 1e-9 * scale
                            && (p.2 - q.2).abs() <= 1e-9 * scale
                            && (p.3 == q.3 || route == Route::Edge)),
                        "point {p:?}: {detail}"
                    );
                }
            }
        }
        // Every route is exercised; the band near `spec` stays rare.
        for r in ["Apart", "Face", "EdgeFaces", "Edge", "Gjk"] {
            assert!(routes.get(r).copied().unwrap_or(0) >= 20, "{routes:?}");
        }
        assert!(band <= 10, "{band} pairs in the band near spec");
        assert!(ambiguous <= 10, "{ambiguous} pairs with another normal");
        println!("{routes:?}, {band} in the band near spec, {ambiguous} with another normal");
    }

    fn cuboid_shape(x: f64, y: f64, z: f64) -> Shape {
        Shape::cuboid(DVec3::new(x, y, z)).unwrap()
    }

    fn sorted_ids(m: &crate::rigid::contact::Manifold) -> Vec<u32> {
        let mut ids: Vec<u32> = m.points.iter().map(|p| p.id).collect();
        ids.sort_unstable();
        ids
    }

    /// A box resting face down on a big one: four points at its corners,
    /// separation 0, and the same ids after a tiny nudge and turn. Then
    /// tilted a hair (as after a step; flat, the boxes' faces tie and the
    /// first box's face wins), in both orders: the same ids after a nudge.
    #[test]
    fn resting_box_has_four_corners_and_stable_ids() {
        let ground = cuboid_shape(5.0, 0.5, 5.0);
        let top = cuboid_shape(0.5, 0.4, 0.3);
        let turn = |angle: f64| {
            DQuat::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), angle)
                * DQuat::from_axis_angle(DVec3::new(1.0, 0.1, -0.4).normalize(), 0.5 * angle)
        };
        let flat = Pose::from_translation(DVec3::new(0.3, 0.9, -0.2));
        let nudge = |p: Pose| {
            Pose::new(
                p.translation + DVec3::new(1e-6, -2e-7, -1e-6),
                turn(1e-6) * p.rotation,
            )
        };
        let tilted = Pose::new(DVec3::new(0.3, 0.9 + 1e-4, -0.2), turn(1e-4));
        // Tilted and swapped, the top box is A, and A's face wins the tie
        // with the ground's (within `tie_margin`): the normal is the tilted
        // face's.
        for (pose, swapped, flat_tol, normal_tol) in [
            (flat, false, 1e-12, 1e-12),
            (tilted, false, 2e-4, 1e-12),
            (tilted, true, 2e-4, 2e-4),
        ] {
            let run = |p: &Pose| {
                if swapped {
                    collide(&top, p, &ground, &Pose::IDENTITY, 0.01).unwrap()
                } else {
                    collide(&ground, &Pose::IDENTITY, &top, p, 0.01).unwrap()
                }
            };
            let m = run(&pose);
            assert_eq!(m.points.len(), 4, "{m:?}");
            let up = if swapped { -DVec3::Y } else { DVec3::Y };
            assert!((m.normal - up).length() <= normal_tol, "{m:?}");
            let mut corners = Vec::new();
            for p in &m.points {
                let (on_ground, on_top) = if swapped {
                    (p.local_b, p.local_a)
                } else {
                    (p.local_a, p.local_b)
                };
                assert!(p.separation.abs() <= flat_tol, "{m:?}");
                assert!((on_ground.y - 0.5).abs() <= 1e-12, "{m:?}");
                assert!((on_top.y + 0.4).abs() <= 1e-12, "{m:?}");
                assert!((on_top.x.abs() - 0.5).abs() <= 1e-12, "{m:?}");
                assert!((on_top.z.abs() - 0.3).abs() <= 1e-12, "{m:?}");
                corners.push((on_top.x > 0.0, on_top.z > 0.0));
            }
            corners.sort_unstable();
            corners.dedup();
            assert_eq!(corners.len(), 4, "{m:?}");
            let ids = sorted_ids(&m);
            let mut unique = ids.clone();
            unique.dedup();
            assert_eq!(unique.len(), 4, "ids unique");
            assert_eq!(ids, sorted_ids(&run(&pose)), "same call, same ids");
            let m2 = run(&nudge(pose));
            assert_eq!(ids, sorted_ids(&m2), "{m:?}\n{m2:?}");
        }
    }

    /// A box overhanging another's edge, its overhanging end dipped by
    /// about a degree (the edge axes win by more than `edge_margin`, and
    /// the faces are clipped along them),
    /// keeps its points and ids from one call to the next under a tiny
    /// perturbation, and they are the generic path's ids.
    #[test]
    fn slightly_tilted_box_keeps_its_ids() {
        let a = cuboid(DVec3::new(2.0, 0.5, 2.0), Pose::IDENTITY);
        let tilt = |angle: f64, y: f64| {
            let q = DQuat::from_axis_angle(DVec3::new(0.3, 0.2, 1.0).normalize(), angle);
            cuboid(
                DVec3::new(0.5, 0.5, 0.5),
                Pose::new(DVec3::new(1.8, y, 0.1), q),
            )
        };
        let (c0, r0) = routed(&a, &tilt(-2e-2, 1.003), 0.01);
        let (c1, r1) = routed(&a, &tilt(-2e-2 - 1e-7, 1.003 - 1e-7), 0.01);
        let (c0, c1) = (c0.unwrap(), c1.unwrap());
        assert_eq!((r0, r1), (Route::EdgeFaces, Route::EdgeFaces));
        assert!(c0.points.len() >= 3, "{c0:?}");
        let ids = |c: &Contact| {
            let mut v: Vec<u32> = c.points.iter().map(|p| p.3).collect();
            v.sort_unstable();
            v
        };
        assert_eq!(ids(&c0), ids(&c1), "{c0:?}\n{c1:?}");
        let g = polytope_polytope(&a, &tilt(-2e-2, 1.003), 0.01, &mut None).unwrap();
        assert_eq!(ids(&g), ids(&c0));
    }

    fn assert_sane(c: &Option<Contact>, what: &str) {
        if let Some(c) = c {
            assert!(c.normal.is_finite(), "{what}: {c:?}");
            assert!((c.normal.length() - 1.0).abs() <= 1e-9, "{what}: {c:?}");
            assert!(c.points.len() <= crate::rigid::contact::MAX_POINTS);
            for p in &c.points {
                assert!(
                    p.0.is_finite() && p.1.is_finite() && p.2.is_finite(),
                    "{what}: {c:?}"
                );
            }
        }
    }

    /// Identical poses, exactly parallel touching edges and faces, zero
    /// separation, and huge and tiny boxes: finite, unit normals, and a
    /// contact wherever the boxes touch.
    #[test]
    fn degenerate_cases_are_finite() {
        let unit = DVec3::splat(0.5);
        let q45 = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        let cases = [
            // Identical poses, with and without a turn.
            (unit, Pose::IDENTITY, unit, Pose::IDENTITY),
            (
                unit,
                Pose::from_rotation(q45),
                unit,
                Pose::from_rotation(q45),
            ),
            // Same centre, different boxes.
            (
                unit,
                Pose::IDENTITY,
                DVec3::new(2.0, 0.1, 0.3),
                Pose::from_rotation(q45),
            ),
            // Face to face, touching.
            (unit, Pose::IDENTITY, unit, Pose::from_translation(DVec3::X)),
            // Parallel edges touching (boxes side by side diagonally).
            (
                unit,
                Pose::IDENTITY,
                unit,
                Pose::from_translation(DVec3::new(1.0, 1.0, 0.0)),
            ),
            // Corner to corner, touching.
            (
                unit,
                Pose::IDENTITY,
                unit,
                Pose::from_translation(DVec3::ONE),
            ),
            // Edge on face at 45°, touching.
            (
                unit,
                Pose::IDENTITY,
                unit,
                Pose::new(
                    DVec3::new(0.0, 0.5 + 0.5 * 2f64.sqrt(), 0.0),
                    DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4),
                ),
            ),
        ];
        for (k, (ha, pa, hb, pb)) in cases.into_iter().enumerate() {
            for s in [1.0, 1e-6, 1e6] {
                let scaled = |p: Pose| Pose::new(p.translation * s, p.rotation);
                let a = cuboid(ha * s, scaled(pa));
                let b = cuboid(hb * s, scaled(pb));
                for spec in [0.0, 0.01 * s] {
                    let what = format!("case {k}, scale {s}, spec {spec}");
                    let c = box_box(&a, &b, spec);
                    assert_sane(&c, &what);
                    assert!(c.is_some_and(|c| !c.points.is_empty()), "{what}");
                    assert_sane(&box_box(&b, &a, spec), &what);
                }
            }
        }
        // Random pairs at extreme scales.
        let mut rng = Rng(99);
        for round in 0..300 {
            let s = if round % 2 == 0 { 1e-6 } else { 1e6 };
            let (a, b) = random_pair(&mut rng, 0.05);
            let grow = |c: Convex<'static>| {
                let Core::Cuboid(h) = c.core else {
                    unreachable!()
                };
                cuboid(h * s, Pose::new(c.pose.translation * s, c.pose.rotation))
            };
            let (a, b) = (grow(a), grow(b));
            assert_sane(&box_box(&a, &b, 0.05 * s), &format!("round {round}"));
        }
    }

    /// Resting box pairs (as in a stack or a pyramid): the fast path and
    /// the generic one find the same number of points, and so does the
    /// public `collide` call. (Their cost is measured by the bench, not
    /// here: about 3.5 µs per pair for the generic path, 0.35 µs for this
    /// one on the 2-core dev machine.)
    #[test]
    fn resting_pairs_agree_with_the_generic_path() {
        let mut rng = Rng(3);
        let pairs: Vec<(Convex<'static>, Convex<'static>)> = (0..1000)
            .map(|_| {
                let h = DVec3::splat(0.5);
                let lower = Pose::new(
                    rng.in_cube(20.0),
                    DQuat::from_rotation_y(rng.range(-0.01, 0.01)),
                );
                let tilt = DQuat::from_axis_angle(rng.unit(), rng.range(0.0, 1e-3));
                let upper = Pose::new(
                    lower.translation
                        + DVec3::new(
                            rng.range(-0.5, 0.5),
                            1.0 - rng.range(0.0, 2e-3),
                            rng.range(-0.1, 0.1),
                        ),
                    lower.rotation * tilt,
                );
                // In A's frame, as `collide` hands them over.
                (
                    cuboid(h, Pose::IDENTITY),
                    cuboid(h, lower.inverse().mul(&upper)),
                )
            })
            .collect();
        let spec = 0.01;
        let generic: usize = pairs
            .iter()
            .map(|(a, b)| polytope_polytope(a, b, spec, &mut None).map_or(0, |c| c.points.len()))
            .sum();
        let fast: usize = pairs
            .iter()
            .map(|(a, b)| box_box(a, b, spec).map_or(0, |c| c.points.len()))
            .sum();
        let whole: usize = pairs
            .iter()
            .map(|(a, b)| {
                let (Core::Cuboid(ha), Core::Cuboid(hb)) = (a.core, b.core) else {
                    unreachable!()
                };
                let (sa, sb) = (
                    Shape::Cuboid { half_extents: ha },
                    Shape::Cuboid { half_extents: hb },
                );
                collide(&sa, &a.pose, &sb, &b.pose, spec).map_or(0, |m| m.points.len())
            })
            .sum();
        assert!(
            fast > 3 * pairs.len(),
            "{fast} points for {} pairs",
            pairs.len()
        );
        assert_eq!(generic, fast);
        assert_eq!(whole, fast);
    }
}
