//! How closely a GPU (f32) run follows the CPU (f64) run of the same scene.

/// A bound on the difference between a GPU and a CPU run.
///
/// After `steps` steps of a scene whose compared quantity (a position
/// coordinate in m, or a velocity component in m/s) has magnitude up to
/// `scale`, every GPU value lies within
/// [`bound(steps, scale)`](GpuTolerance::bound)
/// `= absolute + relative_per_step · steps · scale` of the CPU value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpuTolerance {
    /// Floor, in the unit of the compared quantity.
    pub absolute: f64,
    /// Growth per step, relative to the quantity's scale.
    pub relative_per_step: f64,
}

impl GpuTolerance {
    /// The largest allowed |GPU − CPU| after `steps` steps for values of
    /// magnitude up to `scale`.
    pub fn bound(&self, steps: u32, scale: f64) -> f64 {
        self.absolute + self.relative_per_step * f64::from(steps) * scale
    }
}

/// The stated agreement of the GPU path with the CPU path, asserted by
/// `physics/tests/gpu_agreement.rs` for free fall with drag and wind (both
/// Euler methods), a spring cloth (also one softened by the substep plan),
/// an exact N-body cluster, and buoyancy with an explosion and control
/// forces.
///
/// `relative_per_step = 4 ε_f32` (ε = 2⁻²³ ≈ 1.19·10⁻⁷, so ≈ 4.8·10⁻⁷):
/// f32 keeps 24 bits, the upload rounds the state once and every step
/// rounds it again, so the difference from the f64 run grows about linearly
/// with the step count, by a fraction of an ulp of the magnitude per step
/// when forces are well conditioned. Interaction forces lose more: a
/// spring's stretch `|d| − L0` and a pair separation are differences of
/// nearby f32 values, and stiff springs feed that back every substep.
/// Measured worst case (cloth velocities): 0.54 ε per step of the scale on
/// Vulkan lavapipe, 0.85 ε on GL llvmpipe; the other scenes 0.02–0.15 ε.
/// The bound leaves a margin of about 5 for other drivers' rounding (fused
/// multiply-adds, `sqrt` accuracy). `absolute = 1e-6` covers values that
/// end near zero.
///
/// The bound holds for well-conditioned scenes over hundreds of steps.
/// Chaotic ones (close N-body encounters, buckling) amplify any difference
/// exponentially, in *any* two precisions, and cannot be bounded this way.
pub const GPU_TOLERANCE: GpuTolerance = GpuTolerance {
    absolute: 1e-6,
    relative_per_step: 4.0 * f32::EPSILON as f64,
};
