//! Stages 4 and 5: colour the contact constraints, then solve in substeps
//! (see [`crate::rigid::solver`] for the method).

use glam::{DQuat, DVec3};

use super::manifolds::FoundManifolds;
use super::shock::Shock;
use super::{StepInputs, StepMemory};
use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::body_index::BodyIndex;
use crate::rigid::joint::JointConstraint;
use crate::rigid::motion::free_rotation;
use crate::rigid::solver::colouring;
use crate::rigid::solver::{ContactConstraint, ContactPass, SolverBody, WideContacts, WidePass};

/// Bodies per parallel work item when integrating them.
const BODIES_PER_ITEM: usize = 512;

/// The solver's state for one step.
#[derive(Debug)]
pub(crate) struct Solve {
    /// Velocities and frozen mass properties, by slot.
    pub(crate) bodies: Vec<SolverBody>,
    /// Each body's acceleration from gravity and the step's forces, m/s²,
    /// by slot (zero for one the solver leaves where it is).
    accel: Vec<DVec3>,
    /// Contact constraints, stored in solve order (colour by colour, pair
    /// order within a colour), so that every pass walks them front to back.
    pub(crate) constraints: Vec<ContactConstraint>,
    /// Where each constraint of the narrow phase's pair order is stored:
    /// `constraints[in_pair_order[k]]` is the `k`-th.
    pub(crate) in_pair_order: Vec<u32>,
    /// The colour of each constraint (as stored).
    colours: Vec<u8>,
    /// The solve order: colour by colour (as stored: each colour a run).
    groups: colouring::Groups,
    /// Whether a constraint can move each body (dynamic and awake).
    movable: Vec<bool>,
    /// Joint rows with their joint's arena index and generation.
    pub(crate) joint_rows: Vec<(u32, u32, JointConstraint)>,
    /// The joints' colours and solve order (coloured like the contacts).
    joint_colours: Vec<u8>,
    joint_groups: colouring::Groups,
    /// Centre of mass and principal rotation of each body at the start.
    pub(crate) start: Vec<(DVec3, DQuat)>,
    /// How fast the position correction moved each body beyond its
    /// velocity over the step, m/s, by slot (filled by [`Solve::run`]).
    pub(crate) push_velocity: Vec<DVec3>,
    /// The contacts solved again with their lower body held (heavy bodies
    /// over light ones), in order.
    shock: Shock,
    /// The constraints in batches of four for the contact passes, and the
    /// bodies' hot state; the impulses are unpacked into `constraints`
    /// where the shock pass and the end of the step read them.
    pub(crate) wide: WideContacts,
}

impl Solve {
    /// Solver bodies from the bodies at the start of the step; the
    /// constraints the narrow phase `found`, coloured, placed in solve order
    /// and prepared; the joint rows (in `memory`, whose other vectors come
    /// empty and are filled here, their room used again).
    pub(crate) fn new(
        bodies: &Arena<RigidBody>,
        found: &FoundManifolds,
        memory: StepMemory,
        inputs: &StepInputs<'_>,
        external: &[(DVec3, DVec3)],
        solve: &ContactPass,
    ) -> Self {
        let stick_speed = inputs.cfg.stick_speed;
        // Each body's acceleration over the step: integrated in every
        // substep, and the speed at which contacts meet (restitution).
        let accel: Vec<DVec3> = bodies
            .iter()
            .zip(external)
            .map(|((_, _, b), &(force, _))| linear_accel(b, inputs.gravity, force))
            .collect();
        let StepMemory {
            constraints: mut placed,
            joint_rows,
            mut solver_bodies,
            mut wide,
            found: _,
        } = memory;
        solver_bodies.clear();
        solver_bodies.extend(bodies.iter().map(|(_, _, b)| {
            let fixed = b.is_fixed_now();
            SolverBody {
                v: b.linvel,
                w: b.angvel,
                inv_mass: if fixed { 0.0 } else { b.inv_mass },
                inv_inertia: if fixed {
                    glam::DMat3::ZERO
                } else {
                    b.inverse_inertia_world()
                },
                dp: DVec3::ZERO,
                dq: DQuat::IDENTITY,
            }
        }));
        let movable: Vec<bool> = bodies.iter().map(|(_, _, b)| !b.is_fixed_now()).collect();
        let ends = found.ends();
        let mut colours = colouring::colour(&ends, &movable);
        let mut groups = colouring::group(&colours);
        let (in_pair_order, solve_order) = into_solve_order(&mut colours, &mut groups);
        let prepare = |c: &mut ContactConstraint| {
            let relative = accel[c.b] - accel[c.a];
            c.prepare_rows(
                &solver_bodies[c.a],
                &solver_bodies[c.b],
                relative,
                stick_speed,
            );
        };
        found.place_in(&solve_order, &mut placed, prepare);
        let shock = Shock::new(&mut placed, &solver_bodies, &movable, stick_speed);
        wide.pack(&placed, &groups, &colours, &movable, &solver_bodies, solve);
        let start = bodies
            .iter()
            .map(|(_, _, b)| (b.com, b.principal_rotation()))
            .collect();
        let joint_ends: Vec<(usize, usize)> =
            joint_rows.iter().map(|(_, _, j)| (j.a, j.b)).collect();
        let joint_colours = colouring::colour(&joint_ends, &movable);
        let joint_groups = colouring::group(&joint_colours);
        Self {
            joint_colours,
            joint_groups,
            bodies: solver_bodies,
            accel,
            constraints: placed,
            in_pair_order,
            colours,
            groups,
            movable,
            joint_rows,
            start,
            push_velocity: Vec::new(),
            shock,
            wide,
        }
    }

    /// Runs `f` on the contacts' batches with the bodies in their hot
    /// state: loaded before, velocities stored after.
    fn wide_contacts(&mut self, f: impl FnOnce(&mut WideContacts)) {
        if self.wide.is_empty() {
            return;
        }
        self.wide.load(&self.bodies);
        f(&mut self.wide);
        self.wide.store(&mut self.bodies, &self.movable);
    }

    /// Runs `f` on every contact constraint, colour by colour.
    fn contacts(
        &mut self,
        f: impl Fn(&mut ContactConstraint, &mut SolverBody, &mut SolverBody) + Sync,
    ) {
        colouring::solve_coloured(
            &mut self.constraints,
            &self.groups,
            &self.colours,
            |c| (c.a, c.b),
            &mut self.bodies,
            &self.movable,
            f,
        );
    }

    /// Runs `f` on every joint row, colour by colour.
    fn joints(
        &mut self,
        f: impl Fn(&mut JointConstraint, &mut SolverBody, &mut SolverBody) + Sync,
    ) {
        colouring::solve_coloured(
            &mut self.joint_rows,
            &self.joint_groups,
            &self.joint_colours,
            |(_, _, j)| (j.a, j.b),
            &mut self.bodies,
            &self.movable,
            |(_, _, j), a, b| f(j, a, b),
        );
    }

    /// The substeps, then restitution. Returns the bodies quarantined
    /// because their velocity stopped being finite.
    pub(crate) fn run(
        &mut self,
        bodies: &mut Arena<RigidBody>,
        index: &BodyIndex,
        external: &[(DVec3, DVec3)],
        inputs: &StepInputs<'_>,
    ) -> Vec<BodyHandle> {
        let cfg = inputs.cfg;
        let n = cfg.substeps.max(1);
        let h = inputs.dt / f64::from(n);
        let (solve, relax) = (
            ContactPass::new(cfg, h, true),
            ContactPass::new(cfg, h, false),
        );
        let (wide_solve, wide_relax) = (WidePass::new(&solve), WidePass::new(&relax));
        let mut quarantined = Vec::new();
        // The bodies in slot order, so the integration can run over chunks
        // of them in parallel (each body is its own work).
        let mut refs: Vec<&mut RigidBody> = bodies.iter_mut().map(|(_, _, b)| b).collect();
        // Each body's principal rotation at the start, and its push: how
        // far the solver's position correction moved it, m, the sum over
        // the substeps of `h (v_moved - v_relaxed)`, the velocity its
        // position moved with less the one the relax pass left it (which
        // carries no bias). It starts at `h v_0` so that every substep can
        // take off `h v` from before its velocity update (the relaxed
        // velocity of the one before, `v_0` for the first); the last
        // relaxed velocity comes off after the substeps.
        let mut starts: Vec<(DQuat, DVec3)> = self
            .start
            .iter()
            .zip(&self.bodies)
            .map(|(s, sb)| (s.1, sb.v * h))
            .collect();
        // Out of `self` for the substeps, which solve through `self` too.
        let accel = std::mem::take(&mut self.accel);
        for _ in 0..n {
            let frozen = crate::parallel::par_map_chunks3(
                &mut refs,
                &mut self.bodies,
                &mut starts,
                BODIES_PER_ITEM,
                |base, bs, sbs, pushes| {
                    let mut frozen = Vec::new();
                    for (i, ((b, sb), (_, push))) in
                        bs.iter_mut().zip(sbs.iter_mut()).zip(pushes).enumerate()
                    {
                        *push -= sb.v * h;
                        let (accel, torque) = (accel[base + i], external[base + i].1);
                        if !integrate_velocity(b, sb, accel, torque, h) {
                            // Non-finite: freeze it now, before a contact can
                            // carry the bad values to a neighbour.
                            *sb = SolverBody {
                                v: DVec3::ZERO,
                                w: DVec3::ZERO,
                                inv_mass: 0.0,
                                inv_inertia: glam::DMat3::ZERO,
                                ..*sb
                            };
                            b.quarantined = true;
                            frozen.push(base + i);
                        }
                    }
                    frozen
                },
            );
            quarantined.extend(frozen.into_iter().flatten().map(|k| index.handles[k]));
            let joints = !self.joint_rows.is_empty();
            if joints {
                self.joints(|j, a, b| j.warm_start(a, b));
                self.wide_contacts(WideContacts::warm_start);
                self.joints(|j, a, b| j.solve(a, b, h, true));
                self.wide_contacts(|w| w.solve(&wide_solve));
            } else {
                self.wide_contacts(|w| {
                    w.warm_start();
                    w.solve(&wide_solve);
                });
            }
            if !self.shock.is_empty() {
                for k in self.shock.contacts() {
                    self.wide.unpack_one(k, &mut self.constraints[k]);
                }
                self.shock
                    .run(&mut self.constraints, &mut self.bodies, &solve);
            }
            crate::parallel::par_map_chunks3(
                &mut refs,
                &mut self.bodies,
                &mut starts,
                BODIES_PER_ITEM,
                |_, bs, sbs, starts| {
                    for ((b, sb), (q0, push)) in bs.iter_mut().zip(sbs.iter_mut()).zip(starts) {
                        integrate_position(b, sb, *q0, h);
                        *push += sb.v * h;
                    }
                },
            );
            if joints {
                self.joints(|j, a, b| j.solve(a, b, h, false));
            }
            self.wide_contacts(|w| w.solve(&wide_relax));
        }
        self.wide.unpack(&mut self.constraints);
        self.accel = accel;
        self.push_velocity = starts
            .iter()
            .zip(&self.bodies)
            .zip(&self.movable)
            .map(|(((_, push), sb), &movable)| {
                if movable {
                    (*push - sb.v * h) / inputs.dt
                } else {
                    DVec3::ZERO
                }
            })
            .collect();
        let threshold = cfg.restitution_threshold;
        if self.constraints.iter().any(|c| c.restitution != 0.0) {
            self.contacts(|c, a, b| c.restitute(a, b, threshold));
        }
        quarantined
    }
}

/// Renumbers the colouring for constraints stored in the order `groups`
/// solves them in (each colour a run of the vector, so the passes read the
/// constraints front to back, which the memory system streams): the
/// colours and groups as stored, and returns where each constraint of the
/// pair order is stored and, the other way, which one each place holds.
fn into_solve_order(colours: &mut Vec<u8>, groups: &mut colouring::Groups) -> (Vec<u32>, Vec<u32>) {
    let order = std::mem::take(&mut groups.order);
    *colours = order.iter().map(|&k| colours[k as usize]).collect();
    let mut in_pair_order = vec![0u32; order.len()];
    for (at, &k) in order.iter().enumerate() {
        in_pair_order[k as usize] = at as u32;
    }
    groups.order = (0..order.len() as u32).collect();
    (in_pair_order, order)
}

/// The body's acceleration `accel` (m/s², [`linear_accel`]), its scripted
/// and external torques (`torque`, N·m) and damping over one substep.
/// Returns false (changing nothing) if the result is not finite.
fn integrate_velocity(
    b: &RigidBody,
    sb: &mut SolverBody,
    accel: DVec3,
    torque: DVec3,
    h: f64,
) -> bool {
    if b.is_fixed_now() {
        return true;
    }
    let v = (sb.v + accel * h) / (1.0 + h * b.linear_damping);
    let w =
        (sb.w + sb.inv_inertia * ((b.control_torque + torque) * h)) / (1.0 + h * b.angular_damping);
    if !(v.is_finite() && w.is_finite()) {
        return false;
    }
    sb.v = v;
    sb.w = w;
    true
}

/// A body's acceleration from gravity, its scripted force and `force`
/// (the force generators' and attachments'), m/s²; zero for a body the
/// solver leaves where it is (not dynamic, asleep, quarantined).
fn linear_accel(b: &RigidBody, gravity: DVec3, force: DVec3) -> DVec3 {
    if b.is_fixed_now() {
        return DVec3::ZERO;
    }
    gravity * b.gravity_scale + (b.control_force + force) * b.inv_mass
}

/// Moves a body over one substep: translation with its velocity, rotation
/// by the free-body splitting (which also turns the angular velocity the way
/// a spinning body's does). `q0` is its principal rotation at the start of
/// the step.
fn integrate_position(b: &mut RigidBody, sb: &mut SolverBody, q0: DQuat, h: f64) {
    match b.kind {
        BodyKind::Static => {}
        BodyKind::Kinematic => {
            b.com += sb.v * h;
            sb.dp += sb.v * h;
            let angle = sb.w.length() * h;
            if angle > 0.0 {
                b.rotation =
                    (DQuat::from_axis_angle(sb.w / sb.w.length(), angle) * b.rotation).normalize();
            }
            sb.dq = (b.principal_rotation() * q0.inverse()).normalize();
        }
        BodyKind::Dynamic => {
            if b.quarantined || b.sleeping {
                return;
            }
            b.com += sb.v * h;
            sb.dp += sb.v * h;
            let q = b.principal_rotation();
            let inv = b.inv_principal_inertia;
            let q = if inv.x == inv.y && inv.y == inv.z {
                // Equal principal moments (cubes, spheres): a torque-free
                // body keeps its angular velocity and turns about it; one
                // exact rotation.
                if sb.w == DVec3::ZERO {
                    q
                } else {
                    (DQuat::from_scaled_axis(sb.w * h) * q).normalize()
                }
            } else {
                let pi = inv.recip() * (q.inverse() * sb.w);
                let (q, pi) = free_rotation(q, pi, inv, h);
                sb.w = q * (inv * pi);
                q
            };
            b.rotation = (q * b.principal.inverse()).normalize();
            sb.dq = (q * q0.inverse()).normalize();
        }
    }
}
