//! One manifold's contact constraint: its points' normal and friction rows,
//! prepared in `f64` and solved one constraint at a time (the reference the
//! four-wide passes of `wide.rs` are tested against, and what the shock
//! pass runs).

use glam::{DMat3, DQuat, DVec3};

use super::block::{cholesky, cholesky_solve, BlockMatrix};
use super::*;

/// Normal speed (m/s) below which a point counts as resting when it
/// carries a heavier body's load.
const RESTING_SPEED: f64 = 0.1;

/// The non-penetration rows of a manifold's points, by lanes.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct NormalRows {
    /// Anchors from each centre of mass, m. The normal speed of point `i`
    /// is `n · (v_b - v_a) + rb_i · (n × ω_b) - ra_i · (n × ω_a)`, and an
    /// impulse `λ_i` turns A by `-I_a⁻¹ (ra_i × n) λ_i` and B by `I_b⁻¹
    /// (rb_i × n) λ_i`. (The angular rows `ra × n` and `rb × n` are not
    /// kept: the solve streams every constraint in every pass, and they
    /// made it a fifth larger.)
    pub(crate) ra: LaneVec,
    pub(crate) rb: LaneVec,
    /// Inverse effective mass `K_ii`, 1/kg (0 in unused lanes).
    pub(crate) k: Lanes,
    /// `separation - n · (rb - ra)` at the start of the step, m.
    pub(crate) base: Lanes,
    /// Accumulated impulse, N·s (kept across steps for warm starting).
    pub(crate) impulse: Lanes,
    /// The load each point carries without giving way, N·s: its warm
    /// start for a resting point of a contact that carries a heavier
    /// body's load ([`ContactConstraint::carry_load`]), else 0. A soft
    /// contact rests `load / (m ω²)` deep on its effective mass `m`, and
    /// under a light body carrying a heavy one that depth grows with their
    /// ratio; measured from the load carried, it does not.
    pub(crate) carried: Lanes,
    /// Largest impulse seen this step (a point that never pushed gets no
    /// restitution), N·s.
    pub(crate) max_impulse: Lanes,
    /// Impulse over the whole step (all substeps and restitution), N·s:
    /// divided by the step, the average contact force.
    pub(crate) total_impulse: Lanes,
    /// Normal relative speed at which each point meets, m/s (for
    /// restitution; see [`impact_speed`]).
    pub(crate) approach: Lanes,
}

/// The constraint of one manifold between bodies `a` and `b`.
#[derive(Debug, Clone)]
pub(crate) struct ContactConstraint {
    pub(crate) a: usize,
    pub(crate) b: usize,
    /// World normal from A to B.
    pub(crate) normal: DVec3,
    pub(crate) friction_static: f64,
    pub(crate) friction_dynamic: f64,
    pub(crate) restitution: f64,
    /// How many points (lanes) are used.
    pub(crate) len: usize,
    /// The points' non-penetration rows.
    pub(crate) rows: NormalRows,
    /// Friction acts at the centre of the points ([`Self::centres`]): two
    /// tangent rows ([`Self::tangents`]) and a twist row about the normal,
    /// limited by `μ` times the points' total normal impulse (and, for the
    /// twist, times their mean distance from the centre).
    pub(crate) friction: [Row; 2],
    pub(crate) twist: Row,
    /// Mean distance of the points from their centre, m.
    pub(crate) twist_radius: f64,
    /// Whether the centre was sticking at the start of the step.
    pub(crate) sticking: bool,
    /// How fast the step's forces press B towards A along the normal,
    /// m/s² (0 when they pull apart): gravity on a body above the ground.
    pub(crate) closing_accel: f64,
    /// Cholesky factors of the points' normal block `K + Γ` for the solve
    /// and the relax passes (see [`ContactConstraint::solve_normals_block`]),
    /// or `None` when the block is not used (one point, or not positive
    /// definite).
    pub(crate) block: Option<Box<[BlockMatrix; 2]>>,
}

/// What the constraint of one manifold is built from, as the narrow phase
/// hands it over: the bodies' slots, the normal from A to B, the combined
/// materials (static and dynamic friction, restitution) and the points
/// with their warm-start impulses. Less than half the size of the
/// constraint, which the solver builds where it solves it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ContactSource {
    pub(crate) ends: (usize, usize),
    pub(crate) normal: DVec3,
    pub(crate) materials: (f64, f64, f64),
    pub(crate) points: [PointConstraint; MAX_POINTS],
    /// How many of `points` are used.
    pub(crate) len: usize,
}

/// Relative regularisation of the relax pass's block (which is singular
/// for more than three points: a face contact has three degrees of
/// freedom), as a fraction of each point's own inverse mass.
const RELAX_REGULARISATION: f64 = 1e-6;

/// The normal speed at which a point meets, m/s (negative: closing): a
/// point `gap` m apart at the start of the step, closing at `vn` m/s and
/// pressed together at `closing_accel` m/s², meets at
/// `-√(vn² + 2·closing_accel·gap)`. Restitution answers this speed, not
/// the speed at the start of the step: a ball falling onto the ground from
/// a few centimetres up meets it faster than it started the step, and its
/// bounce came out short by a first-order error in the step (about 10 % of
/// the height at 60 Hz).
fn impact_speed(vn: f64, gap: f64, closing_accel: f64) -> f64 {
    if vn >= 0.0 || gap <= 0.0 {
        return vn;
    }
    -(vn * vn + 2.0 * closing_accel * gap).sqrt()
}

/// Relative velocity of B's anchor against A's, m/s.
#[inline]
fn relative_velocity(a: &SolverBody, b: &SolverBody, ra: DVec3, rb: DVec3) -> DVec3 {
    b.v + b.w.cross(rb) - a.v - a.w.cross(ra)
}

impl ContactConstraint {
    /// The constraint of a manifold as the narrow phase hands it over (not
    /// yet prepared), its friction gathered from the points' cached shares.
    pub(crate) fn new(source: &ContactSource) -> Self {
        let ContactSource {
            ends: (a, b),
            normal,
            materials: (friction_static, friction_dynamic, restitution),
            points,
            len,
        } = *source;
        let len = len.min(MAX_POINTS);
        let mut rows = NormalRows::default();
        for (i, p) in points[..len].iter().enumerate() {
            rows.ra.set(i, p.ra);
            rows.rb.set(i, p.rb);
            rows.base[i] = p.base_separation;
            rows.impulse[i] = p.normal_impulse;
        }
        let mut c = Self {
            a,
            b,
            normal,
            friction_static,
            friction_dynamic,
            restitution,
            len,
            rows,
            friction: [Row::default(); 2],
            twist: Row::default(),
            twist_radius: 0.0,
            sticking: false,
            closing_accel: 0.0,
            block: None,
        };
        c.gather_friction(&points[..len]);
        c
    }

    /// Accumulated normal impulse of point `i`, N·s.
    pub(crate) fn normal_impulse(&self, i: usize) -> f64 {
        self.rows.impulse[i]
    }

    /// Normal impulse of all points over the whole step, N·s.
    pub(crate) fn total_normal_impulse(&self) -> f64 {
        self.rows.total_impulse.iter().sum()
    }

    /// The smallest separation of the points at the start of the step, m.
    pub(crate) fn start_separation(&self) -> f64 {
        (0..self.len)
            .map(|i| self.start_gap(i))
            .fold(f64::INFINITY, f64::min)
    }

    /// Point `i`'s separation at the start of the step, m (what
    /// [`Self::separations`] gives before either body moves, to rounding).
    fn start_gap(&self, i: usize) -> f64 {
        let rows = &self.rows;
        rows.base[i] + self.normal.dot(rows.rb.get(i) - rows.ra.get(i))
    }

    /// The friction directions: a fixed function of the normal
    /// ([`tangent_basis`]), found again where needed (the solve streams
    /// every constraint each pass, and keeping them made each 48 bytes
    /// larger).
    #[inline]
    pub(crate) fn tangents(&self) -> [DVec3; 2] {
        tangent_basis(self.normal)
    }

    /// The centre of the points, on A and on B (anchors from each centre of
    /// mass, world, m), where friction acts; found again where needed, as
    /// the tangents are.
    #[inline]
    pub(crate) fn centres(&self) -> (DVec3, DVec3) {
        let len = self.len.max(1) as f64;
        let mean = |v: &LaneVec| (0..self.len).map(|i| v.get(i)).sum::<DVec3>() / len;
        (mean(&self.rows.ra), mean(&self.rows.rb))
    }

    /// The point's anchor on A, its offset from the centre `centre_a` in
    /// the contact plane, m.
    fn planar_offset(&self, centre_a: DVec3, i: usize) -> DVec3 {
        let n = self.normal;
        let d = self.rows.ra.get(i) - centre_a;
        d - n * n.dot(d)
    }

    /// The centre of the points and the manifold's friction and twist
    /// impulses rebuilt from the points' cached shares (the inverse of
    /// [`Self::point_tangent_impulses`]).
    fn gather_friction(&mut self, pts: &[PointConstraint]) {
        let len = self.len.max(1) as f64;
        let (centre_a, _) = self.centres();
        let n = self.normal;
        let [t1, t2] = self.tangents();
        let (mut f1, mut f2, mut twist, mut radius) = (0.0, 0.0, 0.0, 0.0);
        for (i, p) in pts.iter().enumerate() {
            let [s1, s2] = p.cached_tangent;
            f1 += s1;
            f2 += s2;
            let d = self.planar_offset(centre_a, i);
            twist += d.cross(t1 * s1 + t2 * s2).dot(n);
            radius += d.length();
        }
        self.friction[0].impulse = f1;
        self.friction[1].impulse = f2;
        self.twist.impulse = twist;
        self.twist_radius = radius / len;
    }

    /// Each point's share of the friction and twist impulses, along the two
    /// tangents, N·s: the friction split evenly, the twist as tangential
    /// impulses about the centre. Their sum is the friction impulse and
    /// their moment about the centre the twist impulse, so caching these
    /// per point (matched by feature id next step) loses nothing while the
    /// points persist.
    pub(crate) fn point_tangent_impulses(&self) -> [[f64; 2]; MAX_POINTS] {
        let mut out = [[0.0; 2]; MAX_POINTS];
        let n = self.normal;
        let [t1, t2] = self.tangents();
        let (centre_a, _) = self.centres();
        let spread: f64 = (0..self.len)
            .map(|i| self.planar_offset(centre_a, i).length_squared())
            .sum();
        let len = self.len.max(1) as f64;
        for (i, o) in out.iter_mut().enumerate().take(self.len) {
            let mut j =
                t1 * (self.friction[0].impulse / len) + t2 * (self.friction[1].impulse / len);
            if spread > 0.0 {
                j += n.cross(self.planar_offset(centre_a, i)) * (self.twist.impulse / spread);
            }
            *o = [t1.dot(j), t2.dot(j)];
        }
        out
    }

    /// Effective masses, the angular rows, the normal block and the
    /// speeds the points meet at, from the bodies at the start of the step,
    /// B's acceleration relative to A's over the step (`accel`, m/s²:
    /// gravity and applied forces) and the softness of the solve pass.
    pub(crate) fn prepare(
        &mut self,
        a: &SolverBody,
        b: &SolverBody,
        accel: DVec3,
        stick_speed: f64,
        solve: &ContactPass,
    ) {
        self.prepare_rows(a, b, accel, stick_speed);
        self.block = self.factor_block(a, b, solve).map(Box::new);
    }

    /// [`Self::prepare`] but for the normal block, which is left out (the
    /// wide passes factor it where they pack the constraint, into their
    /// own lanes, so that the step allocates nothing for it).
    pub(crate) fn prepare_rows(
        &mut self,
        a: &SolverBody,
        b: &SolverBody,
        accel: DVec3,
        stick_speed: f64,
    ) {
        let n = self.normal;
        let linear = n.dot(b.v - a.v);
        let closing_accel = (-n.dot(accel)).max(0.0);
        self.closing_accel = closing_accel;
        let gaps: Lanes = std::array::from_fn(|i| self.start_gap(i));
        let rows = &mut self.rows;
        for (i, &gap) in gaps.iter().enumerate().take(self.len) {
            let (ca, cb) = (rows.ra.get(i).cross(n), rows.rb.get(i).cross(n));
            rows.k[i] =
                a.inv_mass + b.inv_mass + ca.dot(a.inv_inertia * ca) + cb.dot(b.inv_inertia * cb);
            let vn = linear + cb.dot(b.w) - ca.dot(a.w);
            rows.approach[i] = impact_speed(vn, gap, closing_accel);
        }
        rows.max_impulse = [0.0; MAX_POINTS];
        rows.total_impulse = [0.0; MAX_POINTS];
        let (ca, cb) = self.centres();
        let [t1, t2] = self.tangents();
        self.friction[0].prepare(a, b, ca, cb, t1);
        self.friction[1].prepare(a, b, ca, cb, t2);
        self.twist.prepare_angular(a, b, n);
        let dv = relative_velocity(a, b, ca, cb);
        self.sticking = (dv - n * n.dot(dv)).length() < stick_speed;
        self.block = None;
    }

    /// The normal block `K_ij = J_i M⁻¹ J_jᵀ` of the points (how a unit
    /// impulse at point `j` changes the normal speed at point `i`), plus
    /// the diagonal `Γ` that makes the solve pass soft (`γ_i = (is/ms)
    /// K_ii`, see [`Self::solve_normals_block`]) or the relax pass barely
    /// regularised; factored for both passes.
    #[allow(clippy::needless_range_loop)] // i, j index a symmetric matrix
    pub(crate) fn factor_block(
        &self,
        a: &SolverBody,
        b: &SolverBody,
        solve: &ContactPass,
    ) -> Option<[BlockMatrix; 2]> {
        let len = self.len;
        if len < 2 {
            return None;
        }
        let (rows, n) = (&self.rows, self.normal);
        // The points' angular rows `ra × n`, `rb × n`.
        let c: [(DVec3, DVec3); MAX_POINTS] =
            std::array::from_fn(|i| (rows.ra.get(i).cross(n), rows.rb.get(i).cross(n)));
        let mut k = [[0.0; MAX_POINTS]; MAX_POINTS];
        for i in 0..len {
            let (ia, ib) = (a.inv_inertia * c[i].0, b.inv_inertia * c[i].1);
            for j in 0..=i {
                let (ca, cb) = c[j];
                let kij = a.inv_mass + b.inv_mass + ca.dot(ia) + cb.dot(ib);
                k[i][j] = kij;
                k[j][i] = kij;
            }
        }
        let soft = solve.impulse_scale / solve.mass_scale;
        let (mut ks, mut kr) = (k, k);
        for i in 0..MAX_POINTS {
            if i < len {
                ks[i][i] += soft * k[i][i];
                kr[i][i] += RELAX_REGULARISATION * k[i][i];
            } else {
                ks[i][i] = 1.0;
                kr[i][i] = 1.0;
            }
        }
        Some([cholesky(&ks)?, cholesky(&kr)?])
    }

    /// Normal speeds of the points, m/s (positive: separating).
    #[inline]
    fn normal_speeds(&self, a: &SolverBody, b: &SolverBody) -> Lanes {
        let n = self.normal;
        let linear = n.dot(b.v - a.v);
        let (wb, wa) = (
            self.rows.rb.dot(n.cross(b.w)),
            self.rows.ra.dot(n.cross(a.w)),
        );
        std::array::from_fn(|i| linear + wb[i] - wa[i])
    }

    /// Normal speed of point `i`, m/s.
    #[inline]
    fn normal_speed(&self, a: &SolverBody, b: &SolverBody, i: usize) -> f64 {
        let rows = &self.rows;
        let n = self.normal;
        n.dot(b.v - a.v) + rows.rb.get(i).dot(n.cross(b.w)) - rows.ra.get(i).dot(n.cross(a.w))
    }

    /// Applies normal impulse `x` (N·s) at point `i`: `+` on B, `-` on A.
    #[inline]
    fn push_one(&self, a: &mut SolverBody, b: &mut SolverBody, i: usize, x: f64) {
        let n = self.normal;
        a.v -= n * (x * a.inv_mass);
        b.v += n * (x * b.inv_mass);
        a.w -= a.inv_inertia * (self.rows.ra.get(i).cross(n) * x);
        b.w += b.inv_inertia * (self.rows.rb.get(i).cross(n) * x);
    }

    /// Applies normal impulses `x` (N·s, one per point): `+` on B, `-` on A.
    #[inline]
    fn push(&self, a: &mut SolverBody, b: &mut SolverBody, x: &Lanes) {
        let sum: f64 = x.iter().sum();
        let n = self.normal;
        a.v -= n * (sum * a.inv_mass);
        b.v += n * (sum * b.inv_mass);
        a.w -= a.inv_inertia * self.rows.ra.weighted_sum(x).cross(n);
        b.w += b.inv_inertia * self.rows.rb.weighted_sum(x).cross(n);
    }

    /// Solves the normal rows of all points at once (a block solve): the
    /// impulses `x` with `(K + Γ) x = -(v + bias + Γ λ)`, which is where
    /// point-by-point iteration would converge. Solving the points one
    /// after another instead leaves their impulses lopsided after a few
    /// passes, which rocks tall stacks. Used when every point is touching
    /// and no impulse comes out negative; returns false (changing nothing)
    /// otherwise, and the points are solved one by one.
    #[allow(clippy::needless_range_loop)] // lanes of several arrays
    fn solve_normals_block(
        &mut self,
        a: &mut SolverBody,
        b: &mut SolverBody,
        pass: &ContactPass,
        separations: &Lanes,
    ) -> bool {
        let Some(block) = &self.block else {
            return false;
        };
        let len = self.len;
        if separations[..len].iter().any(|&s| s > 0.0) {
            return false;
        }
        let (l, soft) = if pass.use_bias {
            (&block[0], pass.impulse_scale / pass.mass_scale)
        } else {
            (&block[1], 0.0)
        };
        let vn = self.normal_speeds(a, b);
        let rows = &self.rows;
        let rhs: Lanes = std::array::from_fn(|i| {
            let bias = if pass.use_bias {
                (pass.bias_rate * separations[i]).max(-pass.push_out)
            } else {
                0.0
            };
            let r = -(vn[i] + bias + soft * rows.k[i] * self.give(i));
            if i < len {
                r
            } else {
                0.0
            }
        });
        let x = cholesky_solve(l, rhs);
        let feasible = |i: usize| {
            let total = rows.impulse[i] + x[i];
            total.is_finite() && total >= 0.0
        };
        if !(0..len).all(feasible) {
            return false;
        }
        let rows = &mut self.rows;
        for i in 0..MAX_POINTS {
            rows.impulse[i] += x[i];
            rows.max_impulse[i] = rows.max_impulse[i].max(x[i]);
            if !pass.use_bias {
                rows.total_impulse[i] += rows.impulse[i];
            }
        }
        self.push(a, b, &x);
        true
    }

    /// Marks the contact as carrying a heavier body's load, before any
    /// pass of the step: each resting point carries its warm start (see
    /// [`NormalRows::carried`]); a point that met at more than
    /// [`RESTING_SPEED`] carries none (its warm start may be an impact's,
    /// not a load's).
    pub(crate) fn carry_load(&mut self) {
        let rows = &mut self.rows;
        for i in 0..self.len {
            if rows.approach[i].abs() <= RESTING_SPEED {
                rows.carried[i] = rows.impulse[i];
            }
        }
    }

    /// The impulse point `i`'s soft give is measured by, N·s: what it holds
    /// beyond the load it carries.
    #[inline]
    fn give(&self, i: usize) -> f64 {
        self.rows.impulse[i] - self.rows.carried[i]
    }

    /// Re-applies the accumulated impulses (warm start). The scalar
    /// reference of the wide pass (`wide::Batch::warm_start`), which the
    /// step runs.
    #[cfg(test)]
    pub(crate) fn warm_start(&self, a: &mut SolverBody, b: &mut SolverBody) {
        self.push(a, b, &self.rows.impulse);
        let [t1, t2] = self.tangents();
        let [f1, f2] = &self.friction;
        let linear = t1 * f1.impulse + t2 * f2.impulse;
        a.v -= linear * a.inv_mass;
        b.v += linear * b.inv_mass;
        a.w -=
            f1.ang_a * f1.impulse + f2.ang_a * f2.impulse + self.twist.ang_a * self.twist.impulse;
        b.w +=
            f1.ang_b * f1.impulse + f2.ang_b * f2.impulse + self.twist.ang_b * self.twist.impulse;
    }

    /// One pass: friction and twist at the centre (limited by the normal
    /// impulses so far), then non-penetration (soft when `pass.use_bias`):
    /// all points at once where possible, else point by point; so the
    /// constraint that matters most is solved last. The step runs it four
    /// constraints at a time (`wide::Batch::solve`, tested against this),
    /// and the shock pass runs it on one ([`Self::solve_held`]).
    pub(crate) fn solve(&mut self, a: &mut SolverBody, b: &mut SolverBody, pass: &ContactPass) {
        let n = self.normal;
        let mu = if self.sticking {
            self.friction_static
        } else {
            self.friction_dynamic
        };
        let pressed: f64 = self.rows.impulse.iter().sum();
        let limit = mu * pressed;
        // Both tangent rows from the same relative velocity, then the pair
        // clamped to the friction circle (isotropic Coulomb).
        let (centre_a, centre_b) = self.centres();
        let dv = relative_velocity(a, b, centre_a, centre_b);
        let [t1, t2] = self.tangents();
        let [f1, f2] = &mut self.friction;
        let mut new1 = f1.impulse - f1.mass * t1.dot(dv);
        let mut new2 = f2.impulse - f2.mass * t2.dot(dv);
        let size = (new1 * new1 + new2 * new2).sqrt();
        if size > limit {
            let scale = if size > 0.0 { limit / size } else { 0.0 };
            new1 *= scale;
            new2 *= scale;
        }
        let (d1, d2) = (new1 - f1.impulse, new2 - f2.impulse);
        f1.impulse = new1;
        f2.impulse = new2;
        f1.apply(a, b, t1, d1);
        f2.apply(a, b, t2, d2);
        // Twist about the normal.
        let twist_limit = limit * self.twist_radius;
        let tw = &mut self.twist;
        let spin = n.dot(b.w - a.w);
        let total = crate::limits::clamp_magnitude(tw.impulse - tw.mass * spin, twist_limit);
        let applied = total - tw.impulse;
        tw.impulse = total;
        a.w -= tw.ang_a * applied;
        b.w += tw.ang_b * applied;

        let separations = self.separations(a, b);
        if self.solve_normals_block(a, b, pass, &separations) {
            return;
        }
        let (h, use_bias) = (pass.h, pass.use_bias);
        for (i, &s) in separations.iter().enumerate().take(self.len) {
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
            let vn = self.normal_speed(a, b, i);
            let give = self.give(i);
            let rows = &mut self.rows;
            let mass = if rows.k[i] > 0.0 {
                1.0 / rows.k[i]
            } else {
                0.0
            };
            let impulse = -mass * ms * (vn + bias) - is * give;
            let total = (rows.impulse[i] + impulse).max(0.0);
            let applied = total - rows.impulse[i];
            rows.impulse[i] = total;
            rows.max_impulse[i] = rows.max_impulse[i].max(applied);
            if !use_bias {
                // The relax ends the substep: this is its impulse.
                rows.total_impulse[i] += total;
            }
            self.push_one(a, b, i, applied);
        }
    }

    /// Shock propagation (Guendelman, Bridson & Fedkiw, "Nonconvex rigid
    /// bodies with stacking", SIGGRAPH 2003): the pass solved once more,
    /// whole (friction, twist and the normal rows), on a copy of the
    /// constraint prepared with the lower body held still (A when
    /// `hold_a`), so the upper body ends it resting on the lower one
    /// whatever their masses. (Point by point, a light body under a heavy
    /// one passes on only about its own mass's worth of the heavy one's
    /// momentum a pass, and the heavy one sank through it.) Only the upper
    /// body's velocity changes; the copy's impulses are dropped, since the
    /// warm start would apply them to both bodies.
    pub(crate) fn solve_held(
        &self,
        a: &mut SolverBody,
        b: &mut SolverBody,
        hold_a: bool,
        stick_speed: f64,
        pass: &ContactPass,
    ) {
        let (mut held_a, mut held_b) = (*a, *b);
        let held = if hold_a { &mut held_a } else { &mut held_b };
        held.inv_mass = 0.0;
        held.inv_inertia = DMat3::ZERO;
        let mut copy = self.clone();
        copy.prepare(&held_a, &held_b, DVec3::ZERO, stick_speed, pass);
        copy.solve(&mut held_a, &mut held_b, pass);
        if hold_a {
            *b = held_b;
        } else {
            *a = held_a;
        }
    }

    /// The points' separations now, from how far the anchors have moved
    /// since the start of the step, m: `n · (dq r)` is `(dq⁻¹ n) · r`, so
    /// each body's rotation turns the normal once instead of every anchor.
    fn separations(&self, a: &SolverBody, b: &SolverBody) -> Lanes {
        let n = self.normal;
        let na = if a.dq == DQuat::IDENTITY {
            n
        } else {
            a.dq.inverse() * n
        };
        let nb = if b.dq == DQuat::IDENTITY {
            n
        } else {
            b.dq.inverse() * n
        };
        let moved = n.dot(b.dp - a.dp);
        let (sb, sa) = (self.rows.rb.dot(nb), self.rows.ra.dot(na));
        std::array::from_fn(|i| moved + sb[i] - sa[i] + self.rows.base[i])
    }

    /// Restitution: points that met faster than the threshold and pushed
    /// leave with `e` times the energy of the speed they met at (see
    /// [`impact_speed`]): `e` times that speed where they meet, less what
    /// the step's forces take from it over the gap a point that stopped
    /// short of its surface still has (a speculative point stops up to a
    /// substep's travel short), so the bounce rises as high either way.
    pub(crate) fn restitute(&mut self, a: &mut SolverBody, b: &mut SolverBody, threshold: f64) {
        if self.restitution == 0.0 {
            return;
        }
        let e = self.restitution;
        let separations = self.separations(a, b);
        for (i, &separation) in separations.iter().enumerate().take(self.len) {
            let rows = &self.rows;
            if rows.approach[i] > -threshold || rows.max_impulse[i] == 0.0 {
                continue;
            }
            let vn = self.normal_speed(a, b, i);
            let mass = if rows.k[i] > 0.0 {
                1.0 / rows.k[i]
            } else {
                0.0
            };
            let leave = e * rows.approach[i];
            let short = separation.max(0.0);
            let target = (leave * leave - 2.0 * self.closing_accel * short)
                .max(0.0)
                .sqrt();
            let total = (rows.impulse[i] - mass * (vn - target)).max(0.0);
            let applied = total - rows.impulse[i];
            let rows = &mut self.rows;
            rows.impulse[i] = total;
            rows.total_impulse[i] += applied;
            self.push_one(a, b, i, applied);
        }
    }
}
