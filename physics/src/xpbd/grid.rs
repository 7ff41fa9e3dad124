//! A uniform grid over points, for neighbour queries, and the neighbour
//! lists built from it.
//!
//! Space is cut into cubic cells of one size. A small occupied region keys
//! its cells densely (the cell's place in the box of occupied cells); a
//! large or scattered one hashes the cell coordinates into a power-of-two
//! table (the three-prime hash of Teschner et al., "Optimized Spatial
//! Hashing for Collision Detection of Deformable Objects", VMV 2003). The
//! points are sorted by cell key with a counting sort: counts per key,
//! prefix sums, then a scatter in point index order. The sort is stable,
//! so within a cell the points stand in ascending index order, and the
//! grid is a function of the positions alone, never of timing.
//!
//! [`Neighbours`] lists, for every point, the other points within a radius,
//! ascending by index, as one compressed (CSR) array. Points are taken in
//! chunks of a fixed size, each chunk on one thread with its own list, and
//! the lists are joined in chunk order: the same bits on any number of
//! threads.

use glam::Vec3;

use crate::parallel::for_each_chunk_with;

/// Points per parallel work item of [`Neighbours::build`].
pub(crate) const CHUNK: usize = 1024;

/// A dense box may hold this many cells per point before the grid hashes.
const DENSE_CELLS_PER_POINT: i64 = 4;
/// Fewest cells of a dense box or entries of a hash table.
const MIN_TABLE: usize = 1024;

/// How cell coordinates become keys.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Layout {
    /// The box of occupied cells from `origin`, `dims` cells along each
    /// axis: key `x + dims.x (y + dims.y z)` in box coordinates.
    Dense { origin: [i64; 3], dims: [i64; 3] },
    /// Hashed into a table of `mask + 1` (a power of two) entries.
    Hashed { mask: u32 },
}

/// A uniform grid over a set of points, rebuilt in place.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    /// Edge of a cell, m.
    cell: f32,
    inv_cell: f32,
    layout: Layout,
    /// Per key, where its points start in `order`; one more entry than
    /// keys.
    start: Vec<u32>,
    /// Each point's key, in index order.
    keys: Vec<u32>,
    /// Point indices sorted by key, ascending within a key.
    order: Vec<u32>,
    /// The positions in `order`'s order, m.
    sorted: Vec<Vec3>,
}

impl Default for Grid {
    fn default() -> Self {
        Self {
            cell: 1.0,
            inv_cell: 1.0,
            layout: Layout::Dense {
                origin: [0; 3],
                dims: [1; 3],
            },
            start: vec![0, 0],
            keys: Vec::new(),
            order: Vec::new(),
            sorted: Vec::new(),
        }
    }
}

/// The cell holding `p` (coordinates saturate far out; a NaN lands in 0).
#[inline(always)]
fn cell_of(p: Vec3, inv_cell: f32) -> [i64; 3] {
    let c = (p * inv_cell).floor();
    [
        i64::from(c.x as i32),
        i64::from(c.y as i32),
        i64::from(c.z as i32),
    ]
}

/// The three-prime hash of a cell (Teschner et al. 2003).
#[inline(always)]
fn hash(c: [i64; 3]) -> u32 {
    (c[0] as u32).wrapping_mul(73_856_093)
        ^ (c[1] as u32).wrapping_mul(19_349_663)
        ^ (c[2] as u32).wrapping_mul(83_492_791)
}

impl Grid {
    /// Edge of a cell, m.
    pub(crate) fn cell(&self) -> f32 {
        self.cell
    }

    /// How many points the grid was built over.
    pub(crate) fn len(&self) -> usize {
        self.order.len()
    }

    /// The key of cell `c`, if the grid has it (a dense box has only the
    /// cells of its box).
    #[inline(always)]
    fn key(&self, c: [i64; 3]) -> Option<u32> {
        match self.layout {
            Layout::Dense { origin, dims } => {
                let d = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
                if (0..3).all(|a| d[a] >= 0 && d[a] < dims[a]) {
                    Some((d[0] + dims[0] * (d[1] + dims[1] * d[2])) as u32)
                } else {
                    None
                }
            }
            Layout::Hashed { mask } => Some(hash(c) & mask),
        }
    }

    /// Sorts the points `x` (m) into cells of edge `cell` (m), reusing the
    /// buffers. A `cell` that is not finite and > 0 is taken as 1 m.
    pub(crate) fn build(&mut self, x: &[Vec3], cell: f32) {
        let cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            1.0
        };
        self.cell = cell;
        self.inv_cell = 1.0 / cell;
        let n = x.len();
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for &p in x {
            let c = cell_of(p, self.inv_cell);
            for a in 0..3 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        let table = if n == 0 {
            self.layout = Layout::Dense {
                origin: [0; 3],
                dims: [1; 3],
            };
            1
        } else {
            let dims = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1];
            let cells = dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]);
            let limit = (DENSE_CELLS_PER_POINT * n as i64).max(MIN_TABLE as i64);
            if cells <= limit {
                self.layout = Layout::Dense { origin: lo, dims };
                cells as usize
            } else {
                let size = (2 * n).next_power_of_two().max(MIN_TABLE);
                self.layout = Layout::Hashed {
                    mask: (size - 1) as u32,
                };
                size
            }
        };

        // Counting sort: counts in start[k + 1], prefix sums, stable
        // scatter with start[k] as the cursor, then shift back.
        self.keys.clear();
        self.start.clear();
        self.start.resize(table + 1, 0);
        for &p in x {
            let k = self.key(cell_of(p, self.inv_cell)).unwrap_or(0);
            self.keys.push(k);
            self.start[k as usize + 1] += 1;
        }
        for k in 0..table {
            self.start[k + 1] += self.start[k];
        }
        self.order.clear();
        self.order.resize(n, 0);
        for (i, &k) in self.keys.iter().enumerate() {
            let slot = &mut self.start[k as usize];
            self.order[*slot as usize] = i as u32;
            *slot += 1;
        }
        for k in (1..=table).rev() {
            self.start[k] = self.start[k - 1];
        }
        self.start[0] = 0;
        self.sorted.clear();
        self.sorted.extend(self.order.iter().map(|&i| x[i as usize]));
    }

    /// The points of the sorted slots `from..to`.
    #[inline(always)]
    fn visit(&self, from: u32, to: u32, f: &mut impl FnMut(u32, Vec3)) {
        let (from, to) = (from as usize, to as usize);
        for (&i, &q) in self.order[from..to].iter().zip(&self.sorted[from..to]) {
            f(i, q);
        }
    }

    /// Calls `f(index, position)` for every point in the 27 cells around
    /// the cell of `p`: a superset of the points within one cell edge of
    /// `p`. Each point comes once, in an order fixed by the built points
    /// and `p` (box cells row by row; hashed cells by ascending key, a
    /// key shared by several cells visited once).
    pub(crate) fn for_each_candidate(&self, p: Vec3, mut f: impl FnMut(u32, Vec3)) {
        if self.order.is_empty() {
            return;
        }
        let c = cell_of(p, self.inv_cell);
        match self.layout {
            Layout::Dense { origin, dims } => {
                let d = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
                let x0 = (d[0] - 1).max(0);
                let x1 = (d[0] + 1).min(dims[0] - 1);
                if x0 > x1 {
                    return;
                }
                for z in (d[2] - 1).max(0)..=(d[2] + 1).min(dims[2] - 1) {
                    for y in (d[1] - 1).max(0)..=(d[1] + 1).min(dims[1] - 1) {
                        // A row of up to three cells is one run of slots.
                        let row = dims[0] * (y + dims[1] * z);
                        let from = self.start[(row + x0) as usize];
                        let to = self.start[(row + x1 + 1) as usize];
                        self.visit(from, to, &mut f);
                    }
                }
            }
            Layout::Hashed { mask } => {
                let mut keys = [0u32; 27];
                let mut k = 0;
                for dz in -1..=1 {
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            keys[k] = hash([c[0] + dx, c[1] + dy, c[2] + dz]) & mask;
                            k += 1;
                        }
                    }
                }
                keys.sort_unstable();
                let mut last = None;
                for &key in &keys {
                    if last == Some(key) {
                        continue;
                    }
                    last = Some(key);
                    let from = self.start[key as usize];
                    let to = self.start[key as usize + 1];
                    self.visit(from, to, &mut f);
                }
            }
        }
    }

    /// Calls `f(index, position)` for every point closer than `r` (m) to
    /// `p`, in [`Grid::for_each_candidate`]'s order. `r` is at most the
    /// cell edge: a larger one finds only the points within a cell edge.
    pub(crate) fn for_each_within(&self, p: Vec3, r: f32, mut f: impl FnMut(u32, Vec3)) {
        let r = r.min(self.cell);
        let r2 = r * r;
        self.for_each_candidate(p, |i, q| {
            if (q - p).length_squared() < r2 {
                f(i, q);
            }
        });
    }
}

/// For every point of a set, the other points within a radius, ascending
/// by index, in one compressed array.
#[derive(Debug, Clone, Default)]
pub(crate) struct Neighbours {
    /// Per point, where its neighbours start in `index`; one more entry
    /// than points.
    start: Vec<u32>,
    /// Neighbour indices, point after point.
    index: Vec<u32>,
    /// One list per chunk of points, joined in chunk order.
    pieces: Vec<Vec<u32>>,
}

impl Neighbours {
    /// Lists, for every point of `x` (m), the other points closer than `r`
    /// (m), ascending by index. Builds `grid` over `x` with cells of edge
    /// `r` on the way. An `r` that is not finite and > 0 lists nothing.
    pub(crate) fn build(&mut self, grid: &mut Grid, x: &[Vec3], r: f32) {
        let n = x.len();
        self.start.clear();
        self.start.resize(n + 1, 0);
        self.index.clear();
        grid.build(x, r);
        if !(r.is_finite() && r > 0.0) || n == 0 {
            return;
        }
        let pieces = n.div_ceil(CHUNK);
        if self.pieces.len() < pieces {
            self.pieces.resize_with(pieces, Vec::new);
        }
        let grid = &*grid;
        let r2 = r * r;
        for_each_chunk_with(
            &mut self.start[1..],
            CHUNK,
            &mut self.pieces,
            |base, counts, list| {
                list.clear();
                for (k, count) in counts.iter_mut().enumerate() {
                    let i = base + k;
                    let p = x[i];
                    let before = list.len();
                    grid.for_each_candidate(p, |j, q| {
                        if j as usize != i && (q - p).length_squared() < r2 {
                            list.push(j);
                        }
                    });
                    list[before..].sort_unstable();
                    *count = (list.len() - before) as u32;
                }
            },
        );
        for i in 0..n {
            self.start[i + 1] += self.start[i];
        }
        for piece in &self.pieces[..pieces] {
            self.index.extend_from_slice(piece);
        }
    }

    /// How many points the lists are for.
    pub(crate) fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// The neighbours of point `i`, ascending.
    #[inline(always)]
    pub(crate) fn of(&self, i: usize) -> &[u32] {
        &self.index[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// All pairs listed (each pair twice, once from either side).
    pub(crate) fn total(&self) -> usize {
        self.index.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// splitmix64 numbers in `[0, 1)`.
    fn rng(seed: u64) -> impl FnMut() -> f32 {
        let mut s = seed;
        move || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn points(n: usize, size: f32, seed: u64) -> Vec<Vec3> {
        let mut r = rng(seed);
        (0..n)
            .map(|_| Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * size)
            .collect()
    }

    fn brute(x: &[Vec3], r: f32) -> Vec<Vec<u32>> {
        x.iter()
            .enumerate()
            .map(|(i, &p)| {
                (0..x.len() as u32)
                    .filter(|&j| j as usize != i && (x[j as usize] - p).length_squared() < r * r)
                    .collect()
            })
            .collect()
    }

    fn check(x: &[Vec3], r: f32) {
        let mut grid = Grid::default();
        let mut nb = Neighbours::default();
        nb.build(&mut grid, x, r);
        let want = brute(x, r);
        assert_eq!(nb.len(), x.len());
        for (i, w) in want.iter().enumerate() {
            assert_eq!(nb.of(i), &w[..], "point {i}");
        }
        // The query visits each point at most once.
        for &p in x.iter().take(200) {
            let mut seen = Vec::new();
            grid.for_each_candidate(p, |j, _| seen.push(j));
            let n = seen.len();
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), n);
        }
    }

    #[test]
    fn dense_grid_matches_brute_force() {
        // 3000 points in a 2 m box, cells of 0.2 m: 1000 cells, dense.
        let x = points(3000, 2.0, 1);
        let mut grid = Grid::default();
        grid.build(&x, 0.2);
        assert!(matches!(grid.layout, Layout::Dense { .. }));
        check(&x, 0.2);
    }

    #[test]
    fn hashed_grid_matches_brute_force() {
        // Scattered points in a 50 m box with small cells: hashed, and
        // a small table so distinct cells share keys.
        let mut x = points(2000, 50.0, 2);
        x.extend(points(1000, 1.0, 3));
        let mut grid = Grid::default();
        grid.build(&x, 0.3);
        assert!(matches!(grid.layout, Layout::Hashed { .. }));
        check(&x, 0.3);
    }

    #[test]
    fn bad_input_does_not_panic() {
        let mut grid = Grid::default();
        let mut nb = Neighbours::default();
        let x = vec![
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::splat(f32::INFINITY),
            Vec3::splat(-1e30),
            Vec3::ZERO,
        ];
        nb.build(&mut grid, &x, 0.5);
        assert_eq!(nb.len(), 4);
        nb.build(&mut grid, &x, f32::NAN);
        assert_eq!(nb.total(), 0);
        nb.build(&mut grid, &[], 0.5);
        assert_eq!(nb.len(), 0);
        grid.for_each_candidate(Vec3::ZERO, |_, _| panic!("empty grid"));
    }

    #[test]
    fn one_thread_and_many_threads_agree() {
        let x = points(20_000, 4.0, 4);
        let mut grid = Grid::default();
        let mut one = Neighbours::default();
        crate::parallel::sequential(|| one.build(&mut grid, &x, 0.15));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let mut many = Neighbours::default();
        pool.install(|| many.build(&mut grid, &x, 0.15));
        assert!(one.total() > 0);
        assert_eq!(one.start, many.start);
        assert_eq!(one.index, many.index);
    }
}
