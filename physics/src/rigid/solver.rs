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

    #[inline]
    fn apply(&mut self, r: DVec3, impulse: DVec3) {
        self.v += impulse * self.inv_mass;
        self.w += self.inv_inertia * r.cross(impulse);
    }
}

/// One contact point inside a [`ContactConstraint`].
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PointConstraint {
    /// Anchors from each centre of mass at the start of the step, world, m.
    pub(crate) ra: DVec3,
    pub(crate) rb: DVec3,
    /// `separation - n · (rb - ra)` at the start: adding `n · (current
    /// anchor offset)` gives the current separation.
    pub(crate) base_separation: f64,
    pub(crate) normal_mass: f64,
    pub(crate) tangent_mass: [f64; 2],
    /// Accumulated impulses, N·s (kept across steps for warm starting).
    pub(crate) normal_impulse: f64,
    pub(crate) tangent_impulse: [f64; 2],
    /// Normal relative velocity before solving, m/s (for restitution).
    pub(crate) relative_velocity: f64,
    /// Largest normal impulse seen this step (a point that never pushed gets
    /// no restitution).
    pub(crate) max_normal_impulse: f64,
    /// Whether the point was sticking at the start of the step.
    pub(crate) sticking: bool,
    /// Feature id from the narrow phase.
    pub(crate) id: u32,
    /// The point on A in A's body frame, m (for warm-start matching).
    pub(crate) anchor_a: DVec3,
}

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
    pub(crate) points: Vec<PointConstraint>,
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

impl ContactConstraint {
    /// Effective masses and the pre-solve velocities, from the bodies at the
    /// start of the step.
    pub(crate) fn prepare(&mut self, bodies: &[SolverBody], stick_speed: f64) {
        let (a, b) = (&bodies[self.a], &bodies[self.b]);
        let n = self.normal;
        for p in &mut self.points {
            let k = |dir: DVec3| {
                let (ca, cb) = (p.ra.cross(dir), p.rb.cross(dir));
                a.inv_mass + b.inv_mass + ca.dot(a.inv_inertia * ca) + cb.dot(b.inv_inertia * cb)
            };
            let inv = |k: f64| if k > 0.0 { 1.0 / k } else { 0.0 };
            p.normal_mass = inv(k(n));
            p.tangent_mass = [inv(k(self.tangents[0])), inv(k(self.tangents[1]))];
            let dv = b.v + b.w.cross(p.rb) - a.v - a.w.cross(p.ra);
            p.relative_velocity = n.dot(dv);
            p.sticking = (dv - n * p.relative_velocity).length() < stick_speed;
            p.max_normal_impulse = 0.0;
        }
    }

    /// Re-applies the accumulated impulses (warm start).
    pub(crate) fn warm_start(&self, bodies: &mut [SolverBody]) {
        let (a, b) = pair(bodies, self.a, self.b);
        for p in &self.points {
            let impulse = self.normal * p.normal_impulse
                + self.tangents[0] * p.tangent_impulse[0]
                + self.tangents[1] * p.tangent_impulse[1];
            a.apply(p.ra, -impulse);
            b.apply(p.rb, impulse);
        }
    }

    /// One pass over the points: friction (limited by the normal impulses
    /// so far), then non-penetration (soft when `use_bias`), so the
    /// constraint that matters most is solved last.
    pub(crate) fn solve(
        &mut self,
        bodies: &mut [SolverBody],
        cfg: &SolverConfig,
        h: f64,
        use_bias: bool,
    ) {
        let (a, b) = pair(bodies, self.a, self.b);
        let n = self.normal;
        let hertz = cfg.contact_hertz.min(0.25 / h);
        let (bias_rate, mass_scale, impulse_scale) = softness(hertz, cfg.contact_damping_ratio, h);
        for p in &mut self.points {
            let mu = if p.sticking {
                self.friction_static
            } else {
                self.friction_dynamic
            };
            let limit = mu * p.normal_impulse;
            for (k, t) in self.tangents.iter().enumerate() {
                let dv = b.v + b.w.cross(p.rb) - a.v - a.w.cross(p.ra);
                let impulse = -p.tangent_mass[k] * t.dot(dv);
                let total = (p.tangent_impulse[k] + impulse).clamp(-limit, limit);
                let applied = total - p.tangent_impulse[k];
                p.tangent_impulse[k] = total;
                a.apply(p.ra, -*t * applied);
                b.apply(p.rb, *t * applied);
            }
        }
        for p in &mut self.points {
            // Current separation from how far the anchors have moved.
            let d = (b.dp + b.dq * p.rb) - (a.dp + a.dq * p.ra);
            let s = n.dot(d) + p.base_separation;
            let (bias, ms, is) = if s > 0.0 {
                (s / h, 1.0, 0.0) // speculative: just do not close the gap
            } else if use_bias {
                (
                    (bias_rate * s).max(-cfg.push_out),
                    mass_scale,
                    impulse_scale,
                )
            } else {
                (0.0, 1.0, 0.0)
            };
            let dv = b.v + b.w.cross(p.rb) - a.v - a.w.cross(p.ra);
            let vn = n.dot(dv);
            let impulse = -p.normal_mass * ms * (vn + bias) - is * p.normal_impulse;
            let total = (p.normal_impulse + impulse).max(0.0);
            let applied = total - p.normal_impulse;
            p.normal_impulse = total;
            p.max_normal_impulse = p.max_normal_impulse.max(applied);
            a.apply(p.ra, -n * applied);
            b.apply(p.rb, n * applied);
        }
    }

    /// Restitution: points that were approaching faster than the threshold
    /// and pushed leave at `e` times their approach speed.
    pub(crate) fn restitute(&mut self, bodies: &mut [SolverBody], threshold: f64) {
        if self.restitution == 0.0 {
            return;
        }
        let (a, b) = pair(bodies, self.a, self.b);
        let n = self.normal;
        for p in &mut self.points {
            if p.relative_velocity > -threshold || p.max_normal_impulse == 0.0 {
                continue;
            }
            let vn = n.dot(b.v + b.w.cross(p.rb) - a.v - a.w.cross(p.ra));
            let impulse = -p.normal_mass * (vn + self.restitution * p.relative_velocity);
            let total = (p.normal_impulse + impulse).max(0.0);
            let applied = total - p.normal_impulse;
            p.normal_impulse = total;
            a.apply(p.ra, -n * applied);
            b.apply(p.rb, n * applied);
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
        let mut c = ContactConstraint {
            a: 0,
            b: 1,
            normal: DVec3::Y,
            tangents: tangent_basis(DVec3::Y),
            friction_static: 0.6,
            friction_dynamic: 0.5,
            restitution: 0.0,
            points: vec![PointConstraint {
                rb: DVec3::new(0.0, -0.5, 0.0),
                base_separation: 0.5,
                ..Default::default()
            }],
        };
        // base: separation 0 with rb pointing down half a metre: s = n·(dp + rb) + base = -0.5 + 0.5 = 0.
        let mut y = 0.0;
        for _ in 0..120 {
            c.prepare(&bodies, cfg.stick_speed);
            c.points[0].normal_impulse = c.points[0].normal_impulse.max(0.0);
            for _ in 0..cfg.substeps {
                bodies[1].v.y -= 9.81 * h;
                c.warm_start(&mut bodies);
                c.solve(&mut bodies, &cfg, h, true);
                let v = bodies[1].v;
                bodies[1].dp += v * h;
                c.solve(&mut bodies, &cfg, h, false);
            }
            y += bodies[1].dp.y;
            // Start the next step from the moved body.
            c.points[0].base_separation += bodies[1].dp.y;
            bodies[1].dp = DVec3::ZERO;
        }
        assert!(y.abs() < 1e-3, "sank {y}");
        assert!(bodies[1].v.length() < 1e-6);
        let per_substep = c.points[0].normal_impulse;
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
