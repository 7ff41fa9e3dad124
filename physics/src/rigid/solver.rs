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
//! Friction is Coulomb: each point has two tangent impulses clamped to
//! `μ · normal impulse`, with the static coefficient while the point sticks
//! and the dynamic one once it slides.

use glam::{DMat3, DQuat, DVec3};

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

    /// Applies `lambda` (N·s) along `d`: `+` on B, `-` on A.
    #[inline]
    fn apply(&self, a: &mut SolverBody, b: &mut SolverBody, d: DVec3, lambda: f64) {
        a.v -= d * (lambda * a.inv_mass);
        a.w -= self.ang_a * lambda;
        b.v += d * (lambda * b.inv_mass);
        b.w += self.ang_b * lambda;
    }
}

/// One contact point inside a [`ContactConstraint`].
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PointConstraint {
    /// Anchors from each centre of mass at the start of the step, world, m.
    pub(crate) ra: DVec3,
    pub(crate) rb: DVec3,
    /// The non-penetration row.
    pub(crate) normal: Row,
    /// The two friction rows.
    pub(crate) tangent: [Row; 2],
    /// `separation - n · (rb - ra)` at the start: adding `n · (current
    /// anchor offset)` gives the current separation.
    pub(crate) base_separation: f64,
    /// Normal relative velocity before solving, m/s (for restitution).
    pub(crate) relative_velocity: f64,
    /// Largest normal impulse seen this step (a point that never pushed gets
    /// no restitution).
    pub(crate) max_normal_impulse: f64,
    /// Normal impulse over the whole step (all substeps and restitution),
    /// N·s: divided by the step, the average contact force.
    pub(crate) total_normal_impulse: f64,
    /// Whether the point was sticking at the start of the step.
    pub(crate) sticking: bool,
    /// Feature id from the narrow phase.
    pub(crate) id: u32,
    /// The point on A in A's body frame, m (for warm-start matching).
    pub(crate) anchor_a: DVec3,
}

impl PointConstraint {
    /// A point with anchors `ra`, `rb` and warm-start impulses (normal,
    /// the two tangents), N·s.
    pub(crate) fn new(ra: DVec3, rb: DVec3, normal: f64, tangent: [f64; 2]) -> Self {
        let mut p = Self {
            ra,
            rb,
            ..Default::default()
        };
        p.normal.impulse = normal;
        p.tangent[0].impulse = tangent[0];
        p.tangent[1].impulse = tangent[1];
        p
    }

    /// Accumulated normal impulse, N·s.
    pub(crate) fn normal_impulse(&self) -> f64 {
        self.normal.impulse
    }

    /// Accumulated friction impulses, N·s.
    pub(crate) fn tangent_impulse(&self) -> [f64; 2] {
        [self.tangent[0].impulse, self.tangent[1].impulse]
    }
}

/// Most points one manifold's constraint holds.
pub(crate) const MAX_POINTS: usize = crate::rigid::contact::MAX_POINTS;

/// The constraint of one manifold between bodies `a` and `b`.
#[derive(Debug, Clone)]
pub(crate) struct ContactConstraint {
    pub(crate) a: usize,
    pub(crate) b: usize,
    /// World normal from A to B.
    pub(crate) normal: DVec3,
    pub(crate) tangents: [DVec3; 2],
    pub(crate) friction_static: f64,
    pub(crate) friction_dynamic: f64,
    pub(crate) restitution: f64,
    /// The points; only the first `len` are used.
    pub(crate) points: [PointConstraint; MAX_POINTS],
    pub(crate) len: usize,
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
#[inline]
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

/// Relative velocity of B's anchor against A's, m/s.
#[inline]
fn relative_velocity(a: &SolverBody, b: &SolverBody, ra: DVec3, rb: DVec3) -> DVec3 {
    b.v + b.w.cross(rb) - a.v - a.w.cross(ra)
}

impl ContactConstraint {
    /// The used points.
    pub(crate) fn points(&self) -> &[PointConstraint] {
        &self.points[..self.len]
    }

    /// Effective masses, the angular rows and the pre-solve velocities,
    /// from the bodies at the start of the step.
    pub(crate) fn prepare(&mut self, a: &SolverBody, b: &SolverBody, stick_speed: f64) {
        let n = self.normal;
        let [t1, t2] = self.tangents;
        for p in &mut self.points[..self.len] {
            let (ra, rb) = (p.ra, p.rb);
            p.normal.prepare(a, b, ra, rb, n);
            p.tangent[0].prepare(a, b, ra, rb, t1);
            p.tangent[1].prepare(a, b, ra, rb, t2);
            let dv = relative_velocity(a, b, ra, rb);
            p.relative_velocity = n.dot(dv);
            p.sticking = (dv - n * p.relative_velocity).length() < stick_speed;
            p.max_normal_impulse = 0.0;
            p.total_normal_impulse = 0.0;
        }
    }

    /// Re-applies the accumulated impulses (warm start).
    pub(crate) fn warm_start(&self, a: &mut SolverBody, b: &mut SolverBody) {
        let [t1, t2] = self.tangents;
        for p in self.points() {
            let (ln, l1, l2) = (p.normal.impulse, p.tangent[0].impulse, p.tangent[1].impulse);
            let j = self.normal * ln + t1 * l1 + t2 * l2;
            a.v -= j * a.inv_mass;
            a.w -= p.normal.ang_a * ln + p.tangent[0].ang_a * l1 + p.tangent[1].ang_a * l2;
            b.v += j * b.inv_mass;
            b.w += p.normal.ang_b * ln + p.tangent[0].ang_b * l1 + p.tangent[1].ang_b * l2;
        }
    }

    /// One pass over the points: friction (limited by the normal impulses
    /// so far), then non-penetration (soft when `pass.use_bias`), so the
    /// constraint that matters most is solved last.
    pub(crate) fn solve(&mut self, a: &mut SolverBody, b: &mut SolverBody, pass: &ContactPass) {
        let n = self.normal;
        let tangents = self.tangents;
        let (mu_static, mu_dynamic) = (self.friction_static, self.friction_dynamic);
        for p in &mut self.points[..self.len] {
            let mu = if p.sticking { mu_static } else { mu_dynamic };
            let limit = mu * p.normal.impulse;
            for (row, t) in p.tangent.iter_mut().zip(tangents) {
                let vt = t.dot(relative_velocity(a, b, p.ra, p.rb));
                let total = (row.impulse - row.mass * vt).clamp(-limit, limit);
                let applied = total - row.impulse;
                row.impulse = total;
                row.apply(a, b, t, applied);
            }
        }
        let (h, use_bias) = (pass.h, pass.use_bias);
        let a_moved = a.dq != DQuat::IDENTITY;
        let b_moved = b.dq != DQuat::IDENTITY;
        for p in &mut self.points[..self.len] {
            // Current separation from how far the anchors have moved.
            let ra_now = if a_moved { a.dq * p.ra } else { p.ra };
            let rb_now = if b_moved { b.dq * p.rb } else { p.rb };
            let s = n.dot((b.dp + rb_now) - (a.dp + ra_now)) + p.base_separation;
            let (bias, ms, is) = if s > 0.0 {
                (s / h, 1.0, 0.0) // speculative: just do not close the gap
            } else if use_bias {
                (
                    (pass.bias_rate * s).max(-pass.push_out),
                    pass.mass_scale,
                    pass.impulse_scale,
                )
            } else {
                (0.0, 1.0, 0.0)
            };
            let vn = n.dot(relative_velocity(a, b, p.ra, p.rb));
            let row = &mut p.normal;
            let impulse = -row.mass * ms * (vn + bias) - is * row.impulse;
            let total = (row.impulse + impulse).max(0.0);
            let applied = total - row.impulse;
            row.impulse = total;
            p.max_normal_impulse = p.max_normal_impulse.max(applied);
            if !use_bias {
                // The relax ends the substep: this is its impulse.
                p.total_normal_impulse += total;
            }
            row.apply(a, b, n, applied);
        }
    }

    /// Restitution: points that were approaching faster than the threshold
    /// and pushed leave at `e` times their approach speed.
    pub(crate) fn restitute(&mut self, a: &mut SolverBody, b: &mut SolverBody, threshold: f64) {
        if self.restitution == 0.0 {
            return;
        }
        let (n, e) = (self.normal, self.restitution);
        for p in &mut self.points[..self.len] {
            if p.relative_velocity > -threshold || p.max_normal_impulse == 0.0 {
                continue;
            }
            let vn = n.dot(relative_velocity(a, b, p.ra, p.rb));
            let row = &mut p.normal;
            let total = (row.impulse - row.mass * (vn + e * p.relative_velocity)).max(0.0);
            let applied = total - row.impulse;
            row.impulse = total;
            p.total_normal_impulse += applied;
            row.apply(a, b, n, applied);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit-mass cube-like body resting on a fixed ground through one
    /// point under gravity: the solver holds it and the normal impulse per
    /// step equals m g dt.
    #[test]
    fn a_resting_point_carries_the_weight() {
        let cfg = SolverConfig::default();
        let dt = 1.0 / 60.0;
        let h = dt / f64::from(cfg.substeps);
        let mut bodies = vec![
            SolverBody::fixed(),
            SolverBody {
                inv_mass: 1.0,
                inv_inertia: DMat3::IDENTITY * 6.0,
                ..SolverBody::fixed()
            },
        ];
        let mut points = [PointConstraint::default(); MAX_POINTS];
        points[0] = PointConstraint {
            base_separation: 0.5,
            ..PointConstraint::new(DVec3::ZERO, DVec3::new(0.0, -0.5, 0.0), 0.0, [0.0; 2])
        };
        let mut c = ContactConstraint {
            a: 0,
            b: 1,
            normal: DVec3::Y,
            tangents: tangent_basis(DVec3::Y),
            friction_static: 0.6,
            friction_dynamic: 0.5,
            restitution: 0.0,
            points,
            len: 1,
        };
        let (solve, relax) = (
            ContactPass::new(&cfg, h, true),
            ContactPass::new(&cfg, h, false),
        );
        // base: separation 0 with rb pointing down half a metre: s = n·(dp + rb) + base = -0.5 + 0.5 = 0.
        let mut y = 0.0;
        for _ in 0..120 {
            c.prepare(&bodies[0], &bodies[1], cfg.stick_speed);
            c.points[0].normal.impulse = c.points[0].normal.impulse.max(0.0);
            for _ in 0..cfg.substeps {
                bodies[1].v.y -= 9.81 * h;
                let (a, b) = pair(&mut bodies, 0, 1);
                c.warm_start(a, b);
                c.solve(a, b, &solve);
                let v = bodies[1].v;
                bodies[1].dp += v * h;
                let (a, b) = pair(&mut bodies, 0, 1);
                c.solve(a, b, &relax);
            }
            y += bodies[1].dp.y;
            // Start the next step from the moved body.
            c.points[0].base_separation += bodies[1].dp.y;
            bodies[1].dp = DVec3::ZERO;
        }
        assert!(y.abs() < 1e-3, "sank {y}");
        assert!(bodies[1].v.length() < 1e-6);
        let per_substep = c.points[0].normal.impulse;
        assert!((per_substep - 9.81 * h).abs() < 1e-9, "{per_substep}");
    }

    #[test]
    fn tangent_basis_is_orthonormal() {
        for n in [
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(1.0, 2.0, -3.0).normalize(),
            DVec3::new(-0.9, 0.1, 0.1).normalize(),
        ] {
            let [t1, t2] = tangent_basis(n);
            assert!((t1.length() - 1.0).abs() < 1e-12 && (t2.length() - 1.0).abs() < 1e-12);
            assert!(t1.dot(n).abs() < 1e-12 && t2.dot(n).abs() < 1e-12 && t1.dot(t2).abs() < 1e-12);
        }
    }
}
