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
//!
//! The same lower bound answers "are they farther apart than `limit`?"
//! early ([`gjk_within`]): the narrow phase asks only whether a pair comes
//! within the speculative distance, and most pairs the broad phase hands
//! over do not; on curved shapes, where GJK converges slowly, proving that
//! takes a few iterations where the exact distance takes dozens.
//!
//! Nothing here allocates: the simplex lives on the stack ([`Simplex`]).

use glam::DVec3;

/// A vertex of the simplex: the Minkowski point and the two support points
/// it came from (all m, in the common frame).
#[derive(Debug, Clone, Copy, Default)]
pub struct SupportPoint {
    /// `a − b`.
    pub w: DVec3,
    /// Support point of A.
    pub a: DVec3,
    /// Support point of B.
    pub b: DVec3,
}

/// One to four support points (a point, segment, triangle or
/// tetrahedron), on the stack; reads as a slice.
#[derive(Debug, Clone, Copy, Default)]
pub struct Simplex {
    pts: [SupportPoint; 4],
    len: usize,
}

impl Simplex {
    fn one(p: SupportPoint) -> Self {
        let mut s = Self::default();
        s.push(p);
        s
    }

    fn push(&mut self, p: SupportPoint) {
        self.pts[self.len] = p;
        self.len += 1;
    }
}

impl std::ops::Deref for Simplex {
    type Target = [SupportPoint];
    fn deref(&self) -> &[SupportPoint] {
        &self.pts[..self.len]
    }
}

/// Which vertices of a segment or triangle hold the point nearest the
/// origin (indices into it) and their barycentric weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Nearest {
    idx: [usize; 3],
    w: [f64; 3],
    len: usize,
}

impl Nearest {
    fn vertex(i: usize) -> Self {
        Self {
            idx: [i, 0, 0],
            w: [1.0, 0.0, 0.0],
            len: 1,
        }
    }

    fn edge(i: usize, j: usize, t: f64) -> Self {
        Self {
            idx: [i, j, 0],
            w: [1.0 - t, t, 0.0],
            len: 2,
        }
    }

    /// The vertices used and their weights, in pairs.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.idx[..self.len]
            .iter()
            .copied()
            .zip(self.w[..self.len].iter().copied())
    }

    /// `Σ w_k pts[idx_k]`.
    pub(crate) fn point(&self, pts: &[DVec3]) -> DVec3 {
        self.iter().map(|(k, l)| pts[k] * l).sum()
    }
}

/// What GJK found.
// Returned by value and used at once, never stored: the simplex stays on
// the stack rather than in an allocation per overlapping pair.
#[allow(clippy::large_enum_variant)]
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
    Overlapping(Simplex),
}

const MAX_ITERATIONS: usize = 128;
/// Relative tolerance on `|v|²` for convergence.
const REL_TOL: f64 = 1e-12;
/// Relative margin over the limit of [`gjk_within`].
const LIMIT_MARGIN: f64 = 1e-9;

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
    gjk_within(sa, sb, initial_dir, scale, f64::INFINITY)
        .expect("no finite distance exceeds an infinite limit")
}

/// [`gjk`], stopping as soon as the sets are shown to be more than `limit`
/// (m) apart: `None` then. Whenever it returns a result, that result is
/// bit for bit what [`gjk`] returns.
pub fn gjk_within<FA, FB>(
    sa: &FA,
    sb: &FB,
    initial_dir: DVec3,
    scale: f64,
    limit: f64,
) -> Option<GjkResult>
where
    FA: Fn(DVec3) -> DVec3,
    FB: Fn(DVec3) -> DVec3,
{
    gjk_or_axis(sa, sb, initial_dir, scale, limit).ok()
}

/// [`gjk_within`], answering "more than `limit` apart" with the axis that
/// showed it: `Err(n)`, a unit vector from A towards B with
/// `min(B·n) − max(A·n) > limit`.
pub(crate) fn gjk_or_axis<FA, FB>(
    sa: &FA,
    sb: &FB,
    initial_dir: DVec3,
    scale: f64,
    limit: f64,
) -> Result<GjkResult, DVec3>
where
    FA: Fn(DVec3) -> DVec3,
    FB: Fn(DVec3) -> DVec3,
{
    let abs_tol = (1e-10 * scale).max(1e-300);
    // Below the touching tolerance `gjk` may answer "overlapping": never
    // stop early there. The relative margin keeps the bound's rounding
    // from ever cutting off a pair `gjk` would measure within `limit`.
    let limit = limit.max(abs_tol) * (1.0 + LIMIT_MARGIN);
    let mut dir = if initial_dir.length_squared() > 0.0 && initial_dir.is_finite() {
        initial_dir
    } else {
        DVec3::X
    };
    let first = support(sa, sb, -dir);
    let mut simplex = Simplex::one(first);
    let mut weights = [1.0, 0.0, 0.0, 0.0];
    let mut v = first.w;
    let mut best_v2 = f64::INFINITY;
    for _ in 0..MAX_ITERATIONS {
        let v2 = v.length_squared();
        if v2 <= abs_tol * abs_tol {
            return Ok(GjkResult::Overlapping(simplex));
        }
        dir = -v;
        let w = support(sa, sb, dir);
        // Lower bound test: the set lies beyond v·w / |v| along v.
        let vw = v.dot(w.w);
        if vw > 0.0 && vw * vw > limit * limit * v2 {
            // Every point of A − B is farther than `limit` from the origin
            // along v (and the distance `gjk` would report is at least as
            // large): A lies beyond B along v.
            return Err(-v / v2.sqrt());
        }
        if v2 - vw <= REL_TOL * v2 + abs_tol * abs_tol {
            break;
        }
        if simplex
            .iter()
            .any(|s| s.w.distance_squared(w.w) <= abs_tol * abs_tol)
        {
            break;
        }
        simplex.push(w);
        let Some((new_simplex, new_weights)) = closest_on_simplex(&simplex) else {
            return Ok(GjkResult::Overlapping(simplex));
        };
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
        return Ok(GjkResult::Overlapping(simplex));
    }
    Ok(GjkResult::Separated {
        distance,
        point_a,
        point_b,
    })
}

/// The smallest sub-simplex holding the point nearest the origin and its
/// barycentric weights; `None` when the (tetrahedral) simplex holds the
/// origin.
fn closest_on_simplex(s: &Simplex) -> Option<(Simplex, [f64; 4])> {
    let nearest = match s.len() {
        1 => Nearest::vertex(0),
        2 => closest_segment(s[0].w, s[1].w),
        3 => closest_triangle(s[0].w, s[1].w, s[2].w),
        _ => return closest_tetrahedron(s),
    };
    Some(pick(s, &nearest, |k| k))
}

/// The vertices `nearest` names (through `map`, from its indices to the
/// simplex's) and their weights.
fn pick(s: &Simplex, nearest: &Nearest, map: impl Fn(usize) -> usize) -> (Simplex, [f64; 4]) {
    let mut out = Simplex::default();
    let mut w = [0.0; 4];
    for (k, (i, l)) in nearest.iter().enumerate() {
        out.push(s[map(i)]);
        w[k] = l;
    }
    (out, w)
}

/// Closest point to the origin on segment `ab`: used vertex indices and weights.
pub(crate) fn closest_segment(a: DVec3, b: DVec3) -> Nearest {
    let ab = b - a;
    let denom = ab.length_squared();
    let t = if denom > 0.0 {
        (-a).dot(ab) / denom
    } else {
        0.0
    };
    if t <= 0.0 {
        Nearest::vertex(0)
    } else if t >= 1.0 {
        Nearest::vertex(1)
    } else {
        Nearest::edge(0, 1, t)
    }
}

/// Closest point to the origin on triangle `abc` (Ericson §5.1.5).
pub(crate) fn closest_triangle(a: DVec3, b: DVec3, c: DVec3) -> Nearest {
    let p = DVec3::ZERO;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return Nearest::vertex(0);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return Nearest::vertex(1);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return Nearest::edge(0, 1, v);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return Nearest::vertex(2);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return Nearest::edge(0, 2, w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return Nearest::edge(1, 2, w);
    }
    let sum = va + vb + vc;
    if sum.abs() <= f64::MIN_POSITIVE || !sum.is_finite() {
        // Degenerate (collinear) triangle: best of its edges.
        let pts = [a, b, c];
        let mut best = Nearest::vertex(0);
        let mut best_d = f64::INFINITY;
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            let seg = closest_segment(pts[i], pts[j]);
            let q = seg.point(&[pts[i], pts[j]]);
            if q.length_squared() < best_d {
                best_d = q.length_squared();
                let ends = [i, j];
                best = seg;
                for k in 0..best.len {
                    best.idx[k] = ends[seg.idx[k]];
                }
            }
        }
        return best;
    }
    let denom = 1.0 / sum;
    let v = vb * denom;
    let w = vc * denom;
    Nearest {
        idx: [0, 1, 2],
        w: [1.0 - v - w, v, w],
        len: 3,
    }
}

/// The face of the tetrahedron nearest the origin, or `None` when the
/// origin is inside.
fn closest_tetrahedron(s: &Simplex) -> Option<(Simplex, [f64; 4])> {
    let faces = [[0, 1, 2, 3], [0, 2, 3, 1], [0, 3, 1, 2], [1, 3, 2, 0]];
    let mut best: Option<(Simplex, [f64; 4])> = None;
    let mut best_d = f64::INFINITY;
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
            let nearest = closest_triangle(a, b, c);
            let q = nearest.point(&[a, b, c]);
            if q.length_squared() < best_d {
                best_d = q.length_squared();
                best = Some(pick(s, &nearest, |k| f[k]));
            }
        }
    }
    best
}
