// Cloth self-collision on the GPU (physics/src/xpbd/soft/self_collision.rs):
// particles of one soft body that no constraint joins keep two collision
// radii apart. The crate puts `grid.wgsl` (the neighbour grid) before this
// file.
//
// Once a step the grid's passes place every particle where it stands as
// the step begins; its neighbours within `reach` (the contact distance
// plus twice how far the fastest particle goes in the step, as on the
// CPU) are its candidates for the step. Each substep of the soft body,
// after its contacts with rigid bodies, `keep` copies the positions to
// `before` and `self_collide` moves each particle by its share of the push
// that separates each close pair, from the positions as they stood (a
// Jacobi pass: each invocation writes only its own particle). Its
// candidates come in the grid's order, not the CPU's, so the sum of its
// pushes may round differently.
//
// Units: m. A particle is a vec4: xyz position (m), w its inverse mass
// (1/kg; 0: pinned).

const WORKGROUP_SIZE: u32 = 64u;

// The uniform block of a step (`SelfParams` in `gpu/self_collision.rs`).
struct SelfParams {
    // Particles.
    n: u32,
    // Keys of the grid's hash table (a power of two).
    table: u32,
    // 1 / the cell's edge (the reach), 1/m.
    inv_cell: f32,
    // The candidates' reach, squared, m².
    reach2: f32,
    // Two collision radii, m.
    contact: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> params: SelfParams;
// The soft body's positions (its `x`).
@group(0) @binding(1) var<storage, read_write> x: array<vec4<f32>>;
// Where the grid placed each particle: where it stood as the step began.
@group(0) @binding(2) var<storage, read_write> grid_points: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> sorted: array<Slot>;
@group(0) @binding(4) var<storage, read_write> cells: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> start: array<u32>;
// Per particle, where its joined particles start (n + 1 offsets), then
// the particles joined to it by a constraint or a triangle, ascending.
@group(0) @binding(6) var<storage, read> joined: array<u32>;
// The positions as the substep's pass found them.
@group(0) @binding(7) var<storage, read_write> before: array<vec4<f32>>;

fn linear(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WORKGROUP_SIZE;
}

fn grid_position(i: u32) -> vec3<f32> {
    return x[i].xyz;
}

fn grid_table() -> u32 {
    return params.table;
}

fn grid_inv_cell() -> f32 {
    return params.inv_cell;
}

fn grid_reach2() -> f32 {
    return params.reach2;
}

// Whether a constraint or a triangle joins particles `i` and `j`.
fn is_joined(i: u32, j: u32) -> bool {
    let lists = params.n + 1u;
    for (var e = joined[i]; e < joined[i + 1u]; e++) {
        let k = joined[lists + e];
        if (k >= j) {
            return k == j;
        }
    }
    return false;
}

// The positions as they stand, for the pass after.
@compute @workgroup_size(64)
fn keep(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    before[i] = x[i];
}

// Each particle that can move, pushed out of its close candidates by its
// share (its inverse mass over the pair's) of what separates them.
@compute @workgroup_size(64)
fn self_collide(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let own = before[i];
    let wi = own.w;
    if (wi <= 0.0) {
        return;
    }
    var push = vec3<f32>(0.0);
    var walk = walk_from(i);
    loop {
        let j = next_neighbour(&walk);
        if (j == GRID_END) {
            break;
        }
        let other = before[j];
        let d = own.xyz - other.xyz;
        let len = length(d);
        if (len >= params.contact || len < 1e-9 || is_joined(i, j)) {
            continue;
        }
        let share = wi / (wi + other.w);
        push += d * ((params.contact - len) / len * share);
    }
    let p = x[i];
    let moved = p.xyz + push;
    if (all(abs(moved) <= vec3<f32>(3.0e38))) {
        x[i] = vec4<f32>(moved, p.w);
    }
}
