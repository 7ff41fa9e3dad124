//! The broad phase: which pairs of bodies might touch.
//!
//! # The problem
//!
//! With n bodies there are n²/2 pairs, but in a game scene each body
//! touches a handful of others. The broad phase finds the pairs whose
//! bounding boxes overlap, in less than O(n²), and should do almost no work
//! for bodies that did not move (a settled pyramid, a sleeping pile). Its
//! output feeds the narrow phase and, through it, the solver, so its order
//! must be deterministic: the same boxes must give the same pair list on
//! every machine and every worker count, whatever the history of inserts
//! and removals that led there.
//!
//! # Options
//!
//! * **Brute force**, O(n²): the reference ([`brute_force_pairs`]).
//! * **Sweep and prune** ([`SweepAndPrune`]): sort the boxes along one axis
//!   (the one where the centres vary most) and sweep. Coherent motion keeps
//!   the sort cheap, but every update touches every box, and boxes that
//!   overlap along the sweep axis but not in space (columns of a stack seen
//!   side-on) are all tested.
//! * **Dynamic AABB tree** ([`DynamicTree`]): a bounding volume hierarchy
//!   over *fat* boxes (the tight box plus a margin, stretched along the last
//!   displacement). A proxy is reinserted only when its tight box leaves its
//!   fat box, so resting and slow bodies cost nothing; only proxies that
//!   moved query the tree for new pairs. Insertion picks the sibling by the
//!   surface-area heuristic and rebalances with AVL rotations; a top-down
//!   binned-SAH [`rebuild`](DynamicTree::rebuild) is there for static level
//!   geometry. The same tree answers scene queries (box overlap, ray cast).
//!
//! # Why the tree
//!
//! Measured on 10 000 boxes of about 1 m, margin 0.1 m, 60 updates, one
//! thread each, both engines producing the identical pair list (asserted).
//! Command: `cargo run --release -p inertia-physics --example
//! broad_phase_bench`; shared
//! 2-core x86-64 VM (Intel Xeon), quietest of three runs, ms. "Build" is
//! inserting everything plus the first pair update; "update" is one step's
//! proxy updates plus the pair update.
//!
//! | scene                                  | pairs  | tree build | tree update | SAP build | SAP update |
//! |----------------------------------------|-------:|-----------:|------------:|----------:|-----------:|
//! | pyramid of cubes, resting, 1e-4 m jitter | 73 559 |       20.0 |        0.44 |      19.4 |       18.3 |
//! | random cloud, every box moving 0.02 m  |  6 093 |       23.3 |        2.88 |      17.8 |       18.4 |
//! | random cloud, 10 % of boxes moving     |  5 484 |       22.9 |        0.62 |      18.8 |       19.7 |
//!
//! Building costs about the same (SAP up to 25 % less: sorting beats
//! inserting one by one), but per step the tree is 6× faster when everything moves and 30–40× faster when
//! little does, because a proxy whose tight box stays in its fat box costs
//! one containment test and nothing else. The SAP here is the simple kind
//! (sort and sweep every step); a persistent-endpoint SAP (Bullet's
//! `btAxisSweep3`) would narrow the gap for coherent motion, but still
//! suffers from boxes overlapping on the sweep axis only, and cannot answer
//! ray casts. So [`BroadPhase`] is the tree; [`SweepAndPrune`] stays as the
//! measured alternative and a second reference in the tests.
//!
//! Incremental insertion keeps the tree shallow (height 14–16 for 10 000
//! proxies, 14 even for sorted insertion), but its SAH quality — the
//! summed area of internal nodes over the root's,
//! [`area_ratio`](DynamicTree::area_ratio) — is 104–168 on these scenes;
//! a binned-SAH [`rebuild`](DynamicTree::rebuild) (4–10 ms) brings it to
//! 69–77, which is why static level geometry should be rebuilt once
//! loaded.
//!
//! # Determinism
//!
//! Pairs are stored canonically (`a < b` by key) and the list is kept
//! sorted, so it depends only on the set of proxies and their fat boxes,
//! never on the tree's shape, insertion order or the number of threads that
//! ran the queries. Fat boxes in turn depend only on each proxy's own
//! sequence of moves. Static–static pairs are never reported.
//!
//! # Credits
//!
//! Erin Catto, "Dynamic Bounding Volume Hierarchies", GDC 2019, and Box2D's
//! `b2DynamicTree` (fat boxes, SAH insertion with inherited cost, AVL
//! rotations, the move buffer); Nathanael Presson's `btDbvt` in Bullet;
//! Ingo Wald, "On fast construction of SAH-based bounding volume
//! hierarchies" (2007), for binned SAH; Christer Ericson, *Real-Time
//! Collision Detection* §7.5, for sweep and prune on the axis of largest
//! variance.

mod sap;
mod tree;

use rustc_hash::FxHashMap;

use glam::DVec3;

use crate::parallel::par_map_chunks;
use crate::rigid::aabb::Aabb;

pub use sap::SweepAndPrune;
pub use tree::{DynamicTree, ProxyId};

/// Default fat-box margin, m: Box2D's 0.1 m for metre-sized bodies — big
/// enough that a body at rest or crawling is not reinserted every step,
/// small enough not to create many false pairs.
pub const DEFAULT_MARGIN: f64 = 0.1;

/// How many steps of the last displacement a fat box anticipates (Box2D's
/// `b2_aabbMultiplier`).
pub const DISPLACEMENT_LOOKAHEAD: f64 = 4.0;

/// Largest coordinate, displacement or ray component accepted, m. Far
/// beyond any game world (a millionth of the way to the nearest star), yet
/// small enough that surface areas stay finite and SAH costs comparable;
/// f64 still resolves about 0.1 mm out there.
pub const MAX_COORDINATE: f64 = 1e12;

/// Moving proxies per parallel work item when finding new pairs.
const QUERY_CHUNK: usize = 256;

/// Why a broad-phase call was refused. Every refusal leaves the structure
/// unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BroadPhaseError {
    /// A coordinate or displacement was NaN or infinite. Fix the body's
    /// pose or shape.
    #[error("{what} must be finite, got {value}")]
    NonFinite {
        /// Which input was bad, e.g. "proxy box".
        what: &'static str,
        /// The offending value (one component).
        value: f64,
    },
    /// A coordinate beyond ±[`MAX_COORDINATE`] m: almost surely a body that
    /// has flown off; remove it or bring it back.
    #[error("{what} must lie within ±{max} m, got {value}")]
    OutOfRange {
        /// Which input was bad.
        what: &'static str,
        /// The offending value (one component).
        value: f64,
        /// The limit, m.
        max: f64,
    },
    /// A box with `min > max` on some axis.
    #[error("box min {min} exceeds max {max}")]
    Inverted {
        /// Lowest corner given, m.
        min: DVec3,
        /// Highest corner given, m.
        max: DVec3,
    },
    /// The fat-box margin must be finite, `>= 0` and at most
    /// [`MAX_COORDINATE`] m.
    #[error("fat-box margin must be in [0, 1e12] m, got {0}")]
    BadMargin(f64),
    /// A ray's `max_t` must be `>= 0` (`+∞` allowed).
    #[error("ray max_t must be >= 0, got {0}")]
    BadRayLength(f64),
    /// The key is already in the broad phase; remove it first.
    #[error("proxy key {0} is already present")]
    DuplicateKey(u32),
    /// No proxy has this key.
    #[error("no proxy with key {0}")]
    UnknownKey(u32),
    /// The tree has no live proxy with this id.
    #[error("no proxy with id {0}")]
    UnknownProxy(u32),
    /// The node pool is out of `u32` indices.
    #[error("too many proxies for 32-bit node indices")]
    TooManyProxies,
    /// A consistency check failed (`validate`): a bug, please report it.
    #[error("broad phase invariant broken at node {node}: {what}")]
    Invariant {
        /// Node (or proxy) index where it was found.
        node: u32,
        /// What is wrong.
        what: &'static str,
    },
}

/// Two proxy keys whose fat boxes overlap, `a < b`. Ordered by `a`, then
/// `b`: the order of every pair list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Pair {
    /// The smaller key.
    pub a: u32,
    /// The larger key.
    pub b: u32,
}

impl Pair {
    /// The canonical pair of two keys, in either order.
    #[inline]
    pub fn new(x: u32, y: u32) -> Pair {
        Pair {
            a: x.min(y),
            b: x.max(y),
        }
    }
}

pub(crate) fn check_vec(what: &'static str, v: DVec3) -> Result<(), BroadPhaseError> {
    for value in v.to_array() {
        if !value.is_finite() {
            return Err(BroadPhaseError::NonFinite { what, value });
        }
        if value.abs() > MAX_COORDINATE {
            return Err(BroadPhaseError::OutOfRange {
                what,
                value,
                max: MAX_COORDINATE,
            });
        }
    }
    Ok(())
}

pub(crate) fn check_aabb(b: &Aabb) -> Result<(), BroadPhaseError> {
    check_vec("proxy box min", b.min)?;
    check_vec("proxy box max", b.max)?;
    if b.min.cmple(b.max).all() {
        Ok(())
    } else {
        Err(BroadPhaseError::Inverted {
            min: b.min,
            max: b.max,
        })
    }
}

/// The fat box for a tight box: grown by `margin` m and stretched by
/// [`DISPLACEMENT_LOOKAHEAD`] × `displacement` (m) on the side it moves to.
pub(crate) fn fat_box(tight: &Aabb, margin: f64, displacement: DVec3) -> Aabb {
    let mut fat = tight.expanded(margin);
    let d = displacement * DISPLACEMENT_LOOKAHEAD;
    fat.min += d.min(DVec3::ZERO);
    fat.max += d.max(DVec3::ZERO);
    // Inputs and margin are within MAX_COORDINATE, so this stays finite.
    fat
}

/// Whether a proxy keeps its fat box `old`: the tight box is still inside,
/// and `old` is not much larger than the `fresh` one it would get (Box2D's
/// "huge box" test, so a box stretched by a fast move shrinks back once the
/// body slows down).
pub(crate) fn keep_fat_box(old: &Aabb, tight: &Aabb, fresh: &Aabb, margin: f64) -> bool {
    old.contains(tight) && fresh.expanded(4.0 * margin).contains(old)
}

/// Every overlapping pair among `proxies` (key, box, static), O(n²), sorted:
/// the reference the tests hold the broad phases to.
pub fn brute_force_pairs(proxies: &[(u32, Aabb, bool)]) -> Vec<Pair> {
    let mut out = Vec::new();
    for (i, (ka, ba, sa)) in proxies.iter().enumerate() {
        for (kb, bb, sb) in &proxies[i + 1..] {
            if !(*sa && *sb) && ba.intersects(bb) {
                out.push(Pair::new(*ka, *kb));
            }
        }
    }
    out.sort_unstable();
    out
}

#[derive(Debug, Clone, Copy)]
struct ProxyInfo {
    key: u32,
    /// The last tight box given, m.
    tight: Aabb,
    is_static: bool,
    /// Fat box changed (or proxy inserted) since the last pair update.
    moved: bool,
}

/// The incremental broad phase: a [`DynamicTree`] of proxies keyed by the
/// caller's `u32` (a body index), plus the persistent, sorted set of
/// overlapping pairs.
///
/// Per step: [`update`](Self::update) every body that moved, then
/// [`update_pairs`](Self::update_pairs); read [`pairs`](Self::pairs) (all
/// current pairs) or [`added_pairs`](Self::added_pairs) and
/// [`removed_pairs`](Self::removed_pairs) (the changes).
///
/// ```
/// use inertia_physics::glam::DVec3;
/// use inertia_physics::rigid::aabb::Aabb;
/// use inertia_physics::rigid::broad_phase::{BroadPhase, Pair};
///
/// let mut bp = BroadPhase::default();
/// let unit = |x: f64| Aabb::from_center_half_extents(DVec3::new(x, 0.0, 0.0), DVec3::splat(0.5));
/// bp.insert(7, unit(0.0), true)?;
/// bp.insert(3, unit(0.9), false)?;
/// bp.insert(5, unit(5.0), false)?;
/// bp.update_pairs();
/// assert_eq!(bp.pairs(), &[Pair::new(3, 7)]);
/// # Ok::<(), inertia_physics::rigid::broad_phase::BroadPhaseError>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct BroadPhase {
    tree: DynamicTree,
    /// key → proxy. Only looked up, never iterated, so its order is moot;
    /// hashed by FxHash (a multiply per key), not SipHash: the narrow
    /// phase looks two keys up per pair.
    proxies: FxHashMap<u32, ProxyId>,
    /// By `ProxyId::index`.
    info: Vec<Option<ProxyInfo>>,
    /// Keys inserted, moved or removed since the last pair update.
    touched: Vec<u32>,
    pairs: Vec<Pair>,
    added: Vec<Pair>,
    removed: Vec<Pair>,
    /// By key: whether the proxy is touched, set during a pair update only.
    marks: Vec<bool>,
    /// The pair list before the last update, emptied: the next update's
    /// memory.
    spare: Vec<Pair>,
}

impl BroadPhase {
    /// An empty broad phase with fat-box margin `margin` m
    /// ([`DEFAULT_MARGIN`] by [`Default`]).
    ///
    /// # Errors
    /// A margin outside `[0, MAX_COORDINATE]` (or NaN).
    pub fn new(margin: f64) -> Result<Self, BroadPhaseError> {
        Ok(Self {
            tree: DynamicTree::new(margin)?,
            ..Self::default()
        })
    }

    /// The tree, for scene queries and statistics.
    #[inline]
    pub fn tree(&self) -> &DynamicTree {
        &self.tree
    }

    /// Number of proxies.
    #[inline]
    pub fn len(&self) -> usize {
        self.proxies.len()
    }

    /// True when there is no proxy.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.proxies.is_empty()
    }

    /// True when a proxy has this key.
    #[inline]
    pub fn contains(&self, key: u32) -> bool {
        self.proxies.contains_key(&key)
    }

    /// Adds proxy `key` with tight box `aabb` (m). Static proxies are never
    /// paired with each other.
    ///
    /// # Errors
    /// A key already present, a non-finite or inverted box, or a full tree;
    /// nothing changes.
    pub fn insert(&mut self, key: u32, aabb: Aabb, is_static: bool) -> Result<(), BroadPhaseError> {
        if self.proxies.contains_key(&key) {
            return Err(BroadPhaseError::DuplicateKey(key));
        }
        let id = self.tree.create_proxy(aabb, key)?;
        if self.info.len() <= id.index() {
            self.info.resize(id.index() + 1, None);
        }
        self.info[id.index()] = Some(ProxyInfo {
            key,
            tight: aabb,
            is_static,
            moved: true,
        });
        self.proxies.insert(key, id);
        self.touched.push(key);
        Ok(())
    }

    /// Removes proxy `key`; its pairs go at the next pair update.
    ///
    /// # Errors
    /// An unknown key.
    pub fn remove(&mut self, key: u32) -> Result<(), BroadPhaseError> {
        let id = *self
            .proxies
            .get(&key)
            .ok_or(BroadPhaseError::UnknownKey(key))?;
        self.tree.destroy_proxy(id)?;
        self.proxies.remove(&key);
        self.info[id.index()] = None;
        self.touched.push(key);
        Ok(())
    }

    /// Moves proxy `key` to tight box `aabb` (m) after a step that moved it
    /// by `displacement` (m). Returns `true` when its fat box changed, so
    /// the next pair update will look for its new pairs.
    ///
    /// # Errors
    /// An unknown key, a non-finite or inverted box or a non-finite
    /// displacement; nothing changes.
    pub fn update(
        &mut self,
        key: u32,
        aabb: Aabb,
        displacement: DVec3,
    ) -> Result<bool, BroadPhaseError> {
        let id = *self
            .proxies
            .get(&key)
            .ok_or(BroadPhaseError::UnknownKey(key))?;
        let moved = self.tree.move_proxy(id, aabb, displacement)?;
        if let Some(info) = self.info.get_mut(id.index()).and_then(Option::as_mut) {
            info.tight = aabb;
            if moved && !info.moved {
                info.moved = true;
                self.touched.push(key);
            }
        }
        Ok(moved)
    }

    /// Whether the tight boxes (as last inserted or updated) of a pair's
    /// proxies overlap; true when either is unknown. A pair comes from its
    /// fat boxes, which stay put while a proxy moves within them, so many
    /// pairs are farther apart than their tight boxes allow.
    pub fn tight_boxes_overlap(&self, pair: &Pair) -> bool {
        let tight = |key: u32| {
            let id = self.proxies.get(&key)?;
            self.info.get(id.index())?.as_ref().map(|i| i.tight)
        };
        match (tight(pair.a), tight(pair.b)) {
            (Some(a), Some(b)) => a.intersects(&b),
            _ => true,
        }
    }

    /// The fat box of proxy `key` (m): what pairs are made of.
    pub fn fat_aabb(&self, key: u32) -> Option<Aabb> {
        self.tree.fat_aabb(*self.proxies.get(&key)?)
    }

    /// Every proxy as `(key, fat box, static)`, in proxy-id order: the input
    /// for [`brute_force_pairs`].
    pub fn proxies(&self) -> Vec<(u32, Aabb, bool)> {
        self.info
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let p = p.as_ref()?;
                let id = *self.proxies.get(&p.key)?;
                debug_assert_eq!(id.index(), i);
                Some((p.key, self.tree.fat_aabb(id)?, p.is_static))
            })
            .collect()
    }

    /// Brings the pair set up to date with the moves, inserts and removals
    /// since the last call. Only proxies whose fat box changed query the
    /// tree (in parallel); pairs between unmoved proxies are kept as they
    /// are. The result is sorted and independent of thread count.
    pub fn update_pairs(&mut self) {
        if self.touched.is_empty() {
            // Nothing left its fat box: the common case for a settled scene.
            self.added.clear();
            self.removed.clear();
            return;
        }
        let mut touched = std::mem::take(&mut self.touched);
        touched.sort_unstable();
        touched.dedup();
        let mut movers: Vec<(u32, ProxyId)> = touched
            .iter()
            .filter_map(|&k| Some((k, *self.proxies.get(&k)?)))
            .collect();

        let tree = &self.tree;
        let info = &self.info;
        let found = par_map_chunks(&mut movers, QUERY_CHUNK, |_, chunk| {
            let mut stack = Vec::with_capacity(64);
            let mut out = Vec::new();
            for &(key, id) in chunk.iter() {
                let (Some(Some(me)), Some(fat)) = (info.get(id.index()), tree.fat_aabb(id)) else {
                    continue;
                };
                tree.query_with(&fat, &mut stack, |hit| {
                    if hit == id {
                        return true;
                    }
                    if let Some(Some(other)) = info.get(hit.index()) {
                        // When both moved, the smaller key's query reports it.
                        let reported_by_other = other.moved && other.key < key;
                        let both_static = me.is_static && other.is_static;
                        if !(reported_by_other || both_static) {
                            out.push(Pair::new(key, other.key));
                        }
                    }
                    true
                });
            }
            out
        });
        let mut fresh: Vec<Pair> = found.into_iter().flatten().collect();
        fresh.sort_unstable();
        fresh.dedup();
        self.merge_pairs(&touched, &fresh);

        for (_, id) in &movers {
            if let Some(Some(p)) = self.info.get_mut(id.index()) {
                p.moved = false;
            }
        }
        touched.clear();
        self.touched = touched;
    }

    /// The pair set after the proxies `touched` (sorted) moved and found
    /// the pairs `fresh` (sorted): the old pairs of untouched proxies are
    /// kept, those of touched ones give way to `fresh`. One walk over the
    /// old pairs and `fresh` (a pile of thousands has a hundred thousand
    /// pairs, of which a step touches a few), which also sorts out the
    /// pairs added and removed.
    fn merge_pairs(&mut self, touched: &[u32], fresh: &[Pair]) {
        let top = touched.last().map_or(0, |&k| k as usize + 1);
        if self.marks.len() < top {
            self.marks.resize(top, false);
        }
        for &k in touched {
            self.marks[k as usize] = true;
        }
        let marks = &self.marks;
        let is_touched = |k: u32| marks.get(k as usize).copied().unwrap_or(false);
        let old = std::mem::take(&mut self.pairs);
        let mut out = std::mem::take(&mut self.spare);
        out.clear();
        out.reserve(old.len() + fresh.len());
        self.added.clear();
        self.removed.clear();
        let mut fresh = fresh.iter().copied().peekable();
        for &p in &old {
            while let Some(q) = fresh.next_if(|&q| q < p) {
                // New: no old pair has it.
                out.push(q);
                self.added.push(q);
            }
            if fresh.next_if_eq(&p).is_some() {
                // Found again: kept, neither added nor removed.
                out.push(p);
            } else if is_touched(p.a) || is_touched(p.b) {
                // A touched proxy's pair not found again: the boxes parted.
                self.removed.push(p);
            } else {
                out.push(p);
            }
        }
        for q in fresh {
            out.push(q);
            self.added.push(q);
        }
        for &k in touched {
            self.marks[k as usize] = false;
        }
        self.pairs = out;
        self.spare = old;
    }

    /// Every overlapping pair of fat boxes as of the last
    /// [`update_pairs`](Self::update_pairs), sorted.
    #[inline]
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// Pairs that began at the last [`update_pairs`](Self::update_pairs), sorted.
    #[inline]
    pub fn added_pairs(&self) -> &[Pair] {
        &self.added
    }

    /// Pairs that ended at the last [`update_pairs`](Self::update_pairs)
    /// (boxes parted, or a proxy was removed), sorted.
    #[inline]
    pub fn removed_pairs(&self) -> &[Pair] {
        &self.removed
    }

    /// Calls `f(key)` for every proxy whose fat box overlaps `aabb` (m), in
    /// tree order; `f` returns `false` to stop.
    pub fn query(&self, aabb: &Aabb, mut f: impl FnMut(u32) -> bool) {
        self.tree
            .query(aabb, |id| self.tree.user_data(id).is_none_or(&mut f));
    }

    /// Casts a ray against the fat boxes; as
    /// [`DynamicTree::ray_cast`], with the proxy's key in place of its id.
    ///
    /// # Errors
    /// As [`DynamicTree::ray_cast`].
    pub fn ray_cast(
        &self,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        mut f: impl FnMut(u32, f64) -> f64,
    ) -> Result<(), BroadPhaseError> {
        self.tree
            .ray_cast(origin, dir, max_t, |id, t| match self.tree.user_data(id) {
                Some(key) => f(key, t),
                None => max_t,
            })
    }

    /// Rebuilds the tree top-down (binned SAH). Pairs are unaffected.
    pub fn rebuild(&mut self) {
        self.tree.rebuild();
    }

    /// Checks the tree's invariants, that every fat box contains its tight
    /// box, and that keys, proxies and side table agree.
    ///
    /// # Errors
    /// [`BroadPhaseError::Invariant`] naming the first problem.
    #[doc(hidden)]
    pub fn validate(&self) -> Result<(), BroadPhaseError> {
        self.tree.validate()?;
        if self.tree.len() != self.proxies.len() {
            return Err(BroadPhaseError::Invariant {
                node: 0,
                what: "tree size differs from the key map",
            });
        }
        for (i, p) in self.info.iter().enumerate() {
            let Some(p) = p else { continue };
            let node = i as u32;
            let bad = |what| Err(BroadPhaseError::Invariant { node, what });
            match self.proxies.get(&p.key) {
                Some(id) if id.index() == i => {}
                _ => return bad("side table key does not map back to its proxy"),
            }
            match self.tree.fat_aabb(ProxyId::from_index(node)) {
                Some(fat) if fat.contains(&p.tight) => {}
                Some(_) => return bad("fat box does not contain the tight box"),
                None => return bad("side table names a dead proxy"),
            }
        }
        Ok(())
    }
}
