//! Stage 6: joints keep their impulses or break, contact and force events,
//! the contact cache for the next step, and the bodies' new velocities (or
//! quarantine).

use glam::DVec3;

use super::bodies::BodyIndex;
use super::substeps::Solve;
use super::{
    CachedPoint, ContactEvent, ContactEventKind, ContactForceEvent, ContactKey, Contacts,
    PairContact, RigidStepOut, StepInputs, StepMemory,
};
use crate::arena::Arena;
use crate::handle::{BodyHandle, JointHandle};
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::joint::Joint;
use crate::rigid::solver::ContactConstraint;

/// What the earlier stages found, besides the solver state.
#[derive(Debug)]
pub(crate) struct Found {
    /// Overlapping pairs from the narrow phase, with whether a sensor is involved.
    pub(crate) touching: Vec<((BodyHandle, BodyHandle), bool)>,
    /// Body pairs (keys, sorted) whose cache entries carry over unchanged.
    pub(crate) carried: Vec<((u32, u32), (u32, u32))>,
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
        in_pair_order,
        joint_rows,
        start,
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
    // children next to each other), each read once: what pushed, the pairs
    // in contact, and the impulses to keep.
    let walked = walk(
        in_pair_order.iter().map(|&at| &constraints[at as usize]),
        inputs.dt,
    );

    // Pairs pushed apart count as touching even if they started a hair
    // apart; their total normal force feeds the force events. Both these
    // and the narrow phase's touching pairs are sorted, so they merge in
    // one walk.
    let pushed = walked.pushed;
    let threshold = |h: BodyHandle| {
        bodies
            .get(h.index, h.generation)
            .map_or(f64::MAX, |b| b.contact_force_threshold)
    };
    for &((a, b), force, normal, _) in &pushed {
        if force > threshold(a).min(threshold(b)) {
            out.forces.push(ContactForceEvent {
                a,
                b,
                force,
                normal,
            });
        }
    }
    let touching = merge_touching(found.touching, pushed.iter().map(|p| p.0));
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

    // The pairs in contact, for the rules' queries; pairs that stayed put
    // keep theirs.
    let mut pairs = walked.pairs;
    if !found.carried.is_empty() {
        let mut kept = found.carried.iter().peekable();
        let key = |h: BodyHandle| (h.index, h.generation);
        pairs.extend(contacts.pairs.iter().copied().filter(|p| {
            let k = (key(p.a), key(p.b));
            while kept.next_if(|&&c| c < k).is_some() {}
            kept.peek().is_some_and(|&&c| c == k)
        }));
        pairs.sort_by_key(|p| (key(p.a), key(p.b)));
    }
    contacts.pairs = pairs;

    // The impulses, for the next step's warm start. Pairs that stayed put
    // keep their entries; every other entry is replaced by this step's.
    let fresh = walked.cache;
    if found.carried.is_empty() {
        contacts.cache = fresh.into_iter().collect();
    } else {
        // Both in key order: one walk.
        let mut kept = found.carried.iter().peekable();
        contacts.cache.retain(|k, _| {
            while kept.next_if(|&&p| p < (k.a, k.b)).is_some() {}
            kept.peek().is_some_and(|&&p| p == (k.a, k.b))
        });
        contacts.cache.extend(fresh);
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
            if !frozen {
                b.quarantined = true;
                quarantined.push(index.handles[k]);
            }
        } else if b.kind != BodyKind::Static {
            b.linvel = sb.v;
            b.angvel = sb.w;
        }
    }
    let mut solver_bodies = solver_bodies;
    solver_bodies.clear();
    contacts.memory = StepMemory {
        constraints,
        joint_rows,
        solver_bodies,
    };
    out.start = start;
    out.quarantined = quarantined;
    out
}

/// What finish reads from the constraints.
struct Walked {
    /// Each pair that pushed: the pair, its total normal force (N), the
    /// normal of the manifold that pushed hardest and that one's force.
    pushed: Vec<((BodyHandle, BodyHandle), f64, DVec3, f64)>,
    /// One entry a pair of bodies in contact (a compound's manifolds
    /// merged).
    pairs: Vec<PairContact>,
    /// Each manifold's impulses, for the next step's warm start.
    cache: Vec<(ContactKey, Vec<CachedPoint>)>,
}

/// Reads what finish needs from each constraint (in pair order), once.
fn walk<'a>(
    constraints: impl Iterator<Item = &'a (ContactKey, ContactConstraint)>,
    dt: f64,
) -> Walked {
    let mut w = Walked {
        pushed: Vec::new(),
        pairs: Vec::new(),
        cache: Vec::new(),
    };
    for (key, c) in constraints {
        let (a, b) = (handle(key.a), handle(key.b));
        let impulse = c.total_normal_impulse();
        let total = impulse / dt;
        if total > 0.0 {
            match w.pushed.last_mut() {
                Some(last) if last.0 == (a, b) => {
                    last.1 += total;
                    if total > last.3 {
                        last.2 = c.normal;
                        last.3 = total;
                    }
                }
                _ => w.pushed.push(((a, b), total, c.normal, total)),
            }
        }
        let separation = c.start_separation();
        match w.pairs.last_mut() {
            Some(p) if (p.a, p.b) == (a, b) => {
                let harder = impulse > 0.0 && impulse > p.impulse;
                let deeper = p.impulse == 0.0 && impulse == 0.0 && separation < p.separation;
                if harder || deeper {
                    p.normal = c.normal;
                }
                p.impulse += impulse;
                p.separation = p.separation.min(separation);
                p.points += c.len;
            }
            _ => w.pairs.push(PairContact {
                a,
                b,
                normal: c.normal,
                separation,
                impulse,
                points: c.len,
            }),
        }
        let shares = c.point_tangent_impulses();
        let pts = (0..c.len)
            .map(|i| {
                let (id, anchor_a) = c.point_id(i);
                CachedPoint {
                    id,
                    anchor_a,
                    normal: c.normal_impulse(i),
                    tangent: shares[i],
                }
            })
            .collect();
        w.cache.push((*key, pts));
    }
    w
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
