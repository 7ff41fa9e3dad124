//! The contact solver: soft constraints with substepping ("Soft Step").
//!
//! # Design
//!
//! A world step of `dt` is cut into `n` substeps of `h = dt / n`. In each:
//! velocities are integrated (gravity, forces), the contact impulses of the
//! previous substep are re-applied (warm start), contacts are solved *with*
//! a soft position bias, positions are integrated, and contacts are solved
//! again *without* the bias (relax) so the push-out does not leave energy
//! behind. Restitution is applied once at the end, then impulses are kept
//! for the next step's warm start.
//!
//! Contacts are **soft constraints** (a spring-damper in the constraint
//! space, as in Catto's "Solver2D" / Box2D v3 and Tonge's TGS-soft): the
//! position error is corrected at a stiffness given in hertz and a damping
//! ratio, with the correction velocity capped (`push_out`), so deep overlaps
//! separate gradually instead of exploding, and the substepping gives the
//! stiffness of many iterations at the cost of few. The separation of each
//! point is re-evaluated every substep from how far the bodies have moved
//! since the manifold was made, so collision detection runs once per step.
//!
//! Points that are still apart (positive separation, speculative contacts)
//! only remove the velocity that would close the gap within the substep,
//! which is what stops fast bodies without continuous collision in most
//! cases.
//!
//! A soft contact gives way in proportion to its load over its effective
//! mass, and one pass passes on about the lighter body's mass worth of
//! momentum, so a heavy body on a light one sank through it (and the
//! light one through the ground). Those contacts, and every contact under
//! them down to the ground, are solved once more each substep, lowest
//! first, with the lower body held still (`ContactConstraint::solve_held`,
//! ordered by `pipeline/shock.rs`), and their resting points measure their
//! soft give from the load they carried at the start of the step, not
//! from zero (`NormalRows::carried`).
//!
//! Friction is Coulomb: each point has two tangent impulses clamped to
//! `μ · normal impulse`, with the static coefficient while the point sticks
//! and the dynamic one once it slides.
//!
//! The constraints are prepared here in `f64`, one at a time; the step's
//! passes run four constraints of a colour at a time in `f32`
//! (`wide.rs`), on the bodies' hot state (`hot.rs`). The scalar passes below
//! are the reference they are tested against, and what the shock pass
//! runs.

use glam::{DMat3, DQuat, DVec3};

mod block;
pub(crate) mod colouring;
mod contact;
mod hot;
pub(crate) mod lanes;
#[cfg(test)]
mod tests;
mod wide;

pub(crate) use block::BlockMatrix;
pub(crate) use contact::{ContactConstraint, ContactSource};
pub(crate) use wide::{WideContacts, WidePass};

/// Tuning of the contact solver. Defaults follow Box2D v3's, which are
/// chosen for 60 Hz worlds with 4 substeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverConfig {
    /// Substeps per world step (also the solver's effective iterations).
    pub substeps: u32,
    /// Stiffness of the contact position correction, Hz (capped at a quarter
    /// of the substep rate so it stays stable).
    pub contact_hertz: f64,
    /// Damping ratio of the position correction (10 = heavily overdamped:
    /// no bounce from the correction itself).
    pub contact_damping_ratio: f64,
    /// Fastest a position correction may push bodies apart, m/s.
    pub push_out: f64,
    /// Relative normal speed below which restitution is ignored, m/s (so
    /// resting bodies do not jitter).
    pub restitution_threshold: f64,
    /// Tangential speed below which a contact counts as sticking (static
    /// friction applies), m/s.
    pub stick_speed: f64,
    /// When resting islands fall asleep.
    pub sleep: crate::rigid::island::SleepConfig,
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            substeps: 4,
            contact_hertz: 30.0,
            contact_damping_ratio: 10.0,
            push_out: 3.0,
            restitution_threshold: 1.0,
            stick_speed: 0.01,
            sleep: crate::rigid::island::SleepConfig::default(),
        }
    }
}

/// A body as the solver sees it: velocities, inverse mass properties frozen
/// for the step, and how far it has moved since the step began.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SolverBody {
    pub(crate) v: DVec3,
    pub(crate) w: DVec3,
    pub(crate) inv_mass: f64,
    /// World inverse inertia at the start of the step, 1/(kg·m²).
    pub(crate) inv_inertia: DMat3,
    /// Translation since the start of the step, m.
    pub(crate) dp: DVec3,
    /// Rotation since the start of the step.
    pub(crate) dq: DQuat,
}

impl SolverBody {
    /// A body that never moves.
    #[cfg(test)]
    pub(crate) fn fixed() -> Self {
        Self {
            v: DVec3::ZERO,
            w: DVec3::ZERO,
            inv_mass: 0.0,
            inv_inertia: DMat3::ZERO,
            dp: DVec3::ZERO,
            dq: DQuat::IDENTITY,
        }
    }
}

/// One row of a contact point (its normal or one friction direction):
/// what a unit impulse along the row does to the angular velocities, the
/// effective mass and the impulse accumulated so far.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Row {
    /// `I_a⁻¹ (ra × d)` and `I_b⁻¹ (rb × d)` for the row's direction `d`:
    /// the change of angular velocity per unit impulse, 1/(kg·m).
    pub(crate) ang_a: DVec3,
    pub(crate) ang_b: DVec3,
    /// Effective mass along the row, kg.
    pub(crate) mass: f64,
    /// Accumulated impulse, N·s (kept across steps for warm starting).
    pub(crate) impulse: f64,
}

impl Row {
    /// The row along `d` for anchors `ra`, `rb`, keeping its impulse.
    #[inline]
    fn prepare(&mut self, a: &SolverBody, b: &SolverBody, ra: DVec3, rb: DVec3, d: DVec3) {
        let (ca, cb) = (ra.cross(d), rb.cross(d));
        self.ang_a = a.inv_inertia * ca;
        self.ang_b = b.inv_inertia * cb;
        let k = a.inv_mass + b.inv_mass + ca.dot(self.ang_a) + cb.dot(self.ang_b);
        self.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
    }

    /// A purely angular row about `d` (twist), keeping its impulse.
    #[inline]
    fn prepare_angular(&mut self, a: &SolverBody, b: &SolverBody, d: DVec3) {
        self.ang_a = a.inv_inertia * d;
        self.ang_b = b.inv_inertia * d;
        let k = d.dot(self.ang_a) + d.dot(self.ang_b);
        self.mass = if k > 0.0 { 1.0 / k } else { 0.0 };
    }

    /// Applies `lambda` (N·s) along `d`: `+` on B, `-` on A.
    #[inline]
    fn apply(&self, a: &mut SolverBody, b: &mut SolverBody, d: DVec3, lambda: f64) {
        a.v -= d * (lambda * a.inv_mass);
        a.w -= self.ang_a * lambda;
        b.v += d * (lambda * b.inv_mass);
        b.w += self.ang_b * lambda;
    }
}

/// One contact point as the narrow phase hands it over: anchors and
/// warm-start impulses. The solver keeps its working data by lanes (see
/// [`NormalRows`]); what the contact cache keeps of the point is kept
/// apart from it (`CachedPoint`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PointConstraint {
    /// Anchors from each centre of mass at the start of the step, world, m.
    pub(crate) ra: DVec3,
    pub(crate) rb: DVec3,
    /// Warm-start normal impulse, N·s.
    pub(crate) normal_impulse: f64,
    /// This point's share of the manifold's friction impulse when it was
    /// cached, along the two tangents, N·s (see
    /// [`ContactConstraint::point_tangent_impulses`]).
    pub(crate) cached_tangent: [f64; 2],
    /// `separation - n · (rb - ra)` at the start: adding `n · (current
    /// anchor offset)` gives the current separation.
    pub(crate) base_separation: f64,
}

impl PointConstraint {
    /// A point with anchors `ra`, `rb` and warm-start impulses (normal,
    /// the two tangents), N·s.
    pub(crate) fn new(ra: DVec3, rb: DVec3, normal: f64, tangent: [f64; 2]) -> Self {
        Self {
            ra,
            rb,
            normal_impulse: normal,
            cached_tangent: tangent,
            ..Default::default()
        }
    }
}

/// Most points one manifold's constraint holds.
pub(crate) const MAX_POINTS: usize = crate::rigid::contact::MAX_POINTS;

/// One number per point of a manifold (lanes past the point count are 0).
pub(crate) type Lanes = [f64; MAX_POINTS];

/// One vector per point of a manifold, stored by component, so the work of
/// the four points is four-wide arithmetic (one AVX register of `f64`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct LaneVec {
    x: Lanes,
    y: Lanes,
    z: Lanes,
}

impl LaneVec {
    #[inline]
    fn set(&mut self, i: usize, v: DVec3) {
        (self.x[i], self.y[i], self.z[i]) = (v.x, v.y, v.z);
    }

    #[inline]
    fn get(&self, i: usize) -> DVec3 {
        DVec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// `v · self_i` in every lane.
    #[inline]
    fn dot(&self, v: DVec3) -> Lanes {
        std::array::from_fn(|i| self.x[i] * v.x + self.y[i] * v.y + self.z[i] * v.z)
    }

    /// `Σ_i w_i self_i`.
    #[inline]
    fn weighted_sum(&self, w: &Lanes) -> DVec3 {
        let dot = |c: &Lanes| c.iter().zip(w).map(|(c, w)| c * w).sum::<f64>();
        DVec3::new(dot(&self.x), dot(&self.y), dot(&self.z))
    }
}

/// Two unit vectors that make `(n, t1, t2)` an orthonormal basis; a fixed
/// function of `n`, so friction directions never depend on history.
pub(crate) fn tangent_basis(n: DVec3) -> [DVec3; 2] {
    let t1 = if n.x.abs() < 0.57735 {
        DVec3::new(0.0, n.z, -n.y)
    } else {
        DVec3::new(n.y, -n.x, 0.0)
    }
    .normalize();
    [t1, n.cross(t1)]
}

/// Softness coefficients of a constraint: `(bias_rate, mass_scale, impulse_scale)`.
pub(crate) fn softness(hertz: f64, zeta: f64, h: f64) -> (f64, f64, f64) {
    if hertz <= 0.0 {
        return (0.0, 1.0, 0.0);
    }
    let omega = 2.0 * std::f64::consts::PI * hertz;
    let a1 = 2.0 * zeta + h * omega;
    let a2 = h * omega * a1;
    let a3 = 1.0 / (1.0 + a2);
    (omega / a1, a2 * a3, a3)
}

/// What one solver pass over the contacts needs besides the bodies: the
/// substep and the contact softness at that substep.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ContactPass {
    /// The substep, s.
    pub(crate) h: f64,
    /// Whether to correct penetration (the solve) or not (the relax).
    pub(crate) use_bias: bool,
    /// From [`softness`] at the contact stiffness, capped at a quarter of
    /// the substep rate.
    pub(crate) bias_rate: f64,
    pub(crate) mass_scale: f64,
    pub(crate) impulse_scale: f64,
    /// Fastest push-out, m/s.
    pub(crate) push_out: f64,
}

impl ContactPass {
    /// The pass for substep `h` under `cfg`.
    pub(crate) fn new(cfg: &SolverConfig, h: f64, use_bias: bool) -> Self {
        let hertz = cfg.contact_hertz.min(0.25 / h);
        let (bias_rate, mass_scale, impulse_scale) = softness(hertz, cfg.contact_damping_ratio, h);
        Self {
            h,
            use_bias,
            bias_rate,
            mass_scale,
            impulse_scale,
            push_out: cfg.push_out,
        }
    }
}

/// Mutable references to two different bodies.
pub(crate) fn pair(
    bodies: &mut [SolverBody],
    a: usize,
    b: usize,
) -> (&mut SolverBody, &mut SolverBody) {
    debug_assert_ne!(a, b);
    if a < b {
        let (lo, hi) = bodies.split_at_mut(b);
        (&mut lo[a], &mut hi[0])
    } else {
        let (lo, hi) = bodies.split_at_mut(a);
        (&mut hi[0], &mut lo[b])
    }
}
