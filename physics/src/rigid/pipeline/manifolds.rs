//! Stage 3: the narrow phase. Every broad-phase pair gives its manifolds
//! (in parallel, results kept in pair order) and each manifold a contact
//! constraint warm-started from the cache; every joint gives its row.

use std::collections::BTreeSet;

use glam::DVec3;

use super::apart::SeparatingAxes;
use super::bodies::Links;
use super::cache::Cursor;
use super::pairs::{leaves, pair_bodies, speculative_distance};
use super::{
    CachedManifold, CachedPoint, ContactCache, ContactKey, Reference, ANCHOR_MATCH_DISTANCE,
};
use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::{CombineRule, RigidBody};
use crate::rigid::body_index::BodyIndex;
use crate::rigid::broad_phase::{BroadPhase, Pair};
use crate::rigid::contact::{ContactPoint, Manifold, ManifoldCount};
use crate::rigid::joint::{Joint, JointConstraint};
use crate::rigid::narrow::{collide, collide_apart};
use crate::rigid::pose::Pose;
use crate::rigid::solver::{ContactConstraint, ContactSource, PointConstraint, MAX_POINTS};

/// Pairs per parallel work item.
const PAIRS_PER_ITEM: usize = 64;
/// Constraints placed (and prepared) per parallel work item.
const PLACE_ITEM: usize = 256;

/// A manifold with points, as the narrow phase found it.
#[derive(Debug)]
pub(crate) struct FoundManifold {
    /// Which manifold.
    pub(crate) key: ContactKey,
    /// What the contact cache keeps of it (its impulses are filled in
    /// once solved).
    pub(crate) kept: CachedManifold,
    /// What its constraint is built from, warm-started from the cache.
    pub(crate) source: ContactSource,
}

/// The manifolds with points, in pair order, as the parallel runs of
/// pairs found them (run after run). The solver places copies of their
/// constraints in the order it solves them ([`FoundManifolds::place_in`]); the
/// finish stage reads them back beside what the cache keeps.
#[derive(Debug, Default)]
pub(crate) struct FoundManifolds {
    runs: Vec<Vec<FoundManifold>>,
}

impl FoundManifolds {
    /// The two bodies (slots) of every constraint, in pair order.
    pub(crate) fn ends(&self) -> Vec<(usize, usize)> {
        self.all().map(|f| f.source.ends).collect()
    }

    /// Adds a manifold at the end of the last run.
    fn push(&mut self, found: FoundManifold) {
        match self.runs.last_mut() {
            Some(run) => run.push(found),
            None => self.runs.push(vec![found]),
        }
    }

    /// The manifolds, in pair order.
    fn all(&self) -> impl Iterator<Item = &FoundManifold> {
        self.runs.iter().flatten()
    }

    /// Each manifold's key and what the cache keeps of it, in pair order,
    /// taken out (the rest stays where it is, and the runs' memory, for
    /// [`Self::into_memory`]).
    pub(crate) fn take_kept(&mut self) -> impl Iterator<Item = (ContactKey, CachedManifold)> + '_ {
        self.runs
            .iter_mut()
            .flatten()
            .map(|f| (f.key, std::mem::take(&mut f.kept)))
    }

    /// The runs, emptied, with their memory: what the next step's narrow
    /// phase fills again ([`find`]) rather than allocate anew (several MB
    /// for a pile of thousands, which the allocator would otherwise hand
    /// back to the system and fault in, zeroed, every step).
    pub(crate) fn into_memory(mut self) -> Vec<Vec<FoundManifold>> {
        for run in &mut self.runs {
            run.clear();
        }
        self.runs
    }

    /// The constraints in `order` (indices in pair order; each once), built
    /// and passed through `f` (in parallel) where they are placed, in
    /// `into` (emptied first; its memory is kept from step to step).
    pub(crate) fn place_in(
        &self,
        order: &[u32],
        into: &mut Vec<ContactConstraint>,
        f: impl Fn(&mut ContactConstraint) + Sync + Send,
    ) {
        let all: Vec<&ContactSource> = self.all().map(|f| &f.source).collect();
        into.clear();
        into.reserve(order.len());
        let places = &mut into.spare_capacity_mut()[..order.len()];
        crate::parallel::par_map_chunks(places, PLACE_ITEM, |base, chunk| {
            for (j, place) in chunk.iter_mut().enumerate() {
                f(place.write(ContactConstraint::new(all[order[base + j] as usize])));
            }
        });
        // SAFETY: the chunks cover all of `places`, and each of its
        // elements was written above; had anything panicked, this line is
        // not reached and the written elements are only leaked.
        unsafe { into.set_len(order.len()) };
    }
}

/// What the narrow phase found.
#[derive(Debug, Default)]
pub(crate) struct Narrow {
    /// One constraint per manifold with points.
    pub(crate) constraints: FoundManifolds,
    /// Pairs that overlap (or touched and stayed put), with whether either
    /// body is a sensor.
    pub(crate) touching: Vec<((BodyHandle, BodyHandle), bool)>,
    /// Body pairs (keys) that stay put this step: their cache entries carry
    /// over as they are.
    pub(crate) carried: Vec<((u32, u32), (u32, u32))>,
    /// Deepest overlap, m.
    pub(crate) deepest: f64,
    /// Shape pairs collided and manifolds used again.
    pub(crate) count: ManifoldCount,
    /// Shape pairs found apart, with the axis that showed it (A's body
    /// frame), in key order: the next step's [`SeparatingAxes`].
    pub(crate) apart: Vec<(ContactKey, DVec3)>,
}

/// What a run of pairs looks up from the last step, in key order.
struct Lookups<'a> {
    /// The contact cache.
    manifolds: Cursor<'a>,
    /// The separating axes.
    axes: Cursor<'a, DVec3>,
}

/// The first cache key a pair could have.
fn first_key(index: &BodyIndex, pair: &Pair) -> ContactKey {
    let key = |i: u32| {
        index
            .slot_of_index(i)
            .map_or((i, 0), |k| (i, index.handles[k].generation))
    };
    ContactKey {
        a: key(pair.a),
        b: key(pair.b),
        child_a: 0,
        child_b: 0,
    }
}

/// Manifolds and constraints of every pair. Runs of consecutive pairs are
/// the parallel work items; results are joined in pair order.
#[allow(clippy::too_many_arguments)] // the stage's inputs, each read as is
pub(crate) fn find(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    links: &Links<'_>,
    broad: &BroadPhase,
    cache: &ContactCache,
    axes: &SeparatingAxes,
    touched: &BTreeSet<(BodyHandle, BodyHandle)>,
    dt: f64,
    memory: &mut Vec<Vec<FoundManifold>>,
    apart: Vec<(ContactKey, DVec3)>,
) -> Narrow {
    // Each run of pairs with a list to fill, from the last step's memory.
    let mut runs: Vec<(&[Pair], Vec<FoundManifold>)> = broad
        .pairs()
        .chunks(PAIRS_PER_ITEM)
        .map(|run| (run, memory.pop().unwrap_or_default()))
        .collect();
    let outs = crate::parallel::par_map_chunks(&mut runs, 1, |_, item| {
        let mut out = Narrow::default();
        let Some((run, list)) = item.first_mut() else {
            return out;
        };
        let (run, mut list) = (*run, std::mem::take(list));
        // About a manifold a pair at most (compounds aside): room for them
        // up front, not grown (and moved) as they come.
        list.reserve(run.len());
        out.constraints.runs.push(list);
        let Some(first) = run.first() else {
            return out;
        };
        let from = first_key(index, first);
        let mut lookups = Lookups {
            manifolds: cache.cursor_from(&from),
            axes: axes.cursor_from(&from),
        };
        for pair in run {
            one_pair(
                bodies,
                index,
                links,
                broad,
                pair,
                &mut lookups,
                touched,
                dt,
                &mut out,
            );
        }
        out
    });
    // `apart` comes empty, with the memory of an earlier step's axes.
    let mut narrow = Narrow {
        apart,
        ..Narrow::default()
    };
    for out in outs {
        narrow.apart.extend(out.apart);
        narrow.touching.extend(out.touching);
        narrow.constraints.runs.extend(out.constraints.runs);
        narrow.carried.extend(out.carried);
        narrow.deepest = narrow.deepest.max(out.deepest);
        narrow.count += out.count;
    }
    narrow
}

/// Adds what one pair gives to `out`.
#[allow(clippy::too_many_arguments)]
fn one_pair(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    links: &Links<'_>,
    broad: &BroadPhase,
    pair: &Pair,
    lookups: &mut Lookups<'_>,
    touched: &BTreeSet<(BodyHandle, BodyHandle)>,
    dt: f64,
    out: &mut Narrow,
) {
    let Some(((ia, ba), (ib, bb))) = pair_bodies(bodies, index, pair) else {
        return;
    };
    let (ha, hb) = (index.handles[ia], index.handles[ib]);
    let sensor = ba.sensor || bb.sensor;
    if ba.inv_mass == 0.0 && bb.inv_mass == 0.0 && !sensor {
        return;
    }
    // Bodies joined by a joint do not collide with each other.
    if links.joined(ha, hb) {
        return;
    }
    let (ka, kb) = ((ha.index, ha.generation), (hb.index, hb.generation));
    // Contacts between bodies that all stay put this step (asleep, static)
    // are not recomputed: their cache and touching state carry over.
    if ba.is_fixed_now() && bb.is_fixed_now() && !sensor {
        out.carried.push((ka, kb));
        if touched.contains(&(ha, hb)) {
            out.touching.push(((ha, hb), false));
        }
        return;
    }
    // Each tight box holds its shape grown by how far the body can move
    // this step plus the speculative distance, so boxes apart put the
    // shapes farther apart than the speculative distance: no contact.
    if !broad.tight_boxes_overlap(pair) {
        return;
    }
    let (Some(sa), Some(sb)) = (&ba.shape, &bb.shape) else {
        return;
    };
    let speculative = speculative_distance(ba, bb, dt);
    let (pose_a, pose_b) = (ba.pose(), bb.pose());
    let mut touching = false;
    let mut add = |(ca, pa): (usize, &Pose),
                   (cb, pb): (usize, &Pose),
                   m: Manifold,
                   reference: Option<Reference>,
                   cached: Option<&CachedManifold>| {
        if m.is_empty() {
            return;
        }
        if m.min_separation().is_some_and(|s| s <= 0.0) {
            touching = true;
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
        let (kept, source) = kept_and_source((ia, ba, pa), (ib, bb, pb), &m, reference, cached);
        out.constraints.push(FoundManifold { key, kept, source });
    };
    let compound =
        |s: &crate::rigid::shape::Shape| matches!(s, crate::rigid::shape::Shape::Compound(_));
    if !compound(sa) && !compound(sb) {
        // The last manifold again while the bodies have barely moved
        // relative to each other (see `Reference`); else the shapes
        // collided, with room for the next steps' drift.
        let key = ContactKey {
            a: ka,
            b: kb,
            child_a: 0,
            child_b: 0,
        };
        let cached = lookups.manifolds.get(&key);
        let axis = lookups.axes.get(&key);
        let recycled = cached.and_then(|c| {
            let r = c.reference?;
            r.holds(ba, bb, speculative)
                .then(|| (c.manifold(&pose_a, &pose_b), r))
        });
        let (m, reference) = match recycled {
            Some(found) => {
                out.count.recycled += 1;
                found
            }
            None => {
                out.count.collided += 1;
                let reach = Reference::reach(speculative);
                // Two support queries along last step's separating axis
                // settle most pairs that stay apart.
                let mut apart = axis.copied();
                let Ok(m) = collide_apart(sa, &pose_a, sb, &pose_b, reach, &mut apart) else {
                    return;
                };
                if let Some(axis) = apart {
                    out.apart.push((key, axis));
                }
                (m, Reference::between(ba, bb, reach))
            }
        };
        let here = (0, &Pose::IDENTITY);
        add(here, here, m, Some(reference), cached);
    } else {
        let (mut la, mut lb) = (Vec::new(), Vec::new());
        leaves(sa, Pose::IDENTITY, &mut la);
        leaves(sb, Pose::IDENTITY, &mut lb);
        for (ca, (pa, shape_a)) in la.iter().enumerate() {
            for (cb, (pb, shape_b)) in lb.iter().enumerate() {
                out.count.collided += 1;
                let Ok(m) = collide(
                    shape_a,
                    &pose_a.mul(pa),
                    shape_b,
                    &pose_b.mul(pb),
                    speculative,
                ) else {
                    continue;
                };
                let key = ContactKey {
                    a: ka,
                    b: kb,
                    child_a: ca as u32,
                    child_b: cb as u32,
                };
                if !m.is_empty() {
                    let cached = lookups.manifolds.get(&key);
                    add((ca, pa), (cb, pb), m, None, cached);
                }
            }
        }
    }
    if touching {
        out.touching.push(((ha, hb), sensor));
    }
}

/// What the cache keeps of one manifold between `a` and `b` (each with its
/// slot and the child shape's pose in its body frame; impulses left 0),
/// and what its constraint is built from, warm-started from `cached`.
fn kept_and_source(
    (ia, a, child_a): (usize, &RigidBody, &Pose),
    (ib, b, child_b): (usize, &RigidBody, &Pose),
    m: &Manifold,
    reference: Option<Reference>,
    cached: Option<&CachedManifold>,
) -> (CachedManifold, ContactSource) {
    let (pose_a, pose_b) = (a.pose().mul(child_a), b.pose().mul(child_b));
    let n = m.normal;
    let mut points = [PointConstraint::default(); MAX_POINTS];
    let mut kept = Vec::with_capacity(m.points.len().min(MAX_POINTS));
    let len = m.points.len().min(MAX_POINTS);
    for (slot, p) in points.iter_mut().zip(&m.points) {
        let (wa, wb) = (
            pose_a.transform_point(p.local_a),
            pose_b.transform_point(p.local_b),
        );
        let (ra, rb) = (wa - a.com, wb - b.com);
        let anchor_a = child_a.transform_point(p.local_a);
        let warm = cached.map(|c| &c.points).and_then(|c| {
            c.iter().find(|q| q.id == p.id).or_else(|| {
                c.iter()
                    .map(|q| (q, (q.anchor_a.as_dvec3() - anchor_a).length()))
                    .filter(|(_, d)| *d < ANCHOR_MATCH_DISTANCE)
                    .min_by(|x, y| x.1.total_cmp(&y.1))
                    .map(|(q, _)| q)
            })
        });
        *slot = PointConstraint {
            base_separation: p.separation - n.dot(rb - ra),
            ..PointConstraint::new(
                ra,
                rb,
                warm.map_or(0.0, |q| f64::from(q.normal)),
                warm.map_or([0.0; 2], |q| q.tangent.map(f64::from)),
            )
        };
        kept.push(CachedPoint {
            id: p.id,
            anchor_a: anchor_a.as_vec3(),
            anchor_b: child_b.transform_point(p.local_b).as_vec3(),
            gap: (p.separation - n.dot(wb - wa)) as f32,
            normal: 0.0,
            tangent: [0.0; 2],
        });
    }
    let source = ContactSource {
        ends: (ia, ib),
        normal: n,
        materials: (
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
    };
    let kept = CachedManifold {
        normal_a: (a.pose().rotation.inverse() * n).as_vec3(),
        reference,
        points: kept,
        impulse: 0.0,
        separation: 0.0,
    };
    (kept, source)
}

impl CachedManifold {
    /// The manifold again, its separations measured from the bodies' poses
    /// now (`pose_a`, `pose_b`: body frames, which are the shapes' frames
    /// of a manifold that is used again).
    fn manifold(&self, pose_a: &Pose, pose_b: &Pose) -> Manifold {
        // Unit again in full precision.
        let normal = (pose_a.rotation * self.normal_a.as_dvec3()).normalize();
        let points = self
            .points
            .iter()
            .map(|p| {
                let (local_a, local_b) = (p.anchor_a.as_dvec3(), p.anchor_b.as_dvec3());
                let (wa, wb) = (
                    pose_a.transform_point(local_a),
                    pose_b.transform_point(local_b),
                );
                ContactPoint {
                    local_a,
                    local_b,
                    separation: f64::from(p.gap) + normal.dot(wb - wa),
                    id: p.id,
                }
            })
            .collect();
        Manifold { normal, points }
    }
}

/// The row of every joint between bodies that still exist with one side
/// free to move, with the joint's arena index and generation, into `rows`
/// (emptied first).
pub(crate) fn joint_rows(
    bodies: &Arena<RigidBody>,
    index: &BodyIndex,
    joints: &Arena<Joint>,
    rows: &mut Vec<(u32, u32, JointConstraint)>,
) {
    rows.clear();
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
}
