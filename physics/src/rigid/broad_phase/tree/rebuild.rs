//! Top-down rebuild of a [`DynamicTree`] by the binned surface-area
//! heuristic (Wald, "On fast construction of SAH-based bounding volume
//! hierarchies", 2007): at each node the leaf centres are dropped into a
//! dozen bins along their longest axis and the split between bins with the
//! least `area × count` on both sides wins. Better trees than incremental
//! insertion, for geometry that will not move again.

use glam::DVec3;

use super::{DynamicTree, Node, FREE, NULL};
use crate::rigid::aabb::Aabb;

/// Bins per axis: 12 is the usual sweet spot (Wald 2007).
const SAH_BINS: usize = 12;
/// Past this depth a rebuild splits at the median instead of by SAH, so a
/// pathological input cannot make it recurse deeply.
const SAH_MAX_DEPTH: u32 = 48;

impl DynamicTree {
    /// Rebuilds the hierarchy top-down by binned SAH over the current fat
    /// boxes. Proxy ids and boxes are kept; only the internal nodes change.
    /// O(n log n); worth it after loading static geometry, whose incremental
    /// tree is never improved by later moves.
    pub fn rebuild(&mut self) {
        let mut leaves = Vec::with_capacity(self.leaf_count);
        for i in 0..self.nodes.len() {
            let node = &self.nodes[i];
            if node.height == FREE {
                continue;
            }
            if node.is_leaf() {
                leaves.push(i as u32);
            } else {
                self.release(i as u32);
            }
        }
        self.root = NULL;
        if leaves.is_empty() {
            return;
        }
        let mut centers: Vec<(u32, DVec3)> = leaves
            .iter()
            .map(|&l| (l, self.nodes[l as usize].aabb.center()))
            .collect();
        let root = self.build(&mut centers, 0);
        self.nodes[root as usize].parent = NULL;
        self.root = root;
    }

    /// Builds a subtree over `items` (leaf index, centre), returns its root.
    fn build(&mut self, items: &mut [(u32, DVec3)], depth: u32) -> u32 {
        if let [(leaf, _)] = items {
            return *leaf;
        }
        let split = self.sah_split(items, depth);
        let (left, right) = items.split_at_mut(split);
        let l = self.build(left, depth + 1);
        let r = self.build(right, depth + 1);
        let (nl, nr) = (&self.nodes[l as usize], &self.nodes[r as usize]);
        let node = Node {
            aabb: nl.aabb.union(&nr.aabb),
            parent: NULL,
            child1: l,
            child2: r,
            height: 1 + nl.height.max(nr.height),
            user_data: NULL,
        };
        let p = self.allocate(node);
        self.nodes[l as usize].parent = p;
        self.nodes[r as usize].parent = p;
        p
    }

    /// Reorders `items` and returns the split point (in `1..len`): binned
    /// SAH along the longest axis of the centres, the median when the
    /// centres coincide, SAH finds no split or the tree is already deep.
    fn sah_split(&self, items: &mut [(u32, DVec3)], depth: u32) -> usize {
        let n = items.len();
        let mut cmin = DVec3::splat(f64::INFINITY);
        let mut cmax = DVec3::splat(f64::NEG_INFINITY);
        for (_, c) in items.iter() {
            cmin = cmin.min(*c);
            cmax = cmax.max(*c);
        }
        let ext = cmax - cmin;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let median = |items: &mut [(u32, DVec3)]| {
            items.select_nth_unstable_by(n / 2, |a, b| {
                a.1[axis].total_cmp(&b.1[axis]).then(a.0.cmp(&b.0))
            });
            n / 2
        };
        if ext[axis] <= 0.0 || ext[axis].is_nan() || depth >= SAH_MAX_DEPTH {
            return median(items);
        }
        let bin_of = |c: DVec3| {
            let b = ((c[axis] - cmin[axis]) / ext[axis] * SAH_BINS as f64) as usize;
            b.min(SAH_BINS - 1)
        };
        let mut counts = [0usize; SAH_BINS];
        let mut boxes: [Option<Aabb>; SAH_BINS] = [None; SAH_BINS];
        for &(leaf, c) in items.iter() {
            let b = bin_of(c);
            counts[b] += 1;
            let lb = self.nodes[leaf as usize].aabb;
            boxes[b] = Some(boxes[b].map_or(lb, |x| x.union(&lb)));
        }
        // Area × count of everything right of each plane, swept from the right.
        let mut right_cost = [0.0; SAH_BINS];
        let (mut acc, mut cnt) = (None::<Aabb>, 0usize);
        for b in (1..SAH_BINS).rev() {
            if let Some(bx) = boxes[b] {
                acc = Some(acc.map_or(bx, |a| a.union(&bx)));
            }
            cnt += counts[b];
            right_cost[b] = acc.map_or(0.0, |a| a.surface_area()) * cnt as f64;
        }
        let (mut acc, mut cnt) = (None::<Aabb>, 0usize);
        let mut best = (f64::INFINITY, 0usize);
        for b in 0..SAH_BINS - 1 {
            if let Some(bx) = boxes[b] {
                acc = Some(acc.map_or(bx, |a| a.union(&bx)));
            }
            cnt += counts[b];
            if cnt == 0 || cnt == n {
                continue;
            }
            let cost = acc.map_or(0.0, |a| a.surface_area()) * cnt as f64 + right_cost[b + 1];
            if cost < best.0 {
                best = (cost, b);
            }
        }
        if !best.0.is_finite() {
            return median(items);
        }
        // Partition: bins <= best to the left, keeping the order stable
        // enough to be deterministic (it depends only on the input order).
        let mut split = 0;
        for i in 0..n {
            if bin_of(items[i].1) <= best.1 {
                items.swap(i, split);
                split += 1;
            }
        }
        if split == 0 || split == n {
            return median(items);
        }
        split
    }
}
