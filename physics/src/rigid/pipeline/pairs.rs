//! Stage 2: the broad phase, and waking sleepers that an awake body is
//! about to hit.

use super::{AABB_MARGIN, SPECULATIVE_DISTANCE};
use crate::arena::Arena;
use crate::rigid::aabb::Aabb;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::body_index::BodyIndex;
use crate::rigid::broad_phase::{BroadPhase, Pair};
use crate::rigid::narrow::collide;
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;

/// Bodies whose boxes one parallel work item computes.
const BOXES_PER_ITEM: usize = 256;

/// Brings the broad phase up to date with the bodies (creating it after a
/// restore) and returns it with this step's overlapping pairs.
pub(crate) fn update<'a>(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    broad: &'a mut Option<BroadPhase>,
    dt: f64,
) -> &'a BroadPhase {
    let broad = broad.get_or_insert_with(|| BroadPhase::new(AABB_MARGIN).expect("valid margin"));
    // Proxies of bodies that are gone or have no shape. (Removing a body
    // drops the whole broad phase, so this only finds anything when the
    // counts disagree.)
    let present: Vec<bool> = bodies.iter().map(|(_, _, b)| b.shape.is_some()).collect();
    if broad.len() != present.iter().filter(|&&p| p).count() {
        let stale: Vec<u32> = broad
            .proxies()
            .into_iter()
            .map(|(key, _, _)| key)
            .filter(|&key| index.slot_of_index(key).is_none_or(|k| !present[k]))
            .collect();
        for key in stale {
            let _ = broad.remove(key);
        }
    }
    // Each moving body's box (in parallel: a hull's box turns every
    // vertex), then the tree takes them in body order.
    let mut moving: Vec<(u32, &RigidBody, Option<Aabb>)> = bodies
        .iter()
        .enumerate()
        .filter(|(k, (_, _, b))| {
            // Sleeping and static bodies do not move: their boxes stand.
            let stands = b.sleeping || b.kind == BodyKind::Static;
            b.shape.is_some() && !(stands && broad.contains(index.handles[*k].index))
        })
        .map(|(k, (_, _, b))| (index.handles[k].index, b, None))
        .collect();
    crate::parallel::par_map_chunks(&mut moving, BOXES_PER_ITEM, |_, run| {
        for (_, b, aabb) in run {
            let reach = (b.linvel.length() + b.angvel.length() * b.shape_radius()) * dt
                + SPECULATIVE_DISTANCE;
            *aabb = b.shape.as_ref().map(|s| s.aabb(&b.pose()).expanded(reach));
        }
    });
    for (key, b, aabb) in moving {
        let Some(aabb) = aabb else { continue };
        let ok = if broad.contains(key) {
            broad.update(key, aabb, b.linvel * dt).is_ok()
        } else {
            broad.insert(key, aabb, b.kind == BodyKind::Static).is_ok()
        };
        if !ok {
            let _ = broad.remove(key);
        }
    }
    broad.update_pairs();
    broad
}

/// A body with its slot.
pub(crate) type Slotted<'a> = (usize, &'a RigidBody);

/// The two bodies of a broad-phase pair, with their slots.
pub(crate) fn pair_bodies<'a>(
    bodies: &'a Arena<RigidBody>,
    index: &BodyIndex,
    pair: &Pair,
) -> Option<(Slotted<'a>, Slotted<'a>)> {
    let (ia, ib) = (index.slot_of_index(pair.a)?, index.slot_of_index(pair.b)?);
    let (ha, hb) = (index.handles[ia], index.handles[ib]);
    Some((
        (ia, bodies.get(ha.index, ha.generation)?),
        (ib, bodies.get(hb.index, hb.generation)?),
    ))
}

/// An awake body about to hit a sleeping one wakes it before anything is
/// solved: one that moves faster than a resting body (`sleep`'s
/// tolerances) and can close the gap between them this step
/// ([`wake_reach`]). A resting body beside a sleeping one, however near,
/// does not wake it; were it to, two resting neighbours a centimetre apart
/// would wake each other in turn for ever (the one awake wakes the other
/// as it falls asleep). Nor does one resting against it: the shapes
/// collided afresh here may touch where the pair's kept manifold, which
/// decides their islands, has them a hair apart, and a heap and a box
/// resting beside it then woke each other as each fell asleep. If they do
/// meet, the contact wakes the sleeper at the next step. Returns whether
/// any body woke (so the caller wakes their islands).
pub(crate) fn wake_before_contact(
    bodies: &mut Arena<RigidBody>,
    index: &BodyIndex,
    broad: &BroadPhase,
    dt: f64,
    sleep: &crate::rigid::island::SleepConfig,
) -> bool {
    if !bodies.iter().any(|(_, _, b)| b.sleeping) {
        return false;
    }
    let mut to_wake = Vec::new();
    for pair in broad.pairs() {
        let Some(((ia, ba), (ib, bb))) = pair_bodies(bodies, index, pair) else {
            continue;
        };
        let awake_dynamic = |b: &RigidBody| {
            b.kind == BodyKind::Dynamic
                && !b.sleeping
                && !b.quarantined
                && !sleep.slow(b.linvel.length(), b.angvel.length())
        };
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
        let reach = wake_reach(ba, bb, dt);
        let hit = match (&ba.shape, &bb.shape) {
            (Some(sa), Some(sb)) if reach > 0.0 => {
                shapes_near(sa, &ba.pose(), sb, &bb.pose(), reach)
            }
            _ => false,
        };
        if hit {
            to_wake.push(index.handles[sleeper]);
        }
    }
    for h in &to_wake {
        if let Some(b) = bodies.get_mut(h.index, h.generation) {
            b.wake();
        }
    }
    !to_wake.is_empty()
}

/// The leaf shapes of a shape with their poses in the body frame.
pub(crate) fn leaves<'a>(shape: &'a Shape, pose: Pose, out: &mut Vec<(Pose, &'a Shape)>) {
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
pub(crate) fn speculative_distance(a: &RigidBody, b: &RigidBody, dt: f64) -> f64 {
    let closing = (a.linvel - b.linvel).length() * dt;
    SPECULATIVE_DISTANCE + closing.min(closing_cap(a, b))
}

/// The most two bodies are taken to close in on each other in a step, m:
/// their size, or no limit when either is `ccd`.
fn closing_cap(a: &RigidBody, b: &RigidBody) -> f64 {
    if a.ccd || b.ccd {
        f64::INFINITY
    } else {
        a.shape_radius().max(b.shape_radius())
    }
}

/// How far two bodies can close in on each other this step, m: their
/// relative speed, and each one's spin at its radius, times the step,
/// within [`closing_cap`].
fn wake_reach(a: &RigidBody, b: &RigidBody, dt: f64) -> f64 {
    let speed = (a.linvel - b.linvel).length()
        + a.angvel.length() * a.shape_radius()
        + b.angvel.length() * b.shape_radius();
    (speed * dt).min(closing_cap(a, b))
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
