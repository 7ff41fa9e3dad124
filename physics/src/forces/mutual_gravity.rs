//! Gravity between the particles of one system (Newton):
//! `F_ij = G m_i m_j (x_j - x_i) / (|x_j - x_i|² + ε²)^(3/2)`.
//!
//! The softening length `ε` (m) keeps close encounters finite; the matching
//! potential is `-G m_i m_j / sqrt(r² + ε²)`, so energy stays consistent with
//! the force. Two methods:
//!
//! * **Exact**, O(N²): every pair; each particle sums its partners in index
//!   order, so the result does not depend on the thread count, and the pair
//!   terms are bit-exact opposites, so total momentum is conserved to
//!   rounding.
//! * **Barnes–Hut**, O(N log N): distant groups of particles are replaced by
//!   their centre of mass when `cell size / distance < θ` (see
//!   [`barnes_hut`](super::barnes_hut)).
//!
//! Pinned particles attract others but do not move; quarantined particles
//! take no part.

use glam::DVec3;

use crate::error::{non_negative, positive, PhysicsError};
use crate::parallel::{par_map_chunks, CHUNK};

/// How mutual gravity is summed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GravityMethod {
    /// All pairs, O(N²).
    Exact,
    /// Barnes–Hut octree with opening angle `theta` in (0, 2]; 0.5 is a common choice.
    BarnesHut {
        /// Opening angle: a cell of size `s` at distance `d` is used whole when `s / d < theta`.
        theta: f64,
    },
}

/// Newtonian gravity between all particles of a system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MutualGravity {
    /// Gravitational constant, m³/(kg·s²) (SI: 6.674e-11; games often use 1).
    pub g_constant: f64,
    /// Softening length `ε`, m.
    pub softening: f64,
    /// Summation method.
    pub method: GravityMethod,
}

impl Default for MutualGravity {
    fn default() -> Self {
        Self {
            g_constant: 6.674_30e-11,
            softening: 0.0,
            method: GravityMethod::Exact,
        }
    }
}

impl MutualGravity {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        positive("gravitational constant", self.g_constant)?;
        non_negative("gravity softening", self.softening)?;
        if let GravityMethod::BarnesHut { theta } = self.method {
            if !(theta.is_finite() && theta > 0.0 && theta <= 2.0) {
                return Err(PhysicsError::BadTheta(theta));
            }
        }
        Ok(())
    }
}

/// Adds the exact all-pairs gravitational force on each particle to `out`, N.
/// `mass[j] == 0` marks a particle that takes no part.
pub(crate) fn exact_forces(x: &[DVec3], mass: &[f64], g: f64, eps2: f64, out: &mut [DVec3]) {
    par_map_chunks(out, CHUNK / 16, |base, chunk| {
        for (k, o) in chunk.iter_mut().enumerate() {
            let i = base + k;
            if mass[i] == 0.0 {
                continue;
            }
            let xi = x[i];
            let mut acc = DVec3::ZERO;
            for (j, (&xj, &mj)) in x.iter().zip(mass).enumerate() {
                if j == i || mj == 0.0 {
                    continue;
                }
                let d = xj - xi;
                let r2 = d.length_squared() + eps2;
                let inv_r = 1.0 / r2.sqrt();
                acc += (mj * inv_r * inv_r * inv_r) * d;
            }
            *o += (g * mass[i]) * acc;
        }
    });
}

/// Exact total gravitational potential energy, J (each pair once, in index order).
pub(crate) fn exact_potential(x: &[DVec3], mass: &[f64], g: f64, eps2: f64) -> f64 {
    let per_particle = {
        let mut phi = vec![0.0f64; x.len()];
        par_map_chunks(&mut phi, CHUNK / 16, |base, chunk| {
            for (k, p) in chunk.iter_mut().enumerate() {
                let i = base + k;
                if mass[i] == 0.0 {
                    continue;
                }
                let mut s = 0.0;
                for j in i + 1..x.len() {
                    if mass[j] == 0.0 {
                        continue;
                    }
                    s += mass[j] / ((x[j] - x[i]).length_squared() + eps2).sqrt();
                }
                *p = -g * mass[i] * s;
            }
        });
        phi
    };
    per_particle.iter().sum()
}

/// Gravitational acceleration on each of `positions` (m) with `masses` (kg),
/// m/s², by `method`: a standalone entry point for checks and benchmarks
/// (the step uses the same code). A mass of 0 takes no part.
pub fn accelerations(positions: &[DVec3], masses: &[f64], gravity: &MutualGravity) -> Vec<DVec3> {
    let mut force = vec![DVec3::ZERO; positions.len()];
    let eps2 = gravity.softening * gravity.softening;
    match gravity.method {
        GravityMethod::Exact => {
            exact_forces(positions, masses, gravity.g_constant, eps2, &mut force)
        }
        GravityMethod::BarnesHut { theta } => super::barnes_hut::Octree::build(positions, masses)
            .forces(
                positions,
                masses,
                gravity.g_constant,
                eps2,
                theta,
                &mut force,
            ),
    }
    force
        .iter()
        .zip(masses)
        .map(|(f, &m)| if m > 0.0 { *f / m } else { DVec3::ZERO })
        .collect()
}
