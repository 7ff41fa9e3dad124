//! Stage 3: the narrow phase. Every broad-phase pair gives its manifolds
//! (in parallel, results kept in pair order) and each manifold a contact
//! constraint warm-started from the cache; every joint gives its row.

use std::collections::{BTreeMap, BTreeSet};

use super::bodies::{BodyIndex, Links};
use super::pairs::{leaves, pair_bodies, speculative_distance};
use super::{CachedPoint, ContactKey, ANCHOR_MATCH_DISTANCE};
use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::{CombineRule, RigidBody};
use crate::rigid::broad_phase::Pair;
use crate::rigid::contact::Manifold;
use crate::rigid::joint::{Joint, JointConstraint};
use crate::rigid::narrow::collide;
use crate::rigid::pose::Pose;
use crate::rigid::solver::{ContactConstraint, PointConstraint, MAX_POINTS};

/// Pairs per parallel work item.
const PAIRS_PER_ITEM: usize = 64;

/// What the narrow phase found.
#[derive(Debug, Default)]
pub(crate) struct Narrow {
    /// One constraint per manifold with points, in pair order.
    pub(crate) constraints: Vec<(ContactKey, ContactConstraint)>,
    /// Pairs that overlap (or touched and stayed put), with whether either
    /// body is a sensor.
    pub(crate) touching: Vec<((BodyHandle, BodyHandle), bool)>,
    /// Cache entries of pairs that stay put this step, carried over as they are.
    pub(crate) carried: Vec<(ContactKey, Vec<CachedPoint>)>,
    /// Deepest overlap, m.
    pub(crate) deepest: f64,
}

/// The outcome of one pair.
#[derive(Debug, Default)]
struct PairOut {
    touching: Option<bool>,
    constraints: Vec<(ContactKey, ContactConstraint)>,
    carried: Vec<(ContactKey, Vec<CachedPoint>)>,
    deepest: f64,
}

/// Manifolds and constraints of every pair.
pub(crate) fn find(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    links: &Links<'_>,
    pairs: &[Pair],
    cache: &BTreeMap<ContactKey, Vec<CachedPoint>>,
    touched: &BTreeSet<(BodyHandle, BodyHandle)>,
    dt: f64,
) -> Narrow {
    let outs = crate::parallel::par_map(pairs, PAIRS_PER_ITEM, |pair| {
        one_pair(bodies, index, links, pair, cache, touched, dt)
    });
    let mut narrow = Narrow::default();
    for (pair, out) in pairs.iter().zip(outs) {
        if let Some(sensor) = out.touching {
            if let (Some(ia), Some(ib)) = (index.slot_of_index(pair.a), index.slot_of_index(pair.b))
            {
                narrow
                    .touching
                    .push(((index.handles[ia], index.handles[ib]), sensor));
            }
        }
        narrow.constraints.extend(out.constraints);
        narrow.carried.extend(out.carried);
        narrow.deepest = narrow.deepest.max(out.deepest);
    }
    narrow
}

fn one_pair(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    links: &Links<'_>,
    pair: &Pair,
    cache: &BTreeMap<ContactKey, Vec<CachedPoint>>,
    touched: &BTreeSet<(BodyHandle, BodyHandle)>,
    dt: f64,
) -> PairOut {
    let mut out = PairOut::default();
    let Some(((ia, ba), (ib, bb))) = pair_bodies(bodies, index, pair) else {
        return out;
    };
    let (ha, hb) = (index.handles[ia], index.handles[ib]);
    let sensor = ba.sensor || bb.sensor;
    if ba.inv_mass == 0.0 && bb.inv_mass == 0.0 && !sensor {
        return out;
    }
    // Bodies joined by a joint do not collide with each other.
    if links.joined(ha, hb) {
        return out;
    }
    let (ka, kb) = ((ha.index, ha.generation), (hb.index, hb.generation));
    // Contacts between bodies that all stay put this step (asleep, static)
    // are not recomputed: their cache and touching state carry over.
    if ba.is_fixed_now() && bb.is_fixed_now() && !sensor {
        let lo = ContactKey {
            a: ka,
            b: kb,
            child_a: 0,
            child_b: 0,
        };
        let hi = ContactKey {
            child_a: u32::MAX,
            child_b: u32::MAX,
            ..lo
        };
        out.carried = cache.range(lo..=hi).map(|(k, v)| (*k, v.clone())).collect();
        if touched.contains(&(ha, hb)) {
            out.touching = Some(false);
        }
        return out;
    }
    let (Some(sa), Some(sb)) = (&ba.shape, &bb.shape) else {
        return out;
    };
    let speculative = speculative_distance(ba, bb, dt);
    let (pose_a, pose_b) = (ba.pose(), bb.pose());
    let mut add = |ca: usize, pa: &Pose, shape_a, cb: usize, pb: &Pose, shape_b| {
        let Ok(m) = collide(
            shape_a,
            &pose_a.mul(pa),
            shape_b,
            &pose_b.mul(pb),
            speculative,
        ) else {
            return;
        };
        if m.is_empty() {
            return;
        }
        if m.min_separation().is_some_and(|s| s <= 0.0) {
            out.touching = Some(sensor);
        }
        if sensor {
            // Sensors only report: no constraint.
            return;
        }
        if let Some(sep) = m.min_separation() {
            out.deepest = out.deepest.max(-sep);
        }
        let key = ContactKey {
            a: ka,
            b: kb,
            child_a: ca as u32,
            child_b: cb as u32,
        };
        let c = constraint(ia, ib, ba, bb, pa, pb, &m, cache.get(&key));
        out.constraints.push((key, c));
    };
    let compound =
        |s: &crate::rigid::shape::Shape| matches!(s, crate::rigid::shape::Shape::Compound(_));
    if !compound(sa) && !compound(sb) {
        add(0, &Pose::IDENTITY, sa, 0, &Pose::IDENTITY, sb);
    } else {
        let (mut la, mut lb) = (Vec::new(), Vec::new());
        leaves(sa, Pose::IDENTITY, &mut la);
        leaves(sb, Pose::IDENTITY, &mut lb);
        for (ca, (pa, shape_a)) in la.iter().enumerate() {
            for (cb, (pb, shape_b)) in lb.iter().enumerate() {
                add(ca, pa, shape_a, cb, pb, shape_b);
            }
        }
    }
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
    let mut points = [PointConstraint::default(); MAX_POINTS];
    let len = m.points.len().min(MAX_POINTS);
    for (slot, p) in points.iter_mut().zip(&m.points) {
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
        *slot = PointConstraint {
            base_separation: p.separation - n.dot(rb - ra),
            id: p.id,
            anchor_a,
            ..PointConstraint::new(
                ra,
                rb,
                warm.map_or(0.0, |q| q.normal),
                warm.map_or([0.0; 2], |q| q.tangent),
            )
        };
    }
    ContactConstraint::new(
        (ia, ib),
        n,
        (
            CombineRule::combine(
                (a.friction_static, a.friction_combine),
                (b.friction_static, b.friction_combine),
            ),
            CombineRule::combine(
                (a.friction_dynamic, a.friction_combine),
                (b.friction_dynamic, b.friction_combine),
            ),
            CombineRule::combine(
                (a.restitution, a.restitution_combine),
                (b.restitution, b.restitution_combine),
            ),
        ),
        points,
        len,
    )
}

/// The row of every joint between bodies that still exist with one side
/// free to move, with the joint's arena index and generation.
pub(crate) fn joint_rows(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    joints: &Arena<Joint>,
) -> Vec<(u32, u32, JointConstraint)> {
    let mut rows = Vec::new();
    for (jindex, generation, j) in joints.iter() {
        let (Some(ia), Some(ib)) = (index.slot(j.desc.a), index.slot(j.desc.b)) else {
            continue;
        };
        let (Some(ba), Some(bb)) = (
            bodies.get(j.desc.a.index, j.desc.a.generation),
            bodies.get(j.desc.b.index, j.desc.b.generation),
        ) else {
            continue;
        };
        if ba.is_fixed_now() && bb.is_fixed_now() {
            continue;
        }
        let (pa, pb) = (
            ba.pose().transform_point(j.desc.anchor_a),
            bb.pose().transform_point(j.desc.anchor_b),
        );
        rows.push((
            jindex,
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
    rows
}
