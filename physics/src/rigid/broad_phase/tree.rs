//! The dynamic AABB tree: a bounding volume hierarchy over fat boxes that is
//! updated one proxy at a time.
//!
//! Nodes live in a pool (`Vec<Node>`) with a free list, so a proxy's id is a
//! stable node index and removing proxies never moves others. Leaves hold the
//! proxies' fat boxes; every internal node has exactly two children and holds
//! their union. Insertion descends by the surface-area heuristic (the cost of
//! a node is its area, the probability that a random query ray or box hits it)
//! and the walk back up applies AVL-style rotations, which keep the height
//! O(log n) even for sorted insertion. [`DynamicTree::rebuild`] rebuilds the
//! whole hierarchy top-down with binned SAH, the better tree for geometry
//! that will not move again. The module note in
//! [`broad_phase`](super) gives the design and the credits.

mod rebuild;

use glam::DVec3;

use super::{
    check_aabb, check_vec, fat_box, keep_fat_box, BroadPhaseError, DEFAULT_MARGIN, MAX_COORDINATE,
};
use crate::rigid::aabb::Aabb;

const NULL: u32 = u32::MAX;
/// Marks a node in the free list.
const FREE: i32 = -1;

/// A proxy in a [`DynamicTree`]: the index of its leaf node. Ids of removed
/// proxies are reused by later insertions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(transparent)]
pub struct ProxyId(u32);

impl ProxyId {
    pub(crate) fn from_index(i: u32) -> Self {
        ProxyId(i)
    }

    /// The node index, dense from 0: usable to index side tables.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

#[derive(Debug, Clone)]
struct Node {
    /// Fat box for a leaf, union of the children otherwise; m.
    aabb: Aabb,
    parent: u32,
    /// `NULL` for a leaf.
    child1: u32,
    child2: u32,
    /// 0 for a leaf, 1 + the taller child otherwise, [`FREE`] in the free list.
    height: i32,
    /// The caller's tag, for leaves.
    user_data: u32,
}

impl Node {
    #[inline]
    fn is_leaf(&self) -> bool {
        self.child1 == NULL
    }
}

/// A dynamic bounding volume hierarchy of fat AABBs.
#[derive(Debug, Clone)]
pub struct DynamicTree {
    nodes: Vec<Node>,
    free: Vec<u32>,
    root: u32,
    leaf_count: usize,
    /// Fat-box margin, m.
    margin: f64,
}

impl Default for DynamicTree {
    /// An empty tree with [`DEFAULT_MARGIN`].
    fn default() -> Self {
        Self {
            nodes: Vec::new(),
            free: Vec::new(),
            root: NULL,
            leaf_count: 0,
            margin: DEFAULT_MARGIN,
        }
    }
}

impl DynamicTree {
    /// An empty tree whose leaves are the tight boxes grown by `margin` m on
    /// every side.
    ///
    /// # Errors
    /// A margin outside `[0, MAX_COORDINATE]` (or NaN).
    pub fn new(margin: f64) -> Result<Self, BroadPhaseError> {
        if !(0.0..=MAX_COORDINATE).contains(&margin) {
            return Err(BroadPhaseError::BadMargin(margin));
        }
        Ok(Self {
            margin,
            ..Self::default()
        })
    }

    /// The fat-box margin, m.
    #[inline]
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// Number of proxies.
    #[inline]
    pub fn len(&self) -> usize {
        self.leaf_count
    }

    /// True when the tree holds no proxy.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.leaf_count == 0
    }

    /// Height of the tree: 0 for empty or a single leaf.
    pub fn height(&self) -> u32 {
        match self.nodes.get(self.root as usize) {
            Some(n) => n.height.max(0) as u32,
            None => 0,
        }
    }

    /// Nodes in the pool, free ones included (memory use, not tree size).
    #[inline]
    pub fn node_capacity(&self) -> usize {
        self.nodes.len()
    }

    /// Sum of the surface areas of the internal nodes over the root's: the
    /// SAH quality of the tree (lower is better), 0 when there is no
    /// internal node.
    pub fn area_ratio(&self) -> f64 {
        let Some(root) = self.nodes.get(self.root as usize) else {
            return 0.0;
        };
        let root_area = root.aabb.surface_area();
        if root.is_leaf() || root_area <= 0.0 {
            return 0.0;
        }
        let total: f64 = self
            .nodes
            .iter()
            .filter(|n| n.height > 0)
            .map(|n| n.aabb.surface_area())
            .sum();
        total / root_area
    }

    /// The fat box of a proxy (m), or `None` for an id that is not a proxy.
    pub fn fat_aabb(&self, id: ProxyId) -> Option<Aabb> {
        self.leaf(id).ok().map(|n| self.nodes[n as usize].aabb)
    }

    /// The caller's tag of a proxy, or `None` for an id that is not a proxy.
    pub fn user_data(&self, id: ProxyId) -> Option<u32> {
        self.leaf(id).ok().map(|n| self.nodes[n as usize].user_data)
    }

    /// Inserts a proxy for the tight box `aabb` (m), tagged `user_data`.
    ///
    /// # Errors
    /// A non-finite or inverted box (or one so large that its fat box
    /// overflows), or a full pool (`u32` indices). The tree is unchanged.
    pub fn create_proxy(&mut self, aabb: Aabb, user_data: u32) -> Result<ProxyId, BroadPhaseError> {
        check_aabb(&aabb)?;
        let fat = fat_box(&aabb, self.margin, DVec3::ZERO);
        // A proxy may need a leaf and a new parent.
        let fresh = 2usize.saturating_sub(self.free.len());
        if self.nodes.len() + fresh > NULL as usize {
            return Err(BroadPhaseError::TooManyProxies);
        }
        let leaf = self.allocate(Node {
            aabb: fat,
            parent: NULL,
            child1: NULL,
            child2: NULL,
            height: 0,
            user_data,
        });
        self.insert_leaf(leaf);
        self.leaf_count += 1;
        Ok(ProxyId(leaf))
    }

    /// Removes a proxy and returns its tag.
    ///
    /// # Errors
    /// An id that is not a live proxy; the tree is unchanged.
    pub fn destroy_proxy(&mut self, id: ProxyId) -> Result<u32, BroadPhaseError> {
        let leaf = self.leaf(id)?;
        self.remove_leaf(leaf);
        let user_data = self.nodes[leaf as usize].user_data;
        self.release(leaf);
        self.leaf_count -= 1;
        Ok(user_data)
    }

    /// Moves a proxy to the tight box `aabb` (m) after a step that moved it
    /// by `displacement` (m). Returns `true` when the proxy was reinserted
    /// with a new fat box: the tight box left the old fat box, or the old
    /// fat box had grown far larger than needed. Otherwise nothing changes.
    ///
    /// The new fat box is the tight box plus the margin, stretched along the
    /// displacement so a body moving steadily stays inside it for a few steps.
    ///
    /// # Errors
    /// An unknown id, or a non-finite or inverted box or displacement; the
    /// tree is unchanged.
    pub fn move_proxy(
        &mut self,
        id: ProxyId,
        aabb: Aabb,
        displacement: DVec3,
    ) -> Result<bool, BroadPhaseError> {
        let leaf = self.leaf(id)?;
        check_aabb(&aabb)?;
        check_vec("proxy displacement", displacement)?;
        let fat = fat_box(&aabb, self.margin, displacement);
        if keep_fat_box(&self.nodes[leaf as usize].aabb, &aabb, &fat, self.margin) {
            return Ok(false);
        }
        self.remove_leaf(leaf);
        self.nodes[leaf as usize].aabb = fat;
        self.insert_leaf(leaf);
        Ok(true)
    }

    /// Calls `f` with every proxy whose fat box overlaps or touches `aabb`
    /// (m), in tree order; `f` returns `false` to stop. A box with NaN finds
    /// nothing.
    pub fn query(&self, aabb: &Aabb, mut f: impl FnMut(ProxyId) -> bool) {
        let mut stack = Vec::with_capacity(64);
        self.query_with(aabb, &mut stack, &mut f);
    }

    /// [`query`](Self::query) with a caller-owned traversal stack, so many
    /// queries can reuse one allocation.
    pub(crate) fn query_with(
        &self,
        aabb: &Aabb,
        stack: &mut Vec<u32>,
        mut f: impl FnMut(ProxyId) -> bool,
    ) {
        stack.clear();
        if self.root != NULL {
            stack.push(self.root);
        }
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if !node.aabb.intersects(aabb) {
                continue;
            }
            if node.is_leaf() {
                if !f(ProxyId(i)) {
                    return;
                }
            } else {
                stack.push(node.child1);
                stack.push(node.child2);
            }
        }
    }

    /// Casts the ray `origin + t dir` (m; `dir` need not be unit length, `t`
    /// is in units of it) for `t` in `[0, max_t]` against the fat boxes.
    ///
    /// `f(proxy, t_enter)` is called for each proxy whose box the ray
    /// reaches, with `t_enter` the entry parameter (0 when the origin is
    /// inside). Its return value steers the search: a negative value (or
    /// NaN) stops it; otherwise `max_t` becomes the smaller of the two, so
    /// returning `max_t` visits every hit and returning the exact hit
    /// parameter of the shape inside finds only closer ones. Hits come in
    /// tree order, not by distance.
    ///
    /// # Errors
    /// A non-finite origin or direction, or a `max_t` that is NaN or
    /// negative (`+∞` is allowed). Nothing is called.
    pub fn ray_cast(
        &self,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        mut f: impl FnMut(ProxyId, f64) -> f64,
    ) -> Result<(), BroadPhaseError> {
        check_vec("ray origin", origin)?;
        check_vec("ray direction", dir)?;
        if max_t.is_nan() || max_t < 0.0 {
            return Err(BroadPhaseError::BadRayLength(max_t));
        }
        let mut max_t = max_t;
        let mut stack = Vec::with_capacity(64);
        if self.root != NULL {
            stack.push(self.root);
        }
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let Some(t) = ray_box(origin, dir, max_t, &node.aabb) else {
                continue;
            };
            if node.is_leaf() {
                let r = f(ProxyId(i), t);
                if r.is_nan() || r < 0.0 {
                    return Ok(());
                }
                max_t = max_t.min(r);
            } else {
                stack.push(node.child1);
                stack.push(node.child2);
            }
        }
        Ok(())
    }

    /// Checks every structural invariant: parent links, heights, every
    /// internal box holding its children's, the leaf count and the free list.
    ///
    /// # Errors
    /// [`BroadPhaseError::Invariant`] naming the first broken node.
    #[doc(hidden)]
    pub fn validate(&self) -> Result<(), BroadPhaseError> {
        let bad = |node: u32, what: &'static str| Err(BroadPhaseError::Invariant { node, what });
        let mut seen = vec![false; self.nodes.len()];
        let mut leaves = 0usize;
        if self.root != NULL {
            if self.nodes[self.root as usize].parent != NULL {
                return bad(self.root, "root has a parent");
            }
            let mut stack = vec![self.root];
            while let Some(i) = stack.pop() {
                let Some(node) = self.nodes.get(i as usize) else {
                    return bad(i, "index out of the pool");
                };
                if std::mem::replace(&mut seen[i as usize], true) {
                    return bad(i, "reached twice");
                }
                if node.height == FREE {
                    return bad(i, "free node in the tree");
                }
                if node.is_leaf() {
                    if node.height != 0 || node.child2 != NULL {
                        return bad(i, "leaf with height or child");
                    }
                    leaves += 1;
                    continue;
                }
                let (c1, c2) = (node.child1, node.child2);
                let (Some(n1), Some(n2)) =
                    (self.nodes.get(c1 as usize), self.nodes.get(c2 as usize))
                else {
                    return bad(i, "child out of the pool");
                };
                if n1.parent != i || n2.parent != i {
                    return bad(i, "child's parent link is wrong");
                }
                if node.height != 1 + n1.height.max(n2.height) {
                    return bad(i, "height is not 1 + the taller child");
                }
                if !node.aabb.contains(&n1.aabb) || !node.aabb.contains(&n2.aabb) {
                    return bad(i, "box does not contain a child's box");
                }
                stack.push(c1);
                stack.push(c2);
            }
        }
        if leaves != self.leaf_count {
            return bad(self.root, "leaf count differs from the proxies reached");
        }
        let mut free_seen = vec![false; self.nodes.len()];
        for &f in &self.free {
            match self.nodes.get(f as usize) {
                Some(n) if n.height == FREE && !seen[f as usize] => {}
                _ => return bad(f, "free list names a live node"),
            }
            if std::mem::replace(&mut free_seen[f as usize], true) {
                return bad(f, "free list names a node twice");
            }
        }
        let reached = seen.iter().filter(|&&s| s).count();
        if reached + self.free.len() != self.nodes.len() {
            return bad(self.root, "node leaked: neither in the tree nor free");
        }
        Ok(())
    }

    // ------------------------------------------------------------ internals

    /// The node index of a live leaf.
    fn leaf(&self, id: ProxyId) -> Result<u32, BroadPhaseError> {
        match self.nodes.get(id.index()) {
            Some(n) if n.height == 0 => Ok(id.0),
            _ => Err(BroadPhaseError::UnknownProxy(id.0)),
        }
    }

    /// Takes a node from the free list or grows the pool. Callers have
    /// checked that an index is available.
    fn allocate(&mut self, node: Node) -> u32 {
        if let Some(i) = self.free.pop() {
            self.nodes[i as usize] = node;
            i
        } else {
            self.nodes.push(node);
            (self.nodes.len() - 1) as u32
        }
    }

    fn release(&mut self, i: u32) {
        let n = &mut self.nodes[i as usize];
        n.height = FREE;
        n.parent = NULL;
        n.child1 = NULL;
        n.child2 = NULL;
        self.free.push(i);
    }

    /// Puts a detached leaf into the tree: SAH descent to the best sibling
    /// (Box2D v2.4's greedy descent with inherited cost), a new parent, then
    /// refit and rebalance up to the root.
    fn insert_leaf(&mut self, leaf: u32) {
        if self.root == NULL {
            self.root = leaf;
            self.nodes[leaf as usize].parent = NULL;
            return;
        }
        let leaf_box = self.nodes[leaf as usize].aabb;
        let mut index = self.root;
        while !self.nodes[index as usize].is_leaf() {
            let node = &self.nodes[index as usize];
            let (c1, c2) = (node.child1, node.child2);
            let area = node.aabb.surface_area();
            let combined = node.aabb.union(&leaf_box).surface_area();
            // Making `index` the sibling costs a new parent of this area...
            let cost_here = 2.0 * combined;
            // ...and pushing the leaf further down grows `index` by this much.
            let inherited = 2.0 * (combined - area);
            let child_cost = |c: u32| {
                let n = &self.nodes[c as usize];
                let grown = n.aabb.union(&leaf_box).surface_area();
                if n.is_leaf() {
                    grown + inherited
                } else {
                    grown - n.aabb.surface_area() + inherited
                }
            };
            let (cost1, cost2) = (child_cost(c1), child_cost(c2));
            if cost_here < cost1 && cost_here < cost2 {
                break;
            }
            index = if cost1 < cost2 { c1 } else { c2 };
        }
        let sibling = index;
        let old_parent = self.nodes[sibling as usize].parent;
        let (sib_box, sib_height) = {
            let sib = &self.nodes[sibling as usize];
            (sib.aabb, sib.height)
        };
        let new_parent = self.allocate(Node {
            aabb: sib_box.union(&leaf_box),
            parent: old_parent,
            child1: sibling,
            child2: leaf,
            height: sib_height + 1,
            user_data: NULL,
        });
        if old_parent == NULL {
            self.root = new_parent;
        } else {
            self.replace_child(old_parent, sibling, new_parent);
        }
        self.nodes[sibling as usize].parent = new_parent;
        self.nodes[leaf as usize].parent = new_parent;
        self.refit_up(new_parent);
    }

    /// Detaches a leaf (it stays allocated); its parent is freed and the
    /// sibling takes the parent's place.
    fn remove_leaf(&mut self, leaf: u32) {
        if leaf == self.root {
            self.root = NULL;
            return;
        }
        let parent = self.nodes[leaf as usize].parent;
        let p = &self.nodes[parent as usize];
        let grand = p.parent;
        let sibling = if p.child1 == leaf { p.child2 } else { p.child1 };
        self.nodes[sibling as usize].parent = grand;
        if grand == NULL {
            self.root = sibling;
        } else {
            self.replace_child(grand, parent, sibling);
        }
        self.release(parent);
        self.nodes[leaf as usize].parent = NULL;
        if grand != NULL {
            self.refit_up(grand);
        }
    }

    fn replace_child(&mut self, parent: u32, old: u32, new: u32) {
        let p = &mut self.nodes[parent as usize];
        if p.child1 == old {
            p.child1 = new;
        } else {
            p.child2 = new;
        }
    }

    /// From `index` to the root: rebalance, then recompute height and box.
    fn refit_up(&mut self, mut index: u32) {
        while index != NULL {
            index = self.balance(index);
            let (c1, c2) = {
                let n = &self.nodes[index as usize];
                (n.child1, n.child2)
            };
            let (a1, h1) = (self.nodes[c1 as usize].aabb, self.nodes[c1 as usize].height);
            let (a2, h2) = (self.nodes[c2 as usize].aabb, self.nodes[c2 as usize].height);
            let n = &mut self.nodes[index as usize];
            n.height = 1 + h1.max(h2);
            n.aabb = a1.union(&a2);
            index = n.parent;
        }
    }

    /// An AVL rotation at `a` when its children's heights differ by more
    /// than one: the taller child moves up and `a` takes the place of that
    /// child's smaller grandchild. Returns the root of the subtree.
    fn balance(&mut self, a: u32) -> u32 {
        let na = &self.nodes[a as usize];
        if na.is_leaf() || na.height < 2 {
            return a;
        }
        let (b, c) = (na.child1, na.child2);
        let diff = self.nodes[c as usize].height - self.nodes[b as usize].height;
        if diff > 1 {
            self.rotate_up(a, c, b, false)
        } else if diff < -1 {
            self.rotate_up(a, b, c, true)
        } else {
            a
        }
    }

    /// Lifts the tall child `up` of `a` over it; `other` is `a`'s other
    /// child; `up_is_child1` says which slot of `a` `up` occupied.
    fn rotate_up(&mut self, a: u32, up: u32, other: u32, up_is_child1: bool) -> u32 {
        let (f, g) = {
            let n = &self.nodes[up as usize];
            (n.child1, n.child2)
        };
        let a_parent = self.nodes[a as usize].parent;
        self.nodes[up as usize].child1 = a;
        self.nodes[up as usize].parent = a_parent;
        self.nodes[a as usize].parent = up;
        if a_parent == NULL {
            self.root = up;
        } else {
            self.replace_child(a_parent, a, up);
        }
        // The taller grandchild stays under `up`; the shorter goes to `a`.
        let (keep, give) = if self.nodes[f as usize].height > self.nodes[g as usize].height {
            (f, g)
        } else {
            (g, f)
        };
        self.nodes[up as usize].child2 = keep;
        if up_is_child1 {
            self.nodes[a as usize].child1 = give;
        } else {
            self.nodes[a as usize].child2 = give;
        }
        self.nodes[give as usize].parent = a;
        let (ao, ho) = (
            self.nodes[other as usize].aabb,
            self.nodes[other as usize].height,
        );
        let (ag, hg) = (
            self.nodes[give as usize].aabb,
            self.nodes[give as usize].height,
        );
        let (ak, hk) = (
            self.nodes[keep as usize].aabb,
            self.nodes[keep as usize].height,
        );
        let a_box = ao.union(&ag);
        let a_height = 1 + ho.max(hg);
        {
            let n = &mut self.nodes[a as usize];
            n.aabb = a_box;
            n.height = a_height;
        }
        let n = &mut self.nodes[up as usize];
        n.aabb = a_box.union(&ak);
        n.height = 1 + a_height.max(hk);
        up
    }
}

/// Slab test: the entry parameter of `origin + t dir` into `b` for `t` in
/// `[0, max_t]`, or `None` when it misses. Divides rather than multiplying
/// by a reciprocal, so axis-parallel rays never make `0 · ∞ = NaN`.
fn ray_box(origin: DVec3, dir: DVec3, max_t: f64, b: &Aabb) -> Option<f64> {
    let (mut t0, mut t1) = (0.0f64, max_t);
    for axis in 0..3 {
        let (o, d) = (origin[axis], dir[axis]);
        let (lo, hi) = (b.min[axis], b.max[axis]);
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (mut ta, mut tb) = ((lo - o) / d, (hi - o) / d);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
        if t0 > t1 {
            return None;
        }
    }
    Some(t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_test_axis_parallel_and_inside() {
        let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
        assert_eq!(
            ray_box(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 10.0, &b),
            Some(1.0)
        );
        assert_eq!(
            ray_box(DVec3::new(-1.0, 1.5, 0.5), DVec3::X, 10.0, &b),
            None
        );
        assert_eq!(ray_box(DVec3::splat(0.5), DVec3::X, 10.0, &b), Some(0.0));
        assert_eq!(ray_box(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 0.5, &b), None);
        assert_eq!(
            ray_box(DVec3::new(-1.0, 0.5, 0.5), -DVec3::X, 10.0, &b),
            None
        );
    }
}
