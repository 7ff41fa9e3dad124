//! Mass properties: mass, centre of mass and inertia tensor, and the algebra
//! that moves, combines and diagonalises them.
//!
//! # Design note
//!
//! **What.** A rigid body's response to forces is fixed by three numbers: its
//! mass `m` (kg), its centre of mass `c` (m) and its inertia tensor `I`
//! (kg·m²) about `c`. We keep `I` as a full symmetric 3×3 matrix in the
//! frame of the shape that produced it, because a compound or a hull is not
//! aligned with its principal axes; [`MassProperties::principal_axes`] gives
//! the diagonal form when a body wants it.
//!
//! **Moving and combining.** A pose rotates the tensor, `I' = R I Rᵀ`, and
//! moves the centre; combining parts sums the masses, takes the
//! mass-weighted mean centre, and brings each part's tensor to the common
//! centre with the parallel-axis theorem `I_c = I_i + m_i (|d|² E − d dᵀ)`,
//! `d = c_i − c` (Goldstein, *Classical Mechanics*, §5.3).
//!
//! **Polyhedra.** Options were: Monte Carlo (slow, inexact); decomposing
//! into tetrahedra from a reference point and summing their covariance
//! matrices (Blow & Binstock 2004, "How to find the inertia tensor (or other
//! mass properties) of a 3D solid body represented by a triangle mesh");
//! Mirtich's divergence-theorem reduction from volume to surface to face
//! projections (Mirtich 1996, "Fast and accurate computation of polyhedral
//! mass properties", J. Graphics Tools 1(2)); and Eberly's restatement of
//! Mirtich for triangles (Eberly 2002/2009, "Polyhedral Mass Properties
//! (Revisited)", Geometric Tools). We use Eberly's: it is exact for a
//! polyhedron (up to rounding), one pass over the triangles with a handful
//! of multiplications each, and needs no choice of projection plane. Faces
//! are triangulated as fans, which is exact for the convex faces of a hull.
//! The vertices are first shifted to their mean so that the third-order
//! moments do not cancel catastrophically for a small body far from the
//! origin; the result is shifted back.
//!
//! **Principal axes.** Options were the closed-form roots of the
//! characteristic cubic (fast, but eigenvectors lose accuracy when moments
//! repeat, as for a cube or a cylinder), QR iteration, and cyclic Jacobi.
//! Jacobi rotations (Golub & Van Loan, *Matrix Computations*, §8.5; the
//! update follows Press et al., *Numerical Recipes*, §11.1) are unconditionally
//! stable for symmetric matrices, converge quadratically, give orthonormal
//! eigenvectors by construction, and do not care about repeated eigenvalues:
//! any orthonormal basis of a repeated eigenspace diagonalises the tensor.
//! On a 3×3 they finish in a few sweeps.

use glam::{DMat3, DQuat, DVec3};

use super::pose::Pose;

/// Mass, centre of mass and inertia tensor of a solid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the shape's (or body's) frame, m.
    pub center_of_mass: DVec3,
    /// Inertia tensor about the centre of mass, in the same frame, kg·m²;
    /// symmetric. Diagonal entries are the moments `∫ (y² + z²) dm`, ...;
    /// off-diagonal entries are the negated products `−∫ x y dm`, ...
    pub inertia: DMat3,
}

impl Default for MassProperties {
    fn default() -> Self {
        Self::ZERO
    }
}

impl MassProperties {
    /// No mass: the identity for [`combine`](Self::combine).
    pub const ZERO: MassProperties = MassProperties {
        mass: 0.0,
        center_of_mass: DVec3::ZERO,
        inertia: DMat3::ZERO,
    };

    /// Mass properties from their parts: mass (kg), centre of mass (m) and
    /// inertia about that centre (kg·m²).
    #[inline]
    pub const fn new(mass: f64, center_of_mass: DVec3, inertia: DMat3) -> Self {
        Self {
            mass,
            center_of_mass,
            inertia,
        }
    }

    /// The same solid seen from a parent frame in which its frame sits at
    /// `pose`: the centre is transformed as a point and the tensor rotated,
    /// `R I Rᵀ`. The mass is unchanged.
    pub fn transformed(&self, pose: &Pose) -> MassProperties {
        let r = DMat3::from_quat(pose.rotation);
        MassProperties {
            mass: self.mass,
            center_of_mass: pose.transform_point(self.center_of_mass),
            inertia: symmetrize(r * self.inertia * r.transpose()),
        }
    }

    /// The mass properties of a body made of `parts` (all in one frame):
    /// masses add, the centre is the mass-weighted mean, and each tensor is
    /// moved to that centre by the parallel-axis theorem. Parts must not
    /// overlap, or the overlap counts twice. No parts (or zero total mass)
    /// gives [`MassProperties::ZERO`] inertia about the origin.
    pub fn combine(parts: &[MassProperties]) -> MassProperties {
        let mass: f64 = parts.iter().map(|p| p.mass).sum();
        if mass <= 0.0 || !mass.is_finite() {
            return MassProperties {
                mass: if mass.is_finite() { mass } else { f64::NAN },
                ..MassProperties::ZERO
            };
        }
        let center = parts
            .iter()
            .fold(DVec3::ZERO, |acc, p| acc + p.center_of_mass * p.mass)
            / mass;
        let inertia = parts.iter().fold(DMat3::ZERO, |acc, p| {
            acc + parallel_axis(p.inertia, p.mass, p.center_of_mass - center)
        });
        MassProperties {
            mass,
            center_of_mass: center,
            inertia: symmetrize(inertia),
        }
    }

    /// Principal moments of inertia (kg·m², ascending) and the rotation `R`
    /// that takes vectors from the principal frame to the shape frame, so
    /// that `inertia == R · diag(moments) · Rᵀ` (to rounding).
    ///
    /// `R` is a proper rotation (determinant +1). When moments repeat (a
    /// cube, a cylinder about its radial axes) any orthonormal basis of the
    /// repeated eigenspace is a valid answer; the one returned is
    /// deterministic for a given tensor.
    pub fn principal_axes(&self) -> (DVec3, DQuat) {
        let (values, vectors) = symmetric_eigen(self.inertia);
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        let moments = DVec3::new(values[order[0]], values[order[1]], values[order[2]]);
        // Re-orthonormalise and complete right-handed, so det R = +1 exactly
        // up to rounding whatever the signs Jacobi left on the columns.
        let c0 = vectors.col(order[0]).normalize_or(DVec3::X);
        let v1 = vectors.col(order[1]);
        let c1 = (v1 - c0 * c0.dot(v1)).normalize_or(c0.any_orthonormal_vector());
        let c2 = c0.cross(c1);
        let rotation = DQuat::from_mat3(&DMat3::from_cols(c0, c1, c2)).normalize();
        (moments, rotation)
    }
}

/// Inertia (kg·m²) about a point displaced by `offset` (m) from the centre of
/// mass, given the `inertia` about the centre and the `mass` (kg): the
/// parallel-axis (Huygens–Steiner) theorem `I + m (|d|² E − d dᵀ)`.
pub fn parallel_axis(inertia: DMat3, mass: f64, offset: DVec3) -> DMat3 {
    let d = offset;
    let outer = DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    inertia + (DMat3::from_diagonal(DVec3::splat(d.length_squared())) - outer) * mass
}

/// `(A + Aᵀ) / 2`: removes the asymmetry rounding leaves after products.
fn symmetrize(a: DMat3) -> DMat3 {
    (a + a.transpose()) * 0.5
}

/// Eigenvalues and eigenvectors (as columns) of a symmetric 3×3 matrix by
/// cyclic Jacobi rotations. Only the symmetric part of `m` is used.
fn symmetric_eigen(m: DMat3) -> ([f64; 3], DMat3) {
    let m = symmetrize(m);
    // a[row][col]
    let mut a = m.transpose().to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    const PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
    for _sweep in 0..50 {
        let mut rotated = false;
        for &(p, q) in &PAIRS {
            let apq = a[p][q];
            // Negligible next to the diagonal (or exactly zero): drop it. The
            // factor is far below rounding of the diagonal, so the result
            // is as accurate as the arithmetic allows.
            if apq == 0.0 || apq.abs() <= 1e-18 * (a[p][p].abs() + a[q][q].abs()) {
                a[p][q] = 0.0;
                a[q][p] = 0.0;
                continue;
            }
            if !apq.is_finite() {
                continue;
            }
            rotated = true;
            // Rotation angle φ with t = tan φ the smaller root of
            // t² + 2θt − 1 = 0, θ = (a_qq − a_pp) / (2 a_pq) (NR eq. 11.1.8).
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            let t = if theta.abs() > 1e150 {
                0.5 / theta
            } else {
                theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
            };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J, V ← V J, with J the identity except
            // J_pp = J_qq = c, J_pq = s, J_qp = −s.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * row_p[k] - s * row_q[k]);
            a[q] = std::array::from_fn(|k| s * row_p[k] + c * row_q[k]);
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            for row in v.iter_mut() {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
        if !rotated {
            break;
        }
    }
    let vectors = DMat3::from_cols_array_2d(&v).transpose();
    ([a[0][0], a[1][1], a[2][2]], vectors)
}

/// Volume (m³), centroid (m) and inertia tensor about the centroid per unit
/// density (m⁵) of the closed polyhedron whose boundary is `triangles`
/// (indices into `vertices`, counter-clockwise seen from outside).
///
/// Eberly, "Polyhedral Mass Properties (Revisited)", after Mirtich 1996.
/// The result is meaningless unless the triangles close a volume.
pub(crate) fn polyhedron(
    vertices: &[DVec3],
    triangles: impl Iterator<Item = [usize; 3]>,
) -> (f64, DVec3, DMat3) {
    if vertices.is_empty() {
        return (0.0, DVec3::ZERO, DMat3::ZERO);
    }
    let origin = vertices.iter().fold(DVec3::ZERO, |a, &v| a + v) / vertices.len() as f64;
    // ∫1, ∫x, ∫y, ∫z, ∫x², ∫y², ∫z², ∫xy, ∫yz, ∫zx over the volume.
    let mut s = [0.0f64; 10];
    for [i0, i1, i2] in triangles {
        let p0 = vertices[i0] - origin;
        let p1 = vertices[i1] - origin;
        let p2 = vertices[i2] - origin;
        // Unnormalised outward normal (twice the area vector).
        let d = (p1 - p0).cross(p2 - p0);
        let (f1x, f2x, f3x, g0x, g1x, g2x) = subexpressions(p0.x, p1.x, p2.x);
        let (_, f2y, f3y, g0y, g1y, g2y) = subexpressions(p0.y, p1.y, p2.y);
        let (_, f2z, f3z, g0z, g1z, g2z) = subexpressions(p0.z, p1.z, p2.z);
        s[0] += d.x * f1x;
        s[1] += d.x * f2x;
        s[2] += d.y * f2y;
        s[3] += d.z * f2z;
        s[4] += d.x * f3x;
        s[5] += d.y * f3y;
        s[6] += d.z * f3z;
        s[7] += d.x * (p0.y * g0x + p1.y * g1x + p2.y * g2x);
        s[8] += d.y * (p0.z * g0y + p1.z * g1y + p2.z * g2y);
        s[9] += d.z * (p0.x * g0z + p1.x * g1z + p2.x * g2z);
    }
    const MULT: [f64; 10] = [
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 24.0,
        1.0 / 24.0,
        1.0 / 60.0,
        1.0 / 60.0,
        1.0 / 60.0,
        1.0 / 120.0,
        1.0 / 120.0,
        1.0 / 120.0,
    ];
    for (si, m) in s.iter_mut().zip(MULT) {
        *si *= m;
    }
    let volume = s[0];
    if volume <= 0.0 || !volume.is_finite() {
        return (volume, origin, DMat3::ZERO);
    }
    let c = DVec3::new(s[1], s[2], s[3]) / volume;
    // Second moments about the centroid (still in the shifted frame).
    let xx = s[4] - volume * c.x * c.x;
    let yy = s[5] - volume * c.y * c.y;
    let zz = s[6] - volume * c.z * c.z;
    let xy = s[7] - volume * c.x * c.y;
    let yz = s[8] - volume * c.y * c.z;
    let zx = s[9] - volume * c.z * c.x;
    let inertia = DMat3::from_cols(
        DVec3::new(yy + zz, -xy, -zx),
        DVec3::new(-xy, zz + xx, -yz),
        DVec3::new(-zx, -yz, xx + yy),
    );
    (volume, c + origin, inertia)
}

/// Eberly's per-axis subexpressions for one triangle's coordinates
/// `w0, w1, w2`: `(f1, f2, f3, g0, g1, g2)`.
#[inline]
fn subexpressions(w0: f64, w1: f64, w2: f64) -> (f64, f64, f64, f64, f64, f64) {
    let temp0 = w0 + w1;
    let f1 = temp0 + w2;
    let temp1 = w0 * w0;
    let temp2 = temp1 + w1 * temp0;
    let f2 = temp2 + w2 * f1;
    let f3 = w0 * temp1 + w1 * temp2 + w2 * f2;
    let g0 = f2 + w0 * (f1 + w0);
    let g1 = f2 + w1 * (f1 + w1);
    let g2 = f2 + w2 * (f1 + w2);
    (f1, f2, f3, g0, g1, g2)
}
