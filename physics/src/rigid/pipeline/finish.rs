//! Stage 6: joints keep their impulses or break, contact and force events,
//! the contact cache for the next step, and the bodies' new velocities (or
//! quarantine).

use glam::DVec3;

use super::substeps::Solve;
use super::{
    CachedManifold, ContactEvent, ContactEventKind, ContactForceEvent, ContactKey, Contacts,
    PairContact, RigidStepOut, StepInputs, StepMemory,
};
use crate::arena::Arena;
use crate::handle::{BodyHandle, JointHandle};
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::body_index::BodyIndex;
use crate::rigid::joint::Joint;
use crate::rigid::solver::ContactConstraint;

/// What the earlier stages found, besides the solver state.
#[derive(Debug)]
pub(crate) struct Found {
    /// The manifolds with points, in pair order.
    pub(crate) manifolds: super::manifolds::FoundManifolds,
    /// Overlapping pairs from the narrow phase, with whether a sensor is involved.
    pub(crate) touching: Vec<((BodyHandle, BodyHandle), bool)>,
    /// Body pairs (keys, sorted) whose cache entries carry over unchanged.
    pub(crate) carried: Vec<((u32, u32), (u32, u32))>,
    /// Deepest overlap, m.
    pub(crate) deepest: f64,
    /// Bodies quarantined during the substeps.
    pub(crate) quarantined: Vec<BodyHandle>,
}

pub(crate) fn finish(
    bodies: &mut Arena<RigidBody>,
    joints: &mut Arena<Joint>,
    contacts: &mut Contacts,
    index: &BodyIndex,
    solve: Solve,
    found: Found,
    inputs: &StepInputs<'_>,
) -> RigidStepOut {
    let mut out = RigidStepOut::default();
    let n = inputs.cfg.substeps.max(1);
    let h = inputs.dt / f64::from(n);
    let Solve {
        bodies: solver_bodies,
        constraints,
        in_pair_order,
        joint_rows,
        start,
        push_velocity,
        wide,
        ..
    } = solve;

    // Joints keep their impulses for the next step, or break.
    let mut joint_rows = joint_rows;
    for (jindex, generation, row) in joint_rows.drain(..) {
        if row.joint.force(h) > row.joint.desc.break_force {
            joints.remove(jindex, generation);
            out.broken_joints.push(JointHandle {
                index: jindex,
                generation,
            });
        } else if let Some(j) = joints.get_mut(jindex, generation) {
            *j = row.joint;
        }
    }

    // One walk over the constraints in pair order (a pair's compound
    // children next to each other), each read once: the impulses to keep,
    // and what the pairs in contact (and so those that pushed) are read
    // from.
    let mut manifolds = found.manifolds;
    let fresh = walk(
        in_pair_order.len(),
        manifolds
            .take_kept()
            .zip(&in_pair_order)
            .map(|((key, kept), &at)| (key, kept, &constraints[at as usize])),
    );

    // Pairs pushed apart count as touching even if they started a hair
    // apart; their total normal force feeds the force events. Both these
    // and the narrow phase's touching pairs are sorted, so they merge in
    // one walk.
    let pairs: Vec<PairContact> =
        super::cache::pair_contacts(fresh.iter().map(|(k, m)| (k, m)), bodies).collect();
    let pushed = || pairs.iter().filter(|p| p.impulse > 0.0);
    let threshold = |h: BodyHandle| {
        bodies
            .get(h.index, h.generation)
            .map_or(f64::MAX, |b| b.contact_force_threshold)
    };
    for p in pushed() {
        let force = p.impulse / inputs.dt;
        if force > threshold(p.a).min(threshold(p.b)) {
            out.forces.push(ContactForceEvent {
                a: p.a,
                b: p.b,
                force,
                normal: p.normal,
            });
        }
    }
    let touching = merge_touching(found.touching, pushed().map(|p| (p.a, p.b)));
    // Begin: touching now, not before; end: before, not now.
    let mut before = contacts.touching.iter().peekable();
    for &(pair, sensor) in &touching {
        while before.next_if(|&&old| old < pair).is_some() {}
        if before.next_if(|&&old| old == pair).is_none() {
            out.events.push(ContactEvent {
                kind: ContactEventKind::Begin,
                a: pair.0,
                b: pair.1,
                sensor,
            });
        }
    }
    let mut now = touching.iter().map(|t| t.0).peekable();
    for &(a, b) in &contacts.touching {
        while now.next_if(|&p| p < (a, b)).is_some() {}
        if now.next_if(|&p| p == (a, b)).is_none() {
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
    contacts.touching = touching.into_iter().map(|t| t.0).collect();
    contacts.deepest_penetration = found.deepest;

    // The impulses, for the next step's warm start and the rules' pair
    // queries. Pairs that stayed put keep their entries; every other entry
    // is replaced by this step's.
    if found.carried.is_empty() {
        contacts.cache = super::ContactCache::new(fresh);
    } else {
        // Both in key order: one walk.
        let mut kept = found.carried.iter().peekable();
        contacts.cache.retain(|k| {
            while kept.next_if(|&&p| p < (k.a, k.b)).is_some() {}
            kept.peek().is_some_and(|&&p| p == (k.a, k.b))
        });
        contacts.cache.merge(fresh);
    }
    let mut constraints = constraints;
    constraints.clear();

    // New velocities, or quarantine where the state is not finite.
    let mut quarantined = found.quarantined;
    for (k, (_, _, b)) in bodies.iter_mut().enumerate() {
        let sb = &solver_bodies[k];
        let finite =
            b.com.is_finite() && b.rotation.is_finite() && sb.v.is_finite() && sb.w.is_finite();
        let frozen = b.quarantined && quarantined.contains(&index.handles[k]);
        if frozen || !finite {
            b.com = start[k].0;
            b.rotation = (start[k].1 * b.principal.inverse()).normalize();
            b.linvel = DVec3::ZERO;
            b.angvel = DVec3::ZERO;
            b.push_velocity = DVec3::ZERO;
            if !frozen {
                b.quarantined = true;
                quarantined.push(index.handles[k]);
            }
        } else if b.kind != BodyKind::Static {
            b.linvel = sb.v;
            b.angvel = sb.w;
            b.push_velocity = push_velocity[k];
        }
    }
    let mut solver_bodies = solver_bodies;
    solver_bodies.clear();
    contacts.memory = StepMemory {
        constraints,
        joint_rows,
        solver_bodies,
        found: manifolds.into_memory(),
        wide,
    };
    out.start = start;
    out.quarantined = quarantined;
    out
}

/// Each of the `count` manifolds (in pair order) with the impulses its
/// solved constraint ended the step with, for the next step's warm start,
/// and what the pair queries read of it: its impulse over the step and its
/// separation at the start.
fn walk<'a>(
    count: usize,
    manifolds: impl Iterator<Item = (ContactKey, CachedManifold, &'a ContactConstraint)>,
) -> Vec<(ContactKey, CachedManifold)> {
    let mut cache = Vec::with_capacity(count);
    for (key, mut kept, c) in manifolds {
        kept.impulse = c.total_normal_impulse() as f32;
        kept.separation = c.start_separation() as f32;
        let shares = c.point_tangent_impulses();
        for (i, p) in kept.points.iter_mut().enumerate() {
            p.normal = c.normal_impulse(i) as f32;
            p.tangent = shares[i].map(|t| t as f32);
        }
        cache.push((key, kept));
    }
    cache
}

/// The union of the narrow phase's touching pairs (sorted, with their
/// sensor flag) and the pairs that pushed (sorted), sorted, each pair once.
fn merge_touching(
    found: Vec<((BodyHandle, BodyHandle), bool)>,
    pushed: impl Iterator<Item = (BodyHandle, BodyHandle)>,
) -> Vec<((BodyHandle, BodyHandle), bool)> {
    let mut out = Vec::with_capacity(found.len());
    let mut pushed = pushed.peekable();
    for (pair, sensor) in found {
        while let Some(p) = pushed.next_if(|&p| p < pair) {
            out.push((p, false));
        }
        pushed.next_if(|&p| p == pair);
        out.push((pair, sensor));
    }
    out.extend(pushed.map(|p| (p, false)));
    out
}
