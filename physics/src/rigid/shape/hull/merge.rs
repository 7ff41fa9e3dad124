//! From Quickhull's triangles to polygon faces: coplanar triangles merged,
//! slivers absorbed, mid-edge vertices dropped, and the result checked.
//!
//! See the design note in [`hull`](super) for the rules and why.

use glam::DVec3;

use super::quickhull::MeshTri;
use super::{chain_loop, ConvexHull, Face, SLIVER};

/// A polygon mesh over input point indices, in scaled coordinates.
#[derive(Debug)]
pub(super) struct PolygonMesh {
    /// Each face's loop of point indices, counter-clockwise from outside.
    faces: Vec<Vec<u32>>,
    /// Each face's outward unit normal, from all the triangles it was made
    /// of (so dropping collinear vertices later does not disturb it).
    normals: Vec<DVec3>,
}

/// Outward unit normal of triangle `t`; for a sliver whose normal rounds
/// to zero, that of the triangle across its longest edge.
fn tri_normal(p: &[DVec3], tris: &[MeshTri], t: usize) -> DVec3 {
    let v = tris[t].v;
    if let Some((n, _)) = newell(p, &v) {
        return n;
    }
    let [a, b, c] = v.map(|i| p[i as usize]);
    let edges = [(b - a).length(), (c - b).length(), (a - c).length()];
    let k = (0..3).fold(0, |m, k| if edges[k] > edges[m] { k } else { m });
    let across = &tris[tris[t].adj[k] as usize];
    newell(p, &across.v).map(|(n, _)| n).unwrap_or(DVec3::Y)
}

impl PolygonMesh {
    pub(super) fn from_triangles(p: &[DVec3], tris: &[MeshTri]) -> PolygonMesh {
        PolygonMesh {
            faces: tris.iter().map(|t| t.v.to_vec()).collect(),
            normals: (0..tris.len()).map(|t| tri_normal(p, tris, t)).collect(),
        }
    }

    /// Closed and consistently oriented (every directed edge once, its
    /// reverse once), planar faces, and Euler characteristic 2.
    pub(super) fn is_valid(&self, p: &[DVec3], tol: f64) -> bool {
        let mut directed = Vec::new();
        for (f, &n) in self.faces.iter().zip(&self.normals) {
            if f.len() < 3 || !planar(p, f, n, tol) {
                return false;
            }
            for k in 0..f.len() {
                directed.push((f[k], f[(k + 1) % f.len()]));
            }
        }
        directed.sort_unstable();
        if directed.windows(2).any(|w| w[0] == w[1]) {
            return false;
        }
        if directed
            .iter()
            .any(|&(a, b)| directed.binary_search(&(b, a)).is_err())
        {
            return false;
        }
        let mut verts: Vec<u32> = directed.iter().map(|e| e.0).collect();
        verts.sort_unstable();
        verts.dedup();
        let v = verts.len() as i64;
        let e = (directed.len() / 2) as i64;
        let f = self.faces.len() as i64;
        v - e + f == 2
    }

    /// The public hull: vertices renumbered in ascending input order.
    pub(super) fn into_hull(self, points: &[DVec3], tolerance: f64) -> ConvexHull {
        let mut used: Vec<u32> = self.faces.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        let remap = |i: u32| used.binary_search(&i).map(|k| k as u32).unwrap_or(0);
        let vertices: Vec<DVec3> = used.iter().map(|&i| points[i as usize]).collect();
        let mut edges = Vec::new();
        let faces: Vec<Face> = self
            .faces
            .iter()
            .zip(self.normals)
            .map(|(f, normal)| {
                let mut loop_: Vec<u32> = f.iter().map(|&i| remap(i)).collect();
                let start = (0..loop_.len()).min_by_key(|&k| loop_[k]).unwrap_or(0);
                loop_.rotate_left(start);
                for k in 0..loop_.len() {
                    let (a, b) = (loop_[k], loop_[(k + 1) % loop_.len()]);
                    if a < b {
                        edges.push([a, b]);
                    }
                }
                let offset = loop_
                    .iter()
                    .map(|&i| normal.dot(vertices[i as usize]))
                    .fold(f64::NEG_INFINITY, f64::max);
                Face {
                    vertices: loop_,
                    normal,
                    offset,
                }
            })
            .collect();
        edges.sort_unstable();
        let edge_faces = super::edge_faces(&faces);
        let extent = vertices
            .iter()
            .map(|v| v.abs().max_element())
            .fold(0.0, f64::max);
        let quads = super::quads(&vertices);
        ConvexHull {
            quads,
            vertices,
            faces,
            edges,
            edge_faces,
            tolerance,
            extent,
        }
    }
}

/// True when polygon `f` (indices into `p`) lies within `2 SLIVER tol` of
/// a plane of normal `n`; false for a zero normal. A triangle is planar by
/// definition (a sliver's rounded normal would only fail it spuriously).
fn planar(p: &[DVec3], f: &[u32], n: DVec3, tol: f64) -> bool {
    if n == DVec3::ZERO || !n.is_finite() {
        return false;
    }
    if f.len() == 3 {
        return true;
    }
    let (lo, hi) = f
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &i| {
            let d = n.dot(p[i as usize]);
            (lo.min(d), hi.max(d))
        });
    hi - lo <= 2.0 * SLIVER * tol
}

/// Newell's normal of the polygon `f` (indices into `p`) and the largest
/// `n · v` over its vertices; `None` when the normal vanishes.
fn newell(p: &[DVec3], f: &[u32]) -> Option<(DVec3, f64)> {
    // Relative to the first vertex, which keeps the sums small.
    let o = p[f[0] as usize];
    let mut n = DVec3::ZERO;
    for k in 0..f.len() {
        let a = p[f[k] as usize] - o;
        let b = p[f[(k + 1) % f.len()] as usize] - o;
        n += a.cross(b);
    }
    let len = n.length();
    if len <= 0.0 || !len.is_finite() {
        return None;
    }
    let n = n / len;
    let offset = f
        .iter()
        .map(|&i| n.dot(p[i as usize]))
        .fold(f64::NEG_INFINITY, f64::max);
    Some((n, offset))
}

/// Merges adjacent coplanar triangles into polygons, absorbs slivers into
/// their neighbours, and removes vertices left in the middle of an edge.
pub(super) fn merge_coplanar(p: &[DVec3], tris: &[MeshTri], tol: f64) -> PolygonMesh {
    // Per triangle: area, longest edge, and whether it is a sliver: a
    // height over its longest edge within a few tolerances, so that its
    // plane is rounding noise.
    let mut areas = Vec::with_capacity(tris.len());
    let mut longest = Vec::with_capacity(tris.len());
    let mut sliver = Vec::with_capacity(tris.len());
    for t in tris {
        let [a, b, c] = t.v.map(|i| p[i as usize]);
        let edges = [(b - a).length(), (c - b).length(), (a - c).length()];
        let k = (0..3).fold(0, |m, k| if edges[k] > edges[m] { k } else { m });
        let area = 0.5 * (b - a).cross(c - a).length();
        areas.push(area);
        longest.push(k);
        let height = 2.0 * area / edges[k];
        sliver.push(height.is_nan() || height <= SLIVER * tol);
    }
    let mut order: Vec<usize> = (0..tris.len()).collect();
    order.sort_by(|&a, &b| areas[b].total_cmp(&areas[a]).then(a.cmp(&b)));

    // 1. Grow a group from each largest unassigned triangle over neighbours
    //    whose vertices lie within `tol` of the seed's plane (vertices only,
    //    not the neighbour's own normal, which is noise for a sliver).
    //    Slivers seed nothing.
    let mut group = vec![u32::MAX; tris.len()];
    let mut groups = 0u32;
    for &seed in &order {
        if group[seed] != u32::MAX {
            continue;
        }
        let g = groups;
        groups += 1;
        group[seed] = g;
        if sliver[seed] {
            continue;
        }
        let sn = tris[seed].n;
        let sd = sn.dot(p[tris[seed].v[0] as usize]);
        let mut stack = vec![seed as u32];
        while let Some(t) = stack.pop() {
            for n in tris[t as usize].adj {
                let near = |&i: &u32| (sn.dot(p[i as usize]) - sd).abs() <= tol;
                if group[n as usize] == u32::MAX && tris[n as usize].v.iter().all(near) {
                    group[n as usize] = g;
                    stack.push(n);
                }
            }
        }
    }

    // 2. A group made only of slivers joins the group across the longest
    //    edge of one of its slivers (the face that sliver lies along),
    //    preferring a group with a real plane. That moves the face's
    //    outline by at most the sliver's height. Repeat while chains of
    //    slivers still hang together on their own.
    let mut parent: Vec<u32> = (0..groups).collect();
    let find = |parent: &[u32], mut g: u32| {
        while parent[g as usize] != g {
            g = parent[g as usize];
        }
        g
    };
    for _round in 0..64 {
        let mut solid = vec![false; groups as usize];
        for t in 0..tris.len() {
            if !sliver[t] {
                solid[find(&parent, group[t]) as usize] = true;
            }
        }
        // Best target per sliver-only root, ranked by (across a sliver's
        // longest edge, target has a real plane, edge length): a group
        // whose slivers' long edges all lie inside it (a thin strip) goes
        // across its longest outer edge instead.
        let mut best: Vec<Option<(bool, bool, f64, u32)>> = vec![None; groups as usize];
        for t in 0..tris.len() {
            let r = find(&parent, group[t]);
            if solid[r as usize] {
                continue;
            }
            for k in 0..3 {
                let to = find(&parent, group[tris[t].adj[k] as usize]);
                if to == r {
                    continue;
                }
                let [a, b] = [tris[t].v[k], tris[t].v[(k + 1) % 3]].map(|i| p[i as usize]);
                let cand = (k == longest[t], solid[to as usize], (b - a).length(), to);
                let better = match best[r as usize] {
                    None => true,
                    Some((l, s, len, _)) => (cand.0, cand.1, cand.2) > (l, s, len),
                };
                if better {
                    best[r as usize] = Some(cand);
                }
            }
        }
        let mut changed = false;
        for r in 0..groups {
            if let Some((_, _, _, to)) = best[r as usize] {
                let (from, to) = (find(&parent, r), find(&parent, to));
                if from != to {
                    parent[from as usize] = to;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    for g in &mut group {
        *g = find(&parent, *g);
    }

    // 3. Each group's outline, in seed order. A group whose outline is not
    //    one simple loop stays as separate triangles.
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); groups as usize];
    for (t, &g) in group.iter().enumerate() {
        members[g as usize].push(t as u32);
    }
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut normals: Vec<DVec3> = Vec::new();
    for (g, ms) in members.iter().enumerate() {
        if ms.len() == 1 {
            faces.push(tris[ms[0] as usize].v.to_vec());
            normals.push(tri_normal(p, tris, ms[0] as usize));
            continue;
        }
        let mut boundary: Vec<(u32, u32)> = Vec::new();
        for &m in ms {
            let t = &tris[m as usize];
            for k in 0..3 {
                if group[t.adj[k] as usize] != g as u32 {
                    boundary.push((t.v[k], t.v[(k + 1) % 3]));
                }
            }
        }
        let ring: Option<Vec<u32>> =
            chain_loop(&mut boundary, |e| *e).map(|r| r.iter().map(|e| e.0).collect());
        let ring = ring.and_then(|r| {
            let (n, _) = newell(p, &r)?;
            planar(p, &r, n, tol).then_some((r, n))
        });
        match ring {
            Some((ring, n)) => {
                faces.push(ring);
                normals.push(n);
            }
            None => {
                for &m in ms {
                    faces.push(tris[m as usize].v.to_vec());
                    normals.push(tri_normal(p, tris, m as usize));
                }
            }
        }
    }

    // 4. A vertex on only two faces sits in the middle of their common
    //    edge: drop it from both. A face left with two vertices was a notch
    //    (a sliver sharing two edges with one face) and collapses into an
    //    edge; that can leave new two-face vertices, so repeat.
    loop {
        let mut all: Vec<u32> = faces.iter().flatten().copied().collect();
        all.sort_unstable();
        let degree = |i: u32| all.partition_point(|&x| x <= i) - all.partition_point(|&x| x < i);
        let mut changed = false;
        for f in &mut faces {
            let before = f.len();
            f.retain(|&i| degree(i) >= 3);
            changed |= f.len() != before;
        }
        if !changed {
            break;
        }
        let mut k = 0;
        while k < faces.len() {
            if faces[k].len() < 3 {
                faces.remove(k);
                normals.remove(k);
            } else {
                k += 1;
            }
        }
    }
    PolygonMesh { faces, normals }
}
