//! Cloth self-collision: particles of one soft body that no constraint
//! joins keep `2 · collision_radius` apart.
//!
//! Candidates are found once a step on the neighbour grid (`xpbd/grid.rs`,
//! a counting sort, so the lists do not depend on the thread count),
//! within the contact distance plus how far the fastest particle goes in
//! the step. Each substep every particle then gathers, from its candidates
//! in their list's order, its share of the push that separates each close
//! pair (by the pair's inverse masses), from the positions as they stood (a
//! Jacobi pass), and moves by it: a pair's two shares add up to the whole
//! overlap, and each particle writes only itself.

use glam::Vec3;

use crate::parallel::{par_map_chunks, CHUNK};

use super::super::grid::{Grid, Neighbours};
use super::SoftBody;

/// What self-collision keeps between steps: derived data, rebuilt.
#[derive(Debug, Clone, Default)]
pub(crate) struct SelfCollision {
    grid: Grid,
    near: Neighbours,
    /// Per particle, the particles joined to it by a constraint
    /// (ascending), in `joined`; one more entry than particles.
    joined_start: Vec<u32>,
    joined: Vec<u32>,
    /// The edges the joins were built for.
    edges: usize,
    /// Positions as the substep's pass found them.
    before: Vec<Vec3>,
}

impl PartialEq for SelfCollision {
    /// Derived data: any two are alike.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Which particles of `body` are joined, each distance constraint's and
/// each triangle's: per particle where its list starts (one more entry
/// than particles), and the lists, each ascending.
pub(crate) fn joined(body: &SoftBody) -> (Vec<u32>, Vec<u32>) {
    let n = body.x.len();
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    for d in &body.distance.items {
        pairs.push((d.p[0], d.p[1]));
        pairs.push((d.p[1], d.p[0]));
    }
    for t in &body.triangles {
        for k in 0..3 {
            pairs.push((t[k], t[(k + 1) % 3]));
            pairs.push((t[(k + 1) % 3], t[k]));
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    let mut start = vec![0; n + 1];
    for &(a, _) in &pairs {
        start[a as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    (start, pairs.into_iter().map(|(_, b)| b).collect())
}

impl SelfCollision {
    /// Rebuilds which particles are joined when the constraints changed.
    fn joins(&mut self, body: &SoftBody) {
        let n = body.x.len();
        if self.joined_start.len() == n + 1 && self.edges == body.distance.items.len() {
            return;
        }
        (self.joined_start, self.joined) = joined(body);
        self.edges = body.distance.items.len();
    }

    fn is_joined(&self, i: usize, j: u32) -> bool {
        let list = &self.joined[self.joined_start[i] as usize..self.joined_start[i + 1] as usize];
        list.binary_search(&j).is_ok()
    }

    /// Finds the candidates of the step.
    pub(crate) fn prepare(&mut self, body: &SoftBody, reach: f32) {
        self.joins(body);
        self.near.build(&mut self.grid, &body.x, reach);
    }

    /// One pass: every particle pushed out of the particles near it.
    pub(crate) fn project(&mut self, body: &mut SoftBody, radius: f32) {
        let contact = 2.0 * radius;
        self.before.clear();
        self.before.extend_from_slice(&body.x);
        let (before, w, this) = (&self.before, &body.w, &*self);
        par_map_chunks(&mut body.x, CHUNK, |base, xs| {
            for (k, x) in xs.iter_mut().enumerate() {
                let i = base + k;
                let wi = w[i];
                if wi <= 0.0 {
                    continue;
                }
                let mut push = Vec3::ZERO;
                for &j in this.near.of(i) {
                    let d = before[i] - before[j as usize];
                    let len = d.length();
                    if len >= contact || len < 1e-9 || this.is_joined(i, j) {
                        continue;
                    }
                    let share = wi / (wi + w[j as usize]);
                    push += d * ((contact - len) / len * share);
                }
                let moved = *x + push;
                if moved.is_finite() {
                    *x = moved;
                }
            }
        });
    }
}
