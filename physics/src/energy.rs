//! Energy accounting: what the world reports after each step.

/// Mechanical energy of a system or the whole world, J.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energy {
    /// `Σ ½ m v²`.
    pub kinetic: f64,
    /// Uniform gravity, `Σ -m (g · x)` (zero at the origin).
    pub gravity_uniform: f64,
    /// Mutual gravity, `Σ_pairs -G m_i m_j / sqrt(r² + ε²)`.
    pub gravity_mutual: f64,
    /// Springs, `Σ ½ k (L - L0)²`.
    pub spring: f64,
}

impl Energy {
    /// Kinetic plus every potential.
    pub fn total(&self) -> f64 {
        self.kinetic + self.gravity_uniform + self.gravity_mutual + self.spring
    }

    /// Sum of two reports.
    pub fn add(&self, o: &Energy) -> Energy {
        Energy {
            kinetic: self.kinetic + o.kinetic,
            gravity_uniform: self.gravity_uniform + o.gravity_uniform,
            gravity_mutual: self.gravity_mutual + o.gravity_mutual,
            spring: self.spring + o.spring,
        }
    }
}
