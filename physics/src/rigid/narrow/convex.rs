//! General convex–convex contact: a shape as a *core* plus a radius, GJK on
//! the cores for the normal (EPA when the cores overlap), then a manifold
//! from the two shapes' supporting features (polygon, segment or point),
//! the incident one clipped against the reference one.

use std::borrow::Cow;

use glam::DVec3;

use super::epa::epa;
use super::gjk::{gjk_or_axis, GjkResult};
use super::{pack_id, reduce, Contact};
use crate::rigid::pose::Pose;
use crate::rigid::shape::hull::{ConvexHull, Face};

/// The inner shape that a ball of `radius` sweeps to make the real one.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Core<'a> {
    /// A sphere's centre.
    Point,
    /// A capsule's inner segment, half length along Y, m.
    Segment(f64),
    /// A box's half extents, m.
    Cuboid(DVec3),
    /// A cylinder along Y: half height, radius, m.
    Cylinder(f64, f64),
    /// A convex hull.
    Hull(&'a ConvexHull),
    /// One triangle of a mesh or heightfield (vertices, m), two-sided.
    Triangle([DVec3; 3]),
}

/// A convex shape placed in the common frame (A's shape frame).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Convex<'a> {
    pub core: Core<'a>,
    /// Radius swept around the core, m (spheres and capsules).
    pub radius: f64,
    /// Shape frame → common frame.
    pub pose: Pose,
}

/// Rim points used for a cylinder's cap as a polygon.
const CYLINDER_RIM: usize = 8;
/// `|cos|` below which a segment counts as perpendicular to the normal
/// (about 1.1°) and so touches along its length.
const SEGMENT_PARALLEL: f64 = 0.02;
/// Least `cos` between a reference polygon's plane normal and the contact
/// normal for face clipping (about 26°); below it, a single point.
const FACE_ALIGNED: f64 = 0.9;

impl Convex<'_> {
    /// Support of the core along `d` (common frame), m.
    pub fn core_support(&self, d: DVec3) -> DVec3 {
        // The first shape of a pair is in its own frame: no turning there.
        let turned = self.pose.rotation != glam::DQuat::IDENTITY;
        let l = if turned {
            self.pose.inverse_transform_vector(d)
        } else {
            d
        };
        let p = match self.core {
            Core::Point => DVec3::ZERO,
            Core::Segment(h) => DVec3::new(0.0, if l.y >= 0.0 { h } else { -h }, 0.0),
            Core::Cuboid(h) => DVec3::select(l.cmpge(DVec3::ZERO), h, -h),
            Core::Cylinder(hh, r) => {
                let y = if l.y >= 0.0 { hh } else { -hh };
                DVec3::new(l.x, 0.0, l.z).normalize_or_zero() * r + DVec3::new(0.0, y, 0.0)
            }
            Core::Hull(h) => h.support(l),
            Core::Triangle(t) => {
                let mut best = t[0];
                for &v in &t[1..] {
                    if v.dot(l) > best.dot(l) {
                        best = v;
                    }
                }
                best
            }
        };
        if turned {
            self.pose.transform_point(p)
        } else {
            p + self.pose.translation
        }
    }

    /// Rough size of the shape (m) for tolerances.
    pub fn size(&self) -> f64 {
        let c = match self.core {
            Core::Point => 0.0,
            Core::Segment(h) => h,
            Core::Cuboid(h) => h.max_element(),
            Core::Cylinder(hh, r) => hh.max(r),
            Core::Hull(h) => h.extent(),
            Core::Triangle(t) => t.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max),
        };
        c + self.radius
    }

    /// True for cores with flat faces (box, hull, triangle).
    pub fn polytope(&self) -> Option<Polytope<'_>> {
        type Parts<'b> = (Cow<'b, [DVec3]>, Cow<'b, [Face]>, Cow<'b, [[u32; 2]]>);
        let (verts, faces, edges): Parts<'_> = match self.core {
            Core::Cuboid(h) => {
                let (v, f) = cuboid_topology(h);
                (
                    Cow::Owned(v),
                    Cow::Owned(f),
                    Cow::Borrowed(&CUBOID_EDGES[..]),
                )
            }
            Core::Hull(h) => (
                Cow::Borrowed(h.vertices()),
                Cow::Borrowed(h.faces()),
                Cow::Borrowed(h.edges()),
            ),
            Core::Triangle(t) => {
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                let faces = vec![
                    Face {
                        vertices: vec![0, 1, 2],
                        normal: n,
                        offset: n.dot(t[0]),
                    },
                    Face {
                        vertices: vec![0, 2, 1],
                        normal: -n,
                        offset: -n.dot(t[0]),
                    },
                ];
                (
                    Cow::Owned(t.to_vec()),
                    Cow::Owned(faces),
                    Cow::Borrowed(&TRIANGLE_EDGES[..]),
                )
            }
            _ => return None,
        };
        let edge_faces = match self.core {
            Core::Hull(h) => Some(h.edge_faces()),
            _ => None,
        };
        Some(Polytope {
            verts,
            faces,
            edges,
            edge_faces,
            pose: self.pose,
        })
    }

    /// The feature of the *full* shape's core most extreme along `d`
    /// (common frame): its points (common frame) with small ids, the face
    /// index, and the polygon's unit plane normal when it is a polygon.
    pub fn feature(&self, d: DVec3) -> Feature {
        let l = self.pose.inverse_transform_vector(d).normalize_or_zero();
        let mut f = match self.core {
            Core::Point => Feature::point(DVec3::ZERO, 0),
            Core::Segment(h) => {
                if l.y.abs() < SEGMENT_PARALLEL {
                    Feature {
                        pts: vec![DVec3::new(0.0, -h, 0.0), DVec3::new(0.0, h, 0.0)],
                        ids: vec![1, 2],
                        face: 0,
                        plane: None,
                    }
                } else if l.y > 0.0 {
                    Feature::point(DVec3::new(0.0, h, 0.0), 2)
                } else {
                    Feature::point(DVec3::new(0.0, -h, 0.0), 1)
                }
            }
            Core::Cylinder(hh, r) => {
                if l.y.abs() >= FACE_ALIGNED {
                    let y = hh * l.y.signum();
                    let k = CYLINDER_RIM as f64;
                    let mut pts: Vec<DVec3> = (0..CYLINDER_RIM)
                        .map(|i| {
                            let a = std::f64::consts::TAU * i as f64 / k;
                            DVec3::new(r * a.cos(), y, r * a.sin())
                        })
                        .collect();
                    // Counter-clockwise seen from outside.
                    if l.y > 0.0 {
                        pts.reverse();
                    }
                    let ids = (1..=CYLINDER_RIM as u32).collect();
                    Feature {
                        pts,
                        ids,
                        face: if l.y > 0.0 { 1 } else { 2 },
                        plane: Some(DVec3::new(0.0, l.y.signum(), 0.0)),
                    }
                } else if l.y.abs() < SEGMENT_PARALLEL {
                    let radial = DVec3::new(l.x, 0.0, l.z).normalize_or(DVec3::X) * r;
                    Feature {
                        pts: vec![radial - DVec3::Y * hh, radial + DVec3::Y * hh],
                        ids: vec![1, 2],
                        face: 3,
                        plane: None,
                    }
                } else {
                    let p = self.pose.inverse_transform_point(self.core_support(d));
                    Feature::point(p, 0)
                }
            }
            _ => {
                let Some(poly) = self.polytope() else {
                    return Feature::point(DVec3::ZERO, 0);
                };
                let fi = poly.best_face_local(l);
                let face = &poly.faces[fi];
                Feature {
                    pts: face
                        .vertices
                        .iter()
                        .map(|&i| poly.verts[i as usize])
                        .collect(),
                    ids: face.vertices.iter().map(|&i| i + 1).collect(),
                    face: fi as u32,
                    plane: Some(face.normal),
                }
            }
        };
        for p in &mut f.pts {
            *p = self.pose.transform_point(*p);
        }
        f.plane = f.plane.map(|n| self.pose.transform_vector(n));
        f
    }
}

/// A supporting feature: 1 point, a segment or a polygon.
#[derive(Debug, Clone)]
pub(crate) struct Feature {
    pub pts: Vec<DVec3>,
    pub ids: Vec<u32>,
    pub face: u32,
    pub plane: Option<DVec3>,
}

impl Feature {
    fn point(p: DVec3, id: u32) -> Feature {
        Feature {
            pts: vec![p],
            ids: vec![id],
            face: 0,
            plane: None,
        }
    }
}

/// Box corners: bit 0 = +x, bit 1 = +y, bit 2 = +z.
fn cuboid_topology(h: DVec3) -> (Vec<DVec3>, Vec<Face>) {
    let verts: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 != 0 { h.x } else { -h.x },
                if i & 2 != 0 { h.y } else { -h.y },
                if i & 4 != 0 { h.z } else { -h.z },
            )
        })
        .collect();
    // Counter-clockwise seen from outside.
    let quads: [([u32; 4], DVec3, f64); 6] = [
        ([1, 3, 7, 5], DVec3::X, h.x),
        ([0, 4, 6, 2], DVec3::NEG_X, h.x),
        ([2, 6, 7, 3], DVec3::Y, h.y),
        ([0, 1, 5, 4], DVec3::NEG_Y, h.y),
        ([4, 5, 7, 6], DVec3::Z, h.z),
        ([0, 2, 3, 1], DVec3::NEG_Z, h.z),
    ];
    let faces = quads
        .iter()
        .map(|(v, n, o)| Face {
            vertices: v.to_vec(),
            normal: *n,
            offset: *o,
        })
        .collect();
    (verts, faces)
}

const CUBOID_EDGES: [[u32; 2]; 12] = [
    [0, 1],
    [2, 3],
    [4, 5],
    [6, 7],
    [0, 2],
    [1, 3],
    [4, 6],
    [5, 7],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];
const TRIANGLE_EDGES: [[u32; 2]; 3] = [[0, 1], [1, 2], [0, 2]];

/// A polytope core in its own frame, with its placement.
#[derive(Debug, Clone)]
pub(crate) struct Polytope<'a> {
    pub verts: Cow<'a, [DVec3]>,
    pub faces: Cow<'a, [Face]>,
    pub edges: Cow<'a, [[u32; 2]]>,
    /// Each edge with its two faces, when the shape keeps them (hulls).
    pub edge_faces: Option<&'a [(u32, u32, usize, usize)]>,
    pub pose: Pose,
}

impl Polytope<'_> {
    /// Index of the face whose normal is closest to the local direction `l`.
    pub fn best_face_local(&self, l: DVec3) -> usize {
        let mut best = 0;
        let mut best_dot = f64::NEG_INFINITY;
        for (i, f) in self.faces.iter().enumerate() {
            let d = f.normal.dot(l);
            if d > best_dot + 1e-12 {
                best_dot = d;
                best = i;
            }
        }
        best
    }
}

/// Contact between two convex shapes in the common frame, by GJK/EPA on
/// the cores and feature clipping. `None` when farther apart than `spec`,
/// with `apart` set to the axis that showed it where GJK stopped early
/// (see [`super::Apart`]).
pub(crate) fn convex_convex(
    a: &Convex<'_>,
    b: &Convex<'_>,
    spec: f64,
    apart: &mut super::Apart,
) -> Option<Contact> {
    let scale = a.size().max(b.size()).max(1e-12);
    let sa = |d: DVec3| a.core_support(d);
    let sb = |d: DVec3| b.core_support(d);
    // Cores farther apart than the radii and the speculative distance
    // make no contact: GJK stops as soon as it proves that.
    let limit = spec + a.radius + b.radius;
    match gjk_or_axis(&sa, &sb, gjk_start(a, b), scale, limit) {
        Ok(found) => convex_convex_from(a, b, spec, scale, found),
        Err(axis) => {
            *apart = Some(axis);
            None
        }
    }
}

/// The direction GJK starts from for `a` against `b`: from B's centre
/// towards A's.
pub(crate) fn gjk_start(a: &Convex<'_>, b: &Convex<'_>) -> DVec3 {
    a.pose.translation - b.pose.translation
}

/// [`convex_convex`] from what GJK found on the cores (started from
/// [`gjk_start`], `scale` as there): a caller that already ran it does not
/// run it again.
pub(crate) fn convex_convex_from(
    a: &Convex<'_>,
    b: &Convex<'_>,
    spec: f64,
    scale: f64,
    found: GjkResult,
) -> Option<Contact> {
    let sa = |d: DVec3| a.core_support(d);
    let sb = |d: DVec3| b.core_support(d);
    // From A's centre towards B's: the fallback axis.
    let init = -gjk_start(a, b);
    let radii = a.radius + b.radius;
    let (normal, sep, pa, pb) = match found {
        GjkResult::Separated {
            distance,
            point_a,
            point_b,
        } => {
            let n = (point_b - point_a) / distance;
            (n, distance - radii, point_a, point_b)
        }
        GjkResult::Overlapping(simplex) => match epa(&sa, &sb, &simplex, scale) {
            Some(p) => (p.normal, -p.depth - radii, p.point_a, p.point_b),
            None => touching_or_fallback(a, b, &simplex, init),
        },
    };
    if (sep.is_nan() || sep > spec) || !normal.is_finite() {
        return None;
    }
    Some(manifold_from_features(a, b, normal, sep, pa, pb, spec))
}

/// GJK stopped within its tolerance of touching but EPA could not build a
/// polytope: use the simplex's closest points if they give a direction,
/// else the centre axis.
fn touching_or_fallback(
    a: &Convex<'_>,
    b: &Convex<'_>,
    simplex: &[super::gjk::SupportPoint],
    init: DVec3,
) -> (DVec3, f64, DVec3, DVec3) {
    if let Some(s) = simplex.first() {
        if simplex.len() == 1 && s.w.length() > 0.0 {
            let n = -s.w.normalize();
            return (n, -a.radius - b.radius, s.a, s.b);
        }
    }
    fallback_axis(a, b, init)
}

/// When EPA cannot run (the cores only touch, or the difference is flat):
/// the axis between the centres and the separation of the projections on it.
pub(crate) fn fallback_axis(
    a: &Convex<'_>,
    b: &Convex<'_>,
    init: DVec3,
) -> (DVec3, f64, DVec3, DVec3) {
    // A flat triangle has one good axis: its normal, towards the other shape.
    let plane = |c: &Convex<'_>, other: &Convex<'_>| match c.core {
        Core::Triangle(t) => {
            let n = c.pose.transform_vector((t[1] - t[0]).cross(t[2] - t[0]));
            let centroid = c.pose.transform_point((t[0] + t[1] + t[2]) / 3.0);
            let n = n.normalize_or_zero();
            Some(if n.dot(other.pose.translation - centroid) < 0.0 {
                -n
            } else {
                n
            })
        }
        _ => None,
    };
    if let Some(n) = plane(a, b) {
        let pa = a.core_support(n);
        let pb = b.core_support(-n);
        let gap = n.dot(pb - pa);
        return (n, gap - a.radius - b.radius, pb - n * gap, pb);
    }
    let n = plane(b, a).map_or(init.normalize_or(DVec3::Y), |m| -m);
    let pa = a.core_support(n);
    let pb = b.core_support(-n);
    let gap = n.dot(pb - pa);
    // Keep the pair consistent (B's point = A's point + gap · n); B's point
    // may then lie slightly off B's surface in this rare degenerate case.
    (n, gap - a.radius - b.radius, pa, pa + n * gap)
}

/// Builds the manifold for normal `n` (A→B, common frame) from the shapes'
/// supporting features; `pa`, `pb` are core witness points and `sep` their
/// separation, used when the features give a single point.
pub(crate) fn manifold_from_features(
    a: &Convex<'_>,
    b: &Convex<'_>,
    n: DVec3,
    sep: f64,
    pa: DVec3,
    pb: DVec3,
    spec: f64,
) -> Contact {
    let fa = a.feature(n);
    let fb = b.feature(-n);
    let single = || Contact {
        normal: n,
        points: vec![(
            pa + n * a.radius,
            pb - n * b.radius,
            sep,
            pack_id(0, fa.face, fb.face, fa.ids[0], fb.ids[0]),
        )],
    };
    if fa.pts.len() < 2 || fb.pts.len() < 2 {
        return single();
    }
    let align_a = fa.plane.map_or(-1.0, |m| m.dot(n));
    let align_b = fb.plane.map_or(-1.0, |m| -m.dot(n));
    let contact = if align_a >= FACE_ALIGNED && align_a + 1e-9 >= align_b {
        clip_features(&fa, &fb, n, a.radius, b.radius, spec, 0)
    } else if align_b >= FACE_ALIGNED {
        clip_features(&fb, &fa, -n, b.radius, a.radius, spec, 1).map(|c| flip(c, n))
    } else if fa.pts.len() == 2 && fb.pts.len() == 2 {
        clip_segments(&fa, &fb, n, a.radius, b.radius, spec)
    } else {
        None
    };
    match contact {
        Some(c) if !c.points.is_empty() => reduce(c),
        _ => single(),
    }
}

fn flip(c: Contact, n: DVec3) -> Contact {
    Contact {
        normal: n,
        points: c
            .points
            .into_iter()
            .map(|(p, q, s, id)| (q, p, s, id))
            .collect(),
    }
}

/// Clips the incident feature `inc` against the side planes of the
/// reference polygon `rf` (plane normal ≈ `n`, pointing from ref to inc).
pub(crate) fn clip_features(
    rf: &Feature,
    inc: &Feature,
    n: DVec3,
    r_ref: f64,
    r_inc: f64,
    spec: f64,
    ref_side: u32,
) -> Option<Contact> {
    let m = rf.plane?;
    let mn = m.dot(n);
    if mn <= 0.0 {
        return None;
    }
    let mut poly: Vec<(DVec3, u32)> = inc
        .pts
        .iter()
        .copied()
        .zip(inc.ids.iter().copied())
        .collect();
    let k = rf.pts.len();
    for j in 0..k {
        let v0 = rf.pts[j];
        let v1 = rf.pts[(j + 1) % k];
        let side = (v1 - v0).cross(n);
        if side.length_squared() == 0.0 {
            continue;
        }
        poly = clip_by_plane(&poly, side, side.dot(v0), j as u32);
        if poly.is_empty() {
            return None;
        }
    }
    let origin = rf.pts[0];
    let mut points = Vec::with_capacity(poly.len());
    for (q, key) in poly {
        let dist = (q - origin).dot(m) / mn;
        let s = dist - r_ref - r_inc;
        if s <= spec {
            let p = q - n * dist;
            points.push((
                p + n * r_ref,
                q - n * r_inc,
                s,
                pack_id(ref_side, rf.face, inc.face, key, 0),
            ));
        }
    }
    Some(Contact { normal: n, points })
}

/// Sutherland–Hodgman against the half space `side · x <= offset`; new
/// points get a key derived from the edge they cut and the plane index.
fn clip_by_plane(poly: &[(DVec3, u32)], side: DVec3, offset: f64, plane: u32) -> Vec<(DVec3, u32)> {
    let mut out = Vec::with_capacity(poly.len() + 2);
    let len = poly.len();
    if len == 0 {
        return out;
    }
    // A segment is a 2-gon: walk it once, not around.
    let edges = if len == 2 { 1 } else { len };
    if len == 1 {
        if side.dot(poly[0].0) <= offset {
            out.push(poly[0]);
        }
        return out;
    }
    for i in 0..edges {
        let (p, kp) = poly[i];
        let (q, kq) = poly[(i + 1) % len];
        let dp = side.dot(p) - offset;
        let dq = side.dot(q) - offset;
        if dp <= 0.0 {
            out.push((p, kp));
        }
        if (dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0) {
            let t = dp / (dp - dq);
            let key = mix(mix(kp.min(kq), kp.max(kq)), 0x100 + plane);
            out.push((p + (q - p) * t, key));
        }
        if len == 2 && dq <= 0.0 {
            out.push((q, kq));
        }
    }
    out
}

/// Two segments (nearly) parallel to each other and ⟂ `n`: the part of B's
/// segment that overlaps A's along A's direction, as up to two points.
fn clip_segments(
    fa: &Feature,
    fb: &Feature,
    n: DVec3,
    ra: f64,
    rb: f64,
    spec: f64,
) -> Option<Contact> {
    let (a0, a1) = (fa.pts[0], fa.pts[1]);
    let axis = a1 - a0;
    let len2 = axis.length_squared();
    if len2 == 0.0 {
        return None;
    }
    let mut pts = Vec::with_capacity(2);
    let (b0, b1) = (fb.pts[0], fb.pts[1]);
    let cross = axis
        .normalize_or_zero()
        .cross((b1 - b0).normalize_or_zero());
    if cross.length() > SEGMENT_PARALLEL {
        return None;
    }
    let t0 = (b0 - a0).dot(axis) / len2;
    let t1 = (b1 - a0).dot(axis) / len2;
    for (t, ib) in [(t0, fb.ids[0]), (t1, fb.ids[1])] {
        // B's endpoint, or where B's segment leaves A's extent along the axis.
        let (tc, key) = if t < 0.0 {
            (0.0, mix(ib, 0x200))
        } else if t > 1.0 {
            (1.0, mix(ib, 0x201))
        } else {
            (t, ib)
        };
        let dt = t1 - t0;
        let s = if dt.abs() > 1e-12 {
            (tc - t0) / dt
        } else if ib == fb.ids[0] {
            0.0
        } else {
            1.0
        };
        if !(-1e-9..=1.0 + 1e-9).contains(&s) {
            continue;
        }
        let q = b0 + (b1 - b0) * s.clamp(0.0, 1.0);
        let p = a0 + axis * tc;
        let dist = (q - p).dot(n);
        let sep = dist - ra - rb;
        if sep <= spec {
            pts.push((
                p + n * ra,
                q - n * rb,
                sep,
                pack_id(0, fa.face, fb.face, key, 0),
            ));
        }
    }
    if pts.len() == 2 && pts[0].0.distance_squared(pts[1].0) < 1e-24 {
        pts.pop();
    }
    Some(Contact {
        normal: n,
        points: pts,
    })
}

/// A small integer hash for feature keys (deterministic).
pub(crate) fn mix(a: u32, b: u32) -> u32 {
    let mut h = a.wrapping_mul(0x9E37_79B1) ^ b.wrapping_add(0x7F4A_7C15).rotate_left(13);
    h ^= h >> 15;
    h = h.wrapping_mul(0x85EB_CA6B);
    h ^= h >> 13;
    h
}
