//! Sweep and prune: the measured alternative to the tree.
//!
//! Every update sorts the fat boxes by their lower bound along the axis in
//! which the box centres vary most, then sweeps: each box is tested against
//! the boxes that start before it ends. Frame-to-frame coherence makes the
//! sort cheap (the standard library's sort is adaptive, so an almost sorted
//! order costs about O(n)), but every update still touches every box, and
//! boxes stacked along the sweep axis (a pyramid seen from the side) are all
//! tested against each other. It keeps the same fat boxes as the tree, by the
//! same rule, so the two report identical pairs; the module note of
//! [`broad_phase`](super) has the numbers.

use std::collections::HashMap;

use glam::DVec3;

use super::{check_aabb, check_vec, fat_box, keep_fat_box, BroadPhaseError, Pair, MAX_COORDINATE};
use crate::rigid::aabb::Aabb;

#[derive(Debug, Clone)]
struct Entry {
    key: u32,
    fat: Aabb,
    is_static: bool,
}

/// A sweep-and-prune broad phase over fat boxes, keyed like
/// [`BroadPhase`](super::BroadPhase).
#[derive(Debug, Clone)]
pub struct SweepAndPrune {
    margin: f64,
    entries: Vec<Entry>,
    /// key → index in `entries`. Only looked up, never iterated.
    index: HashMap<u32, usize>,
    /// Entry indices sorted by `fat.min[axis]` at the last update.
    order: Vec<u32>,
    axis: usize,
    pairs: Vec<Pair>,
}

impl SweepAndPrune {
    /// An empty sweep and prune with fat-box margin `margin` m.
    ///
    /// # Errors
    /// A margin outside `[0, MAX_COORDINATE]` (or NaN).
    pub fn new(margin: f64) -> Result<Self, BroadPhaseError> {
        if !(0.0..=MAX_COORDINATE).contains(&margin) {
            return Err(BroadPhaseError::BadMargin(margin));
        }
        Ok(Self {
            margin,
            entries: Vec::new(),
            index: HashMap::new(),
            order: Vec::new(),
            axis: 0,
            pairs: Vec::new(),
        })
    }

    /// Number of proxies.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when there is no proxy.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Adds a proxy `key` with tight box `aabb` (m).
    ///
    /// # Errors
    /// A key already present, or a bad box; nothing changes.
    pub fn insert(&mut self, key: u32, aabb: Aabb, is_static: bool) -> Result<(), BroadPhaseError> {
        check_aabb(&aabb)?;
        if self.index.contains_key(&key) {
            return Err(BroadPhaseError::DuplicateKey(key));
        }
        let fat = fat_box(&aabb, self.margin, DVec3::ZERO);
        if self.entries.len() >= u32::MAX as usize {
            return Err(BroadPhaseError::TooManyProxies);
        }
        self.index.insert(key, self.entries.len());
        self.order.push(self.entries.len() as u32);
        self.entries.push(Entry {
            key,
            fat,
            is_static,
        });
        Ok(())
    }

    /// Removes proxy `key`. O(n): the sweep order is compacted.
    ///
    /// # Errors
    /// An unknown key.
    pub fn remove(&mut self, key: u32) -> Result<(), BroadPhaseError> {
        let i = self
            .index
            .remove(&key)
            .ok_or(BroadPhaseError::UnknownKey(key))?;
        self.entries.swap_remove(i);
        if let Some(moved) = self.entries.get(i) {
            self.index.insert(moved.key, i);
        }
        // Entry `len` became `i`; entry `i` is gone.
        let last = self.entries.len() as u32;
        self.order.retain(|&e| e as usize != i);
        for e in &mut self.order {
            if *e == last {
                *e = i as u32;
            }
        }
        Ok(())
    }

    /// Moves proxy `key` to tight box `aabb` (m) after a displacement (m);
    /// `true` when its fat box changed. Same rule as
    /// [`DynamicTree::move_proxy`](super::DynamicTree::move_proxy).
    ///
    /// # Errors
    /// An unknown key, or a bad box or displacement; nothing changes.
    pub fn update(
        &mut self,
        key: u32,
        aabb: Aabb,
        displacement: DVec3,
    ) -> Result<bool, BroadPhaseError> {
        let &i = self
            .index
            .get(&key)
            .ok_or(BroadPhaseError::UnknownKey(key))?;
        check_aabb(&aabb)?;
        check_vec("proxy displacement", displacement)?;
        let fat = fat_box(&aabb, self.margin, displacement);
        let e = &mut self.entries[i];
        if keep_fat_box(&e.fat, &aabb, &fat, self.margin) {
            return Ok(false);
        }
        e.fat = fat;
        Ok(true)
    }

    /// The fat box of proxy `key` (m).
    pub fn fat_aabb(&self, key: u32) -> Option<Aabb> {
        self.index.get(&key).map(|&i| self.entries[i].fat)
    }

    /// Recomputes every overlapping pair of fat boxes (not both static),
    /// sorted; see [`pairs`](Self::pairs).
    pub fn update_pairs(&mut self) {
        let n = self.entries.len();
        let axis = if n == 0 {
            0
        } else {
            // Axis of largest variance of the centres (Ericson, RTCD §7.5).
            let mut s = DVec3::ZERO;
            let mut s2 = DVec3::ZERO;
            for e in &self.entries {
                let c = e.fat.center();
                s += c;
                s2 += c * c;
            }
            let var = s2 / n as f64 - (s / n as f64) * (s / n as f64);
            if var.x >= var.y && var.x >= var.z {
                0
            } else if var.y >= var.z {
                1
            } else {
                2
            }
        };
        self.axis = axis;
        let entries = &self.entries;
        self.order.sort_by(|&a, &b| {
            entries[a as usize].fat.min[axis].total_cmp(&entries[b as usize].fat.min[axis])
        });
        self.pairs.clear();
        for (k, &a) in self.order.iter().enumerate() {
            let ea = &entries[a as usize];
            let end = ea.fat.max[axis];
            for &b in &self.order[k + 1..] {
                let eb = &entries[b as usize];
                if eb.fat.min[axis] > end {
                    break;
                }
                if (ea.is_static && eb.is_static) || !ea.fat.intersects(&eb.fat) {
                    continue;
                }
                self.pairs.push(Pair::new(ea.key, eb.key));
            }
        }
        self.pairs.sort_unstable();
    }

    /// The overlapping pairs found by the last
    /// [`update_pairs`](Self::update_pairs), sorted.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }
}
