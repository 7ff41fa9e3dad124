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
//! in grid order (cell run after cell run, ascending by index within a
//! cell), as one compressed (CSR) array. It walks the points in cell
//! order, so the points of a cell share one gathering of the 27 cells
//! around it and filter those candidates eight at a time, then copies the
//! lists into point index order. Both passes cut their work into chunks of a
//! fixed size, each chunk on one thread with its own lists, joined in chunk
//! order: the same bits on any number of threads.

use glam::Vec3;
use wide::f32x8;

use crate::parallel::{for_each_chunk_with, for_each_range_with};

/// Points per parallel work item of [`Neighbours::build`].
pub(crate) const CHUNK: usize = 1024;

/// A dense box may hold this many cells per point before the grid hashes.
const DENSE_CELLS_PER_POINT: i64 = 4;
/// Fewest cells of a dense box or entries of a hash table.
const MIN_TABLE: usize = 1024;

#[cfg(test)]
/// Most runs of slots a box grid's query visits: 5 × 5 rows of cells.
const RUNS: usize = 25;

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

/// `⌊v⌋` as an `i32`, saturating far out; a NaN gives 0. The same as
/// `v.floor() as i32`, without the C library's `floorf` that x86-64
/// without SSE 4.1 calls for `floor`.
#[inline(always)]
fn floor_i32(v: f32) -> i32 {
    let t = v as i32;
    t.saturating_sub(i32::from(t as f32 > v))
}

/// The cell holding `p` (coordinates saturate far out; a NaN lands in 0).
#[inline(always)]
fn cell_of(p: Vec3, inv_cell: f32) -> [i64; 3] {
    let c = p * inv_cell;
    [
        i64::from(floor_i32(c.x)),
        i64::from(floor_i32(c.y)),
        i64::from(floor_i32(c.z)),
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
        self.sorted
            .extend(self.order.iter().map(|&i| x[i as usize]));
    }

    #[cfg(test)]
    /// The runs of sorted slots (`from..to`) whose cells meet the cube of
    /// half-edge `r` (m) around `p`, in a box grid: one run per row of
    /// cells, at most 25 (`r` capped at two cell edges). `None` for a
    /// hashed grid.
    fn runs(&self, p: Vec3, r: f32, runs: &mut [(u32, u32); RUNS]) -> Option<usize> {
        let Layout::Dense { origin, dims } = self.layout else {
            return None;
        };
        let r = r.min(2.0 * self.cell);
        let lo = cell_of(p - Vec3::splat(r), self.inv_cell);
        let hi = cell_of(p + Vec3::splat(r), self.inv_cell);
        let lo = [lo[0] - origin[0], lo[1] - origin[1], lo[2] - origin[2]];
        let hi = [hi[0] - origin[0], hi[1] - origin[1], hi[2] - origin[2]];
        let x0 = lo[0].max(0);
        let x1 = hi[0].min(dims[0] - 1);
        let mut n = 0;
        if x0 > x1 {
            return Some(0);
        }
        for z in lo[2].max(0)..=hi[2].min(dims[2] - 1) {
            for y in lo[1].max(0)..=hi[1].min(dims[1] - 1) {
                // A row of cells is one run of slots.
                let row = dims[0] * (y + dims[1] * z);
                if n < runs.len() {
                    runs[n] = (
                        self.start[(row + x0) as usize],
                        self.start[(row + x1 + 1) as usize],
                    );
                    n += 1;
                }
            }
        }
        Some(n)
    }

    /// Calls `f(from, to)` for the runs of sorted slots of the 27 cells
    /// around cell `c` (m), each slot once: box cells row by row, hashed
    /// cells by ascending key.
    fn for_each_block_run(&self, c: [i64; 3], mut f: impl FnMut(u32, u32)) {
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
                        let row = dims[0] * (y + dims[1] * z);
                        f(
                            self.start[(row + x0) as usize],
                            self.start[(row + x1 + 1) as usize],
                        );
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
                    if last != Some(key) {
                        last = Some(key);
                        f(self.start[key as usize], self.start[key as usize + 1]);
                    }
                }
            }
        }
    }

    #[cfg(test)]
    /// The points of the sorted slots `from..to`.
    #[inline(always)]
    fn visit(&self, from: u32, to: u32, f: &mut impl FnMut(u32, Vec3)) {
        let (from, to) = (from as usize, to as usize);
        for (&i, &q) in self.order[from..to].iter().zip(&self.sorted[from..to]) {
            f(i, q);
        }
    }

    #[cfg(test)]
    /// Calls `f(index, position)` for every point in the cells that meet
    /// the cube of half-edge `r` (m) around `p`: a superset of the points
    /// within `r` of `p`. `r` is capped at two cell edges (a larger one
    /// finds only the points within two cell edges). Each point comes
    /// once, in an order fixed by the built points, `p` and `r` (box cells
    /// row by row; hashed cells by ascending key, a key that several cells
    /// share visited once).
    pub(crate) fn for_each_near(&self, p: Vec3, r: f32, mut f: impl FnMut(u32, Vec3)) {
        if self.order.is_empty() || r.is_nan() || r < 0.0 {
            return;
        }
        let mut runs = [(0u32, 0u32); RUNS];
        if let Some(n) = self.runs(p, r, &mut runs) {
            for &(from, to) in &runs[..n] {
                self.visit(from, to, &mut f);
            }
            return;
        }
        let r = r.min(2.0 * self.cell);
        let lo = cell_of(p - Vec3::splat(r), self.inv_cell);
        let hi = cell_of(p + Vec3::splat(r), self.inv_cell);
        match self.layout {
            Layout::Dense { .. } => {}
            Layout::Hashed { mask } => {
                // At most 5 cells a side: r is capped at two cell edges.
                let mut keys = [0u32; 125];
                let mut k = 0;
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            if k < keys.len() {
                                keys[k] = hash([x, y, z]) & mask;
                                k += 1;
                            }
                        }
                    }
                }
                let keys = &mut keys[..k];
                keys.sort_unstable();
                let mut last = None;
                for &key in keys.iter() {
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

    #[cfg(test)]
    /// Calls `f(index, position)` for every point closer than `r` (m) to
    /// `p`, in [`Grid::for_each_near`]'s order (`r` capped alike).
    pub(crate) fn for_each_within(&self, p: Vec3, r: f32, mut f: impl FnMut(u32, Vec3)) {
        let r = r.min(2.0 * self.cell);
        let r2 = r * r;
        self.for_each_near(p, r, |i, q| {
            if (q - p).length_squared() < r2 {
                f(i, q);
            }
        });
    }
}

/// Room for the neighbours of one point before they go to its list.
const BUFFER: usize = 256;

/// Candidates filtered at a time.
const LANES: usize = 8;

/// The work of one chunk of sorted slots: its points' neighbour lists, in
/// slot order, and the candidates of the cell block at hand.
#[derive(Debug, Clone, Default)]
struct SlotPiece {
    /// The lists, one after another.
    lists: Vec<u32>,
    /// Per slot of the chunk, where its list starts in `lists` and its
    /// length.
    spans: Vec<(u32, u32)>,
    /// The points of the 27 cells around the current cell, by component.
    ids: Vec<u32>,
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
}

impl SlotPiece {
    /// Takes the points of the cells `(from, to)` runs as the candidates.
    fn gather(&mut self, grid: &Grid, c: [i64; 3]) {
        self.ids.clear();
        self.xs.clear();
        self.ys.clear();
        self.zs.clear();
        grid.for_each_block_run(c, |from, to| {
            let (from, to) = (from as usize, to as usize);
            self.ids.extend_from_slice(&grid.order[from..to]);
            for q in &grid.sorted[from..to] {
                self.xs.push(q.x);
                self.ys.push(q.y);
                self.zs.push(q.z);
            }
        });
    }

    /// Appends the candidates closer than `√r2` to `p`, but `skip`, to
    /// `lists`, in the candidates' order. Eight candidates at a time, and
    /// branch-free: every candidate is written and the count moves on for
    /// the near ones only.
    fn filter(&mut self, p: Vec3, r2: f32, skip: u32) {
        let at = self.lists.len();
        let mut buf = [0u32; BUFFER];
        let mut m = 0;
        let (px, py, pz) = (f32x8::splat(p.x), f32x8::splat(p.y), f32x8::splat(p.z));
        let limit = f32x8::splat(r2);
        let full = self.ids.len() / LANES * LANES;
        let mut k = 0;
        while k < full {
            if m + LANES > BUFFER {
                self.lists.extend_from_slice(&buf[..m]);
                m = 0;
            }
            let lane = |v: &[f32]| {
                f32x8::from(<[f32; LANES]>::try_from(&v[k..k + LANES]).unwrap_or_default())
            };
            let dx = lane(&self.xs) - px;
            let dy = lane(&self.ys) - py;
            let dz = lane(&self.zs) - pz;
            let near = (dx * dx + dy * dy + dz * dz).simd_lt(limit).to_bitmask();
            for (l, &j) in self.ids[k..k + LANES].iter().enumerate() {
                buf[m] = j;
                m += ((near >> l) & 1) as usize & usize::from(j != skip);
            }
            k += LANES;
        }
        for k in full..self.ids.len() {
            if m + 1 > BUFFER {
                self.lists.extend_from_slice(&buf[..m]);
                m = 0;
            }
            let j = self.ids[k];
            let q = Vec3::new(self.xs[k], self.ys[k], self.zs[k]);
            buf[m] = j;
            m += usize::from(j != skip && (q - p).length_squared() < r2);
        }
        self.lists.extend_from_slice(&buf[..m]);
        self.spans.push((at as u32, (self.lists.len() - at) as u32));
    }
}

/// For every point of a set, the other points within a radius, in grid
/// order, in one compressed array.
#[derive(Debug, Clone, Default)]
pub(crate) struct Neighbours {
    /// Per point, where its neighbours start in `index`; one more entry
    /// than points.
    start: Vec<u32>,
    /// Neighbour indices, point after point.
    index: Vec<u32>,
    /// One list per chunk of points (by index), joined in chunk order.
    pieces: Vec<Vec<u32>>,
    /// One per chunk of sorted slots.
    slot_pieces: Vec<SlotPiece>,
    /// Each point's sorted slot.
    slot_of: Vec<u32>,
}

impl Neighbours {
    /// Lists, for every point of `x` (m), the other points closer than `r`
    /// (m), in grid order (a function of the positions alone). Builds
    /// `grid` over `x` with cells of edge `r` on the way. An `r` that is
    /// not finite and > 0 lists nothing.
    ///
    /// The points are taken cell by cell, in chunks of sorted slots: the
    /// points of one cell share the candidates of the 27 cells around it,
    /// gathered once. The lists are then copied into index order, chunk by
    /// chunk of points.
    pub(crate) fn build(&mut self, grid: &mut Grid, x: &[Vec3], r: f32) {
        let n = x.len();
        self.start.clear();
        self.start.resize(n + 1, 0);
        self.index.clear();
        grid.build(x, r);
        if !(r.is_finite() && r > 0.0) || n == 0 {
            return;
        }
        let grid = &*grid;
        let r2 = r * r;
        self.slot_of.resize(n, 0);
        for (s, &i) in grid.order.iter().enumerate() {
            self.slot_of[i as usize] = s as u32;
        }
        let pieces = n.div_ceil(CHUNK);
        if self.slot_pieces.len() < pieces {
            self.slot_pieces.resize_with(pieces, SlotPiece::default);
        }
        if self.pieces.len() < pieces {
            self.pieces.resize_with(pieces, Vec::new);
        }
        for_each_range_with(n, CHUNK, &mut self.slot_pieces, |base, len, piece| {
            piece.lists.clear();
            piece.spans.clear();
            let mut current = None;
            for s in base..base + len {
                let p = grid.sorted[s];
                let c = cell_of(p, grid.inv_cell);
                if current != Some(c) {
                    current = Some(c);
                    piece.gather(grid, c);
                }
                piece.filter(p, r2, grid.order[s]);
            }
        });
        let (slot_of, slot_pieces) = (&self.slot_of, &self.slot_pieces);
        for_each_chunk_with(
            &mut self.start[1..],
            CHUNK,
            &mut self.pieces,
            |base, counts, list| {
                list.clear();
                for (k, count) in counts.iter_mut().enumerate() {
                    let s = slot_of[base + k] as usize;
                    let piece = &slot_pieces[s / CHUNK];
                    let (at, len) = piece.spans[s % CHUNK];
                    list.extend_from_slice(&piece.lists[at as usize..(at + len) as usize]);
                    *count = len;
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
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// The neighbours of point `i`, in grid order.
    #[inline(always)]
    pub(crate) fn of(&self, i: usize) -> &[u32] {
        &self.index[self.start[i] as usize..self.start[i + 1] as usize]
    }

    #[cfg(test)]
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
            let mut got = nb.of(i).to_vec();
            got.sort_unstable();
            assert_eq!(got, w[..], "point {i}");
        }
        // The query visits each point at most once.
        for &p in x.iter().take(200) {
            let mut seen = Vec::new();
            grid.for_each_near(p, 0.3, |j, _| seen.push(j));
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
    fn point_queries_match_brute_force_up_to_two_cells() {
        // Dense and hashed grids, queried with radii up to two cell edges.
        let mut scattered = points(1500, 40.0, 5);
        scattered.extend(points(1500, 1.5, 6));
        for (x, cell) in [(points(3000, 2.0, 7), 0.1), (scattered, 0.1)] {
            let mut grid = Grid::default();
            grid.build(&x, cell);
            for r in [0.05, 0.1, 0.2] {
                for &p in x.iter().step_by(37) {
                    let mut got = Vec::new();
                    grid.for_each_within(p, r, |j, _| got.push(j));
                    got.sort_unstable();
                    let want: Vec<u32> = (0..x.len() as u32)
                        .filter(|&j| (x[j as usize] - p).length_squared() < r * r)
                        .collect();
                    assert_eq!(got, want, "r = {r} at {p}");
                }
            }
        }
    }

    #[test]
    fn floor_matches_the_library_floor() {
        let mut r = rng(9);
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0,
            -1e-30,
            3e9,
            -3e9,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        values.extend((0..10_000).map(|_| (r() - 0.5) * 2000.0));
        for v in values {
            assert_eq!(floor_i32(v), v.floor() as i32, "{v}");
        }
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
        grid.for_each_near(Vec3::ZERO, 1.0, |_, _| panic!("empty grid"));
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
