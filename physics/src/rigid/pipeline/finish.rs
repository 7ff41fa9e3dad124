//! Stage 6: joints keep their impulses or break, contact and force events,
//! the contact cache for the next step, and the bodies' new velocities (or
//! quarantine).

use glam::DVec3;

use super::bodies::BodyIndex;
use super::substeps::Solve;
use super::{
    CachedManifold, ContactEvent, ContactEventKind, ContactForceEvent, ContactKey, Contacts,
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
    /// The manifolds with points, in pair order.
    pub(crate) manifolds: super::manifolds::Found,
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
    // children next to each other), each read once: the pairs in contact
    // (and so those that pushed) and the impulses to keep.
    let mut manifolds = found.manifolds;
    let walked = walk(
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
    let pushed = || walked.pairs.iter().filter(|p| p.impulse > 0.0);
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

/// What finish reads from the constraints.
struct Walked {
    /// One entry a pair of bodies with a manifold (a compound's manifolds
    /// merged), in pair order; those with an impulse pushed.
    pairs: Vec<PairContact>,
    /// Each manifold with its impulses, for the next step.
    cache: Vec<(ContactKey, CachedManifold)>,
}

/// Reads what finish needs from each of the `count` manifolds and its
/// solved constraint (in pair order), once.
fn walk<'a>(
    count: usize,
    manifolds: impl Iterator<Item = (ContactKey, CachedManifold, &'a ContactConstraint)>,
) -> Walked {
    let mut w = Walked {
        pairs: Vec::with_capacity(count),
        cache: Vec::with_capacity(count),
    };
    // The impulse of the hardest-pushing manifold of the last pair, N·s.
    let mut hardest = 0.0;
    for (key, mut kept, c) in manifolds {
        let (a, b) = (handle(key.a), handle(key.b));
        let impulse = c.total_normal_impulse();
        let separation = c.start_separation();
        match w.pairs.last_mut() {
            Some(p) if (p.a, p.b) == (a, b) => {
                // The normal of the manifold that pushed hardest; while
                // none has pushed, of the deepest.
                let harder = impulse > hardest;
                let deeper = hardest == 0.0 && impulse == 0.0 && separation < p.separation;
                if harder || deeper {
                    p.normal = c.normal;
                }
                hardest = f64::max(hardest, impulse);
                p.impulse += impulse;
                p.separation = p.separation.min(separation);
                p.points += c.len;
            }
            _ => {
                hardest = impulse;
                w.pairs.push(PairContact {
                    a,
                    b,
                    normal: c.normal,
                    separation,
                    impulse,
                    points: c.len,
                });
            }
        }
        let shares = c.point_tangent_impulses();
        for (i, p) in kept.points.iter_mut().enumerate() {
            p.normal = c.normal_impulse(i);
            p.tangent = shares[i];
        }
        w.cache.push((key, kept));
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

#[cfg(test)]
mod tests {
    use super::super::CachedPoint;
    use super::*;
    use crate::rigid::solver::{ContactSource, PointConstraint, MAX_POINTS};

    /// A one-point manifold between bodies 1 and 2 (child `child`) along
    /// `normal` that pushed with `impulse` N·s.
    fn manifold(
        child: u32,
        normal: DVec3,
        impulse: f64,
    ) -> (ContactKey, CachedManifold, ContactConstraint) {
        let key = ContactKey {
            a: (1, 0),
            b: (2, 0),
            child_a: child,
            child_b: 0,
        };
        let mut points = [PointConstraint::default(); MAX_POINTS];
        points[0] = PointConstraint::new(DVec3::ZERO, DVec3::ZERO, 0.0, [0.0; 2]);
        let mut c = ContactConstraint::new(&ContactSource {
            ends: (0, 1),
            normal,
            materials: (0.5, 0.5, 0.0),
            points,
            len: 1,
        });
        c.rows.total_impulse[0] = impulse;
        let kept = CachedManifold {
            normal_a: normal,
            reference: None,
            points: vec![CachedPoint {
                id: 0,
                anchor_a: DVec3::ZERO,
                anchor_b: DVec3::ZERO,
                gap: 0.0,
                normal: 0.0,
                tangent: [0.0; 2],
            }],
        };
        (key, kept, c)
    }

    /// A compound pressed on through several manifolds reports the normal
    /// of the one that pushed hardest, not of the first whose impulse
    /// outgrew the sum so far; the pair's impulse is their sum.
    #[test]
    fn issue_13_a_pair_contact_takes_the_normal_of_its_hardest_manifold() {
        let found = [
            manifold(0, DVec3::X, 1.0),
            manifold(1, DVec3::Y, 1.5),
            manifold(2, DVec3::Z, 2.0),
        ];
        let walked = walk(
            found.len(),
            found.iter().map(|(k, m, c)| (*k, m.clone(), c)),
        );
        assert_eq!(walked.pairs.len(), 1);
        let p = walked.pairs[0];
        assert_eq!(p.normal, DVec3::Z);
        assert_eq!(p.impulse, 4.5);
        assert_eq!(p.points, 3);
        assert_eq!(walked.cache.len(), 3);
    }
}
