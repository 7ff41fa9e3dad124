//! Stage 6: joints keep their impulses or break, contact and force events,
//! the contact cache for the next step, and the bodies' new velocities (or
//! quarantine).

use std::collections::BTreeMap;

use glam::DVec3;

use super::bodies::BodyIndex;
use super::substeps::Solve;
use super::{
    CachedPoint, ContactEvent, ContactEventKind, ContactForceEvent, ContactKey, Contacts,
    RigidStepOut, StepInputs,
};
use crate::arena::Arena;
use crate::handle::{BodyHandle, JointHandle};
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::joint::Joint;

/// What the earlier stages found, besides the solver state.
#[derive(Debug)]
pub(crate) struct Found {
    /// Overlapping pairs from the narrow phase, with whether a sensor is involved.
    pub(crate) touching: Vec<((BodyHandle, BodyHandle), bool)>,
    /// Cache entries carried over unchanged.
    pub(crate) carried: Vec<(ContactKey, Vec<CachedPoint>)>,
    /// Deepest overlap, m.
    pub(crate) deepest: f64,
    /// Bodies quarantined during the substeps.
    pub(crate) quarantined: Vec<BodyHandle>,
}

fn handle((index, generation): (u32, u32)) -> BodyHandle {
    BodyHandle { index, generation }
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
        joint_rows,
        start,
        ..
    } = solve;

    // Joints keep their impulses for the next step, or break.
    for (jindex, generation, row) in joint_rows {
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

    // Pairs pushed apart count as touching even if they started a hair
    // apart; their total normal force feeds the force events.
    let mut touching: BTreeMap<(BodyHandle, BodyHandle), bool> =
        found.touching.into_iter().collect();
    let mut pair_force: BTreeMap<(BodyHandle, BodyHandle), (f64, DVec3, f64)> = BTreeMap::new();
    for (key, c) in &constraints {
        let total: f64 = c
            .points()
            .iter()
            .map(|p| p.total_normal_impulse)
            .sum::<f64>()
            / inputs.dt;
        if total <= 0.0 {
            continue;
        }
        let pair_key = (handle(key.a), handle(key.b));
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
    contacts.touching = touching.into_keys().collect();
    contacts.deepest_penetration = found.deepest;

    // The impulses, for the next step's warm start.
    contacts.cache = constraints
        .iter()
        .map(|(key, c)| {
            let shares = c.point_tangent_impulses();
            let pts = c
                .points()
                .iter()
                .zip(shares)
                .map(|(p, tangent)| CachedPoint {
                    id: p.id,
                    anchor_a: p.anchor_a,
                    normal: p.normal_impulse(),
                    tangent,
                })
                .collect();
            (*key, pts)
        })
        .chain(found.carried)
        .collect();

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
            if !frozen {
                b.quarantined = true;
                quarantined.push(index.handles[k]);
            }
        } else if b.kind != BodyKind::Static {
            b.linvel = sb.v;
            b.angvel = sb.w;
        }
    }
    out.quarantined = quarantined;
    out
}
