//! The constraints of a soft body and their XPBD projections.
//!
//! Every projection is one XPBD iteration from `λ = 0` (small steps:
//! Macklin et al. 2019), so no multiplier is kept between substeps:
//! `Δλ = −C / (Σ_k w_k |∇_k C|² + α̃)`, `Δx_k = w_k ∇_k C Δλ`, with the
//! compliance scaled by the substep, `α̃ = α / h²`. A compliance of 0 is
//! an inextensible (rigid) constraint.
//!
//! Units: distances in m, angles in rad, volumes in m³; a distance
//! constraint's compliance is in m/N, a bending constraint's in
//! rad/(N·m), a volume constraint's in m³/(N·m) (= 1/Pa).

use glam::Vec3;

use super::super::colouring::Touches;
use super::super::scatter::Scatter;

/// Keeps two particles at a rest distance: rope segments, cloth stretch
/// and shear, the edges of a volumetric body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Distance {
    pub(crate) p: [u32; 2],
    /// Rest length now, m (plasticity moves it).
    pub(crate) rest: f32,
    /// Rest length as built, m.
    pub(crate) rest0: f32,
    /// m/N.
    pub(crate) compliance: f32,
}

impl Touches for Distance {
    fn particles(&self) -> &[u32] {
        &self.p
    }
}

impl Distance {
    /// One projection.
    #[inline(always)]
    pub(crate) fn project(&self, x: Scatter<'_, Vec3>, w: &[f32], inv_h2: f32) {
        let [a, b] = [self.p[0] as usize, self.p[1] as usize];
        let (wa, wb) = (w[a], w[b]);
        // SAFETY: a colour moves each particle once (colouring.rs).
        let (xa, xb) = unsafe { (x.get(a), x.get(b)) };
        let d = xb - xa;
        let len = d.length();
        let k = wa + wb + self.compliance * inv_h2;
        if len < 1e-9 || k <= 0.0 {
            return;
        }
        let n = d / len;
        let dl = -(len - self.rest) / k;
        // SAFETY: as above.
        unsafe {
            x.set(a, xa - n * (wa * dl));
            x.set(b, xb + n * (wb * dl));
        }
    }
}

/// Keeps the angle between two triangles that share an edge: bending.
/// `p = [e0, e1, o0, o1]`: the shared edge, then the vertex of each
/// triangle opposite it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bend {
    pub(crate) p: [u32; 4],
    /// Rest dihedral angle, rad (0 for a flat sheet).
    pub(crate) rest: f32,
    /// rad/(N·m).
    pub(crate) compliance: f32,
}

impl Touches for Bend {
    fn particles(&self) -> &[u32] {
        &self.p
    }
}

/// The signed dihedral angle of the hinge `x = [e0, e1, o0, o1]` (rad, 0
/// when flat, in (−π, π]) and its gradient with respect to each vertex
/// (Bridson et al., "Simulation of Clothing with Folds and Wrinkles",
/// SCA 2003). `None` when a triangle is degenerate.
pub(crate) fn dihedral(x: [Vec3; 4]) -> Option<(f32, [Vec3; 4])> {
    let [x0, x1, x2, x3] = x;
    let e = x1 - x0;
    let e_len = e.length();
    // Area-weighted normals of (x0, x1, x2) and (x1, x0, x3).
    let n1 = (x1 - x0).cross(x2 - x0);
    let n2 = (x3 - x0).cross(x1 - x0);
    let (l1, l2) = (n1.length_squared(), n2.length_squared());
    if e_len < 1e-9 || l1 < 1e-18 || l2 < 1e-18 {
        return None;
    }
    let e_hat = e / e_len;
    // The normals' lengths cancel in the arctangent: no need to normalise.
    let angle = atan2(n1.cross(n2).dot(e_hat), n1.dot(n2));
    // With the angle measured from n1 to n2 about e, each opposite vertex
    // moves the angle against its triangle's normal.
    let g2 = -n1 * (e_len / l1);
    let g3 = -n2 * (e_len / l2);
    let g0 = -(n1 * ((x2 - x1).dot(e_hat) / l1) + n2 * ((x3 - x1).dot(e_hat) / l2));
    let g1 = n1 * ((x2 - x0).dot(e_hat) / l1) + n2 * ((x3 - x0).dot(e_hat) / l2);
    Some((angle, [g0, g1, g2, g3]))
}

/// The angle of `(x, y)`, rad, in [−π, π], to within 1e-5 rad: a
/// polynomial arctangent (Abramowitz & Stegun, Handbook of Mathematical
/// Functions, 4.4.49: |ε| ≤ 1e-5 on [0, 1]) in plain
/// arithmetic, a quarter the cost of the C library's and written the same
/// way in the shaders, so both backends take the same branches.
#[inline(always)]
pub(crate) fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let hi = ax.max(ay);
    if hi == 0.0 {
        return 0.0;
    }
    let a = ax.min(ay) / hi;
    let s = a * a;
    let mut r =
        a * (0.999_866 + s * (-0.330_299_5 + s * (0.180_141 + s * (-0.085_133 + s * 0.020_835_1))));
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// `a − b` wrapped into (−π, π].
fn angle_difference(a: f32, b: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let mut d = a - b;
    if d > PI {
        d -= TAU;
    } else if d <= -PI {
        d += TAU;
    }
    d
}

impl Bend {
    /// One projection.
    #[inline(always)]
    pub(crate) fn project(&self, x: Scatter<'_, Vec3>, w: &[f32], inv_h2: f32) {
        let i = self.p.map(|k| k as usize);
        // SAFETY: a colour moves each particle once (colouring.rs).
        let xs = i.map(|k| unsafe { x.get(k) });
        let Some((angle, grad)) = dihedral(xs) else {
            return;
        };
        let c = angle_difference(angle, self.rest);
        let mut k = self.compliance * inv_h2;
        for j in 0..4 {
            k += w[i[j]] * grad[j].length_squared();
        }
        if k <= 1e-12 {
            return;
        }
        let dl = -c / k;
        for j in 0..4 {
            // SAFETY: as above.
            unsafe { x.set(i[j], xs[j] + grad[j] * (w[i[j]] * dl)) };
        }
    }
}

/// Keeps the volume of a tetrahedron.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tet {
    pub(crate) p: [u32; 4],
    /// Rest volume, m³ (> 0: the vertices are ordered so).
    pub(crate) rest: f32,
    /// 1/Pa.
    pub(crate) compliance: f32,
}

impl Touches for Tet {
    fn particles(&self) -> &[u32] {
        &self.p
    }
}

/// The signed volume of the tetrahedron `x` (positive when `x1 − x0`,
/// `x2 − x0`, `x3 − x0` are right-handed), m³.
pub(crate) fn tet_volume(x: [Vec3; 4]) -> f32 {
    (x[1] - x[0]).cross(x[2] - x[0]).dot(x[3] - x[0]) / 6.0
}

impl Tet {
    /// One projection.
    #[inline(always)]
    pub(crate) fn project(&self, x: Scatter<'_, Vec3>, w: &[f32], inv_h2: f32) {
        let i = self.p.map(|k| k as usize);
        // SAFETY: a colour moves each particle once (colouring.rs).
        let xs = i.map(|k| unsafe { x.get(k) });
        let [x0, x1, x2, x3] = xs;
        let g1 = (x2 - x0).cross(x3 - x0) / 6.0;
        let g2 = (x3 - x0).cross(x1 - x0) / 6.0;
        let g3 = (x1 - x0).cross(x2 - x0) / 6.0;
        let g0 = -(g1 + g2 + g3);
        let grad = [g0, g1, g2, g3];
        let c = tet_volume(xs) - self.rest;
        let mut k = self.compliance * inv_h2;
        for j in 0..4 {
            k += w[i[j]] * grad[j].length_squared();
        }
        if k <= 1e-30 {
            return;
        }
        let dl = -c / k;
        for j in 0..4 {
            // SAFETY: as above.
            unsafe { x.set(i[j], xs[j] + grad[j] * (w[i[j]] * dl)) };
        }
    }
}

/// A long-range attachment (Kim et al., "Long Range Attachments", SCA
/// 2012): a particle stays within its rest distance of a pinned particle,
/// so a hanging cloth cannot stretch away from its pins however many
/// links lie between. It only ever pulls (a unilateral constraint).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tether {
    /// `[particle, pinned anchor]`.
    pub(crate) p: [u32; 2],
    /// Greatest distance allowed, m.
    pub(crate) max: f32,
}

impl Touches for Tether {
    fn particles(&self) -> &[u32] {
        &self.p[..1]
    }
}

impl Tether {
    /// One projection (the anchor is pinned: only the particle moves).
    #[inline(always)]
    pub(crate) fn project(&self, x: Scatter<'_, Vec3>, w: &[f32]) {
        let [a, b] = [self.p[0] as usize, self.p[1] as usize];
        if w[a] <= 0.0 {
            return;
        }
        // SAFETY: a colour moves each particle once; the anchor is pinned
        // and never written.
        let (xa, xb) = unsafe { (x.get(a), x.get(b)) };
        let d = xa - xb;
        let len = d.length();
        if len <= self.max || len < 1e-9 {
            return;
        }
        // SAFETY: as above.
        unsafe { x.set(a, xb + d * (self.max / len)) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hinge(fold: f32) -> [Vec3; 4] {
        // Edge along x; o0 in the xz-plane at +z; o1 folded about the edge.
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.3, 0.0, 1.0),
            Vec3::new(0.6, fold.sin(), -fold.cos()),
        ]
    }

    #[test]
    fn a_flat_hinge_has_angle_zero_and_folds_both_ways() {
        let (a, _) = dihedral(hinge(0.0)).unwrap();
        assert!(a.abs() < 1e-6, "{a}");
        let (up, _) = dihedral(hinge(0.5)).unwrap();
        let (down, _) = dihedral(hinge(-0.5)).unwrap();
        assert!((up.abs() - 0.5).abs() < 1e-5, "{up}");
        assert!((up + down).abs() < 1e-5, "{up} {down}");
    }

    #[test]
    fn dihedral_gradients_match_finite_differences() {
        for fold in [-2.0f32, -0.7, 0.0, 0.4, 1.3, 2.6] {
            let x = hinge(fold);
            let (a0, g) = dihedral(x).unwrap();
            let eps = 1e-3f32;
            for v in 0..4 {
                for c in 0..3 {
                    let mut xp = x;
                    xp[v][c] += eps;
                    let mut xm = x;
                    xm[v][c] -= eps;
                    let fd = angle_difference(dihedral(xp).unwrap().0, dihedral(xm).unwrap().0)
                        / (2.0 * eps);
                    assert!(
                        (fd - g[v][c]).abs() < 2e-2 * (1.0 + fd.abs()),
                        "fold {fold} angle {a0} vertex {v} axis {c}: fd {fd} analytic {}",
                        g[v][c]
                    );
                }
            }
        }
    }

    #[test]
    fn the_polynomial_arctangent_is_within_1e5_rad() {
        let mut worst = 0.0f32;
        for k in 0..3600 {
            let t = k as f32 * std::f32::consts::TAU / 3600.0;
            for r in [1e-3f32, 1.0, 7.0] {
                let (y, x) = (r * t.sin(), r * t.cos());
                worst = worst.max(angle_difference(atan2(y, x), y.atan2(x)).abs());
            }
        }
        assert!(worst < 1.2e-5, "{worst}");
        assert_eq!(atan2(0.0, 1.0), 0.0);
        assert_eq!(atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn tet_volume_is_positive_for_a_right_handed_tet() {
        let x = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        assert!((tet_volume(x) - 1.0 / 6.0).abs() < 1e-7);
    }
}
