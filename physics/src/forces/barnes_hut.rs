//! Barnes–Hut gravity (Barnes & Hut, *Nature* 324, 1986).
//!
//! An octree is built over the particles each step: a cell is split into
//! eight until it holds at most [`LEAF_SIZE`] particles. Each cell stores its
//! total mass and centre of mass. To find the force on a particle the tree is
//! walked from the root; a cell of side `s` whose centre of mass is at
//! distance `d` is taken as one point mass when `s / d < θ`, otherwise its
//! children are opened. Leaves are summed particle by particle.
//!
//! Error: with monopole cells the relative force error grows roughly as θ²;
//! the RMS relative error is below [`rms_error_bound`]`(θ)` on the
//! distributions we test. The build is sequential and
//! ordered (partitioning index lists, no hashing), the walk is parallel per
//! particle, so the result does not depend on the thread count.

use glam::DVec3;

use crate::parallel::{par_map_chunks, CHUNK};

/// Maximum particles in a leaf cell.
pub const LEAF_SIZE: usize = 8;
const MAX_DEPTH: u32 = 48;

/// The RMS relative force error Barnes–Hut stays below for opening angle
/// `theta` ≤ 1 on the distributions in our tests (uniform ball, Plummer-like
/// cluster, thin disc; 3000 bodies, ε = 0.01): `0.1 θ²`. For θ = 0.5 that is
/// 2.5%; measured there: 0.33% (cluster), 0.76% (ball), 1.27% (disc), with
/// the single worst particle at 11%. Leaves far enough away count as one
/// point mass like any other cell. Monopole cells only, so the error falls
/// roughly as θ² to θ³ (Barnes & Hut 1986; Salmon & Warren 1994 discuss the
/// worst cases).
pub fn rms_error_bound(theta: f64) -> f64 {
    (0.1 * theta * theta).max(1e-6)
}

#[derive(Debug, Clone, Copy)]
struct Node {
    /// Centre of mass, m.
    com: DVec3,
    /// Total mass, kg.
    mass: f64,
    /// Side length of the cell, m.
    size: f64,
    /// First child index (children are contiguous, 8 of them), or 0 for a leaf.
    first_child: u32,
    /// For a leaf: range in `Octree::order`.
    start: u32,
    end: u32,
}

/// An octree over one set of positions; rebuilt every step.
#[derive(Debug, Default, Clone)]
pub(crate) struct Octree {
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// `rank[i]`: where particle `i` sits in `order` (u32::MAX if not in the
    /// tree), so a walk can tell in O(1) whether a cell contains it.
    rank: Vec<u32>,
}

impl Octree {
    /// Builds the tree over the particles with `mass > 0`.
    pub(crate) fn build(x: &[DVec3], mass: &[f64]) -> Self {
        let mut order: Vec<u32> = (0..x.len() as u32)
            .filter(|&i| mass[i as usize] > 0.0)
            .collect();
        let mut tree = Octree {
            nodes: Vec::new(),
            order: Vec::new(),
            rank: Vec::new(),
        };
        if order.is_empty() {
            return tree;
        }
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &i in &order {
            lo = lo.min(x[i as usize]);
            hi = hi.max(x[i as usize]);
        }
        let size = (hi - lo).max_element().max(1e-12);
        let center = 0.5 * (lo + hi);
        let n = order.len();
        tree.nodes.push(Node {
            com: DVec3::ZERO,
            mass: 0.0,
            size,
            first_child: 0,
            start: 0,
            end: n as u32,
        });
        tree.split(0, center, x, mass, &mut order, 0);
        tree.rank = vec![u32::MAX; x.len()];
        for (r, &i) in order.iter().enumerate() {
            tree.rank[i as usize] = r as u32;
        }
        tree.order = order;
        tree
    }

    fn split(
        &mut self,
        node: usize,
        center: DVec3,
        x: &[DVec3],
        mass: &[f64],
        order: &mut [u32],
        depth: u32,
    ) {
        let (start, end) = (
            self.nodes[node].start as usize,
            self.nodes[node].end as usize,
        );
        let size = self.nodes[node].size;
        if end - start <= LEAF_SIZE || depth >= MAX_DEPTH {
            let (mut m, mut mx) = (0.0, DVec3::ZERO);
            for &i in &order[start..end] {
                m += mass[i as usize];
                mx += mass[i as usize] * x[i as usize];
            }
            let n = &mut self.nodes[node];
            n.mass = m;
            n.com = mx / m;
            return;
        }
        // Stable partition into octants: counting sort by octant code.
        let octant = |p: DVec3| -> usize {
            (usize::from(p.x >= center.x))
                | (usize::from(p.y >= center.y) << 1)
                | (usize::from(p.z >= center.z) << 2)
        };
        let mut counts = [0usize; 8];
        for &i in &order[start..end] {
            counts[octant(x[i as usize])] += 1;
        }
        let mut offsets = [0usize; 9];
        for k in 0..8 {
            offsets[k + 1] = offsets[k] + counts[k];
        }
        let mut sorted = vec![0u32; end - start];
        let mut cursor = offsets;
        for &i in &order[start..end] {
            let o = octant(x[i as usize]);
            sorted[cursor[o]] = i;
            cursor[o] += 1;
        }
        order[start..end].copy_from_slice(&sorted);

        let first = self.nodes.len();
        self.nodes[node].first_child = first as u32;
        for k in 0..8 {
            self.nodes.push(Node {
                com: DVec3::ZERO,
                mass: 0.0,
                size: 0.5 * size,
                first_child: 0,
                start: (start + offsets[k]) as u32,
                end: (start + offsets[k + 1]) as u32,
            });
        }
        let quarter = 0.25 * size;
        let (mut m, mut mx) = (0.0, DVec3::ZERO);
        for k in 0..8 {
            let child = first + k;
            if self.nodes[child].start == self.nodes[child].end {
                continue;
            }
            let c = center
                + DVec3::new(
                    if k & 1 != 0 { quarter } else { -quarter },
                    if k & 2 != 0 { quarter } else { -quarter },
                    if k & 4 != 0 { quarter } else { -quarter },
                );
            self.split(child, c, x, mass, order, depth + 1);
            m += self.nodes[child].mass;
            mx += self.nodes[child].mass * self.nodes[child].com;
        }
        let n = &mut self.nodes[node];
        n.mass = m;
        n.com = mx / m;
    }

    /// Field at particle `i` (position `xi`): `(Σ m_j d / r³, Σ m_j / r)` with
    /// softening; the caller multiplies by `G m_i`.
    #[inline]
    fn field(
        &self,
        i: u32,
        xi: DVec3,
        x: &[DVec3],
        mass: &[f64],
        theta2: f64,
        eps2: f64,
    ) -> (DVec3, f64) {
        let mut acc = DVec3::ZERO;
        let mut phi = 0.0;
        if self.nodes.is_empty() {
            return (acc, phi);
        }
        let mut stack: [u32; 8 * MAX_DEPTH as usize + 8] = [0; 8 * MAX_DEPTH as usize + 8];
        let mut top = 1usize;
        stack[0] = 0;
        let rank = self.rank.get(i as usize).copied().unwrap_or(u32::MAX);
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.mass == 0.0 {
                continue;
            }
            // A cell far enough away counts as one point mass — leaves
            // included. A cell that contains `i` itself is always opened, so
            // a particle never attracts itself.
            let contains_i = node.start <= rank && rank < node.end;
            let d = node.com - xi;
            let d2 = d.length_squared();
            if !contains_i && node.size * node.size < theta2 * d2 {
                let inv_r = 1.0 / (d2 + eps2).sqrt();
                acc += (node.mass * inv_r * inv_r * inv_r) * d;
                phi += node.mass * inv_r;
                continue;
            }
            if node.first_child == 0 {
                for &j in &self.order[node.start as usize..node.end as usize] {
                    if j == i {
                        continue;
                    }
                    let d = x[j as usize] - xi;
                    let inv_r = 1.0 / (d.length_squared() + eps2).sqrt();
                    let mj = mass[j as usize];
                    acc += (mj * inv_r * inv_r * inv_r) * d;
                    phi += mj * inv_r;
                }
                continue;
            }
            for k in (0..8).rev() {
                stack[top] = node.first_child + k;
                top += 1;
            }
        }
        (acc, phi)
    }

    /// Adds each particle's Barnes–Hut force, N, to `out`.
    pub(crate) fn forces(
        &self,
        x: &[DVec3],
        mass: &[f64],
        g: f64,
        eps2: f64,
        theta: f64,
        out: &mut [DVec3],
    ) {
        let theta2 = theta * theta;
        par_map_chunks(out, CHUNK / 16, |base, chunk| {
            for (k, o) in chunk.iter_mut().enumerate() {
                let i = base + k;
                if mass[i] == 0.0 {
                    continue;
                }
                let (a, _) = self.field(i as u32, x[i], x, mass, theta2, eps2);
                *o += (g * mass[i]) * a;
            }
        });
    }

    /// Barnes–Hut estimate of the total potential energy, J.
    pub(crate) fn potential(
        &self,
        x: &[DVec3],
        mass: &[f64],
        g: f64,
        eps2: f64,
        theta: f64,
    ) -> f64 {
        let theta2 = theta * theta;
        let mut phi = vec![0.0f64; x.len()];
        par_map_chunks(&mut phi, CHUNK / 16, |base, chunk| {
            for (k, p) in chunk.iter_mut().enumerate() {
                let i = base + k;
                if mass[i] > 0.0 {
                    *p = -0.5 * g * mass[i] * self.field(i as u32, x[i], x, mass, theta2, eps2).1;
                }
            }
        });
        phi.iter().sum()
    }
}
