//! The block solve of a manifold's normal rows: its up to 4×4 effective
//! mass matrix factored by Cholesky and solved against the points' speeds.

use super::MAX_POINTS;

/// A lower-triangular Cholesky factor of a manifold's normal block, up to
/// 4×4.
pub(crate) type BlockMatrix = [[f64; MAX_POINTS]; MAX_POINTS];

/// Factors the symmetric 4×4 `k` as `L Lᵀ`; `None` unless it is positive
/// definite. The diagonal holds `1 / L_ii`, so solving multiplies instead
/// of dividing. (Blocks of fewer points are padded with identity rows,
/// which keeps every loop a fixed four long.)
pub(super) fn cholesky(k: &BlockMatrix) -> Option<BlockMatrix> {
    let mut l = [[0.0; MAX_POINTS]; MAX_POINTS];
    for i in 0..MAX_POINTS {
        for j in 0..=i {
            let sum = k[i][j] - (0..j).map(|m| l[i][m] * l[j][m]).sum::<f64>();
            if i == j {
                if sum <= 0.0 || !sum.is_finite() {
                    return None;
                }
                l[i][i] = 1.0 / sum.sqrt();
            } else {
                l[i][j] = sum * l[j][j];
            }
        }
    }
    Some(l)
}

/// Solves `L Lᵀ x = rhs` with `L` from [`cholesky`].
#[inline]
pub(super) fn cholesky_solve(l: &BlockMatrix, rhs: [f64; MAX_POINTS]) -> [f64; MAX_POINTS] {
    let mut y = [0.0; MAX_POINTS];
    for i in 0..MAX_POINTS {
        let mut sum = rhs[i];
        for m in 0..i {
            sum -= l[i][m] * y[m];
        }
        y[i] = sum * l[i][i];
    }
    let mut x = [0.0; MAX_POINTS];
    for i in (0..MAX_POINTS).rev() {
        let mut sum = y[i];
        for m in i + 1..MAX_POINTS {
            sum -= l[m][i] * x[m];
        }
        x[i] = sum * l[i][i];
    }
    x
}
