// XPBD soft bodies on small steps (physics/src/xpbd/soft/), on the GPU.
// The crate puts `bodies.wgsl` (the rigid bodies' shapes, the push out of
// them, the reductions of their pushes) before this file.
//
// Once a step, `find_contacts` keeps the bodies within reach of each
// particle (at most BODY_SLOTS, the CPU's candidates). Each substep is a
// run of dispatches, each its own usage scope (so each sees the writes of
// the one before), in the CPU's order (xpbd/soft/step.rs):
// - `predict` (or `finish` of the last substep fused with this one's
//   prediction);
// - one `project` dispatch per colour of each constraint kind (distance,
//   bending, volume, tethers), in the CPU's colour order;
// - for an inflated shell, the pressure constraint: `shell_gradient`,
//   `shell_sums`, `shell_total`, `shell_apply`;
// - `advance_bodies`, then `attach` (the attachments to rigid bodies, one
//   invocation, in order, each moving its body before the next);
// - `collide` (each particle kept the collision radius out of its
//   contacts' bodies, with friction), and the reductions of what the
//   contacts gave the bodies.
// After the last substep's `finish`, `flow` lets a plastic body's rest
// lengths follow its strain.
//
// A dynamic body shares each correction with the particle as an XPBD
// contact does (`Coupling::press`): each substep `advance_bodies` moves it
// on by the velocity the stage gave it, `collide` keeps each particle's
// pushes, `reduce_chunks` and `reduce_bodies` sum them per body in a fixed
// order, and `take_pushes` moves the body by them (`motion`), so the next
// substep meets it there. Within a colour no two constraints move the
// same particle, so every invocation writes only its own constraint's
// particles and nothing needs atomics; an overflow colour (a particle in
// more than 64 constraints of a kind) is projected by one invocation, in
// order, as the CPU does. The pressure constraint's sums run over chunks
// of SHELL_CHUNK triangles and particles, then over the chunks, in order:
// no atomics there either. The formulas are the CPU's (constraints.rs,
// step.rs), operation for operation, the arctangent the same polynomial.
//
// A particle is a vec4: xyz position (m) and w its inverse mass (1/kg; 0:
// pinned). Units: m, s, kg; compliance per constraint as on the CPU.

const WORKGROUP_SIZE: u32 = 64u;
const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;
const HALF_PI: f32 = 1.57079632679490;
// Triangles, and particles, whose pressure sums one invocation of
// `shell_sums` takes.
const SHELL_CHUNK: u32 = 256u;

// What one dispatch does (a slot of a dynamic-offset uniform buffer).
struct SoftParams {
    // Gravity times the body's scale, m/s² (w unused).
    gravity: vec4<f32>,
    // Substep, s.
    h: f32,
    // 1 / h², 1/s².
    inv_h2: f32,
    // The velocity kept after damping over a substep (1 - damping h).
    keep: f32,
    // Particles.
    n: u32,
    // First constraint of the colour, and how many.
    offset: u32,
    count: u32,
    // 1: the overflow colour, projected by one invocation in order.
    serial: u32,
    // `finish`: 1 when the next substep's prediction follows.
    predict_next: u32,
    // `project`: the constraint kind (0 distance, 1 bending, 2 volume,
    // 3 tether).
    kind: u32,
    // Bodies the particles meet, those they can move, and chunks of
    // PUSH_CHUNK particles (`bodies.wgsl`).
    shapes: u32,
    movable: u32,
    chunks: u32,
    // Collision radius (m) and the body's friction coefficient.
    radius: f32,
    friction: f32,
    // How far from a particle's position at the start of the step bodies
    // are looked for, m: the collision radius and gravity's travel over
    // the step (plus the particle's own, `|v| dt`).
    reach: f32,
    // The whole step, s.
    dt: f32,
    // `collide`: the fraction of the step at the end of its substep.
    t: f32,
    // The substep, s (`bodies.wgsl`'s name for `h`).
    substep: f32,
    // Attachments to rigid bodies (`attach`).
    attachments: u32,
    // The pressure shell: its triangles, and the chunks `shell_sums`
    // takes (of SHELL_CHUNK triangles and of SHELL_CHUNK particles).
    triangles: u32,
    shell_chunks: u32,
    // The volume kept (m³), and the pressure's compliance over h² (Pa⁻¹
    // s⁻²).
    goal_volume: f32,
    pressure_alpha: f32,
    // `flow`: distance constraints, the strain past which a rest length
    // flows, the largest permanent strain, and the fraction of the excess
    // that flows this step.
    distances_n: u32,
    yield_strain: f32,
    max_strain: f32,
    flow_rate: f32,
    pad: u32,
}

// Two particles, rest length (m, bits), compliance (m/N, bits).
struct Distance {
    p: vec2<u32>,
    rest: f32,
    compliance: f32,
}

// Four particles (a hinge: the edge, then the opposite vertices; a
// tetrahedron: its corners), the rest angle (rad) or volume (m³), and the
// compliance.
struct Quad {
    p: vec4<u32>,
    rest: f32,
    compliance: f32,
    pad0: f32,
    pad1: f32,
}

// A particle, its pinned anchor, the longest distance allowed (m).
struct Tether {
    p: vec2<u32>,
    max_len: f32,
    pad: f32,
}

// A particle held to a point of a rigid body (`SoftAttachment`).
struct Attachment {
    // xyz: the point in the body's frame (m); w: the compliance (m/N).
    local: vec4<f32>,
    // x: the particle; y: the body's shape this step (NONE: none).
    who: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: SoftParams;
@group(0) @binding(1) var<storage, read_write> x: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> v: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> prev: array<vec4<f32>>;
// Their rest lengths flow in a plastic body (`flow`).
@group(0) @binding(4) var<storage, read_write> distances: array<Distance>;
@group(0) @binding(5) var<storage, read> bends: array<Quad>;
@group(0) @binding(6) var<storage, read> tets: array<Quad>;
@group(0) @binding(7) var<storage, read> tethers: array<Tether>;
// The bodies the particles meet this step.
@group(0) @binding(8) var<storage, read> shapes: array<Shape>;
// Per particle: the shapes of its contacts for the step (NONE past the
// last).
@group(0) @binding(9) var<storage, read_write> contacts: array<vec4<u32>>;
// BODY_SLOTS per particle: what it gave each contact's body this substep
// (while `params.movable` > 0).
@group(0) @binding(10) var<storage, read_write> pushes: array<Push>;
// Per chunk and movable body, then per body (`bodies.wgsl`).
@group(0) @binding(11) var<storage, read_write> partials: array<Push>;
// Per movable body: what the stage did to it so far.
@group(0) @binding(12) var<storage, read_write> motion: array<Motion>;
// The attachments to rigid bodies, their shapes resolved for the step.
@group(0) @binding(13) var<storage, read> attachments: array<Attachment>;
// The pressure shell: its triangles (three particles each), then, per
// particle, where its list of corners starts (n + 1 offsets), then the
// lists (triangle * 3 + corner, in triangle order).
@group(0) @binding(14) var<storage, read> shell: array<u32>;
// Per particle: the pressure gradient (xyz) and its inverse mass times
// the gradient's square (w); then per chunk of `shell_sums`: the volume
// (x) and the weights (y); then the multiplier's change (x).
@group(0) @binding(15) var<storage, read_write> pressure: array<vec4<f32>>;
// Per distance constraint: its rest length as built (m).
@group(0) @binding(16) var<storage, read> rest0: array<f32>;

fn linear(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WORKGROUP_SIZE;
}

// `v += g h`, `prev = x`, `x += v h` for particles that can move.
fn predict_one(i: u32) {
    let p = x[i];
    prev[i] = p;
    if (p.w > 0.0) {
        let vi = v[i].xyz + params.gravity.xyz * params.h;
        v[i] = vec4<f32>(vi, 0.0);
        x[i] = vec4<f32>(p.xyz + vi * params.h, p.w);
    } else {
        v[i] = vec4<f32>(0.0);
    }
}

@compute @workgroup_size(64)
fn predict(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    predict_one(i);
}

// The substep's velocities, `v = (x - prev) / h`, damped (a particle gone
// non-finite goes back, at rest); then, with `predict_next`, the next
// substep's prediction.
@compute @workgroup_size(64)
fn finish(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i];
    if (p.w <= 0.0) {
        prev[i] = p;
        v[i] = vec4<f32>(0.0);
        return;
    }
    let vi = (p.xyz - prev[i].xyz) * (1.0 / params.h) * params.keep;
    // Not finite: NaN fails every comparison; infinities exceed the range.
    let big = 3.0e38;
    let finite = all(abs(vi) <= vec3<f32>(big)) && all(abs(p.xyz) <= vec3<f32>(big));
    if (finite) {
        v[i] = vec4<f32>(vi, 0.0);
    } else {
        x[i] = prev[i];
        v[i] = vec4<f32>(0.0);
    }
    if (params.predict_next == 1u) {
        predict_one(i);
    }
}

fn project_distance(c: Distance) {
    let a = c.p.x;
    let b = c.p.y;
    let xa = x[a];
    let xb = x[b];
    let d = xb.xyz - xa.xyz;
    let len = sqrt(dot(d, d));
    let k = xa.w + xb.w + c.compliance * params.inv_h2;
    if (len < 1e-9 || k <= 0.0) {
        return;
    }
    let n = d * (1.0 / len);
    let dl = -(len - c.rest) / k;
    x[a] = vec4<f32>(xa.xyz - n * (xa.w * dl), xa.w);
    x[b] = vec4<f32>(xb.xyz + n * (xb.w * dl), xb.w);
}

// The polynomial arctangent of constraints.rs (Abramowitz & Stegun 4.4.49).
fn atan2_poly(y: f32, xx: f32) -> f32 {
    let ax = abs(xx);
    let ay = abs(y);
    let hi = max(ax, ay);
    if (hi == 0.0) {
        return 0.0;
    }
    let a = min(ax, ay) / hi;
    let s = a * a;
    var r = a * (0.999866 + s * (-0.3302995 + s * (0.180141 + s * (-0.085133 + s * 0.0208351))));
    if (ay > ax) {
        r = HALF_PI - r;
    }
    if (xx < 0.0) {
        r = PI - r;
    }
    if (y < 0.0) {
        r = -r;
    }
    return r;
}

fn project_bend(c: Quad) {
    let p0 = x[c.p.x];
    let p1 = x[c.p.y];
    let p2 = x[c.p.z];
    let p3 = x[c.p.w];
    let x0 = p0.xyz;
    let x1 = p1.xyz;
    let x2 = p2.xyz;
    let x3 = p3.xyz;
    let e = x1 - x0;
    let e_len = sqrt(dot(e, e));
    let n1 = cross(e, x2 - x0);
    let n2 = cross(x3 - x0, e);
    let l1 = dot(n1, n1);
    let l2 = dot(n2, n2);
    if (e_len < 1e-9 || l1 < 1e-18 || l2 < 1e-18) {
        return;
    }
    let e_hat = e * (1.0 / e_len);
    let il1 = 1.0 / l1;
    let il2 = 1.0 / l2;
    // The normals' lengths cancel in the arctangent.
    let angle = atan2_poly(dot(cross(n1, n2), e_hat), dot(n1, n2));
    let g2 = -(n1 * (e_len * il1));
    let g3 = -(n2 * (e_len * il2));
    let g0 = -(n1 * (dot(x2 - x1, e_hat) * il1) + n2 * (dot(x3 - x1, e_hat) * il2));
    let g1 = n1 * (dot(x2 - x0, e_hat) * il1) + n2 * (dot(x3 - x0, e_hat) * il2);
    var cv = angle - c.rest;
    if (cv > PI) {
        cv = cv - TAU;
    } else if (cv <= -PI) {
        cv = cv + TAU;
    }
    let k = c.compliance * params.inv_h2 + p0.w * dot(g0, g0) + p1.w * dot(g1, g1)
        + p2.w * dot(g2, g2) + p3.w * dot(g3, g3);
    if (k <= 1e-12) {
        return;
    }
    let dl = -cv / k;
    x[c.p.x] = vec4<f32>(x0 + g0 * (p0.w * dl), p0.w);
    x[c.p.y] = vec4<f32>(x1 + g1 * (p1.w * dl), p1.w);
    x[c.p.z] = vec4<f32>(x2 + g2 * (p2.w * dl), p2.w);
    x[c.p.w] = vec4<f32>(x3 + g3 * (p3.w * dl), p3.w);
}

fn project_tet(c: Quad) {
    let p0 = x[c.p.x];
    let p1 = x[c.p.y];
    let p2 = x[c.p.z];
    let p3 = x[c.p.w];
    let x0 = p0.xyz;
    let x1 = p1.xyz;
    let x2 = p2.xyz;
    let x3 = p3.xyz;
    let g1 = cross(x2 - x0, x3 - x0) / 6.0;
    let g2 = cross(x3 - x0, x1 - x0) / 6.0;
    let g3 = cross(x1 - x0, x2 - x0) / 6.0;
    let g0 = -(g1 + g2 + g3);
    let volume = dot(cross(x1 - x0, x2 - x0), x3 - x0) / 6.0;
    let k = c.compliance * params.inv_h2 + p0.w * dot(g0, g0) + p1.w * dot(g1, g1)
        + p2.w * dot(g2, g2) + p3.w * dot(g3, g3);
    if (k <= 1e-30) {
        return;
    }
    let dl = -(volume - c.rest) / k;
    x[c.p.x] = vec4<f32>(x0 + g0 * (p0.w * dl), p0.w);
    x[c.p.y] = vec4<f32>(x1 + g1 * (p1.w * dl), p1.w);
    x[c.p.z] = vec4<f32>(x2 + g2 * (p2.w * dl), p2.w);
    x[c.p.w] = vec4<f32>(x3 + g3 * (p3.w * dl), p3.w);
}

fn project_tether(c: Tether) {
    let pa = x[c.p.x];
    if (pa.w <= 0.0) {
        return;
    }
    let xb = x[c.p.y].xyz;
    let d = pa.xyz - xb;
    let len = sqrt(dot(d, d));
    if (len <= c.max_len || len < 1e-9) {
        return;
    }
    x[c.p.x] = vec4<f32>(xb + d * (c.max_len / len), pa.w);
}

// The constraint this invocation projects (or, for the overflow colour,
// whether this is the one invocation that projects them all): its index,
// or a value past the colour's end.
fn item(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    let k = linear(id, groups);
    if (params.serial == 1u) {
        return select(0xffffffffu, params.offset, k == 0u);
    }
    return select(0xffffffffu, params.offset + k, k < params.count);
}

fn last(first: u32) -> u32 {
    return select(first + 1u, params.offset + params.count, params.serial == 1u);
}

// Projects the colour's constraints of kind `params.kind` (0 distance,
// 1 bending, 2 volume, 3 tether).
@compute @workgroup_size(64)
fn project(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let first = item(id, groups);
    if (first == 0xffffffffu) {
        return;
    }
    for (var c = first; c < last(first); c = c + 1u) {
        switch params.kind {
            case 0u: {
                project_distance(distances[c]);
            }
            case 1u: {
                project_bend(bends[c]);
            }
            case 2u: {
                project_tet(tets[c]);
            }
            default: {
                project_tether(tethers[c]);
            }
        }
    }
}

// ---- contacts with rigid bodies (coupling.rs) ----

// The shape of contact `slot` of particle `i`, or NONE (`bodies.wgsl`).
fn slot_shape(i: u32, slot: u32) -> u32 {
    return contacts[i][slot];
}

// The bodies within reach of each particle that can move over the step
// (`params.reach` and its own travel), from its position at the start of
// the step, in handle order (at most BODY_SLOTS); its pushes cleared.
@compute @workgroup_size(64)
fn find_contacts(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i];
    var found = vec4<u32>(NONE);
    if (p.w > 0.0) {
        let within = params.reach + length(v[i].xyz) * params.dt;
        var used = 0u;
        for (var k = 0u; k < params.shapes && used < BODY_SLOTS; k++) {
            if (surface(shapes[k], p.xyz, within).found) {
                found[used] = k;
                used += 1u;
            }
        }
    }
    contacts[i] = found;
    if (params.movable > 0u) {
        for (var slot = 0u; slot < BODY_SLOTS; slot++) {
            pushes[i * BODY_SLOTS + slot] = Push(vec4<f32>(0.0), vec4<f32>(0.0));
        }
    }
}

// Each particle kept the collision radius out of its contacts' bodies,
// with friction; a movable body takes its share of each correction
// (`Coupling::press`), kept in the particle's pushes for `take_pushes`.
@compute @workgroup_size(64)
fn collide(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let own = x[i];
    if (own.w <= 0.0) {
        return;
    }
    let q = prev[i].xyz;
    var p = own.xyz;
    for (var slot = 0u; slot < BODY_SLOTS; slot++) {
        if (params.movable > 0u) {
            pushes[i * BODY_SLOTS + slot] = Push(vec4<f32>(0.0), vec4<f32>(0.0));
        }
        let k = contacts[i][slot];
        if (k == NONE) {
            continue;
        }
        let shape = body_at(k, params.t);
        p = press(i, slot, shape, p, q, own.w, params.radius, params.friction);
    }
    x[i] = vec4<f32>(p, own.w);
}

// ---- attachments to rigid bodies (step.rs `attach`) ----

// Every attachment, in order, by one invocation: a zero-length compliant
// constraint from the particle to the body's point, both moved by their
// shares; the body moves before the next attachment meets it.
@compute @workgroup_size(64)
fn attach(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    if (linear(id, groups) != 0u) {
        return;
    }
    for (var k = 0u; k < params.attachments; k++) {
        let a = attachments[k];
        let shape = a.who.y;
        if (shape == NONE) {
            continue;
        }
        let i = a.who.x;
        let own = x[i];
        let s = body_at(shape, params.t);
        let anchor = to_world(s, a.local.xyz);
        let d = own.xyz - anchor;
        let len = length(d);
        if (len < 1e-9 || !finite(len)) {
            continue;
        }
        let n = d / len;
        let total = own.w + inv_mass_along(s, anchor, n) + a.local.w * params.inv_h2;
        if (total <= 0.0) {
            continue;
        }
        let dl = -len / total;
        x[i] = vec4<f32>(own.xyz + n * (own.w * dl), own.w);
        let slot = shapes[shape].kind.y;
        if (slot != NONE) {
            let impulse = -n * dl;
            shift(slot, impulse, cross(anchor - s.com.xyz, impulse));
        }
    }
}

// ---- pressure (step.rs `project_pressure`) ----

// The position of corner `c` of shell triangle `t`.
fn corner(t: u32, c: u32) -> vec3<f32> {
    return x[shell[3u * t + c]].xyz;
}

// Each particle's share of the enclosed volume's gradient, summed over
// its triangles in triangle order (as the CPU adds them).
@compute @workgroup_size(64)
fn shell_gradient(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let offsets = 3u * params.triangles;
    let lists = offsets + params.n + 1u;
    var g = vec3<f32>(0.0);
    for (var e = shell[offsets + i]; e < shell[offsets + i + 1u]; e++) {
        let entry = shell[lists + e];
        let t = entry / 3u;
        let c = entry % 3u;
        g += cross(corner(t, (c + 1u) % 3u), corner(t, (c + 2u) % 3u)) / 6.0;
    }
    let w = x[i].w;
    pressure[i] = vec4<f32>(g, w * dot(g, g));
}

// Each chunk's enclosed volume (of its SHELL_CHUNK triangles) and weights
// (of its SHELL_CHUNK particles), summed in order.
@compute @workgroup_size(64)
fn shell_sums(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let chunk = linear(id, groups);
    if (chunk >= params.shell_chunks) {
        return;
    }
    var volume = 0.0;
    let t_end = min((chunk + 1u) * SHELL_CHUNK, params.triangles);
    for (var t = chunk * SHELL_CHUNK; t < t_end; t++) {
        volume += dot(corner(t, 0u), cross(corner(t, 1u), corner(t, 2u))) / 6.0;
    }
    var weights = 0.0;
    let i_end = min((chunk + 1u) * SHELL_CHUNK, params.n);
    for (var i = chunk * SHELL_CHUNK; i < i_end; i++) {
        weights += pressure[i].w;
    }
    pressure[params.n + chunk] = vec4<f32>(volume, weights, 0.0, 0.0);
}

// The chunks' sums, in order, and the multiplier's change (one
// invocation).
@compute @workgroup_size(64)
fn shell_total(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    if (linear(id, groups) != 0u) {
        return;
    }
    var volume = 0.0;
    var k = params.pressure_alpha;
    for (var chunk = 0u; chunk < params.shell_chunks; chunk++) {
        let s = pressure[params.n + chunk];
        volume += s.x;
        k += s.y;
    }
    var dl = 0.0;
    if (k > 1e-30) {
        dl = -(volume - params.goal_volume) / k;
    }
    pressure[params.n + params.shell_chunks] = vec4<f32>(dl, volume, 0.0, 0.0);
}

// Each particle moved along its gradient by its share.
@compute @workgroup_size(64)
fn shell_apply(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(id, groups);
    if (i >= params.n) {
        return;
    }
    let p = x[i];
    let dl = pressure[params.n + params.shell_chunks].x;
    x[i] = vec4<f32>(p.xyz + pressure[i].xyz * (p.w * dl), p.w);
}

// ---- plasticity (step.rs, after the substeps) ----

// Each distance constraint strained past the yield: its rest length
// moves toward the length that leaves it at the yield strain, by the
// step's fraction, within the largest permanent strain of its length as
// built.
@compute @workgroup_size(64)
fn flow(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = linear(id, groups);
    if (c >= params.distances_n) {
        return;
    }
    var d = distances[c];
    let len = length(x[d.p.y].xyz - x[d.p.x].xyz);
    let strain = len / d.rest - 1.0;
    if (abs(strain) <= params.yield_strain) {
        return;
    }
    let goal = len / (1.0 + params.yield_strain * sign(strain));
    let rest = d.rest + (goal - d.rest) * params.flow_rate;
    let r0 = rest0[c];
    d.rest = clamp(rest, r0 * max(1.0 - params.max_strain, 0.01), r0 * (1.0 + params.max_strain));
    distances[c] = d;
}
