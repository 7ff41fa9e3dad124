//! What a solid wall adds to a fluid particle's density constraint.
//!
//! A particle near a wall lacks the neighbours the wall's side of its
//! kernel would hold, so it reads too light and the fluid near the wall
//! neither resists compression nor holds its level. After Koschier &
//! Bender, "Density Maps for Improved SPH Boundary Handling" (SCA 2017),
//! the wall counts as solid fluid at rest density: a particle at distance
//! `d` from the surface gains `ρ0 Φ(d)`, with `Φ(d)` the density kernel's
//! (spiky's) integral over the solid. Where they map the volume of any shape, we take the
//! solid as the half-space beyond the nearest surface point (a planar
//! approximation, good where the surface is flat over a kernel radius).
//! Then `Φ` depends on `d` alone and is tabulated once.
//!
//! Its gradient term is the integral of spiky's gradient over the solid,
//! `Ψ(d) = ∫ ∂W_spiky/∂n`, as the particle–particle gradients are sums of
//! it (and `Ψ = dΦ/dd`, the same kernel): the wall's part of `∇C` is
//! `Ψ(d) n` (1/m), and `Ψ ≤ 0`, so a compressed particle is pushed off the
//! wall along the normal `n`.
//!
//! The continuum integral counts a little more than the lattice of
//! particles it stands in for would (the lattice's sum only approximates
//! the kernel's integral, and the nearest missing layer stands a full
//! spacing off): a particle of a cubic lattice at rest half a spacing from
//! a wall would read a few per cent above rest density at `h = 2 spacing`,
//! and the fluid would be pushed off every wall. So the table is scaled
//! once, by `(1 − S_half) / Φ(spacing / 2)` with `S_half` the lattice's
//! sum over the particle's own layer and those beyond it: such a particle
//! then reads exactly the rest density.
//!
//! Both integrals are taken numerically in cylindrical coordinates about
//! the normal through the particle: height `u ∈ [d, h]` below the particle
//! and radius `ρ ∈ [0, √(h² − u²)]`, volume element `2π ρ dρ du`. Inside
//! the solid (`d < 0`) the half-space symmetry gives `Φ(d) = 1 − Φ(−d)`
//! and `Ψ(d) = Ψ(−d)`.

use std::f64::consts::PI;

use super::kernels::Kernels;

/// Table entries over `[0, h]`, both ends included.
pub(crate) const ENTRIES: usize = 64;
/// Midpoint-rule steps along each cylindrical coordinate.
const STEPS: usize = 96;

/// `Φ` and `Ψ` tabulated over the distance from the wall.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WallTable {
    /// Support radius h, m.
    h: f32,
    /// Entries per metre, `(ENTRIES − 1) / h`.
    per_m: f32,
    /// `Φ(k h / (ENTRIES − 1))`: spiky's integral over the solid.
    phi: [f32; ENTRIES],
    /// `Ψ(k h / (ENTRIES − 1))`, 1/m: spiky's gradient along the normal,
    /// integrated over the solid.
    grad: [f32; ENTRIES],
    /// The lattice calibration that multiplies both (1 until
    /// [`WallTable::calibrate`]).
    scale: f32,
}

impl WallTable {
    /// Tabulates the half-space integrals for support radius `h` (m, > 0).
    pub(crate) fn new(h: f32) -> Self {
        let hd = f64::from(h);
        let spiky = 15.0 / (PI * hd.powi(6));
        let spiky_grad = -45.0 / (PI * hd.powi(6));
        let mut phi = [0.0f32; ENTRIES];
        let mut grad = [0.0f32; ENTRIES];
        for k in 0..ENTRIES {
            let d = hd * k as f64 / (ENTRIES - 1) as f64;
            let (mut p, mut g) = (0.0f64, 0.0f64);
            let du = (hd - d) / STEPS as f64;
            for a in 0..STEPS {
                let u = d + (a as f64 + 0.5) * du;
                let reach = (hd * hd - u * u).max(0.0).sqrt();
                let dr = reach / STEPS as f64;
                for b in 0..STEPS {
                    let rho = (b as f64 + 0.5) * dr;
                    let r2 = u * u + rho * rho;
                    if r2 >= hd * hd {
                        continue;
                    }
                    let r = r2.sqrt();
                    let dv = 2.0 * PI * rho * dr * du;
                    p += spiky * (hd - r).powi(3) * dv;
                    // ∂W/∂n = W'(r) · (component of the offset along n) / r.
                    g += spiky_grad * (hd - r).powi(2) * (u / r) * dv;
                }
            }
            phi[k] = p as f32;
            grad[k] = g as f32;
        }
        phi[ENTRIES - 1] = 0.0;
        grad[ENTRIES - 1] = 0.0;
        Self {
            h,
            per_m: (ENTRIES - 1) as f32 / h,
            phi,
            grad,
            scale: 1.0,
        }
    }

    /// Scales the table so that a particle of a cubic lattice `spacing` m
    /// apart, half a spacing from the wall, reads rest density, with
    /// `volume` (m³) the weight of a neighbour in the kernel sums. A scale
    /// outside 0.5 to 1.5 (a lattice far too coarse for the kernel) is
    /// clamped.
    pub(crate) fn calibrate(&mut self, kernels: &Kernels, spacing: f32, volume: f32) {
        let s = f64::from(spacing);
        let h = f64::from(kernels.h);
        let reach = (h / s).ceil() as i32;
        let mut half = 0.0f64;
        for k in -reach..=reach {
            for j in 0..=reach {
                for i in -reach..=reach {
                    let r2 = f64::from(i * i + j * j + k * k) * s * s;
                    if r2 < h * h {
                        half += f64::from(kernels.spiky(r2.sqrt() as f32));
                    }
                }
            }
        }
        let half = half * f64::from(volume);
        let (phi, _) = self.integral(0.5 * spacing);
        let scale = if phi > 0.0 {
            (1.0 - half) / f64::from(phi)
        } else {
            1.0
        };
        self.scale = if scale.is_finite() {
            scale.clamp(0.5, 1.5) as f32
        } else {
            1.0
        };
    }

    /// The table as the GPU path takes it: `Φ` and `Ψ` (1/m) at
    /// `k h / (ENTRIES − 1)`, entries per metre, and the calibration
    /// that multiplies both after interpolation.
    #[cfg(feature = "gpu")]
    pub(crate) fn parts(&self) -> (&[f32; ENTRIES], &[f32; ENTRIES], f32, f32) {
        (&self.phi, &self.grad, self.per_m, self.scale)
    }

    #[cfg(test)]
    /// The lattice calibration.
    pub(crate) fn scale(&self) -> f32 {
        self.scale
    }

    /// `(Φ(d), Ψ(d))` at signed distance `d` (m, negative inside the
    /// solid), calibrated: the fraction of rest density the wall adds, and
    /// its gradient along the outward normal, 1/m.
    #[inline]
    pub(crate) fn at(&self, d: f32) -> (f32, f32) {
        let (phi, grad) = self.integral(d);
        (phi * self.scale, grad * self.scale)
    }

    /// The half-space integrals `(Φ(d), Ψ(d))` at signed distance `d` (m)
    /// by linear interpolation, uncalibrated.
    #[inline]
    pub(crate) fn integral(&self, d: f32) -> (f32, f32) {
        if !d.is_finite() {
            return (0.0, 0.0);
        }
        let a = d.abs().min(self.h) * self.per_m;
        let k = (a as usize).min(ENTRIES - 2);
        let t = a - k as f32;
        let phi = self.phi[k] + t * (self.phi[k + 1] - self.phi[k]);
        let grad = self.grad[k] + t * (self.grad[k + 1] - self.grad[k]);
        if d >= 0.0 {
            (phi, grad)
        } else {
            (1.0 - phi, grad)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Φ(d)` in closed form: spiky over a disc at height `u` below the
    /// particle integrates (in `r`, with `ρ dρ = r dr`) to
    /// `(30 / h⁶) (h (h − u)⁴ / 4 − (h − u)⁵ / 5)`, and that over `u`
    /// from `d` to `h` to `(30 / h⁶) (h − d)⁵ (h / 20 − (h − d) / 30)`.
    fn phi_exact(h: f64, d: f64) -> f64 {
        let a = h - d;
        30.0 / h.powi(6) * a.powi(5) * (h / 20.0 - a / 30.0)
    }

    /// `dΦ/dd`, from the closed form.
    fn psi_exact(h: f64, d: f64) -> f64 {
        let a = h - d;
        30.0 / h.powi(6) * (-5.0 * a.powi(4) * (h / 20.0 - a / 30.0) + a.powi(5) / 30.0)
    }

    #[test]
    fn table_ends_and_values() {
        for h in [0.2f32, 1.0] {
            let t = WallTable::new(h);
            let (p0, g0) = t.integral(0.0);
            assert!((p0 - 0.5).abs() < 1e-3, "Φ(0) = {p0}");
            assert!(g0 < 0.0);
            assert_eq!(t.integral(h), (0.0, 0.0));
            assert_eq!(t.integral(2.0 * h), (0.0, 0.0));
            // Deep inside the solid: all of the kernel.
            assert!((t.integral(-h).0 - 1.0).abs() < 1e-6);
            for k in 0..10 {
                let d = h * k as f32 / 10.0;
                let want = phi_exact(f64::from(h), f64::from(d)) as f32;
                let want_grad = psi_exact(f64::from(h), f64::from(d)) as f32;
                let (got, grad) = t.integral(d);
                assert!((got - want).abs() < 2e-3, "Φ({d}) = {got}, want {want}");
                assert!(
                    (grad - want_grad).abs() < 2e-2 / h,
                    "Ψ({d}) = {grad}, want {want_grad}"
                );
            }
            // Φ falls monotonically and Ψ, its slope, is never positive.
            for k in 0..ENTRIES - 1 {
                assert!(t.phi[k + 1] <= t.phi[k]);
                assert!(t.grad[k] <= 0.0);
            }
        }
    }

    #[test]
    fn calibration_makes_a_lattice_at_a_wall_read_rest_density() {
        let (s, h) = (0.1f32, 0.2f32);
        let kernels = Kernels::new(h);
        let volume = (f64::from(s).powi(3) / kernels.lattice_sum(s)) as f32;
        let mut t = WallTable::new(h);
        t.calibrate(&kernels, s, volume);
        assert!(t.scale() > 0.5 && t.scale() < 1.0, "{}", t.scale());
        let mut sum = t.at(0.5 * s).0;
        for k in -2i32..=2 {
            for j in 0i32..=2 {
                for i in -2i32..=2 {
                    let r2 = (i * i + j * j + k * k) as f32 * s * s;
                    sum += volume * kernels.spiky(r2.sqrt());
                }
            }
        }
        assert!((sum - 1.0).abs() < 1e-4, "{sum}");
    }
}
