//! GJK: distance and closest points between two convex sets given only by
//! their support functions.
//!
//! Both sets are expressed in one frame (the narrow phase uses A's shape
//! frame). The algorithm walks a simplex of the Minkowski difference
//! `A − B` towards the origin; the point of `A − B` nearest the origin is
//! `v = p_a − p_b`, so `|v|` is the distance and `p_a`, `p_b` the closest
//! points. Sub-simplex selection follows Ericson, *Real-Time Collision
//! Detection* (2005) §5.1 (closest point on segment, triangle,
//! tetrahedron), and termination follows van den Bergen (1999): stop when
//! the lower bound `v·w / |v|` is within a relative tolerance of `|v|`.

use glam::DVec3;

/// A vertex of the simplex: the Minkowski point and the two support points
/// it came from (all m, in the common frame).
#[derive(Debug, Clone, Copy)]
pub struct SupportPoint {
    /// `a − b`.
    pub w: DVec3,
    /// Support point of A.
    pub a: DVec3,
    /// Support point of B.
    pub b: DVec3,
}

/// What GJK found.
#[derive(Debug, Clone)]
pub enum GjkResult {
    /// The sets are disjoint (or touch): distance and closest points, m.
    Separated {
        /// Distance between the sets, m (>= 0; tiny when touching).
        distance: f64,
        /// Closest point on A, m.
        point_a: DVec3,
        /// Closest point on B, m.
        point_b: DVec3,
    },
    /// The sets overlap or touch (to the tolerance): the final simplex (1
    /// to 4 points) encloses or touches the origin; EPA starts from it.
    Overlapping(Vec<SupportPoint>),
}

const MAX_ITERATIONS: usize = 128;
/// Relative tolerance on `|v|²` for convergence.
const REL_TOL: f64 = 1e-12;

/// Support point of `A − B` along `d`.
#[inline]
pub fn support<FA, FB>(sa: &FA, sb: &FB, d: DVec3) -> SupportPoint
where
    FA: Fn(DVec3) -> DVec3,
    FB: Fn(DVec3) -> DVec3,
{
    let a = sa(d);
    let b = sb(-d);
    SupportPoint { w: a - b, a, b }
}

/// Distance between the convex sets with support functions `sa` and `sb`
/// (each maps a direction to the farthest point, m). `scale` is a size of
/// the problem (m) used for the absolute tolerance on "touching".
pub fn gjk<FA, FB>(sa: &FA, sb: &FB, initial_dir: DVec3, scale: f64) -> GjkResult
where
    FA: Fn(DVec3) -> DVec3,
    FB: Fn(DVec3) -> DVec3,
{
    let abs_tol = (1e-10 * scale).max(1e-300);
    let mut dir = if initial_dir.length_squared() > 0.0 && initial_dir.is_finite() {
        initial_dir
    } else {
        DVec3::X
    };
    let first = support(sa, sb, -dir);
    let mut simplex: Vec<SupportPoint> = vec![first];
    let mut weights: Vec<f64> = vec![1.0];
    let mut v = first.w;
    let mut best_v2 = f64::INFINITY;
    for _ in 0..MAX_ITERATIONS {
        let v2 = v.length_squared();
        if v2 <= abs_tol * abs_tol {
            return GjkResult::Overlapping(simplex);
        }
        dir = -v;
        let w = support(sa, sb, dir);
        // Lower bound test: the set lies beyond v·w / |v| along v.
        if v2 - v.dot(w.w) <= REL_TOL * v2 + abs_tol * abs_tol {
            break;
        }
        if simplex
            .iter()
            .any(|s| s.w.distance_squared(w.w) <= abs_tol * abs_tol)
        {
            break;
        }
        simplex.push(w);
        let (new_simplex, new_weights, inside) = closest_on_simplex(&simplex);
        if inside {
            return GjkResult::Overlapping(simplex);
        }
        let nv: DVec3 = new_simplex
            .iter()
            .zip(&new_weights)
            .map(|(s, &l)| s.w * l)
            .sum();
        let nv2 = nv.length_squared();
        if nv2 >= best_v2 || nv2 >= v2 {
            // No progress: rounding; keep the previous answer.
            break;
        }
        best_v2 = nv2;
        simplex = new_simplex;
        weights = new_weights;
        v = nv;
    }
    let point_a = simplex.iter().zip(&weights).map(|(s, &l)| s.a * l).sum();
    let point_b = simplex.iter().zip(&weights).map(|(s, &l)| s.b * l).sum();
    let distance = v.length();
    if distance <= abs_tol {
        return GjkResult::Overlapping(simplex);
    }
    GjkResult::Separated {
        distance,
        point_a,
        point_b,
    }
}

/// The smallest sub-simplex holding the point nearest the origin, its
/// barycentric weights, and whether the (tetrahedral) simplex holds the
/// origin.
fn closest_on_simplex(s: &[SupportPoint]) -> (Vec<SupportPoint>, Vec<f64>, bool) {
    match s.len() {
        1 => (s.to_vec(), vec![1.0], false),
        2 => {
            let (idx, w) = closest_segment(s[0].w, s[1].w);
            pick(s, &idx, &w)
        }
        3 => {
            let (idx, w) = closest_triangle(s[0].w, s[1].w, s[2].w);
            pick(s, &idx, &w)
        }
        _ => closest_tetrahedron(s),
    }
}

fn pick(s: &[SupportPoint], idx: &[usize], w: &[f64]) -> (Vec<SupportPoint>, Vec<f64>, bool) {
    (idx.iter().map(|&i| s[i]).collect(), w.to_vec(), false)
}

/// Closest point to the origin on segment `ab`: used vertex indices and weights.
pub(crate) fn closest_segment(a: DVec3, b: DVec3) -> (Vec<usize>, Vec<f64>) {
    let ab = b - a;
    let denom = ab.length_squared();
    let t = if denom > 0.0 {
        (-a).dot(ab) / denom
    } else {
        0.0
    };
    if t <= 0.0 {
        (vec![0], vec![1.0])
    } else if t >= 1.0 {
        (vec![1], vec![1.0])
    } else {
        (vec![0, 1], vec![1.0 - t, t])
    }
}

/// Closest point to the origin on triangle `abc` (Ericson §5.1.5).
pub(crate) fn closest_triangle(a: DVec3, b: DVec3, c: DVec3) -> (Vec<usize>, Vec<f64>) {
    let p = DVec3::ZERO;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (vec![0], vec![1.0]);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (vec![1], vec![1.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (vec![0, 1], vec![1.0 - v, v]);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (vec![2], vec![1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (vec![0, 2], vec![1.0 - w, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (vec![1, 2], vec![1.0 - w, w]);
    }
    let sum = va + vb + vc;
    if sum.abs() <= f64::MIN_POSITIVE || !sum.is_finite() {
        // Degenerate (collinear) triangle: best of its edges.
        let mut best = (vec![0], vec![1.0]);
        let mut best_d = f64::INFINITY;
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            let pts = [a, b, c];
            let (idx, w) = closest_segment(pts[i], pts[j]);
            let q: DVec3 = idx
                .iter()
                .zip(&w)
                .map(|(&k, &l)| [pts[i], pts[j]][k] * l)
                .sum();
            if q.length_squared() < best_d {
                best_d = q.length_squared();
                best = (idx.iter().map(|&k| [i, j][k]).collect(), w);
            }
        }
        return best;
    }
    let denom = 1.0 / sum;
    let v = vb * denom;
    let w = vc * denom;
    (vec![0, 1, 2], vec![1.0 - v - w, v, w])
}

fn closest_tetrahedron(s: &[SupportPoint]) -> (Vec<SupportPoint>, Vec<f64>, bool) {
    let faces = [[0, 1, 2, 3], [0, 2, 3, 1], [0, 3, 1, 2], [1, 3, 2, 0]];
    let mut best: Option<(Vec<SupportPoint>, Vec<f64>)> = None;
    let mut best_d = f64::INFINITY;
    let mut inside = true;
    // A nearly flat tetrahedron cannot tell inside from outside reliably:
    // treat it as outside every face and keep the nearest triangle.
    let edge = (1..4)
        .map(|i| (s[i].w - s[0].w).length())
        .fold(0.0, f64::max);
    let vol6 = (s[1].w - s[0].w)
        .dot((s[2].w - s[0].w).cross(s[3].w - s[0].w))
        .abs();
    let flat = vol6.is_nan() || vol6 <= 1e-9 * edge * edge * edge;
    for f in faces {
        let (a, b, c, d) = (s[f[0]].w, s[f[1]].w, s[f[2]].w, s[f[3]].w);
        let n = (b - a).cross(c - a);
        let sign_o = (-a).dot(n);
        let sign_d = (d - a).dot(n);
        // Origin on the far side of this face from the fourth vertex.
        if flat || sign_o * sign_d < 0.0 || sign_d == 0.0 {
            inside = false;
            let (idx, w) = closest_triangle(a, b, c);
            let q: DVec3 = idx.iter().zip(&w).map(|(&k, &l)| [a, b, c][k] * l).sum();
            if q.length_squared() < best_d {
                best_d = q.length_squared();
                best = Some((idx.iter().map(|&k| s[f[k]]).collect(), w));
            }
        }
    }
    match best {
        Some((ss, w)) if !inside => (ss, w, false),
        _ => (s.to_vec(), vec![0.25; 4], true),
    }
}
