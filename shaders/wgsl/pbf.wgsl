// Position-based fluids (physics/src/xpbd/fluid/), on the GPU. The crate
// puts `bodies.wgsl` (the rigid bodies' shapes, and the reductions of
// step 5) and `grid.wgsl` (the neighbour grid) before this file.
//
// The same step as the CPU's `Fluid::step`, stage for stage:
//
// 1. Neighbour grid, once a step, on the positions predicted for the
//    whole step (`x + dt v + dt² g`), by a counting sort:
//    `count` (each particle's cell key; an integer atomic count per
//    key), `scan` (exclusive prefix sum of the counts: where each key's
//    particles start), `scatter` (each particle to a slot of its key,
//    an integer atomic cursor per key) and `sort_cells` (each key's few
//    slots put in ascending particle order, so that the order the
//    atomics left them in is forgotten). A particle's neighbours are the
//    others within the kernel radius h of it at those predicted
//    positions, visited cell by cell of the 27 around it, ascending by
//    index within a cell: a fixed order.
// 2. `find_walls`, once a step: the tangent plane of every boundary shape
//    near each particle, at the surface point nearest its position at the
//    start of the step (at most BODY_SLOTS a particle).
// 3. Per substep of `hs = dt / substeps` (each in its own uniform slot,
//    `params.t` the fraction of the step at its end): `predict`
//    (`v += hs g`, `prev = x`, `x += hs v`), `densities` (density and the
//    multiplier λ, one Jacobi pass, walls as solid fluid from a table),
//    `corrections` (the position deltas, capped; a dynamic body behind a
//    wall takes the push back), `collide` (kept the collision radius out
//    of the shapes where they stand along their path, with friction, a
//    dynamic body sharing each correction; `v = (x − prev) / hs`). With
//    dynamic bodies: `advance_bodies` before the densities, and
//    `reduce_chunks`, `reduce_bodies` and `take_pushes` after `collide`
//    (`bodies.wgsl`).
// 4. After the substeps: vorticity confinement (`vorticity`, `confine`)
//    and XSPH viscosity (`xsph`), each writing new velocities to `next`
//    and `take_velocities` copying them back. The host reads back the
//    dynamic bodies' motion.
//
// Every pass is Jacobi: it reads the state the pass before left and writes
// only its own particle's (or key's) slots, so nothing races. Atomics are
// integer counts and cursors only, and their order is undone by
// `sort_cells`; no floating-point value is ever summed atomically (the
// bodies' pushes are summed by the reductions, in a fixed order). A run
// repeats bit for bit on the same device and driver.
//
// Units: m, s, kg. Positions and velocities are vec4 (w unused).

const WORKGROUP_SIZE: u32 = 64u;
// Entries of the wall table over [0, h] (boundary.rs's ENTRIES).
const WALL_ENTRIES: u32 = 64u;



// The uniform block of one step (`FluidParams` in `gpu/fluid.rs`).
struct FluidParams {
    // Gravity times the fluid's scale, m/s² (w unused).
    gravity: vec4<f32>,
    // Particles.
    n: u32,
    // Keys of the hash table (a power of two).
    table: u32,
    // Boundary shapes.
    shapes: u32,
    // 1: the tensile correction is on.
    tensile: u32,
    // The step, s.
    dt: f32,
    // The substep, s.
    substep: f32,
    // Kernel radius h, m, and h², m².
    h: f32,
    h2: f32,
    // 1 / cell edge (the cell edge is h), 1/m.
    inv_cell: f32,
    // The volume a neighbour weighs in kernel sums, m³.
    volume: f32,
    // Rest density, kg/m³.
    rest: f32,
    // Constraint relaxation ε, 1/m².
    relaxation: f32,
    // Kernel constants: 315 / (64 π h⁹), 15 / (π h⁶), −45 / (π h⁶), and
    // W_spiky(0).
    poly6: f32,
    spiky: f32,
    spiky_grad: f32,
    self_weight: f32,
    // Largest correction a substep, m.
    cap: f32,
    // Tensile correction: −k h² (m²), 1 / W_poly6(Δq) (m³), exponent.
    tensile_scale: f32,
    tensile_inv_w: f32,
    tensile_n: u32,
    // XSPH: c V, m³.
    viscosity: f32,
    // Vorticity confinement: ε dt, m.
    vorticity: f32,
    // Collision radius, m, and the fluid's friction coefficient.
    radius: f32,
    friction: f32,
    // How far from a particle walls are looked for: h + spacing, m, plus
    // |g| dt², m (plus the particle's own |v| dt).
    wall_reach: f32,
    wall_fall: f32,
    // Wall table: entries per metre, and the lattice calibration.
    wall_per_m: f32,
    wall_scale: f32,
    // A particle's inverse mass, 1/kg.
    particle_inv_mass: f32,
    // Shapes the particles can move (dynamic bodies), and chunks of
    // PUSH_CHUNK particles.
    movable: u32,
    chunks: u32,
    // `corrections`, `collide`: the fraction of the step at the end of
    // their substep (a uniform slot per substep).
    t: f32,
    // Φ and Ψ (1/m) at k h / 63, four to a vec4.
    wall_phi: array<vec4<f32>, 16>,
    wall_psi: array<vec4<f32>, 16>,
}



// A wall near a particle over a step: a point of its tangent plane (w: 1
// when the slot is used) and the normal out of the body (w: the shape's
// index); in the body's frame for a body that moves within the stage.
struct Plane {
    point: vec4<f32>,
    normal: vec4<f32>,
}



@group(0) @binding(0) var<uniform> params: FluidParams;
// Positions, velocities, positions at the start of the substep.
@group(0) @binding(1) var<storage, read_write> x: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> v: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> prev: array<vec4<f32>>;
// Corrected positions (substeps), new velocities (after them).
@group(0) @binding(4) var<storage, read_write> next: array<vec4<f32>>;
// Positions predicted for the whole step (where the grid places them).
@group(0) @binding(5) var<storage, read_write> grid_points: array<vec4<f32>>;
// Per slot of the grid: a particle and its predicted position.
@group(0) @binding(6) var<storage, read_write> sorted: array<Slot>;
// Per key: the count, then the scatter's cursor.
@group(0) @binding(7) var<storage, read_write> cells: array<atomic<u32>>;
// Per key, where its slots start; one more entry than keys.
@group(0) @binding(8) var<storage, read_write> start: array<u32>;
// Per particle: the walls' part of ∇C_i (xyz, 1/m) and λ_i (w, m²).
@group(0) @binding(9) var<storage, read_write> lambda: array<vec4<f32>>;
// Per particle: density, kg/m³.
@group(0) @binding(10) var<storage, read_write> density: array<f32>;
// Per particle: vorticity ω, 1/s.
@group(0) @binding(11) var<storage, read_write> omega: array<vec4<f32>>;
// BODY_SLOTS per particle.
@group(0) @binding(12) var<storage, read_write> planes: array<Plane>;
@group(0) @binding(13) var<storage, read> shapes: array<Shape>;
// BODY_SLOTS per particle: what it gave the body behind each of its
// planes over the step (used while `params.movable` > 0).
@group(0) @binding(14) var<storage, read_write> pushes: array<Push>;
// Per chunk, then per movable body: the chunk's pushes; after them, each
// movable body's total.
@group(0) @binding(15) var<storage, read_write> partials: array<Push>;
// Per movable body: what the stage did to it so far.
@group(0) @binding(16) var<storage, read_write> motion: array<Motion>;


fn linear(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WORKGROUP_SIZE;
}


// ---- kernels (kernels.rs) ----

// (W_spiky, dW_spiky/dr / r) at offset `d`: 1/m³ and 1/m⁵.
fn spiky_pair(d: vec3<f32>) -> vec2<f32> {
    let r2 = d.x * d.x + d.y * d.y + d.z * d.z;
    let r = sqrt(r2);
    let t = max(params.h - r, 0.0);
    let t2 = t * t;
    let w = params.spiky * t2 * t;
    var g = 0.0;
    if (r > 0.0) {
        g = params.spiky_grad * t2 / r;
    }
    return vec2<f32>(w, g);
}

// W_poly6 at squared distance `r2` (m²), 1/m³.
fn poly6(r2: f32) -> f32 {
    let d = max(params.h2 - r2, 0.0);
    return params.poly6 * d * d * d;
}

// dW_spiky/dr / r at distance `r` (m), 1/m⁵; 0 at 0 and from h out.
fn spiky_grad_over_r(r: f32) -> f32 {
    if (r >= params.h || r <= 0.0) {
        return 0.0;
    }
    let d = params.h - r;
    return params.spiky_grad * d * d / r;
}

// ---- the neighbour grid (`grid.wgsl`) ----

// Where the grid places particle `i`: its position predicted for the
// whole step (`x + dt v + dt² g`; where it stands when that is not
// finite).
fn grid_position(i: u32) -> vec3<f32> {
    let dt = params.dt;
    let p = x[i].xyz + dt * v[i].xyz + dt * dt * params.gravity.xyz;
    return select(x[i].xyz, p, finite3(p));
}

fn grid_table() -> u32 {
    return params.table;
}

fn grid_inv_cell() -> f32 {
    return params.inv_cell;
}

// Neighbours lie within the kernel radius.
fn grid_reach2() -> f32 {
    return params.h2;
}

// The tangent planes of the shapes near each particle over the step.
@compute @workgroup_size(64)
fn find_walls(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i].xyz;
    let within = params.wall_reach + length(v[i].xyz) * params.dt + params.wall_fall;
    var used = 0u;
    for (var k = 0u; k < params.shapes && used < BODY_SLOTS; k++) {
        let s = surface(shapes[k], p, within);
        if (s.found) {
            // A body that moves within the stage carries its planes along:
            // they are kept in its frame.
            var point = s.point;
            var normal = s.normal;
            let shape = shapes[k];
            if (shape_moves(shape)) {
                point = to_local(shape, point);
                normal = vec3<f32>(dot(shape.axis_x.xyz, normal), dot(shape.axis_y.xyz, normal), dot(shape.axis_z.xyz, normal));
            }
            planes[i * BODY_SLOTS + used] = Plane(vec4<f32>(point, 1.0), vec4<f32>(normal, f32(k)));
            used += 1u;
        }
    }
    for (var k = used; k < BODY_SLOTS; k++) {
        planes[i * BODY_SLOTS + k] = Plane(vec4<f32>(0.0), vec4<f32>(0.0));
    }
}

// The shape behind plane slot `slot` of particle `i`, or NONE
// (`bodies.wgsl`).
fn slot_shape(i: u32, slot: u32) -> u32 {
    let plane = planes[i * BODY_SLOTS + slot];
    return select(NONE, u32(plane.normal.w), plane.point.w > 0.5);
}

// ---- the substeps (step.rs) ----

// `v += hs g`, `prev = x`, `x += hs v`.
@compute @workgroup_size(64)
fn predict(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let hs = params.substep;
    let vi = v[i].xyz + hs * params.gravity.xyz;
    let p = x[i].xyz;
    v[i] = vec4<f32>(vi, 0.0);
    prev[i] = vec4<f32>(p, 0.0);
    x[i] = vec4<f32>(p + hs * vi, 0.0);
}

// Entry k of the wall table's Φ, and of its Ψ (1/m).
fn wall_phi(k: u32) -> f32 {
    return params.wall_phi[k / 4u][k % 4u];
}

fn wall_psi(k: u32) -> f32 {
    return params.wall_psi[k / 4u][k % 4u];
}

// The wall table (boundary.rs `WallTable::at`): (Φ(d), Ψ(d)) at signed
// distance `d` (m), calibrated.
fn wall_at(d: f32) -> vec2<f32> {
    if (!finite(d)) {
        return vec2<f32>(0.0);
    }
    let a = min(abs(d), params.h) * params.wall_per_m;
    let k = min(u32(a), WALL_ENTRIES - 2u);
    let t = a - f32(k);
    let p0 = wall_phi(k);
    let p1 = wall_phi(k + 1u);
    let g0 = wall_psi(k);
    let g1 = wall_psi(k + 1u);
    var phi = p0 + t * (p1 - p0);
    let grad = g0 + t * (g1 - g0);
    if (d < 0.0) {
        phi = 1.0 - phi;
    }
    return vec2<f32>(phi * params.wall_scale, grad * params.wall_scale);
}

// The walls within h of particle `i` at `p` (step.rs's contacts): each
// one's share Φ_k, slope Ψ_k (1/m), normal, the point of its plane
// nearest `p` (m) and its plane slot.
struct Walls {
    phi: array<f32, 4>,
    psi: array<f32, 4>,
    normal: array<vec3<f32>, 4>,
    point: array<vec3<f32>, 4>,
    slot: array<u32, 4>,
    count: u32,
}

fn walls_near(i: u32, p: vec3<f32>) -> Walls {
    var w: Walls;
    w.count = 0u;
    for (var k = 0u; k < BODY_SLOTS; k++) {
        let plane = planes[i * BODY_SLOTS + k];
        if (plane.point.w < 0.5) {
            break;
        }
        var point = plane.point.xyz;
        var normal = plane.normal.xyz;
        let index = u32(plane.normal.w);
        let shape = shapes[index];
        if (shape_moves(shape)) {
            let now = shape_now(shape, params.t);
            point = to_world(now, point);
            normal = now.axis_x.xyz * normal.x + now.axis_y.xyz * normal.y + now.axis_z.xyz * normal.z;
        }
        let d = dot(p - point, normal);
        if (!finite(d) || d >= params.h) {
            continue;
        }
        let t = wall_at(d);
        if (t.x <= 0.0 && t.y == 0.0) {
            continue;
        }
        w.phi[w.count] = t.x;
        w.psi[w.count] = t.y;
        w.normal[w.count] = normal;
        w.point[w.count] = p - normal * d;
        w.slot[w.count] = k;
        w.count += 1u;
    }
    return w;
}

// Wall k's part of ∇C_i: `Ψ_k Π_{m≠k} max(1 − Φ_m, 0) n_k`, 1/m (the
// union of the walls, step.rs's `wall_union`).
fn wall_part(w: ptr<function, Walls>, k: u32) -> vec3<f32> {
    var others = 1.0;
    for (var m = 0u; m < (*w).count; m++) {
        if (m != k) {
            others *= max(1.0 - (*w).phi[m], 0.0);
        }
    }
    return (*w).normal[k] * ((*w).psi[k] * others);
}

// Densities and multipliers: `ρ_i / ρ0 = V Σ_j W_spiky + Φ_walls`,
// `λ_i = −max(C_i, 0) / (Σ_k |∇_k C_i|² + ε)`; the walls' union as
// step.rs's `wall_union`.
@compute @workgroup_size(64)
fn densities(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i].xyz;
    var sum_w = 0.0;
    var grad = vec3<f32>(0.0);
    var sum_sq = 0.0;
    var walk = walk_from(i);
    loop {
        let j = next_neighbour(&walk);
        if (j == GRID_END) {
            break;
        }
        let d = p - x[j].xyz;
        let wg = spiky_pair(d);
        let g = d * wg.y;
        sum_w += wg.x;
        grad += g;
        sum_sq += g.x * g.x + g.y * g.y + g.z * g.z;
    }
    var frac = params.volume * (params.self_weight + sum_w);
    grad = grad * params.volume;
    sum_sq = sum_sq * params.volume * params.volume;

    var walls = walls_near(i, p);
    var outside = 1.0;
    for (var k = 0u; k < walls.count; k++) {
        outside *= max(1.0 - walls.phi[k], 0.0);
    }
    var wall_grad = vec3<f32>(0.0);
    for (var k = 0u; k < walls.count; k++) {
        wall_grad += wall_part(&walls, k);
    }
    if (walls.count > 0u) {
        frac += 1.0 - outside;
        grad += wall_grad;
    }

    density[i] = params.rest * frac;
    let c = frac - 1.0;
    let denom = dot(grad, grad) + sum_sq + params.relaxation;
    var l = 0.0;
    if (c > 0.0 && denom > 0.0) {
        l = -c / denom;
    }
    if (!finite(l)) {
        l = 0.0;
    }
    lambda[i] = vec4<f32>(wall_grad, l);
}

// The Jacobi corrections: `next = x + Δx`,
// `Δx_i = V Σ_j (λ_i + λ_j + s_corr) ∇W_spiky + λ_i ∇_walls`, at most
// `cap` long.
@compute @workgroup_size(64)
fn corrections(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i].xyz;
    let own = lambda[i];
    let li = own.w;
    var sum = vec3<f32>(0.0);
    var walk = walk_from(i);
    loop {
        let j = next_neighbour(&walk);
        if (j == GRID_END) {
            break;
        }
        let o = p - x[j].xyz;
        let g = spiky_pair(o).y;
        var s = li + lambda[j].w;
        if (params.tensile != 0u) {
            let ratio = poly6(o.x * o.x + o.y * o.y + o.z * o.z) * params.tensile_inv_w;
            var pw = ratio;
            for (var e = 1u; e < params.tensile_n; e++) {
                pw *= ratio;
            }
            s += params.tensile_scale * pw;
        }
        sum += o * (s * g);
    }
    let dx = sum * params.volume + own.xyz * li;
    let len = length(dx);
    var scale = 1.0;
    if (!finite(len)) {
        scale = 0.0;
    } else if (len > params.cap) {
        scale = params.cap / len;
    }
    next[i] = vec4<f32>(p + dx * scale, 0.0);
    // The movable bodies behind the walls take the walls' share back,
    // `−Δx_wall / (w_p + w_b)` (`Coupling::push_back`); the substep's
    // pushes start here.
    if (params.movable > 0u) {
        for (var slot = 0u; slot < BODY_SLOTS; slot++) {
            pushes[i * BODY_SLOTS + slot] = Push(vec4<f32>(0.0), vec4<f32>(0.0));
        }
    }
    if (params.movable > 0u && li < 0.0 && scale > 0.0) {
        var walls = walls_near(i, p);
        for (var k = 0u; k < walls.count; k++) {
            let slot = walls.slot[k];
            let shape_index = slot_shape(i, slot);
            if (shapes[shape_index].kind.y == NONE) {
                continue;
            }
            let shape = body_at(shape_index, params.t);
            let moved = wall_part(&walls, k) * (li * scale);
            let point = walls.point[k];
            let w_b = inv_mass_along(shape, point, walls.normal[k]);
            let total = params.particle_inv_mass + w_b;
            if (w_b > 0.0 && total > 0.0) {
                add_push(i, slot, shape, point, -moved / total);
            }
        }
    }
}


// Keeps the corrected position out of the shapes (`Coupling::push_out`,
// with friction), then `v = (x − prev) / hs`; a particle gone non-finite
// goes back to `prev`, at rest.
@compute @workgroup_size(64)
fn collide(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let q = prev[i].xyz;
    var p = next[i].xyz;
    for (var k = 0u; k < params.shapes; k++) {
        let shape = body_at(k, params.t);
        // A movable body's share goes with the plane find_walls found for
        // it (a body no plane of this particle names was out of its reach
        // for the step, and takes none).
        var slot = NONE;
        if (shape.kind.y != NONE) {
            for (var s = 0u; s < BODY_SLOTS; s++) {
                if (slot_shape(i, s) == k) {
                    slot = s;
                    break;
                }
            }
        }
        p = press(i, slot, shape, p, q, params.particle_inv_mass, params.radius, params.friction);
    }
    var vel = (p - q) / params.substep;
    if (!(finite3(p) && finite3(vel))) {
        p = q;
        vel = vec3<f32>(0.0);
    }
    x[i] = vec4<f32>(p, 0.0);
    v[i] = vec4<f32>(vel, 0.0);
}

// ---- after the substeps ----

// Vorticity `ω_i = V Σ_j ∇W(x_i − x_j) × (v_j − v_i)`.
@compute @workgroup_size(64)
fn vorticity(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i].xyz;
    let vi = v[i].xyz;
    var w = vec3<f32>(0.0);
    var walk = walk_from(i);
    loop {
        let j = next_neighbour(&walk);
        if (j == GRID_END) {
            break;
        }
        let d = p - x[j].xyz;
        let g = d * spiky_grad_over_r(length(d));
        w += cross(g, v[j].xyz - vi);
    }
    w = w * params.volume;
    if (!finite3(w)) {
        w = vec3<f32>(0.0);
    }
    omega[i] = vec4<f32>(w, 0.0);
}

// Vorticity confinement: `v_i += ε dt (N × ω_i)`, with `N` the direction
// of `η = Σ_j (|ω_j| − |ω_i|) ∇W(x_i − x_j)`; into `next`.
@compute @workgroup_size(64)
fn confine(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i].xyz;
    let wi_vec = omega[i].xyz;
    let wi = length(wi_vec);
    var eta = vec3<f32>(0.0);
    var walk = walk_from(i);
    loop {
        let j = next_neighbour(&walk);
        if (j == GRID_END) {
            break;
        }
        let d = p - x[j].xyz;
        eta += d * (spiky_grad_over_r(length(d)) * (length(omega[j].xyz) - wi));
    }
    let len = length(eta);
    let vi = v[i].xyz;
    var nv = vi;
    if (len > 1e-12 && finite(len)) {
        let dir = eta / len;
        nv += cross(dir, wi_vec) * params.vorticity;
    }
    if (!finite3(nv)) {
        nv = vi;
    }
    next[i] = vec4<f32>(nv, 0.0);
}

// XSPH viscosity: `v_i += c V Σ_j (v_j − v_i) W_poly6(x_i − x_j)`; into
// `next`.
@compute @workgroup_size(64)
fn xsph(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i].xyz;
    let vi = v[i].xyz;
    var acc = vec3<f32>(0.0);
    var walk = walk_from(i);
    loop {
        let j = next_neighbour(&walk);
        if (j == GRID_END) {
            break;
        }
        let d = p - x[j].xyz;
        let w = poly6(d.x * d.x + d.y * d.y + d.z * d.z);
        acc -= (vi - v[j].xyz) * w;
    }
    var nv = vi + acc * params.viscosity;
    if (!finite3(nv)) {
        nv = vi;
    }
    next[i] = vec4<f32>(nv, 0.0);
}

// `v = next` (after `confine` or `xsph`).
@compute @workgroup_size(64)
fn take_velocities(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    v[i] = next[i];
}

