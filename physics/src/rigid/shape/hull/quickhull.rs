//! Quickhull with exact orientation tests: the triangulated hull.
//!
//! See the design note in [`hull`](super) for why the above/below test is
//! exact while everything else is floating point.

use std::collections::VecDeque;

use glam::DVec3;

use super::chain_loop;
use crate::rigid::shape::ShapeError;

/// A working triangle of the Quickhull mesh.
#[derive(Debug)]
struct Tri {
    /// Point indices, counter-clockwise seen from outside.
    v: [u32; 3],
    /// Outward unit normal (scaled coordinates); zero for a sliver whose
    /// normal rounds away. Only ranks points and seeds merging: every
    /// above/below decision uses the exact predicate.
    n: DVec3,
    /// Plane offset `n · x` (scaled coordinates).
    d: f64,
    /// Triangle across edge `(v[i], v[i + 1])`.
    adj: [u32; 3],
    /// Points strictly above this triangle, not yet on the hull.
    outside: Vec<u32>,
    alive: bool,
}

/// A directed horizon edge `a → b` and the hidden triangle across it.
#[derive(Debug, Clone, Copy)]
struct HorizonEdge {
    a: u32,
    b: u32,
    across: u32,
}

/// Quickhull state over points in scaled coordinates.
#[derive(Debug)]
pub(super) struct Quickhull<'a> {
    p: &'a [DVec3],
    tris: Vec<Tri>,
    queue: VecDeque<u32>,
    /// Per-triangle visit stamp for flood fills.
    mark: Vec<u32>,
    stamp: u32,
}

/// Outward unit normal and offset of triangle `a b c` in floating point,
/// or zero for a sliver.
fn plane(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, f64) {
    let cross = (b - a).cross(c - a);
    let len = cross.length();
    if len <= 0.0 || !len.is_finite() {
        return (DVec3::ZERO, 0.0);
    }
    let n = cross / len;
    (n, n.dot((a + b + c) / 3.0))
}

/// Exact: is `q` strictly above the plane of the counter-clockwise
/// triangle `a b c`? (Shewchuk's `orient3d` is positive when `q` is below.)
#[inline]
fn above(a: DVec3, b: DVec3, c: DVec3, q: DVec3) -> bool {
    let co = |v: DVec3| robust::Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    robust::orient3d(co(a), co(b), co(c), co(q)) < 0.0
}

impl<'a> Quickhull<'a> {
    /// Builds the initial tetrahedron from extreme points and assigns every
    /// other point to the face it is farthest above. Refuses clouds without
    /// volume to within `tol` (scaled units).
    pub(super) fn new(p: &'a [DVec3], tol: f64) -> Result<Self, ShapeError> {
        // Extreme points along the axes; the farthest-apart pair spans the
        // first edge.
        let mut ext = [0usize; 6];
        for (i, q) in p.iter().enumerate() {
            for axis in 0..3 {
                if q[axis] < p[ext[2 * axis]][axis] {
                    ext[2 * axis] = i;
                }
                if q[axis] > p[ext[2 * axis + 1]][axis] {
                    ext[2 * axis + 1] = i;
                }
            }
        }
        let (mut i0, mut i1, mut best) = (0, 0, -1.0);
        for axis in 0..3 {
            let (a, b) = (ext[2 * axis], ext[2 * axis + 1]);
            let d = p[b][axis] - p[a][axis];
            if d > best {
                (i0, i1, best) = (a, b, d);
            }
        }
        if best <= tol {
            return Err(ShapeError::CoincidentPoints);
        }
        // Farthest from the line.
        let dir = (p[i1] - p[i0]).normalize();
        let (mut i2, mut best) = (0, -1.0);
        for (i, q) in p.iter().enumerate() {
            let d = (*q - p[i0]).cross(dir).length_squared();
            if d > best {
                (i2, best) = (i, d);
            }
        }
        if best.sqrt() <= tol {
            return Err(ShapeError::CollinearPoints);
        }
        // Farthest from the plane.
        let n = (p[i1] - p[i0]).cross(p[i2] - p[i0]).normalize();
        let (mut i3, mut best) = (0, -1.0);
        for (i, q) in p.iter().enumerate() {
            let d = n.dot(*q - p[i0]).abs();
            if d > best {
                (i3, best) = (i, d);
            }
        }
        if best <= tol {
            return Err(ShapeError::CoplanarPoints);
        }
        // Base (a, b, c) faces away from d.
        let (a, b, c, d) = if above(p[i0], p[i1], p[i2], p[i3]) {
            (i0, i2, i1, i3)
        } else {
            (i0, i1, i2, i3)
        };
        let ids = [a, b, c, d].map(|i| i as u32);
        let [a, b, c, d] = ids;
        let faces = [[a, b, c], [b, a, d], [c, b, d], [a, c, d]];
        let mut qh = Quickhull {
            p,
            tris: Vec::new(),
            queue: VecDeque::new(),
            mark: Vec::new(),
            stamp: 0,
        };
        for v in faces {
            qh.push_tri(v);
        }
        // Adjacency of the tetrahedron by matching reversed edges.
        for f in 0..4 {
            for e in 0..3 {
                let (u, w) = (faces[f][e], faces[f][(e + 1) % 3]);
                let g = (0..4)
                    .find(|&g| (0..3).any(|k| faces[g][k] == w && faces[g][(k + 1) % 3] == u))
                    .ok_or(ShapeError::HullFailed)?;
                qh.tris[f].adj[e] = g as u32;
            }
        }
        for i in 0..p.len() as u32 {
            if !ids.contains(&i) {
                qh.assign(i, 0..4);
            }
        }
        for f in 0..4 {
            if !qh.tris[f].outside.is_empty() {
                qh.queue.push_back(f as u32);
            }
        }
        Ok(qh)
    }

    fn push_tri(&mut self, v: [u32; 3]) -> u32 {
        let [a, b, c] = v.map(|i| self.p[i as usize]);
        let (n, d) = plane(a, b, c);
        self.tris.push(Tri {
            v,
            n,
            d,
            adj: [u32::MAX; 3],
            outside: Vec::new(),
            alive: true,
        });
        self.mark.push(0);
        (self.tris.len() - 1) as u32
    }

    /// Approximate height of `q` above triangle `f` (scaled units).
    #[inline]
    fn dist(&self, f: u32, q: DVec3) -> f64 {
        let t = &self.tris[f as usize];
        t.n.dot(q) - t.d
    }

    /// Exact: is `q` strictly above triangle `f`?
    #[inline]
    fn sees(&self, f: u32, q: DVec3) -> bool {
        let [a, b, c] = self.tris[f as usize].v.map(|i| self.p[i as usize]);
        above(a, b, c, q)
    }

    /// Puts point `i` in the outside set of the triangle among `candidates`
    /// that it is (exactly) above and (approximately) farthest above; drops
    /// it if it is above none.
    fn assign(&mut self, i: u32, candidates: impl Iterator<Item = u32>) {
        let q = self.p[i as usize];
        let mut best = None;
        let mut best_d = f64::NEG_INFINITY;
        for f in candidates {
            let d = self.dist(f, q);
            if d > best_d && self.sees(f, q) {
                best_d = d;
                best = Some(f);
            }
        }
        if let Some(f) = best {
            self.tris[f as usize].outside.push(i);
        }
    }

    pub(super) fn run(&mut self) {
        while let Some(f) = self.queue.pop_front() {
            let t = &self.tris[f as usize];
            if !t.alive || t.outside.is_empty() {
                continue;
            }
            // The farthest outside point (first on ties).
            let (mut k_best, mut d_best) = (0, f64::NEG_INFINITY);
            for (k, &i) in t.outside.iter().enumerate() {
                let d = self.dist(f, self.p[i as usize]);
                if d > d_best {
                    (k_best, d_best) = (k, d);
                }
            }
            let eye = t.outside[k_best];
            if !self.add_point(f, eye) {
                // Cannot happen with exact predicates; if it does, forget
                // the point rather than tear the mesh.
                let t = &mut self.tris[f as usize];
                t.outside.remove(k_best);
                if !t.outside.is_empty() {
                    self.queue.push_back(f);
                }
            }
        }
    }

    fn next_stamp(&mut self) -> u32 {
        if self.stamp == u32::MAX {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.stamp = 0;
        }
        self.stamp += 1;
        self.stamp
    }

    /// Adds point `eye`, which lies above triangle `start`. Returns false
    /// (and changes nothing) if the seen region's boundary is not one loop.
    fn add_point(&mut self, start: u32, eye: u32) -> bool {
        let e = self.p[eye as usize];
        let s = self.next_stamp();
        // Flood fill the triangles that see the point. With exact
        // predicates this is a topological disk.
        let mut visible = vec![start];
        self.mark[start as usize] = s;
        let mut k = 0;
        while k < visible.len() {
            let f = visible[k];
            k += 1;
            for n in self.tris[f as usize].adj {
                if self.mark[n as usize] != s && self.sees(n, e) {
                    self.mark[n as usize] = s;
                    visible.push(n);
                }
            }
        }
        let Some(horizon) = self.horizon(&visible, s) else {
            return false;
        };
        // Retire the visible triangles, collecting their points.
        let mut orphans = Vec::new();
        for &f in &visible {
            let t = &mut self.tris[f as usize];
            t.alive = false;
            orphans.append(&mut t.outside);
        }
        // The cone from the eye over the horizon.
        let first = self.tris.len() as u32;
        let m = horizon.len() as u32;
        for (j, h) in horizon.iter().enumerate() {
            let id = self.push_tri([h.a, h.b, eye]);
            let j = j as u32;
            self.tris[id as usize].adj = [h.across, first + (j + 1) % m, first + (j + m - 1) % m];
            let across = &mut self.tris[h.across as usize];
            for k in 0..3 {
                if across.v[k] == h.b && across.v[(k + 1) % 3] == h.a {
                    across.adj[k] = id;
                }
            }
        }
        for i in orphans {
            if i != eye {
                self.assign(i, first..first + m);
            }
        }
        for id in first..first + m {
            if !self.tris[id as usize].outside.is_empty() {
                self.queue.push_back(id);
            }
        }
        true
    }

    /// The boundary of the marked region as one loop of directed edges, in
    /// order, or `None` if it is not a single simple loop.
    fn horizon(&self, visible: &[u32], s: u32) -> Option<Vec<HorizonEdge>> {
        let mut edges = Vec::new();
        for &f in visible {
            let t = &self.tris[f as usize];
            for k in 0..3 {
                let n = t.adj[k];
                if self.mark[n as usize] != s {
                    edges.push(HorizonEdge {
                        a: t.v[k],
                        b: t.v[(k + 1) % 3],
                        across: n,
                    });
                }
            }
        }
        chain_loop(&mut edges, |e| (e.a, e.b))
    }

    /// The live triangles, compacted, with adjacency renumbered.
    pub(super) fn triangles(&self) -> Result<Vec<MeshTri>, ShapeError> {
        let mut index = vec![u32::MAX; self.tris.len()];
        let mut count = 0u32;
        for (i, t) in self.tris.iter().enumerate() {
            if t.alive {
                index[i] = count;
                count += 1;
            }
        }
        let mut out = Vec::with_capacity(count as usize);
        for t in self.tris.iter().filter(|t| t.alive) {
            let adj = t
                .adj
                .map(|a| index.get(a as usize).copied().unwrap_or(u32::MAX));
            if adj.contains(&u32::MAX) {
                return Err(ShapeError::HullFailed);
            }
            out.push(MeshTri {
                v: t.v,
                n: t.n,
                adj,
            });
        }
        Ok(out)
    }
}

/// A triangle of the finished Quickhull mesh.
#[derive(Debug, Clone, Copy)]
pub(super) struct MeshTri {
    /// Point indices, counter-clockwise seen from outside.
    pub(super) v: [u32; 3],
    /// Outward unit normal (zero for a sliver), scaled coordinates.
    pub(super) n: DVec3,
    /// Triangle across edge `(v[i], v[i + 1])`.
    pub(super) adj: [u32; 3],
}
