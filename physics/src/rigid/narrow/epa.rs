//! EPA: penetration depth and direction of two overlapping convex sets.
//!
//! Starting from GJK's final simplex (grown to a tetrahedron around the
//! origin), the Expanding Polytope Algorithm (van den Bergen 2001,
//! "Proximity queries and penetration depth computation on 3D game
//! objects") repeatedly takes the face of the polytope nearest the origin
//! and pushes it out to the support point of `A − B` along its normal,
//! until the support point adds less than a tolerance. The nearest face's
//! normal is then the direction that separates B from A fastest, and its
//! distance the depth. On curved shapes it converges to within the
//! tolerance rather than exactly.

use glam::DVec3;

use super::gjk::{support, SupportPoint};

/// What EPA found.
#[derive(Debug, Clone, Copy)]
pub struct Penetration {
    /// Unit direction from A to B along which B must move to separate.
    pub normal: DVec3,
    /// Penetration depth, m (>= 0).
    pub depth: f64,
    /// Deepest point of A along `normal`, m.
    pub point_a: DVec3,
    /// Deepest point of B against `-normal`, m.
    pub point_b: DVec3,
}

#[derive(Debug, Clone, Copy)]
struct PolytopeFace {
    v: [usize; 3],
    n: DVec3,
    d: f64,
}

const MAX_ITERATIONS: usize = 96;

fn make_face(pts: &[SupportPoint], v: [usize; 3]) -> Option<PolytopeFace> {
    let (a, b, c) = (pts[v[0]].w, pts[v[1]].w, pts[v[2]].w);
    let n = (b - a).cross(c - a);
    let len = n.length();
    if len.is_nan() || len <= 0.0 || !len.is_finite() {
        return None;
    }
    let n = n / len;
    Some(PolytopeFace { v, n, d: n.dot(a) })
}

/// Penetration of the overlapping sets with supports `sa`, `sb`, from GJK's
/// `simplex`. `scale` (m) sets the tolerance. `None` if the polytope
/// degenerates (e.g. the sets only touch); callers then fall back.
pub fn epa<FA, FB>(sa: &FA, sb: &FB, simplex: &[SupportPoint], scale: f64) -> Option<Penetration>
where
    FA: Fn(DVec3) -> DVec3,
    FB: Fn(DVec3) -> DVec3,
{
    let tol = 1e-9 * scale.max(1e-300);
    // Start from GJK's simplex grown to a tetrahedron. If rounding left it
    // flat so that it misses the origin, walk it towards the origin: swap
    // the vertex opposite a face the origin lies beyond for the support
    // point along that face's normal (the boolean GJK step), a few times.
    let mut pts: Vec<SupportPoint> = simplex.to_vec();
    grow_to_tetrahedron(sa, sb, &mut pts, tol)?;
    let mut start = None;
    for _ in 0..32 {
        let faces = oriented_faces(&pts)?;
        match faces.iter().position(|f| f.d < -tol) {
            None => {
                start = Some(faces);
                break;
            }
            Some(k) => {
                let f = faces[k];
                let w = support(sa, sb, f.n);
                if w.w.dot(f.n) <= tol {
                    return None; // The origin is outside: no overlap.
                }
                let opposite = (0..4).find(|i| !f.v.contains(i))?;
                pts[opposite] = w;
            }
        }
    }
    let mut faces = start?;
    // Room kept from one iteration to the next: the horizon's edges and the
    // faces that survive it.
    let mut edges: Vec<[usize; 2]> = Vec::with_capacity(16);
    let mut kept: Vec<PolytopeFace> = Vec::with_capacity(faces.len() + 8);
    let mut best = faces[0];
    for iterations in 0..MAX_ITERATIONS {
        let (bi, _) = faces
            .iter()
            .enumerate()
            .min_by(|x, y| x.1.d.total_cmp(&y.1.d))?;
        // The nearest face's distance only grows; a drop means rounding
        // folded the polytope (curved shapes, nearly coplanar supports):
        // keep the last good face.
        if faces[bi].d < best.d - tol && iterations > 0 {
            break;
        }
        best = faces[bi];
        let w = support(sa, sb, best.n);
        let gain = w.w.dot(best.n) - best.d;
        if gain <= tol.max(1e-9 * best.d.abs()) {
            break;
        }
        let wi = pts.len();
        pts.push(w);
        // Remove the faces that see w, keep their horizon edges.
        edges.clear();
        kept.clear();
        for f in faces.drain(..) {
            if f.n.dot(w.w - pts[f.v[0]].w) > 0.0 {
                for e in [[f.v[0], f.v[1]], [f.v[1], f.v[2]], [f.v[2], f.v[0]]] {
                    if let Some(k) = edges.iter().position(|x| x[0] == e[1] && x[1] == e[0]) {
                        edges.swap_remove(k);
                    } else {
                        edges.push(e);
                    }
                }
            } else {
                kept.push(f);
            }
        }
        std::mem::swap(&mut faces, &mut kept);
        for e in &edges {
            if let Some(f) = make_face(&pts, [e[0], e[1], wi]) {
                faces.push(f);
            }
        }
        if faces.is_empty() {
            break;
        }
    }
    // Barycentric coordinates of the origin's projection on the face.
    let p = best.n * best.d;
    let (a, b, c) = (pts[best.v[0]], pts[best.v[1]], pts[best.v[2]]);
    let (l0, l1, l2) = barycentric(p, a.w, b.w, c.w);
    let point_a = a.a * l0 + b.a * l1 + c.a * l2;
    let point_b = a.b * l0 + b.b * l1 + c.b * l2;
    let depth = best.d.max(0.0);
    if !depth.is_finite() || !best.n.is_finite() {
        return None;
    }
    Some(Penetration {
        normal: best.n,
        depth,
        point_a,
        point_b,
    })
}

/// The tetrahedron's faces oriented outward (`None` if it is flat).
fn oriented_faces(pts: &[SupportPoint]) -> Option<Vec<PolytopeFace>> {
    let mut faces = Vec::with_capacity(32);
    let centroid: DVec3 = pts.iter().map(|p| p.w).sum::<DVec3>() * 0.25;
    for f in [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]] {
        let mut face = make_face(pts, f)?;
        if face.n.dot(pts[f[0]].w - centroid) < 0.0 {
            face = make_face(pts, [f[0], f[2], f[1]])?;
        }
        faces.push(face);
    }
    Some(faces)
}

fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (f64, f64, f64) {
    let v0 = b - a;
    let v1 = c - a;
    let v2 = p - a;
    let d00 = v0.dot(v0);
    let d01 = v0.dot(v1);
    let d11 = v1.dot(v1);
    let d20 = v2.dot(v0);
    let d21 = v2.dot(v1);
    let denom = d00 * d11 - d01 * d01;
    if denom.abs() <= f64::MIN_POSITIVE {
        return (1.0, 0.0, 0.0);
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    (1.0 - v - w, v, w)
}

/// Adds support points until `pts` is a tetrahedron of positive volume.
fn grow_to_tetrahedron<FA, FB>(
    sa: &FA,
    sb: &FB,
    pts: &mut Vec<SupportPoint>,
    tol: f64,
) -> Option<()>
where
    FA: Fn(DVec3) -> DVec3,
    FB: Fn(DVec3) -> DVec3,
{
    pts.truncate(4);
    // Drop duplicates / degenerate points and rebuild.
    let mut clean: Vec<SupportPoint> = Vec::with_capacity(4);
    for p in pts.iter() {
        if clean.len() < 4 && is_independent(&clean, p.w, tol) {
            clean.push(*p);
        }
    }
    if clean.is_empty() {
        clean.push(support(sa, sb, DVec3::X));
    }
    let axes = [
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        DVec3::NEG_X,
        DVec3::NEG_Y,
        DVec3::NEG_Z,
        DVec3::new(1.0, 1.0, 1.0).normalize(),
        DVec3::new(-1.0, 1.0, -1.0).normalize(),
    ];
    while clean.len() < 4 {
        let mut dirs: Vec<DVec3> = Vec::new();
        match clean.len() {
            1 => dirs.extend_from_slice(&axes),
            2 => {
                let d = clean[1].w - clean[0].w;
                let p = d.normalize_or(DVec3::X).any_orthonormal_vector();
                let q = d.normalize_or_zero().cross(p);
                dirs.extend_from_slice(&[p, -p, q, -q]);
                dirs.extend_from_slice(&axes);
            }
            _ => {
                let n = (clean[1].w - clean[0].w).cross(clean[2].w - clean[0].w);
                dirs.extend_from_slice(&[n, -n]);
                dirs.extend_from_slice(&axes);
            }
        }
        let mut added = false;
        for d in dirs {
            let s = support(sa, sb, d);
            if is_independent(&clean, s.w, tol) {
                clean.push(s);
                added = true;
                break;
            }
        }
        if !added {
            return None;
        }
    }
    *pts = clean;
    Some(())
}

fn is_independent(pts: &[SupportPoint], w: DVec3, tol: f64) -> bool {
    match pts.len() {
        0 => true,
        1 => pts[0].w.distance(w) > tol,
        2 => {
            let d = pts[1].w - pts[0].w;
            d.cross(w - pts[0].w).length() > tol * d.length()
        }
        3 => {
            let n = (pts[1].w - pts[0].w).cross(pts[2].w - pts[0].w);
            let nl = n.length();
            nl > 0.0 && (w - pts[0].w).dot(n / nl).abs() > tol
        }
        _ => false,
    }
}
