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

mod hot;
pub(crate) mod lanes;
mod wide;

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

/// Normal speed (m/s) below which a point counts as resting when it
/// carries a heavier body's load.
const RESTING_SPEED: f64 = 0.1;

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
    pub(crate) block: Option<Box<[Block; 2]>>,
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

/// A lower-triangular Cholesky factor of a manifold's normal block, up to
/// 4×4.
pub(crate) type Block = [[f64; MAX_POINTS]; MAX_POINTS];

/// Factors the symmetric 4×4 `k` as `L Lᵀ`; `None` unless it is positive
/// definite. The diagonal holds `1 / L_ii`, so solving multiplies instead
/// of dividing. (Blocks of fewer points are padded with identity rows,
/// which keeps every loop a fixed four long.)
fn cholesky(k: &Block) -> Option<Block> {
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
fn cholesky_solve(l: &Block, rhs: [f64; MAX_POINTS]) -> [f64; MAX_POINTS] {
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

/// Relative regularisation of the relax pass's block (which is singular
/// for more than three points: a face contact has three degrees of
/// freedom), as a fraction of each point's own inverse mass.
const RELAX_REGULARISATION: f64 = 1e-6;

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
    ) -> Option<[Block; 2]> {
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
        let mut c = ContactConstraint::new(&ContactSource {
            ends: (0, 1),
            normal: DVec3::Y,
            materials: (0.6, 0.5, 0.0),
            points,
            len: 1,
        });
        let (solve, relax) = (
            ContactPass::new(&cfg, h, true),
            ContactPass::new(&cfg, h, false),
        );
        // base: separation 0 with rb pointing down half a metre: s = n·(dp + rb) + base = -0.5 + 0.5 = 0.
        let mut y = 0.0;
        for _ in 0..120 {
            c.prepare(&bodies[0], &bodies[1], DVec3::ZERO, cfg.stick_speed, &solve);
            c.rows.impulse[0] = c.rows.impulse[0].max(0.0);
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
            c.rows.base[0] += bodies[1].dp.y;
            bodies[1].dp = DVec3::ZERO;
        }
        assert!(y.abs() < 1e-3, "sank {y}");
        assert!(bodies[1].v.length() < 1e-6);
        let per_substep = c.rows.impulse[0];
        assert!((per_substep - 9.81 * h).abs() < 1e-9, "{per_substep}");
    }

    /// A box resting on four corner points: the block solve gives the four
    /// points equal shares of the weight, as symmetry demands (points solved
    /// one by one would not).
    #[test]
    fn four_points_share_a_load_evenly() {
        let cfg = SolverConfig::default();
        let h = 1.0 / 240.0;
        let mut bodies = vec![
            SolverBody::fixed(),
            SolverBody {
                inv_mass: 1.0 / 300.0,
                inv_inertia: DMat3::IDENTITY * (6.0 / 300.0),
                ..SolverBody::fixed()
            },
        ];
        let mut points = [PointConstraint::default(); MAX_POINTS];
        for (k, p) in points.iter_mut().enumerate() {
            let x = if k % 2 == 0 { -0.5 } else { 0.5 };
            let z = if k < 2 { -0.5 } else { 0.5 };
            *p = PointConstraint::new(DVec3::new(x, 0.0, z), DVec3::new(x, -0.5, z), 0.0, [0.0; 2]);
            p.base_separation = 0.5 - 1e-3; // a millimetre of overlap
        }
        let (solve, relax) = (
            ContactPass::new(&cfg, h, true),
            ContactPass::new(&cfg, h, false),
        );
        let mut c = ContactConstraint::new(&ContactSource {
            ends: (0, 1),
            normal: DVec3::Y,
            materials: (0.6, 0.6, 0.0),
            points,
            len: 4,
        });
        c.prepare(&bodies[0], &bodies[1], DVec3::ZERO, cfg.stick_speed, &solve);
        assert!(c.block.is_some());
        for _ in 0..8 {
            bodies[1].v.y -= 9.81 * h;
            let (a, b) = pair(&mut bodies, 0, 1);
            c.warm_start(a, b);
            c.solve(a, b, &solve);
            c.solve(a, b, &relax);
        }
        let impulses: Vec<f64> = c.rows.impulse.to_vec();
        let mean = impulses.iter().sum::<f64>() / 4.0;
        assert!(mean > 0.0);
        for i in &impulses {
            assert!((i - mean).abs() < 1e-9 * mean, "{impulses:?}");
        }
        assert!(
            bodies[1].w.length() < 1e-15,
            "the box turned: {}",
            bodies[1].w
        );
    }

    #[test]
    fn cholesky_solves_a_small_spd_system() {
        let k = [
            [4.0, 1.0, 0.5, 0.0],
            [1.0, 3.0, 0.2, 0.1],
            [0.5, 0.2, 2.0, 0.3],
            [0.0, 0.1, 0.3, 1.0],
        ];
        let l = cholesky(&k).unwrap();
        let rhs = [1.0, -2.0, 0.5, 3.0];
        let x = cholesky_solve(&l, rhs);
        for i in 0..4 {
            let row: f64 = (0..4).map(|j| k[i][j] * x[j]).sum();
            assert!((row - rhs[i]).abs() < 1e-12);
        }
        // Not positive definite: refused.
        let mut bad = k;
        bad[3][3] = -1.0;
        assert!(cholesky(&bad).is_none());
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
