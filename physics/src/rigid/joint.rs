//! Joints between rigid bodies, solved with the contacts in the soft-step
//! substeps (see [`solver`](super::solver)).
//!
//! Every joint holds an anchor on each body (in the body frame). The point
//! part (ball, hinge, fixed) keeps the anchors together with a 3×3 block
//! solve of `C = p_b - p_a = 0`; the angular parts keep axes aligned (hinge)
//! or the whole relative rotation (fixed). A prismatic (slider) joint keeps
//! the relative rotation like a fixed one and B's anchor on the line through
//! A's anchor along an axis fixed in A (two rows across the axis, solved
//! with the three rotation rows as one 5×5 block), and may limit and drive
//! the translation along the axis. All position
//! errors are corrected softly, at [`JOINT_HERTZ`] with
//! [`JOINT_DAMPING_RATIO`], like the contacts, so a joint pulled apart comes
//! back smoothly instead of snapping. Hinge and prismatic limits are
//! one-sided speculative constraints; the motors are velocity constraints
//! with a torque or force cap. A joint may break: when the
//! force it had to apply in a step exceeds its threshold it is removed and
//! reported. Two bodies joined by a joint do not collide with each other.

use glam::{DMat3, DQuat, DVec3};

use crate::handle::BodyHandle;
use crate::rigid::solver::{softness, SolverBody};

/// Stiffness of joint position correction, Hz (capped at a quarter of the
/// substep rate).
pub const JOINT_HERTZ: f64 = 60.0;
/// Damping ratio of joint position correction.
pub const JOINT_DAMPING_RATIO: f64 = 2.0;

/// What a joint constrains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointKind {
    /// The anchors coincide; rotation is free (a ball-and-socket).
    Ball,
    /// The anchors coincide and the bodies turn only about a shared axis
    /// (`axis_a` in A's frame, `axis_b` in B's frame), with optional limits
    /// on the angle and a motor.
    Hinge {
        /// Hinge axis in A's body frame (unit).
        axis_a: DVec3,
        /// Hinge axis in B's body frame (unit).
        axis_b: DVec3,
        /// Lower and upper angle, rad, or `None` for free rotation.
        limits: Option<(f64, f64)>,
        /// Target relative angular speed, rad/s, and the largest torque, N·m.
        motor: Option<(f64, f64)>,
    },
    /// A ball joint whose swing is limited to a cone and whose twist about
    /// the axis is limited to a range: shoulders, hips, necks.
    SwingTwist {
        /// Twist axis in A's body frame (unit).
        axis_a: DVec3,
        /// Twist axis in B's body frame (unit).
        axis_b: DVec3,
        /// Largest angle between the two axes, rad.
        swing_limit: f64,
        /// Lower and upper twist angle about the axis, rad.
        twist_limits: (f64, f64),
    },
    /// The bodies move as one: the anchors coincide and the relative
    /// rotation stays as it was when the joint was made.
    Fixed,
    /// A slider: the relative rotation stays as it was when the joint was
    /// made (as for [`Fixed`](JointKind::Fixed)) and B's anchor stays on the
    /// line through A's anchor along `axis_a`, free to slide along it. The
    /// translation is `axis · (p_b - p_a)` (m), counted from A's anchor, with
    /// optional limits on it and a motor.
    Prismatic {
        /// Slide axis in A's body frame (unit).
        axis_a: DVec3,
        /// Lower and upper translation along the axis, m, or `None` for a
        /// free slide.
        limits: Option<(f64, f64)>,
        /// Target relative speed along the axis, m/s, and the largest
        /// force, N.
        motor: Option<(f64, f64)>,
    },
    /// The anchors stay between `min` and `max` apart (m); with a spring,
    /// pulled towards `rest` at `hertz` with `damping_ratio`.
    Distance {
        /// Smallest allowed distance, m.
        min: f64,
        /// Largest allowed distance, m.
        max: f64,
        /// Optional spring: rest length (m), frequency (Hz), damping ratio.
        spring: Option<(f64, f64, f64)>,
    },
}

/// Everything needed to create a joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDesc {
    /// First body.
    pub a: BodyHandle,
    /// Second body.
    pub b: BodyHandle,
    /// Anchor on A, A's body frame, m.
    pub anchor_a: DVec3,
    /// Anchor on B, B's body frame, m.
    pub anchor_b: DVec3,
    /// What is constrained.
    pub kind: JointKind,
    /// Force above which the joint breaks, N (`f64::MAX` = unbreakable).
    pub break_force: f64,
}

/// A joint as stored: the description plus its warm-start impulses.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    pub(crate) desc: JointDesc,
    /// Relative rotation `q_a⁻¹ q_b` of the body frames when the joint was
    /// made: what a fixed or prismatic joint keeps and where hinge angles
    /// count from.
    pub(crate) reference: DQuat,
    /// Accumulated impulses for warm starting: point (N·s; for a prismatic
    /// joint the two rows across the axis, world), angular (N·m·s), lower/
    /// upper limit and motor (hinge: N·m·s; prismatic: N·s along the axis),
    /// distance spring and min/max limits (N·s).
    pub(crate) linear_impulse: DVec3,
    pub(crate) angular_impulse: DVec3,
    pub(crate) limit_impulse: [f64; 2],
    pub(crate) swing_impulse: f64,
    pub(crate) motor_impulse: f64,
    pub(crate) spring_impulse: f64,
    pub(crate) distance_impulse: [f64; 2],
}

impl Joint {
    pub(crate) fn new(desc: JointDesc, rotation_a: DQuat, rotation_b: DQuat) -> Self {
        Self {
            desc,
            reference: rotation_a.inverse() * rotation_b,
            linear_impulse: DVec3::ZERO,
            angular_impulse: DVec3::ZERO,
            limit_impulse: [0.0; 2],
            swing_impulse: 0.0,
            motor_impulse: 0.0,
            spring_impulse: 0.0,
            distance_impulse: [0.0; 2],
        }
    }

    /// The description it was made from.
    pub fn desc(&self) -> &JointDesc {
        &self.desc
    }

    /// Magnitude of the force the joint applied, N, given the substep `h`
    /// its impulses were accumulated over.
    pub(crate) fn force(&self, h: f64) -> f64 {
        if let JointKind::Prismatic { .. } = self.desc.kind {
            // The rows across the axis and the limit and motor rows along
            // it push in orthogonal directions.
            let axial = self.limit_impulse[0] - self.limit_impulse[1] + self.motor_impulse;
            return self.linear_impulse.length().hypot(axial) / h;
        }
        let axial = self.spring_impulse + self.distance_impulse[0] - self.distance_impulse[1];
        (self.linear_impulse.length() + axial.abs()) / h
    }
}

/// One joint prepared for a step.
#[derive(Debug, Clone)]
pub(crate) struct JointConstraint {
    pub(crate) a: usize,
    pub(crate) b: usize,
    /// Anchors from the centres of mass at the start of the step, world, m.
    pub(crate) ra: DVec3,
    pub(crate) rb: DVec3,
    /// `p_b - p_a` at the start of the step, m.
    pub(crate) base_offset: DVec3,
    /// Body rotations at the start of the step.
    pub(crate) qa0: DQuat,
    pub(crate) qb0: DQuat,
    pub(crate) joint: Joint,
}

fn skew(v: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, v.z, -v.y),
        DVec3::new(-v.z, 0.0, v.x),
        DVec3::new(v.y, -v.x, 0.0),
    )
}

/// Velocity bias of a one-sided limit with position error `c` (m or rad;
/// positive = inside the limit): a speculative "do not cross within this
/// substep" when inside, a soft push back (capped at 3 units/s) when past it
/// and `use_bias`, nothing in the relax pass.
fn limit_bias(c: f64, h: f64, bias_rate: f64, use_bias: bool) -> f64 {
    if c > 0.0 {
        c / h
    } else if use_bias {
        (bias_rate * c).max(-3.0)
    } else {
        0.0
    }
}

fn invert(m: DMat3) -> Option<DMat3> {
    let det = m.determinant();
    (det.abs() > 1e-300 && det.is_finite()).then(|| m.inverse())
}

/// Solves `k x = r` for a symmetric positive definite 5×5 `k` by Cholesky
/// factorisation, or `None` when `k` is (numerically) singular.
fn solve_spd5(k: &[[f64; 5]; 5], r: [f64; 5]) -> Option<[f64; 5]> {
    // k = L Lᵀ with L lower triangular.
    let mut l = [[0.0; 5]; 5];
    for i in 0..5 {
        for j in 0..=i {
            let s = k[i][j] - (0..j).map(|p| l[i][p] * l[j][p]).sum::<f64>();
            if i == j {
                if !(s > 1e-12 * k[i][i] && s.is_finite()) {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // L y = r, then Lᵀ x = y.
    let mut y = [0.0; 5];
    for i in 0..5 {
        y[i] = (r[i] - (0..i).map(|p| l[i][p] * y[p]).sum::<f64>()) / l[i][i];
    }
    let mut x = [0.0; 5];
    for i in (0..5).rev() {
        x[i] = (y[i] - (i + 1..5).map(|p| l[p][i] * x[p]).sum::<f64>()) / l[i][i];
    }
    Some(x)
}

/// Softness of one pass: `(bias_rate, mass_scale, impulse_scale)` as from
/// [`softness`], or `(0, 1, 0)` in the relax pass.
type Soft = (f64, f64, f64);

/// Linear impulse `p` at the anchors and angular impulse `l` on the pair.
fn apply(a: &mut SolverBody, b: &mut SolverBody, ra: DVec3, rb: DVec3, p: DVec3, l: DVec3) {
    a.v -= p * a.inv_mass;
    a.w -= a.inv_inertia * (ra.cross(p) + l);
    b.v += p * b.inv_mass;
    b.w += b.inv_inertia * (rb.cross(p) + l);
}

impl JointConstraint {
    /// Current `p_b - p_a`, m.
    fn offset(&self, a: &SolverBody, b: &SolverBody) -> DVec3 {
        self.base_offset + (b.dp + b.dq * self.rb - self.rb) - (a.dp + a.dq * self.ra - self.ra)
    }

    /// The hinge or twist axis in the world, turned with A.
    fn hinge_axis(&self, a: &SolverBody) -> DVec3 {
        match self.joint.desc.kind {
            JointKind::Hinge { axis_a, .. } | JointKind::SwingTwist { axis_a, .. } => {
                a.dq * (self.qa0 * axis_a)
            }
            _ => DVec3::ZERO,
        }
    }

    /// The slide axis of a prismatic joint in the world, turned with A
    /// (unit).
    fn slide_axis(&self, a: &SolverBody) -> DVec3 {
        match self.joint.desc.kind {
            JointKind::Prismatic { axis_a, .. } => a.dq * (self.qa0 * axis_a),
            _ => DVec3::ZERO,
        }
    }

    /// The swing axis along which the last swing impulse acted.
    fn swing_axis(&self, a: &SolverBody, b: &SolverBody) -> DVec3 {
        match self.joint.desc.kind {
            JointKind::SwingTwist { axis_b, .. } => {
                let (ta, tb) = (self.hinge_axis(a), b.dq * (self.qb0 * axis_b));
                ta.cross(tb).normalize_or_zero()
            }
            _ => DVec3::ZERO,
        }
    }

    /// Two-sided angle limits about `axis` on the angle `angle` (rad):
    /// `lo <= angle <= hi`, accumulated in `limit_impulse`.
    #[allow(clippy::too_many_arguments)]
    fn angle_limits(
        &mut self,
        a: &mut SolverBody,
        b: &mut SolverBody,
        (ra, rb): (DVec3, DVec3),
        axis: DVec3,
        angle: f64,
        (lo, hi): (f64, f64),
        k: f64,
        h: f64,
        bias_rate: f64,
        use_bias: bool,
    ) {
        for (side, c, sign) in [(0, angle - lo, 1.0), (1, hi - angle, -1.0)] {
            let cdot = sign * axis.dot(b.w - a.w);
            let bias = limit_bias(c, h, bias_rate, use_bias);
            let old = self.joint.limit_impulse[side];
            self.joint.limit_impulse[side] = (old - (cdot + bias) / k).max(0.0);
            let applied = (self.joint.limit_impulse[side] - old) * sign;
            apply(a, b, ra, rb, DVec3::ZERO, axis * applied);
        }
    }

    /// Relative rotation of B from where the joint holds it, world frame.
    fn rotation_error(&self, a: &SolverBody, b: &SolverBody) -> DQuat {
        let target = a.dq * self.qa0 * self.joint.reference;
        let err = (b.dq * self.qb0) * target.inverse();
        if err.w < 0.0 {
            -err
        } else {
            err
        }
    }

    /// One pass of a prismatic joint: the motor and the limits along the
    /// axis, then the rotation and B's anchor across the axis as one block.
    ///
    /// Every linear row acts at B's anchor on both bodies: with the axis
    /// fixed in A, `d/dt [t · (p_b - p_a)] = t · (v_b + w_b × r_b - v_a -
    /// w_a × (r_a + d))` for `d = p_b - p_a`, so A is pushed at `r_a + d`.
    #[allow(clippy::too_many_arguments)]
    fn solve_prismatic(
        &mut self,
        a: &mut SolverBody,
        b: &mut SolverBody,
        (ra, rb): (DVec3, DVec3),
        limits: Option<(f64, f64)>,
        motor: Option<(f64, f64)>,
        h: f64,
        soft: Soft,
        use_bias: bool,
    ) {
        let (bias_rate, mass_scale, impulse_scale) = soft;
        let axis = self.slide_axis(a);
        let d = self.offset(a, b);
        let ra_b = ra + d;
        // Relative velocity of B's anchor, m/s.
        let vrel = |a: &SolverBody, b: &SolverBody| b.v + b.w.cross(rb) - a.v - a.w.cross(ra_b);

        // Along the axis: inverse effective mass, 1/kg.
        let (ca, cb) = (ra_b.cross(axis), rb.cross(axis));
        let k = a.inv_mass + b.inv_mass + ca.dot(a.inv_inertia * ca) + cb.dot(b.inv_inertia * cb);
        if k > 0.0 {
            if let Some((speed, max_force)) = motor {
                let cdot = axis.dot(vrel(a, b)) - speed;
                let max = max_force * h;
                let old = self.joint.motor_impulse;
                self.joint.motor_impulse = crate::limits::clamp_magnitude(old - cdot / k, max);
                let p = axis * (self.joint.motor_impulse - old);
                apply(a, b, ra_b, rb, p, DVec3::ZERO);
            }
            if let Some((lo, hi)) = limits {
                let s = axis.dot(d);
                for (side, c, sign) in [(0, s - lo, 1.0), (1, hi - s, -1.0)] {
                    let cdot = sign * axis.dot(vrel(a, b));
                    let bias = limit_bias(c, h, bias_rate, use_bias);
                    let old = self.joint.limit_impulse[side];
                    self.joint.limit_impulse[side] = (old - (cdot + bias) / k).max(0.0);
                    let p = axis * ((self.joint.limit_impulse[side] - old) * sign);
                    apply(a, b, ra_b, rb, p, DVec3::ZERO);
                }
            }
        }

        // B's anchor across the axis (t · d = 0 for both t ⟂ axis, m) and
        // the rotation (as for a fixed joint, rad): five rows `(lin, ang_a,
        // ang_b, c)` with velocity `lin · (v_b - v_a) + ang_b · w_b - ang_a ·
        // w_a` and position error `c`, solved as one block so that the
        // torque of the linear rows about the centres of mass does not undo
        // the rotation rows within the pass (and the other way round).
        let [t1, t2] = crate::rigid::solver::tangent_basis(axis);
        let err = self.rotation_error(a, b);
        let turn = 2.0 * DVec3::new(err.x, err.y, err.z);
        let rows = [
            (t1, ra_b.cross(t1), rb.cross(t1), t1.dot(d)),
            (t2, ra_b.cross(t2), rb.cross(t2), t2.dot(d)),
            (DVec3::ZERO, DVec3::X, DVec3::X, turn.x),
            (DVec3::ZERO, DVec3::Y, DVec3::Y, turn.y),
            (DVec3::ZERO, DVec3::Z, DVec3::Z, turn.z),
        ];
        let mut k = [[0.0; 5]; 5];
        for (i, &(lin_i, ang_a_i, ang_b_i, _)) in rows.iter().enumerate() {
            for (j, &(lin_j, ang_a_j, ang_b_j, _)) in rows.iter().enumerate() {
                k[i][j] = (a.inv_mass + b.inv_mass) * lin_i.dot(lin_j)
                    + ang_a_i.dot(a.inv_inertia * ang_a_j)
                    + ang_b_i.dot(b.inv_inertia * ang_b_j);
            }
        }
        let (lin_acc, ang_acc) = (self.joint.linear_impulse, self.joint.angular_impulse);
        let acc = [
            t1.dot(lin_acc),
            t2.dot(lin_acc),
            ang_acc.x,
            ang_acc.y,
            ang_acc.z,
        ];
        let rhs = rows.map(|(lin, ang_a, ang_b, c)| {
            lin.dot(b.v - a.v) + ang_b.dot(b.w) - ang_a.dot(a.w) + c * bias_rate
        });
        if let Some(x) = solve_spd5(&k, rhs) {
            let imp: [f64; 5] =
                std::array::from_fn(|i| -x[i] * mass_scale - acc[i] * impulse_scale);
            let p = t1 * imp[0] + t2 * imp[1];
            let l = DVec3::new(imp[2], imp[3], imp[4]);
            self.joint.linear_impulse += p;
            self.joint.angular_impulse += l;
            apply(a, b, ra_b, rb, p, l);
        }
    }

    /// Re-applies last step's impulses.
    pub(crate) fn warm_start(&self, a: &mut SolverBody, b: &mut SolverBody) {
        let j = &self.joint;
        let (ra, rb) = (a.dq * self.ra, b.dq * self.rb);
        if let JointKind::Prismatic { .. } = j.desc.kind {
            // The linear rows act at B's anchor (see `solve_prismatic`).
            let ra_b = ra + self.offset(a, b);
            let axial = j.limit_impulse[0] - j.limit_impulse[1] + j.motor_impulse;
            let p = j.linear_impulse + self.slide_axis(a) * axial;
            apply(a, b, ra_b, rb, p, j.angular_impulse);
            return;
        }
        let dir = self.offset(a, b).normalize_or_zero();
        let axial = j.spring_impulse + j.distance_impulse[0] - j.distance_impulse[1];
        let hinge =
            self.hinge_axis(a) * (j.limit_impulse[0] - j.limit_impulse[1] + j.motor_impulse);
        let swing = self.swing_axis(a, b) * -j.swing_impulse;
        apply(
            a,
            b,
            ra,
            rb,
            j.linear_impulse + dir * axial,
            j.angular_impulse + hinge + swing,
        );
    }

    /// One pass: the angular parts, then the point or distance part (a
    /// prismatic joint in its own order, see `solve_prismatic`).
    pub(crate) fn solve(&mut self, a: &mut SolverBody, b: &mut SolverBody, h: f64, use_bias: bool) {
        let hertz = JOINT_HERTZ.min(0.25 / h);
        let (bias_rate, mass_scale, impulse_scale) = if use_bias {
            softness(hertz, JOINT_DAMPING_RATIO, h)
        } else {
            (0.0, 1.0, 0.0)
        };
        let soft = (bias_rate, mass_scale, impulse_scale);
        let inv_i_sum = a.inv_inertia + b.inv_inertia;
        let (ra, rb) = (a.dq * self.ra, b.dq * self.rb);
        match self.joint.desc.kind {
            JointKind::Fixed => {
                let err = self.rotation_error(a, b);
                let c = 2.0 * DVec3::new(err.x, err.y, err.z);
                if let Some(inv) = invert(inv_i_sum) {
                    let imp = -(inv * (b.w - a.w + c * bias_rate)) * mass_scale
                        - self.joint.angular_impulse * impulse_scale;
                    self.joint.angular_impulse += imp;
                    apply(a, b, ra, rb, DVec3::ZERO, imp);
                }
            }
            JointKind::Prismatic { limits, motor, .. } => {
                self.solve_prismatic(a, b, (ra, rb), limits, motor, h, soft, use_bias);
                return;
            }
            JointKind::Hinge {
                axis_b,
                limits,
                motor,
                ..
            } => {
                let axis = self.hinge_axis(a);
                let axis_b_world = b.dq * (self.qb0 * axis_b);
                // Keep the axes aligned: t · (a × b) = 0 for both t ⟂ axis.
                let c = axis.cross(axis_b_world);
                for t in crate::rigid::solver::tangent_basis(axis) {
                    let k = t.dot(inv_i_sum * t);
                    if k > 0.0 {
                        let cdot = t.dot(b.w - a.w);
                        let imp = -(cdot + t.dot(c) * bias_rate) / k * mass_scale
                            - impulse_scale * t.dot(self.joint.angular_impulse);
                        self.joint.angular_impulse += t * imp;
                        apply(a, b, ra, rb, DVec3::ZERO, t * imp);
                    }
                }
                let k = axis.dot(inv_i_sum * axis);
                if k > 0.0 {
                    if let Some((speed, max_torque)) = motor {
                        let cdot = axis.dot(b.w - a.w) - speed;
                        let max = max_torque * h;
                        let old = self.joint.motor_impulse;
                        self.joint.motor_impulse =
                            crate::limits::clamp_magnitude(old - cdot / k, max);
                        apply(
                            a,
                            b,
                            ra,
                            rb,
                            DVec3::ZERO,
                            axis * (self.joint.motor_impulse - old),
                        );
                    }
                    if let Some(range) = limits {
                        let err = self.rotation_error(a, b);
                        let angle = 2.0 * DVec3::new(err.x, err.y, err.z).dot(axis).atan2(err.w);
                        self.angle_limits(
                            a,
                            b,
                            (ra, rb),
                            axis,
                            angle,
                            range,
                            k,
                            h,
                            bias_rate,
                            use_bias,
                        );
                    }
                }
            }
            JointKind::SwingTwist {
                axis_b,
                swing_limit,
                twist_limits,
                ..
            } => {
                let ta = self.hinge_axis(a);
                let tb = b.dq * (self.qb0 * axis_b);
                // Swing: the angle between the axes stays within the cone.
                let n = ta.cross(tb);
                let sin = n.length();
                let theta = sin.atan2(ta.dot(tb));
                if sin > 1e-9 {
                    let n = n / sin;
                    let k = n.dot(inv_i_sum * n);
                    if k > 0.0 {
                        let c = swing_limit - theta;
                        let cdot = -n.dot(b.w - a.w);
                        let bias = limit_bias(c, h, bias_rate, use_bias);
                        let old = self.joint.swing_impulse;
                        self.joint.swing_impulse = (old - (cdot + bias) / k).max(0.0);
                        apply(
                            a,
                            b,
                            ra,
                            rb,
                            DVec3::ZERO,
                            n * -(self.joint.swing_impulse - old),
                        );
                    }
                }
                // Twist about A's axis.
                let k = ta.dot(inv_i_sum * ta);
                if k > 0.0 {
                    let err = self.rotation_error(a, b);
                    let angle = 2.0 * DVec3::new(err.x, err.y, err.z).dot(ta).atan2(err.w);
                    self.angle_limits(
                        a,
                        b,
                        (ra, rb),
                        ta,
                        angle,
                        twist_limits,
                        k,
                        h,
                        bias_rate,
                        use_bias,
                    );
                }
            }
            JointKind::Ball | JointKind::Distance { .. } => {}
        }

        let d = self.offset(a, b);
        if let JointKind::Distance { min, max, spring } = self.joint.desc.kind {
            let len = d.length();
            if len <= f64::MIN_POSITIVE {
                return;
            }
            let n = d / len;
            let (cra, crb) = (ra.cross(n), rb.cross(n));
            let k = a.inv_mass
                + b.inv_mass
                + cra.dot(a.inv_inertia * cra)
                + crb.dot(b.inv_inertia * crb);
            if k <= 0.0 {
                return;
            }
            let vrel =
                |a: &SolverBody, b: &SolverBody| n.dot(b.v + b.w.cross(rb) - a.v - a.w.cross(ra));
            if let Some((rest, hz, zeta)) = spring {
                let (br, ms, is) = softness(hz, zeta, h);
                let imp =
                    -(vrel(a, b) + br * (len - rest)) / k * ms - is * self.joint.spring_impulse;
                self.joint.spring_impulse += imp;
                apply(a, b, ra, rb, n * imp, DVec3::ZERO);
            }
            for (side, c, sign) in [(0, len - min, 1.0), (1, max - len, -1.0)] {
                let cdot = sign * vrel(a, b);
                let bias = limit_bias(c, h, bias_rate, use_bias);
                let old = self.joint.distance_impulse[side];
                self.joint.distance_impulse[side] = (old - (cdot + bias) / k * mass_scale).max(0.0);
                apply(
                    a,
                    b,
                    ra,
                    rb,
                    n * ((self.joint.distance_impulse[side] - old) * sign),
                    DVec3::ZERO,
                );
            }
            return;
        }
        // Point constraint: a 3×3 block.
        let cdot = b.v + b.w.cross(rb) - a.v - a.w.cross(ra);
        let (sa, sb) = (skew(ra), skew(rb));
        let k = DMat3::IDENTITY * (a.inv_mass + b.inv_mass)
            - sa * a.inv_inertia * sa
            - sb * b.inv_inertia * sb;
        if let Some(inv) = invert(k) {
            let imp = -(inv * (cdot + d * bias_rate)) * mass_scale
                - self.joint.linear_impulse * impulse_scale;
            self.joint.linear_impulse += imp;
            apply(a, b, ra, rb, imp, DVec3::ZERO);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_five_by_five_block_solve_inverts_spd_matrices_and_refuses_singular_ones() {
        // k = mᵀ m + I is symmetric positive definite.
        let m: [[f64; 5]; 5] =
            std::array::from_fn(|i| std::array::from_fn(|j| ((3 * i + 7 * j) % 11) as f64 - 5.0));
        let mut k = [[0.0; 5]; 5];
        for i in 0..5 {
            for j in 0..5 {
                k[i][j] =
                    (0..5).map(|p| m[p][i] * m[p][j]).sum::<f64>() + f64::from(u8::from(i == j));
            }
        }
        let r = [1.0, -2.0, 0.5, 3.0, -0.25];
        let x = solve_spd5(&k, r).unwrap();
        for i in 0..5 {
            let kx: f64 = (0..5).map(|j| k[i][j] * x[j]).sum();
            assert!((kx - r[i]).abs() < 1e-9, "row {i}: {kx} vs {}", r[i]);
        }
        // Two equal rows: singular.
        let mut s = k;
        s[4] = s[3];
        for row in &mut s {
            row[4] = row[3];
        }
        assert!(solve_spd5(&s, r).is_none());
    }
}
