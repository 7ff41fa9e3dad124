//! One step of the rigid bodies: find contacts, then integrate and solve in
//! substeps.
//!
//! 1. **forces** — body force generators (wind, buoyancy, ...) are evaluated
//!    once, at the start of the step.
//! 2. **broad phase** — each body's box, grown by how far it can move this
//!    step plus the speculative margin, is updated in the dynamic AABB tree;
//!    the overlapping pairs come out sorted.
//! 3. **narrow phase** — each pair (each pair of child shapes for
//!    compounds) gives a manifold; its points take the impulses they had last
//!    step (matched by feature id) for warm starting.
//! 4. **solve** — [`solver`](super::solver) substeps: integrate velocities,
//!    warm start, solve with bias, integrate positions (with the gyroscopic
//!    splitting of [`motion`](super::motion)), relax; then restitution.
//! 5. **store** — impulses go to the contact cache; bodies get their new
//!    state, or are quarantined if it is not finite.
//!
//! Everything iterates in body-handle order and pair order, so the result
//! does not depend on history the state does not record.

use std::collections::{BTreeMap, BTreeSet};

use glam::{DQuat, DVec3};

use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::broad_phase::BroadPhase;
use crate::rigid::contact::Manifold;
use crate::rigid::forces::BodyField;
use crate::rigid::joint::{Joint, JointConstraint};
use crate::rigid::motion::free_rotation;
use crate::rigid::narrow::collide;
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;
use crate::rigid::solver::{
    tangent_basis, ContactConstraint, PointConstraint, SolverBody, SolverConfig,
};

/// Contacts closer than this are kept as speculative points, m.
pub const SPECULATIVE_DISTANCE: f64 = 0.02;
/// Margin of the broad phase's fat boxes, m.
const AABB_MARGIN: f64 = 0.1;

/// Which manifold: the two bodies (handle order) and the child shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct ContactKey {
    pub(crate) a: (u32, u32),
    pub(crate) b: (u32, u32),
    pub(crate) child_a: u32,
    pub(crate) child_b: u32,
}

/// Impulses of one point kept for warm starting, N·s, with where the point
/// was on body A (body frame, m) for matching when feature ids change.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CachedPoint {
    pub(crate) id: u32,
    pub(crate) anchor_a: DVec3,
    pub(crate) normal: f64,
    pub(crate) tangent: [f64; 2],
}

/// A new point with no cached id takes the impulses of a cached point whose
/// anchor on A lies within this distance, m. (Two parallel faces in contact
/// may swap which one is the reference face from one step to the next,
/// which renames every feature id though the contact has not changed.)
const ANCHOR_MATCH_DISTANCE: f64 = 0.02;

/// Whether a pair of bodies started or stopped touching.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactEventKind {
    /// The bodies touch now and did not at the end of the last step.
    Begin,
    /// The bodies touched at the end of the last step and no longer do.
    End,
}

/// A change of contact between two bodies (`a` before `b` in handle order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ContactEvent {
    /// Began or ended.
    pub kind: ContactEventKind,
    /// First body.
    pub a: BodyHandle,
    /// Second body.
    pub b: BodyHandle,
    /// Whether either body is a sensor (an overlap, not a collision).
    pub sensor: bool,
}

/// Two bodies pressed together harder than one of their thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactForceEvent {
    /// First body.
    pub a: BodyHandle,
    /// Second body.
    pub b: BodyHandle,
    /// Total normal force over the step, N.
    pub force: f64,
    /// Its direction, from `a` to `b`, of the largest manifold.
    pub normal: DVec3,
}

/// What the rigid step reports.
#[derive(Debug, Default)]
pub(crate) struct RigidStepOut {
    pub(crate) quarantined: Vec<BodyHandle>,
    pub(crate) broken_joints: Vec<crate::handle::JointHandle>,
    pub(crate) events: Vec<ContactEvent>,
    pub(crate) forces: Vec<ContactForceEvent>,
}

/// Contact state carried from step to step.
#[derive(Debug, Default)]
pub(crate) struct Contacts {
    /// Warm-start impulses per manifold (world state: saved and hashed).
    pub(crate) cache: BTreeMap<ContactKey, Vec<CachedPoint>>,
    /// Pairs touching at the end of the last step, for begin/end events
    /// (world state: saved and hashed).
    pub(crate) touching: std::collections::BTreeSet<(BodyHandle, BodyHandle)>,
    /// The broad phase; derived from the bodies and rebuilt after a restore.
    broad: Option<BroadPhase>,
    /// Deepest overlap the last step's narrow phase found between two
    /// bodies (not sensors), m; 0 when nothing overlapped. A diagnostic,
    /// derived: not saved.
    pub(crate) deepest_penetration: f64,
}

impl Contacts {
    /// Forgets the broad phase (after a restore or a removal it is rebuilt).
    pub(crate) fn reset_broad_phase(&mut self) {
        self.broad = None;
    }

    /// Drops everything about a removed body.
    pub(crate) fn forget(&mut self, h: BodyHandle) {
        let id = (h.index, h.generation);
        self.cache.retain(|k, _| k.a != id && k.b != id);
        self.touching.retain(|(a, b)| *a != h && *b != h);
        self.broad = None;
    }

    /// Number of manifolds touching last step.
    pub(crate) fn manifold_count(&self) -> usize {
        self.cache.len()
    }
}

/// The leaf shapes of a shape with their poses in the body frame.
fn leaves<'a>(shape: &'a Shape, pose: Pose, out: &mut Vec<(Pose, &'a Shape)>) {
    match shape {
        Shape::Compound(parts) => {
            for (p, child) in parts.iter() {
                leaves(child, pose.mul(p), out);
            }
        }
        s => out.push((pose, s)),
    }
}

/// How far apart two bodies' contact points are still kept, m: the fixed
/// margin plus how far they close in on each other this step. For ordinary
/// bodies the closing part is capped at their size (a fast body may then pass
/// through something thin, as in most engines); with `ccd` on either body it
/// is not capped, so the body is stopped at the first surface in its path.
fn speculative_distance(a: &RigidBody, b: &RigidBody, dt: f64) -> f64 {
    let closing = (a.linvel - b.linvel).length() * dt;
    let cap = if a.ccd || b.ccd {
        f64::INFINITY
    } else {
        a.shape_radius().max(b.shape_radius())
    };
    SPECULATIVE_DISTANCE + closing.min(cap)
}

/// Whether any leaf of `a` comes within `speculative` of any leaf of `b`.
fn shapes_near(a: &Shape, pose_a: &Pose, b: &Shape, pose_b: &Pose, speculative: f64) -> bool {
    let (mut la, mut lb) = (Vec::new(), Vec::new());
    leaves(a, Pose::IDENTITY, &mut la);
    leaves(b, Pose::IDENTITY, &mut lb);
    la.iter().any(|(pa, sa)| {
        lb.iter().any(|(pb, sb)| {
            collide(sa, &pose_a.mul(pa), sb, &pose_b.mul(pb), speculative)
                .is_ok_and(|m| !m.is_empty())
        })
    })
}

/// What the rigid step reads besides the bodies, joints and contacts.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepInputs<'a> {
    /// Body force generators, compiled.
    pub(crate) field: &'a BodyField,
    /// Uniform gravity, m/s².
    pub(crate) gravity: DVec3,
    /// Solver settings.
    pub(crate) cfg: &'a SolverConfig,
    /// Extra force (N) and torque (N·m) per body, e.g. from attachments.
    pub(crate) extra: &'a BTreeMap<BodyHandle, (DVec3, DVec3)>,
    /// The step, s.
    pub(crate) dt: f64,
}

/// Advances every body by `dt`: contacts, joints, motion, events.
pub(crate) fn step(
    bodies: &mut Arena<RigidBody>,
    joints: &mut Arena<Joint>,
    contacts: &mut Contacts,
    inputs: StepInputs<'_>,
) -> RigidStepOut {
    let StepInputs {
        field,
        gravity,
        cfg,
        extra,
        dt,
    } = inputs;
    // 1. Forces, from the state at the start of the step.
    let handles: Vec<BodyHandle> = bodies
        .iter()
        .map(|(index, generation, _)| BodyHandle { index, generation })
        .collect();
    let external: Vec<(DVec3, DVec3)> = bodies
        .iter()
        .map(|(index, generation, b)| {
            let (f, t) = field.force_and_torque(b);
            let (ef, et) = extra
                .get(&BodyHandle { index, generation })
                .copied()
                .unwrap_or_default();
            (f + ef, t + et)
        })
        .collect();

    // Sleeping bodies touched by awake ones wake up (through whole stacks
    // and along joints).
    let joint_links: BTreeSet<(BodyHandle, BodyHandle)> = joints
        .iter()
        .map(|(_, _, j)| (j.desc.a.min(j.desc.b), j.desc.a.max(j.desc.b)))
        .collect();
    let links =
        |touching: &BTreeSet<(BodyHandle, BodyHandle)>| -> BTreeSet<(BodyHandle, BodyHandle)> {
            touching.union(&joint_links).copied().collect()
        };
    crate::rigid::island::wake_touched(bodies, &links(&contacts.touching));

    // 2. Broad phase.
    let broad = contacts
        .broad
        .get_or_insert_with(|| BroadPhase::new(AABB_MARGIN).expect("valid margin"));
    let mut present = Vec::with_capacity(handles.len());
    for (_, _, b) in bodies.iter() {
        present.push(b.shape.is_some());
    }
    let slot_of: BTreeMap<u32, usize> = handles
        .iter()
        .enumerate()
        .map(|(k, h)| (h.index, k))
        .collect();
    for key in broad
        .proxies()
        .into_iter()
        .map(|(k, _, _)| k)
        .collect::<Vec<_>>()
    {
        if slot_of.get(&key).is_none_or(|&k| !present[k]) {
            let _ = broad.remove(key);
        }
    }
    for (k, (_, _, b)) in bodies.iter().enumerate() {
        let Some(shape) = &b.shape else { continue };
        let reach =
            (b.linvel.length() + b.angvel.length() * b.shape_radius()) * dt + SPECULATIVE_DISTANCE;
        let aabb = shape.aabb(&b.pose()).expanded(reach);
        let key = handles[k].index;
        let is_static = b.kind == BodyKind::Static;
        let ok = if broad.contains(key) {
            broad.update(key, aabb, b.linvel * dt).is_ok()
        } else {
            broad.insert(key, aabb, is_static).is_ok()
        };
        if !ok {
            let _ = broad.remove(key);
        }
    }
    broad.update_pairs();

    // An awake body about to hit a sleeping one wakes it (and, through the
    // contacts it rests on, its island) before anything is solved.
    let mut to_wake = Vec::new();
    for pair in broad.pairs() {
        let (Some(&ia), Some(&ib)) = (slot_of.get(&pair.a), slot_of.get(&pair.b)) else {
            continue;
        };
        let (Some(ba), Some(bb)) = (
            bodies.get(handles[ia].index, handles[ia].generation),
            bodies.get(handles[ib].index, handles[ib].generation),
        ) else {
            continue;
        };
        let awake_dynamic =
            |b: &RigidBody| b.kind == BodyKind::Dynamic && !b.sleeping && !b.quarantined;
        let sleeper = if ba.sleeping && awake_dynamic(bb) {
            ia
        } else if bb.sleeping && awake_dynamic(ba) {
            ib
        } else {
            continue;
        };
        if ba.sensor || bb.sensor {
            continue;
        }
        let speculative = speculative_distance(ba, bb, dt);
        let hit = match (&ba.shape, &bb.shape) {
            (Some(sa), Some(sb)) => shapes_near(sa, &ba.pose(), sb, &bb.pose(), speculative),
            _ => false,
        };
        if hit {
            to_wake.push(handles[sleeper]);
        }
    }
    if !to_wake.is_empty() {
        for h in &to_wake {
            if let Some(b) = bodies.get_mut(h.index, h.generation) {
                b.wake();
            }
        }
        crate::rigid::island::wake_touched(bodies, &links(&contacts.touching));
    }

    // 3. Narrow phase.
    let body_list: Vec<&RigidBody> = bodies.iter().map(|(_, _, b)| b).collect();
    let mut solver_bodies: Vec<SolverBody> = body_list
        .iter()
        .map(|b| SolverBody {
            v: b.linvel,
            w: b.angvel,
            inv_mass: if b.is_fixed_now() { 0.0 } else { b.inv_mass },
            inv_inertia: if !b.is_fixed_now() {
                b.inverse_inertia_world()
            } else {
                glam::DMat3::ZERO
            },
            dp: DVec3::ZERO,
            dq: DQuat::IDENTITY,
        })
        .collect();
    let mut constraints: Vec<(ContactKey, ContactConstraint)> = Vec::new();
    // Pairs touching this step, with whether either body is a sensor.
    let mut touching: BTreeMap<(BodyHandle, BodyHandle), bool> = BTreeMap::new();
    // Contacts between bodies that all stay put this step (asleep, static)
    // are not recomputed: their cache and touching state carry over.
    let mut carried: Vec<(ContactKey, Vec<CachedPoint>)> = Vec::new();
    let mut deepest = 0.0_f64;
    for pair in broad.pairs() {
        let (Some(&ia), Some(&ib)) = (slot_of.get(&pair.a), slot_of.get(&pair.b)) else {
            continue;
        };
        let (ba, bb) = (body_list[ia], body_list[ib]);
        let sensor = ba.sensor || bb.sensor;
        if ba.inv_mass == 0.0 && bb.inv_mass == 0.0 && !sensor {
            continue;
        }
        // Bodies joined by a joint do not collide with each other.
        if joint_links.contains(&(handles[ia].min(handles[ib]), handles[ia].max(handles[ib]))) {
            continue;
        }
        if ba.is_fixed_now() && bb.is_fixed_now() && !sensor {
            let (ka, kb) = (
                (handles[ia].index, handles[ia].generation),
                (handles[ib].index, handles[ib].generation),
            );
            carried.extend(
                contacts
                    .cache
                    .iter()
                    .filter(|(k, _)| k.a == ka && k.b == kb)
                    .map(|(k, v)| (*k, v.clone())),
            );
            if contacts.touching.contains(&(handles[ia], handles[ib])) {
                touching.insert((handles[ia], handles[ib]), false);
            }
            continue;
        }
        let (Some(sa), Some(sb)) = (&ba.shape, &bb.shape) else {
            continue;
        };
        let speculative = speculative_distance(ba, bb, dt);
        let (pose_a, pose_b) = (ba.pose(), bb.pose());
        let (mut la, mut lb) = (Vec::new(), Vec::new());
        leaves(sa, Pose::IDENTITY, &mut la);
        leaves(sb, Pose::IDENTITY, &mut lb);
        for (ca, (pa, shape_a)) in la.iter().enumerate() {
            for (cb, (pb, shape_b)) in lb.iter().enumerate() {
                let Ok(m) = collide(
                    shape_a,
                    &pose_a.mul(pa),
                    shape_b,
                    &pose_b.mul(pb),
                    speculative,
                ) else {
                    continue;
                };
                if m.is_empty() {
                    continue;
                }
                if m.min_separation().is_some_and(|s| s <= 0.0) {
                    touching.insert((handles[ia], handles[ib]), sensor);
                }
                if sensor {
                    // Sensors only report: no constraint.
                    continue;
                }
                if let Some(sep) = m.min_separation() {
                    deepest = deepest.max(-sep);
                }
                let key = ContactKey {
                    a: (handles[ia].index, handles[ia].generation),
                    b: (handles[ib].index, handles[ib].generation),
                    child_a: ca as u32,
                    child_b: cb as u32,
                };
                let cached = contacts.cache.get(&key);
                let c = constraint(ia, ib, ba, bb, pa, pb, &m, cached);
                constraints.push((key, c));
            }
        }
    }

    // Joints between bodies that still exist, with one side free to move.
    let slot = |h: BodyHandle| slot_of.get(&h.index).copied().filter(|&k| handles[k] == h);
    let mut joint_rows: Vec<(u32, u32, JointConstraint)> = Vec::new();
    for (index, generation, j) in joints.iter() {
        let (Some(ia), Some(ib)) = (slot(j.desc.a), slot(j.desc.b)) else {
            continue;
        };
        let (ba, bb) = (body_list[ia], body_list[ib]);
        if ba.is_fixed_now() && bb.is_fixed_now() {
            continue;
        }
        let (pa, pb) = (
            ba.pose().transform_point(j.desc.anchor_a),
            bb.pose().transform_point(j.desc.anchor_b),
        );
        joint_rows.push((
            index,
            generation,
            JointConstraint {
                a: ia,
                b: ib,
                ra: pa - ba.com,
                rb: pb - bb.com,
                base_offset: pb - pa,
                qa0: ba.rotation,
                qb0: bb.rotation,
                joint: j.clone(),
            },
        ));
    }

    // 4. Solve in substeps.
    let n = cfg.substeps.max(1);
    let h = dt / f64::from(n);
    for (_, c) in &mut constraints {
        c.prepare(&solver_bodies, cfg.stick_speed);
    }
    let start: Vec<(DVec3, DQuat)> = body_list
        .iter()
        .map(|b| (b.com, b.principal_rotation()))
        .collect();
    drop(body_list);
    let mut quarantined = Vec::new();
    for _ in 0..n {
        for (k, (_, _, b)) in bodies.iter_mut().enumerate() {
            let sb = &mut solver_bodies[k];
            if !integrate_velocity(b, sb, gravity, external[k].0, external[k].1, h) {
                // Non-finite: freeze it now, before a contact can carry the
                // bad values to a neighbour.
                *sb = SolverBody {
                    v: DVec3::ZERO,
                    w: DVec3::ZERO,
                    inv_mass: 0.0,
                    inv_inertia: glam::DMat3::ZERO,
                    ..*sb
                };
                b.quarantined = true;
                quarantined.push(handles[k]);
            }
        }
        for (_, _, j) in &joint_rows {
            j.warm_start(&mut solver_bodies);
        }
        for (_, c) in &constraints {
            c.warm_start(&mut solver_bodies);
        }
        for (_, _, j) in &mut joint_rows {
            j.solve(&mut solver_bodies, h, true);
        }
        for (_, c) in &mut constraints {
            c.solve(&mut solver_bodies, cfg, h, true);
        }
        for ((_, _, b), (sb, s)) in bodies.iter_mut().zip(solver_bodies.iter_mut().zip(&start)) {
            integrate_position(b, sb, s.1, h);
        }
        for (_, _, j) in &mut joint_rows {
            j.solve(&mut solver_bodies, h, false);
        }
        for (_, c) in &mut constraints {
            c.solve(&mut solver_bodies, cfg, h, false);
        }
    }
    // Joints keep their impulses for the next step, or break.
    let mut out = RigidStepOut::default();
    for (index, generation, row) in joint_rows {
        let breaks = row.joint.force(h) > row.joint.desc.break_force;
        if breaks {
            joints.remove(index, generation);
            out.broken_joints
                .push(crate::handle::JointHandle { index, generation });
        } else if let Some(j) = joints.get_mut(index, generation) {
            *j = row.joint;
        }
    }
    for (_, c) in &mut constraints {
        c.restitute(&mut solver_bodies, cfg.restitution_threshold);
    }

    // Pairs pushed apart count as touching even if they started a hair apart;
    // their total normal force feeds the force events.
    let mut pair_force: BTreeMap<(BodyHandle, BodyHandle), (f64, DVec3, f64)> = BTreeMap::new();
    for (key, c) in &constraints {
        let total: f64 = c.points.iter().map(|p| p.normal_impulse).sum::<f64>() * f64::from(n) / dt;
        if total <= 0.0 {
            continue;
        }
        let pair_key = (
            BodyHandle {
                index: key.a.0,
                generation: key.a.1,
            },
            BodyHandle {
                index: key.b.0,
                generation: key.b.1,
            },
        );
        touching.entry(pair_key).or_insert(false);
        let e = pair_force.entry(pair_key).or_insert((0.0, c.normal, 0.0));
        e.0 += total;
        if total > e.2 {
            e.1 = c.normal;
            e.2 = total;
        }
    }
    let threshold = |h: BodyHandle| {
        bodies
            .get(h.index, h.generation)
            .map_or(f64::MAX, |b| b.contact_force_threshold)
    };
    for (&(a, b), &(force, normal, _)) in &pair_force {
        if force > threshold(a).min(threshold(b)) {
            out.forces.push(ContactForceEvent {
                a,
                b,
                force,
                normal,
            });
        }
    }
    for (&(a, b), &sensor) in &touching {
        if !contacts.touching.contains(&(a, b)) {
            out.events.push(ContactEvent {
                kind: ContactEventKind::Begin,
                a,
                b,
                sensor,
            });
        }
    }
    for &(a, b) in &contacts.touching {
        if !touching.contains_key(&(a, b)) {
            let sensor = [a, b]
                .iter()
                .any(|h| bodies.get(h.index, h.generation).is_some_and(|x| x.sensor));
            out.events.push(ContactEvent {
                kind: ContactEventKind::End,
                a,
                b,
                sensor,
            });
        }
    }
    contacts.touching = touching.keys().copied().collect();
    contacts.deepest_penetration = deepest;

    // 5. Store.
    contacts.cache = constraints
        .iter()
        .map(|(key, c)| {
            let pts = c
                .points
                .iter()
                .map(|p| CachedPoint {
                    id: p.id,
                    anchor_a: p.anchor_a,
                    normal: p.normal_impulse,
                    tangent: p.tangent_impulse,
                })
                .collect();
            (*key, pts)
        })
        .chain(carried)
        .collect();
    for (k, (_, _, b)) in bodies.iter_mut().enumerate() {
        let sb = &solver_bodies[k];
        let ok =
            b.com.is_finite() && b.rotation.is_finite() && sb.v.is_finite() && sb.w.is_finite();
        if b.quarantined && quarantined.contains(&handles[k]) {
            b.com = start[k].0;
            b.rotation = (start[k].1 * b.principal.inverse()).normalize();
            b.linvel = DVec3::ZERO;
            b.angvel = DVec3::ZERO;
        } else if !ok {
            b.com = start[k].0;
            b.rotation = (start[k].1 * b.principal.inverse()).normalize();
            b.linvel = DVec3::ZERO;
            b.angvel = DVec3::ZERO;
            b.quarantined = true;
            quarantined.push(handles[k]);
        } else if b.kind != BodyKind::Static {
            b.linvel = sb.v;
            b.angvel = sb.w;
        }
    }
    crate::rigid::island::update(bodies, &links(&contacts.touching), &cfg.sleep, dt);
    out.quarantined = quarantined;
    out
}

/// The constraint for one manifold, warm-started from `cached`.
#[allow(clippy::too_many_arguments)]
fn constraint(
    ia: usize,
    ib: usize,
    a: &RigidBody,
    b: &RigidBody,
    child_a: &Pose,
    child_b: &Pose,
    m: &Manifold,
    cached: Option<&Vec<CachedPoint>>,
) -> ContactConstraint {
    let (pose_a, pose_b) = (a.pose().mul(child_a), b.pose().mul(child_b));
    let n = m.normal;
    let points = m
        .points
        .iter()
        .map(|p| {
            let (wa, wb) = (
                pose_a.transform_point(p.local_a),
                pose_b.transform_point(p.local_b),
            );
            let (ra, rb) = (wa - a.com, wb - b.com);
            let anchor_a = child_a.transform_point(p.local_a);
            let warm = cached.and_then(|c| {
                c.iter().find(|q| q.id == p.id).or_else(|| {
                    c.iter()
                        .map(|q| (q, (q.anchor_a - anchor_a).length()))
                        .filter(|(_, d)| *d < ANCHOR_MATCH_DISTANCE)
                        .min_by(|x, y| x.1.total_cmp(&y.1))
                        .map(|(q, _)| q)
                })
            });
            PointConstraint {
                ra,
                rb,
                base_separation: p.separation - n.dot(rb - ra),
                normal_impulse: warm.map_or(0.0, |q| q.normal),
                tangent_impulse: warm.map_or([0.0; 2], |q| q.tangent),
                id: p.id,
                anchor_a,
                ..Default::default()
            }
        })
        .collect();
    ContactConstraint {
        a: ia,
        b: ib,
        normal: n,
        tangents: tangent_basis(n),
        friction_static: (a.friction_static * b.friction_static).sqrt(),
        friction_dynamic: (a.friction_dynamic * b.friction_dynamic).sqrt(),
        restitution: a.restitution.max(b.restitution),
        points,
    }
}

/// Gravity, external and scripted forces and damping over one substep.
/// Returns false (changing nothing) if the result is not finite.
fn integrate_velocity(
    b: &RigidBody,
    sb: &mut SolverBody,
    gravity: DVec3,
    force: DVec3,
    torque: DVec3,
    h: f64,
) -> bool {
    if b.kind != BodyKind::Dynamic || b.quarantined || b.sleeping {
        return true;
    }
    let accel = gravity * b.gravity_scale + (b.control_force + force) * b.inv_mass;
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
            let inertia = b.inv_principal_inertia.recip();
            let pi = inertia * (q.inverse() * sb.w);
            let (q, pi) = free_rotation(q, pi, b.inv_principal_inertia, h);
            sb.w = q * (b.inv_principal_inertia * pi);
            b.rotation = (q * b.principal.inverse()).normalize();
            sb.dq = (q * q0.inverse()).normalize();
        }
    }
}
