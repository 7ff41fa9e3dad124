// The neighbour grid on the GPU (physics/src/xpbd/grid.rs, hashed
// layout), built by a counting sort: `count` (each particle's cell key; an
// integer atomic count per key), `scan` (exclusive prefix sum of the
// counts: where each key's particles start), `scatter` (each particle to a
// slot of its key, an integer atomic cursor per key; `cells` cleared
// before it) and `sort_cells` (each key's few slots put in ascending
// particle order, so that the order the atomics left them in is
// forgotten). A particle's neighbours are the others within the grid's
// reach of it, visited cell by cell of the 27 around it, ascending by
// index within a cell: a fixed order.
//
// This file is the head of `pbf.wgsl` (fluid neighbours) and of
// `xpbd_self_collision.wgsl` (cloth self-collision's candidates); the
// crate joins them (WGSL has no includes). The shader after it declares
// what the code here uses:
// - `WORKGROUP_SIZE` and `fn linear` (an invocation's index);
// - `params` with `n` (particles);
// - the bindings `grid_points` (array<vec4<f32>>: where the grid placed
//   each particle), `sorted` (array<Slot>), `cells` (array<atomic<u32>>,
//   one a key) and `start` (array<u32>, one more than keys);
// - `fn grid_position(i)` (where the grid places particle `i`, m),
//   `fn grid_table()` (keys, a power of two), `fn grid_inv_cell()` (1 /
//   the cell's edge, 1/m) and `fn grid_reach2()` (the neighbours' reach
//   squared, m², no more than the cell's edge squared).

// Invocations of the single-workgroup prefix sum.
const SCAN_SIZE: u32 = 256u;
// No neighbour left.
const GRID_END: u32 = 0xffffffffu;

// A slot of the neighbour grid: where the grid placed the particle (m)
// and its index (16 bytes).
struct Slot {
    p: vec3<f32>,
    index: u32,
}

var<workgroup> partial: array<u32, 256>;

fn cell_of(p: vec3<f32>) -> vec3<i32> {
    return vec3<i32>(floor(p * grid_inv_cell()));
}

// The three-prime hash (Teschner et al. 2003), masked to the table.
fn key_of(c: vec3<i32>) -> u32 {
    let h = (bitcast<u32>(c.x) * 73856093u) ^ (bitcast<u32>(c.y) * 19349663u)
        ^ (bitcast<u32>(c.z) * 83492791u);
    return h & (grid_table() - 1u);
}

// Each particle placed, and its key's count.
@compute @workgroup_size(64)
fn count(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = grid_position(i);
    grid_points[i] = vec4<f32>(p, 0.0);
    atomicAdd(&cells[key_of(cell_of(p))], 1u);
}

// Exclusive prefix sum of the counts into `start` (one workgroup: each
// invocation sums a run of keys, the runs' sums are scanned in workgroup
// memory, then each invocation writes its run's starts).
@compute @workgroup_size(256)
fn scan(@builtin(local_invocation_index) t: u32) {
    let m = grid_table();
    let per = (m + SCAN_SIZE - 1u) / SCAN_SIZE;
    let lo = min(t * per, m);
    let hi = min(lo + per, m);
    var sum = 0u;
    for (var k = lo; k < hi; k++) {
        sum += atomicLoad(&cells[k]);
    }
    partial[t] = sum;
    workgroupBarrier();
    for (var off = 1u; off < SCAN_SIZE; off *= 2u) {
        var add = 0u;
        if (t >= off) {
            add = partial[t - off];
        }
        workgroupBarrier();
        partial[t] += add;
        workgroupBarrier();
    }
    var run = partial[t] - sum;
    for (var k = lo; k < hi; k++) {
        start[k] = run;
        run += atomicLoad(&cells[k]);
    }
    if (t == SCAN_SIZE - 1u) {
        start[m] = partial[t];
    }
}

// Each particle to a slot of its key (`cells` cleared to serve as the
// cursors).
@compute @workgroup_size(64)
fn scatter(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = grid_points[i].xyz;
    let k = key_of(cell_of(p));
    let slot = start[k] + atomicAdd(&cells[k], 1u);
    sorted[slot] = Slot(p, i);
}

// Each key's slots in ascending particle order (insertion sort: a key
// holds a few particles).
@compute @workgroup_size(64)
fn sort_cells(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = linear(id, groups);
    if (k >= grid_table()) {
        return;
    }
    let lo = start[k];
    let hi = start[k + 1u];
    for (var a = lo + 1u; a < hi; a++) {
        let item = sorted[a];
        var b = a;
        while (b > lo && sorted[b - 1u].index > item.index) {
            sorted[b] = sorted[b - 1u];
            b -= 1u;
        }
        sorted[b] = item;
    }
}

// A walk over the neighbours of one particle: the 27 cells around where
// the grid placed it, each cell's slots in order, keeping the other
// particles of that cell within reach (a key two cells share is visited
// for each, and gives each only its own particles).
struct Walk {
    centre: vec3<f32>,
    home: vec3<i32>,
    current: vec3<i32>,
    me: u32,
    // Next of the 27 cells.
    k: u32,
    slot: u32,
    end: u32,
}

fn walk_from(i: u32) -> Walk {
    let p = grid_points[i].xyz;
    let c = cell_of(p);
    return Walk(p, c, c, i, 0u, 0u, 0u);
}

// The next neighbour's index, or GRID_END.
fn next_neighbour(w: ptr<function, Walk>) -> u32 {
    let reach2 = grid_reach2();
    loop {
        if ((*w).slot < (*w).end) {
            let s = sorted[(*w).slot];
            (*w).slot += 1u;
            let j = s.index;
            if (j == (*w).me || any(cell_of(s.p) != (*w).current)) {
                continue;
            }
            let d = s.p - (*w).centre;
            if (d.x * d.x + d.y * d.y + d.z * d.z < reach2) {
                return j;
            }
            continue;
        }
        if ((*w).k >= 27u) {
            return GRID_END;
        }
        let k = (*w).k;
        let o = vec3<i32>(i32(k % 3u) - 1, i32((k / 3u) % 3u) - 1, i32(k / 9u) - 1);
        (*w).current = (*w).home + o;
        let key = key_of((*w).current);
        (*w).slot = start[key];
        (*w).end = start[key + 1u];
        (*w).k = k + 1u;
    }
    return GRID_END;
}
