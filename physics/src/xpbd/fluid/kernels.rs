//! The smoothing kernels of position-based fluids (Macklin & Müller,
//! "Position Based Fluids", SIGGRAPH 2013, after Müller et al.,
//! "Particle-Based Fluid Simulation for Interactive Applications", SCA
//! 2003): spiky for the densities and their gradients, poly6 for the XSPH
//! viscosity and the tensile correction.
//!
//! The paper takes densities with poly6 and their gradients with spiky
//! (poly6's gradient vanishes as particles close in, spiky's does not, so
//! close particles still push apart). Projected once per small substep,
//! that mismatch does work: the corrections do not follow the gradient of
//! the density they correct, and a tank of fluid left at rest gains energy
//! faster the more substeps it takes (a closed tank at 16 substeps went
//! from rest to 1 m/s in a third of a second). Taking the densities with
//! spiky as well makes every correction follow its constraint's true
//! gradient and keeps spiky's push at short range; poly6's own gradient
//! would let particles pair up (the tank's level sank 8 %).
//!
//! Both kernels have support radius `h` and integrate to 1 over their
//! ball.

use std::f64::consts::PI;

use wide::f32x8;

/// Poly6 and spiky for one support radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Kernels {
    /// Support radius h, m.
    pub(crate) h: f32,
    /// h², m².
    pub(crate) h2: f32,
    /// `315 / (64 π h⁹)`, 1/m⁹.
    pub(crate) poly6: f32,
    /// `15 / (π h⁶)`, 1/m⁶.
    pub(crate) spiky: f32,
    /// `−45 / (π h⁶)`, 1/m⁶.
    pub(crate) spiky_grad: f32,
}

impl Kernels {
    /// The kernels of support radius `h` (m, > 0).
    pub(crate) fn new(h: f32) -> Self {
        let hd = f64::from(h);
        Self {
            h,
            h2: h * h,
            poly6: (315.0 / (64.0 * PI * hd.powi(9))) as f32,
            spiky: (15.0 / (PI * hd.powi(6))) as f32,
            spiky_grad: (-45.0 / (PI * hd.powi(6))) as f32,
        }
    }

    /// `W_poly6 = 315 / (64 π h⁹) (h² − r²)³` at squared distance `r2`
    /// (m²), 1/m³; 0 from `h` out.
    #[inline(always)]
    pub(crate) fn poly6(&self, r2: f32) -> f32 {
        if r2 >= self.h2 {
            return 0.0;
        }
        let d = self.h2 - r2;
        self.poly6 * d * d * d
    }

    /// `spacing³ Σ W_spiky` over a cubic lattice `spacing` m apart, the
    /// particle itself included: what a particle at rest in such a
    /// lattice reads as `ρ / ρ0` (the sum only approximates the kernel's
    /// integral).
    pub(crate) fn lattice_sum(&self, spacing: f32) -> f64 {
        let s = f64::from(spacing);
        let h = f64::from(self.h);
        let reach = (h / s).ceil() as i32;
        let mut sum = 0.0;
        for k in -reach..=reach {
            for j in -reach..=reach {
                for i in -reach..=reach {
                    let r2 = f64::from(i * i + j * j + k * k) * s * s;
                    if r2 < h * h {
                        sum += f64::from(self.spiky(r2.sqrt() as f32));
                    }
                }
            }
        }
        sum * s * s * s
    }

    #[cfg(test)]
    /// `(W_spiky, dW_spiky/dr / r)` at squared distance `r2` (m²): the
    /// density pass's two kernel values for one pair. Both 0 from `h` out;
    /// the gradient's 0 at `r = 0`.
    #[inline(always)]
    pub(crate) fn spiky_pair(&self, r2: f32) -> (f32, f32) {
        if r2 >= self.h2 {
            return (0.0, 0.0);
        }
        let r = r2.sqrt();
        let t = self.h - r;
        let g = if r > 0.0 {
            self.spiky_grad * t * t / r
        } else {
            0.0
        };
        (self.spiky * t * t * t, g)
    }

    /// `Kernels::spiky_pair` (kept in test builds) for eight offsets
    /// `(dx, dy, dz)` (m) at once.
    #[inline(always)]
    pub(crate) fn spiky_pair_x8(&self, dx: f32x8, dy: f32x8, dz: f32x8) -> (f32x8, f32x8) {
        let r2 = dx * dx + dy * dy + dz * dz;
        let r = r2.sqrt();
        let t = (f32x8::splat(self.h) - r).max(f32x8::ZERO);
        let t2 = t * t;
        let w = f32x8::splat(self.spiky) * t2 * t;
        let g = f32x8::splat(self.spiky_grad) * t2 / r;
        (w, r.simd_gt(f32x8::ZERO).select(g, f32x8::ZERO))
    }

    /// `W_poly6` for eight squared distances `r2` (m²) at once.
    #[inline(always)]
    pub(crate) fn poly6_x8(&self, r2: f32x8) -> f32x8 {
        let d = (f32x8::splat(self.h2) - r2).max(f32x8::ZERO);
        f32x8::splat(self.poly6) * d * d * d
    }

    /// `W_spiky = 15 / (π h⁶) (h − r)³` at distance `r` (m), 1/m³; 0 from
    /// `h` out.
    pub(crate) fn spiky(&self, r: f32) -> f32 {
        if r >= self.h || r < 0.0 {
            return 0.0;
        }
        let d = self.h - r;
        self.spiky * d * d * d
    }

    /// `dW_spiky/dr / r = −45 / (π h⁶) (h − r)² / r`, 1/m⁵: the gradient of
    /// spiky at offset `d` (from the neighbour to the particle) is this
    /// times `d`. 0 at `r = 0` (no direction) and from `h` out.
    #[inline(always)]
    pub(crate) fn spiky_grad_over_r(&self, r: f32) -> f32 {
        if r >= self.h || r <= 0.0 {
            return 0.0;
        }
        let d = self.h - r;
        self.spiky_grad * d * d / r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `∫ f(r) 4π r² dr` over `[0, h]` by the midpoint rule.
    fn radial_integral(h: f32, f: impl Fn(f32) -> f32) -> f64 {
        let n = 20_000;
        let dr = f64::from(h) / f64::from(n);
        (0..n)
            .map(|k| {
                let r = (f64::from(k) + 0.5) * dr;
                f64::from(f(r as f32)) * 4.0 * PI * r * r * dr
            })
            .sum()
    }

    #[test]
    fn kernels_integrate_to_one() {
        for h in [0.05f32, 0.2, 1.0, 3.0] {
            let k = Kernels::new(h);
            let poly6 = radial_integral(h, |r| k.poly6(r * r));
            let spiky = radial_integral(h, |r| k.spiky(r));
            assert!((poly6 - 1.0).abs() < 1e-4, "poly6 at h = {h}: {poly6}");
            assert!((spiky - 1.0).abs() < 1e-4, "spiky at h = {h}: {spiky}");
            assert_eq!(k.poly6(h * h), 0.0);
            assert_eq!(k.spiky_grad_over_r(h), 0.0);
            assert_eq!(k.spiky_grad_over_r(0.0), 0.0);
            let rs = [
                0.0,
                0.3 * h,
                0.9 * h,
                h,
                2.0 * h,
                0.5 * h,
                0.1 * h,
                0.99 * h,
            ];
            let (w8, g8) = k.spiky_pair_x8(f32x8::from(rs), f32x8::ZERO, f32x8::ZERO);
            let p8 = k.poly6_x8(f32x8::from(rs.map(|r| r * r)));
            for (l, r) in rs.into_iter().enumerate() {
                let (w, g) = k.spiky_pair(r * r);
                assert!((w - k.spiky(r)).abs() <= 1e-6 * w.abs());
                assert!((g - k.spiky_grad_over_r(r)).abs() <= 1e-5 * g.abs());
                assert!((w8.as_array()[l] - w).abs() <= 1e-6 * w.abs());
                assert!((g8.as_array()[l] - g).abs() <= 1e-5 * g.abs());
                assert!((p8.as_array()[l] - k.poly6(r * r)).abs() <= 1e-5 * k.poly6(r * r));
            }
        }
        let sum = Kernels::new(0.2).lattice_sum(0.1);
        // Spiky's peak at the particle itself weighs heavily on a lattice
        // two spacings wide.
        assert!((sum - 1.236).abs() < 1e-3, "{sum}");
    }

    #[test]
    fn spiky_gradient_is_the_derivative_of_spiky() {
        let k = Kernels::new(0.2);
        for r in [0.01f32, 0.05, 0.1, 0.15, 0.19] {
            let e = 1e-3;
            let numeric = (k.spiky(r + e) - k.spiky(r - e)) / (2.0 * e);
            let analytic = k.spiky_grad_over_r(r) * r;
            assert!(
                (numeric - analytic).abs() <= 1e-2 * analytic.abs(),
                "at r = {r}: {numeric} vs {analytic}"
            );
        }
    }
}
