// Rigid bodies as the particles of a fluid or a soft body see them on the
// GPU (physics/src/xpbd/coupling.rs, physics/src/gpu/bodies.rs): their
// shapes, the surface nearest a particle, and the impulses the particles
// give the dynamic ones back.
//
// This file is the head of `pbf.wgsl` and of `xpbd_soft.wgsl` (the crate
// joins them; WGSL has no includes). The shader after it declares what
// the code here uses:
// - `WORKGROUP_SIZE` and `fn linear` (an invocation's index);
// - `params` with `n` (particles), `movable` (bodies the particles can
//   move), `chunks` (chunks of PUSH_CHUNK particles), `t` (the fraction
//   of the step at the end of the substep) and `substep` (its length, s);
// - the bindings `shapes` (array<Shape>), `pushes` and `partials`
//   (array<Push>), `motion` (array<Motion>);
// - `fn slot_shape(i, slot)`: the shape behind slot `slot` of particle
//   `i` (BODY_SLOTS a particle, found once a step), or NONE.
//
// Contacts share each correction with a movable body as on the CPU
// (coupling.rs): each substep, a particle keeps the push it gives the body
// behind each of its slots in `pushes`; `reduce_chunks` sums each movable
// body's pushes over each chunk of PUSH_CHUNK particles, in particle and
// slot order, `reduce_bodies` sums the chunks in order (a fixed order, so
// a run repeats bit for bit, and no floating-point atomics), and
// `take_pushes` moves the body by the sum (`motion`). `advance_bodies`
// moves it on by the velocity that gave it, substep by substep. Particles
// meet a body where its path over the step and its motion put it
// (`shape_at`).
//
// Units: m, s, kg.

// Shape kinds (`gpu/bodies.rs`).
const SHAPE_CUBOID: u32 = 0u;
const SHAPE_SPHERE: u32 = 1u;
const SHAPE_CAPSULE: u32 = 2u;
// A body particles are attached to but never touch (any shape: only its
// pose and mass matter).
const SHAPE_UNTOUCHED: u32 = 3u;
// Nothing: no neighbour, no shape, a shape the particles cannot move.
const NONE: u32 = 0xffffffffu;
// Bodies a particle keeps over a step.
const BODY_SLOTS: u32 = 4u;
// Particles whose pushes one invocation of `reduce_chunks` sums.
const PUSH_CHUNK: u32 = 1024u;

// A rigid body the particles meet (`gpu/bodies.rs`).
struct Shape {
    // x: SHAPE_* kind; y: the body's slot among the movable ones (the
    // dynamic bodies), or NONE.
    kind: vec4<u32>,
    // Pose: translation (m) and the rotation's columns.
    translation: vec4<f32>,
    axis_x: vec4<f32>,
    axis_y: vec4<f32>,
    axis_z: vec4<f32>,
    // Cuboid: half extents (m); sphere: x = radius; capsule: x = half
    // height, y = radius.
    size: vec4<f32>,
    // Centre of mass (m); w: the body's friction coefficient.
    com: vec4<f32>,
    // Velocity (m/s) and angular velocity (rad/s): the body's mean over
    // the step.
    linvel: vec4<f32>,
    angvel: vec4<f32>,
    // x: inverse mass, 1/kg (0 when the particles cannot move it).
    inv_mass: vec4<f32>,
    // The inverse inertia in the world's frame, by column, 1/(kg m²).
    inv_inertia_x: vec4<f32>,
    inv_inertia_y: vec4<f32>,
    inv_inertia_z: vec4<f32>,
    // The rotation (a unit quaternion, xyzw) now and as the step began,
    // the centre of mass as the step began (m), and the centre of mass in
    // the body's own frame (m): its path over the step.
    rotation: vec4<f32>,
    start_rotation: vec4<f32>,
    start_com: vec4<f32>,
    local_com: vec4<f32>,
}

// What particles pushed a body with in a substep (`Push` of
// coupling.rs): a positional impulse (N s²) and its moment about the
// body's centre of mass (N m s²); w unused.
struct Push {
    impulse: vec4<f32>,
    moment: vec4<f32>,
}

// What a soft body's stage did to a movable body so far (`Motion` of
// coupling.rs): its move (m) and turn (a unit quaternion, xyzw) about its
// centre of mass, the velocities that came with them (m/s, rad/s), and
// the shape it is (x of `shape`).
struct Motion {
    dx: vec4<f32>,
    dq: vec4<f32>,
    dv: vec4<f32>,
    dw: vec4<f32>,
    shape: vec4<u32>,
}

// `v` turned by the unit quaternion `q`.
fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

// `q` turned by the rotation vector `theta` (rad), to first order and
// normalised (coupling.rs's `turned`).
fn turned(q: vec4<f32>, theta: vec3<f32>) -> vec4<f32> {
    // The quaternion product (theta, 0) q.
    let t = vec4<f32>(theta * q.w + cross(theta, q.xyz), -dot(theta, q.xyz));
    return normalize(q + t * 0.5);
}

// `a` to `b` by `t` along the shorter great arc (glam's `slerp`).
fn slerp(a: vec4<f32>, b_in: vec4<f32>, t: f32) -> vec4<f32> {
    var b = b_in;
    var d = dot(a, b);
    if (d < 0.0) {
        b = -b;
        d = -d;
    }
    if (d > 0.9995) {
        return normalize(a + (b - a) * t);
    }
    let theta = acos(d);
    let scale1 = sin(theta * (1.0 - t));
    let scale2 = sin(theta * t);
    let inv = 1.0 / sin(theta);
    return normalize((a * scale1 + b * scale2) * inv);
}

// Shape `s` at fraction `t` of its path over the step (`Coupling::follow`)
// and moved by `m`: where particles meet it, and its velocity with what
// the stage gave it.
fn shape_at(s: Shape, m: Motion, t: f32) -> Shape {
    var out = s;
    let com = mix(s.start_com.xyz, s.com.xyz, t) + m.dx.xyz;
    let q = normalize(quat_mul(m.dq, slerp(s.start_rotation, s.rotation, t)));
    out.translation = vec4<f32>(com - rotate(q, s.local_com.xyz), 0.0);
    out.axis_x = vec4<f32>(rotate(q, vec3<f32>(1.0, 0.0, 0.0)), 0.0);
    out.axis_y = vec4<f32>(rotate(q, vec3<f32>(0.0, 1.0, 0.0)), 0.0);
    out.axis_z = vec4<f32>(rotate(q, vec3<f32>(0.0, 0.0, 1.0)), 0.0);
    out.com = vec4<f32>(com, s.com.w);
    out.linvel = vec4<f32>(s.linvel.xyz + m.dv.xyz, 0.0);
    out.angvel = vec4<f32>(s.angvel.xyz + m.dw.xyz, 0.0);
    return out;
}

// The quaternion product `a b`.
fn quat_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}

// No motion yet.
fn still() -> Motion {
    return Motion(vec4<f32>(0.0), vec4<f32>(0.0, 0.0, 0.0, 1.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<u32>(NONE));
}

// Whether shape `s` moves within the stage: particles can move it, or the
// rigid stage moved it over the step (`Target::moves`).
fn shape_moves(s: Shape) -> bool {
    return s.kind.y != NONE || any(s.start_com != s.com) || any(s.start_rotation != s.rotation);
}

// Shape `k` where particles meet it at fraction `t` of the step.
fn body_at(k: u32, t: f32) -> Shape {
    return shape_now(shapes[k], t);
}

// Shape `s` (read from `shapes`) where particles meet it at fraction `t`
// of the step.
fn shape_now(s: Shape, t: f32) -> Shape {
    if (s.kind.y != NONE) {
        return shape_at(s, motion[s.kind.y], t);
    }
    if (!shape_moves(s)) {
        return s;
    }
    return shape_at(s, still(), t);
}

// Whether `a` is neither infinite nor NaN (by its bits: a compiler may
// fold `a != a`).
fn finite(a: f32) -> bool {
    return (bitcast<u32>(a) & 0x7f800000u) != 0x7f800000u;
}

fn finite3(a: vec3<f32>) -> bool {
    return finite(a.x) && finite(a.y) && finite(a.z);
}

// The surface of a shape nearest a point: the point (m), the normal out
// of the body, the signed distance (m, negative inside; w), and whether
// it counts (`found`).
struct Surface {
    point: vec3<f32>,
    normal: vec3<f32>,
    distance: f32,
    found: bool,
}

fn to_local(s: Shape, p: vec3<f32>) -> vec3<f32> {
    let d = p - s.translation.xyz;
    return vec3<f32>(dot(s.axis_x.xyz, d), dot(s.axis_y.xyz, d), dot(s.axis_z.xyz, d));
}

fn to_world(s: Shape, q: vec3<f32>) -> vec3<f32> {
    return s.axis_x.xyz * q.x + s.axis_y.xyz * q.y + s.axis_z.xyz * q.z + s.translation.xyz;
}

// The ball of radius `r` about `c` (query/project.rs `project_ball`):
// the nearest surface point (xyz) and 1 when inside (w).
fn project_ball(p: vec3<f32>, c: vec3<f32>, r: f32) -> vec4<f32> {
    let d = p - c;
    let l = length(d);
    var u = vec3<f32>(0.0, 1.0, 0.0);
    if (l > 0.0) {
        u = d / l;
    }
    return vec4<f32>(c + u * r, select(0.0, 1.0, l <= r));
}

// The nearest surface point in the shape's frame (xyz) and 1 when `p` is
// inside (w).
fn project_local(s: Shape, p: vec3<f32>) -> vec4<f32> {
    let kind = s.kind.x;
    if (kind == SHAPE_SPHERE) {
        return project_ball(p, vec3<f32>(0.0), s.size.x);
    }
    if (kind == SHAPE_CAPSULE) {
        let hh = s.size.x;
        return project_ball(p, vec3<f32>(0.0, clamp(p.y, -hh, hh), 0.0), s.size.y);
    }
    let h = s.size.xyz;
    let q = clamp(p, -h, h);
    if (any(q != p)) {
        return vec4<f32>(q, 0.0);
    }
    // Inside: out through the nearest face.
    let depth = h - abs(p);
    var out = p;
    if (depth.x <= depth.y && depth.x <= depth.z) {
        out.x = select(-h.x, h.x, p.x >= 0.0);
    } else if (depth.y <= depth.z) {
        out.y = select(-h.y, h.y, p.y >= 0.0);
    } else {
        out.z = select(-h.z, h.z, p.z >= 0.0);
    }
    return vec4<f32>(out, 1.0);
}

// `Coupling::surface`: the surface of shape `s` nearest `p`, found if `p`
// is inside or closer than `within` (m).
fn surface(s: Shape, p: vec3<f32>, within: f32) -> Surface {
    var out = Surface(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
    if (s.kind.x == SHAPE_UNTOUCHED) {
        return out;
    }
    let local = to_local(s, p);
    let proj = project_local(s, local);
    let inside = proj.w > 0.5;
    let distance = distance(local, proj.xyz);
    if (!inside && distance >= within) {
        return out;
    }
    let point = to_world(s, proj.xyz);
    let to = p - point;
    let len = length(to);
    if (len <= 1e-12 || !finite(len)) {
        return out;
    }
    out.point = point;
    out.normal = select(to / len, -to / len, inside);
    out.distance = select(distance, -distance, inside);
    out.found = true;
    return out;
}

// Velocity of shape `s`'s material at `p`, m/s.
fn velocity_at(s: Shape, p: vec3<f32>) -> vec3<f32> {
    return s.linvel.xyz + cross(s.angvel.xyz, p - s.com.xyz);
}

// `1/M + (r × d) · I⁻¹ (r × d)` of shape `s` at `p` along `d`, 1/kg.
fn inv_mass_along(s: Shape, p: vec3<f32>, d: vec3<f32>) -> f32 {
    if (s.inv_mass.x == 0.0) {
        return 0.0;
    }
    let c = cross(p - s.com.xyz, d);
    let ic = s.inv_inertia_x.xyz * c.x + s.inv_inertia_y.xyz * c.y + s.inv_inertia_z.xyz * c.z;
    return s.inv_mass.x + dot(c, ic);
}

// A particle's correction against one body (`Coupling::push_out`).
struct Correction {
    // The correction, m.
    dx: vec3<f32>,
    // The point of the body's surface nearest the particle, m.
    point: vec3<f32>,
    // Whether the particle was within the radius (and the correction is
    // finite).
    found: bool,
}

// The correction that keeps a particle at `p`, where it stood at `q` at
// the start of a substep of `h` s, `radius` (m) out of shape `s`, with
// Coulomb friction: the slide relative to the body's surface over the
// substep, undone up to `mu` (the larger of it and the body's) times the
// normal correction.
fn push_out(s: Shape, p: vec3<f32>, q: vec3<f32>, radius: f32, mu: f32, h: f32) -> Correction {
    var out = Correction(vec3<f32>(0.0), vec3<f32>(0.0), false);
    let surf = surface(s, p, radius);
    if (!surf.found) {
        return out;
    }
    let depth = radius - surf.distance;
    var dx = surf.normal * depth;
    let m = max(mu, s.com.w);
    if (m > 0.0) {
        let moved = (p - q) + dx - velocity_at(s, surf.point) * h;
        let slide = moved - surf.normal * dot(moved, surf.normal);
        let len = length(slide);
        if (len > 1e-12) {
            dx -= slide * min(m * depth / len, 1.0);
        }
    }
    if (!finite3(p + dx)) {
        return out;
    }
    out.dx = dx;
    out.point = surf.point;
    out.found = true;
    return out;
}

// `Coupling::press` against one body: particle `i`, at `p` (where it
// stood at `q` as the substep began, inverse mass `w`, 1/kg), kept
// `radius` (m) out of `shape` with friction `mu`, the pair sharing the
// correction by inverse mass. Returns the particle's new position; the
// body's share goes to the particle's push for slot `slot` (none for
// NONE).
fn press(i: u32, slot: u32, shape: Shape, p: vec3<f32>, q: vec3<f32>, w: f32, radius: f32, mu: f32) -> vec3<f32> {
    let c = push_out(shape, p, q, radius, mu, params.substep);
    if (!c.found) {
        return p;
    }
    let len = length(c.dx);
    var n = vec3<f32>(0.0);
    if (len > 0.0 && finite(len)) {
        n = c.dx / len;
    }
    let w_b = inv_mass_along(shape, c.point, n);
    let total = w + w_b;
    if (total <= 0.0) {
        return p;
    }
    if (w_b > 0.0 && slot != NONE) {
        add_push(i, slot, shape, c.point, -c.dx / total);
    }
    return p + c.dx * (w / total);
}

// Adds the positional impulse `impulse` (N s²), given at `point` (m) to
// the movable body `s` behind slot `slot` of particle `i`, to the
// particle's push for that slot (`Coupling::give`).
fn add_push(i: u32, slot: u32, s: Shape, point: vec3<f32>, impulse: vec3<f32>) {
    if (!finite3(impulse)) {
        return;
    }
    let at = i * BODY_SLOTS + slot;
    let l = pushes[at];
    let moment = cross(point - s.com.xyz, impulse);
    pushes[at] = Push(vec4<f32>(l.impulse.xyz + impulse, 0.0), vec4<f32>(l.moment.xyz + moment, 0.0));
}

// Each chunk of PUSH_CHUNK particles: every movable body's pushes, summed
// in particle and slot order (an invocation a body) into `partials`.
@compute @workgroup_size(64)
fn reduce_chunks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let chunk = wg.x + wg.y * groups.x;
    if (chunk >= params.chunks) {
        return;
    }
    let lo = chunk * PUSH_CHUNK;
    let hi = min(lo + PUSH_CHUNK, params.n);
    for (var body = t; body < params.movable; body += WORKGROUP_SIZE) {
        var impulse = vec4<f32>(0.0);
        var moment = vec4<f32>(0.0);
        for (var i = lo; i < hi; i++) {
            for (var slot = 0u; slot < BODY_SLOTS; slot++) {
                let k = slot_shape(i, slot);
                if (k == NONE || shapes[k].kind.y != body) {
                    continue;
                }
                let l = pushes[i * BODY_SLOTS + slot];
                impulse += l.impulse;
                moment += l.moment;
            }
        }
        partials[chunk * params.movable + body] = Push(impulse, moment);
    }
}

// Each movable body's total: its chunks' pushes, in chunk order, after the
// chunks' in `partials`.
@compute @workgroup_size(64)
fn reduce_bodies(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let body = linear(id, groups);
    if (body >= params.movable) {
        return;
    }
    var impulse = vec4<f32>(0.0);
    var moment = vec4<f32>(0.0);
    for (var chunk = 0u; chunk < params.chunks; chunk++) {
        let l = partials[chunk * params.movable + body];
        impulse += l.impulse;
        moment += l.moment;
    }
    partials[params.chunks * params.movable + body] = Push(impulse, moment);
}

// Each movable body moved on by the velocity the stage gave it, over the
// substep (`Target::advance`).
@compute @workgroup_size(64)
fn advance_bodies(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = linear(id, groups);
    if (b >= params.movable) {
        return;
    }
    var m = motion[b];
    if (all(m.dv.xyz == vec3<f32>(0.0)) && all(m.dw.xyz == vec3<f32>(0.0))) {
        return;
    }
    m.dx = vec4<f32>(m.dx.xyz + m.dv.xyz * params.substep, 0.0);
    m.dq = turned(m.dq, m.dw.xyz * params.substep);
    motion[b] = m;
}

// Movable body `slot` moved by the positional impulse `impulse` (N s²)
// with moment `moment` about its centre of mass (N m s²), and given the
// velocity of that move over the substep (`Target::shift`).
fn shift(slot: u32, impulse: vec3<f32>, moment: vec3<f32>) {
    if (!(finite3(impulse) && finite3(moment))) {
        return;
    }
    var m = motion[slot];
    let s = shapes[m.shape.x];
    let dx = impulse * s.inv_mass.x;
    let dtheta = s.inv_inertia_x.xyz * moment.x + s.inv_inertia_y.xyz * moment.y
        + s.inv_inertia_z.xyz * moment.z;
    m.dx = vec4<f32>(m.dx.xyz + dx, 0.0);
    m.dq = turned(m.dq, dtheta);
    m.dv = vec4<f32>(m.dv.xyz + dx / params.substep, 0.0);
    m.dw = vec4<f32>(m.dw.xyz + dtheta / params.substep, 0.0);
    motion[slot] = m;
}

// Each movable body moved by what the substep's contacts pushed it with
// (summed by `reduce_chunks` and `reduce_bodies`; `Coupling::take_pushes`).
@compute @workgroup_size(64)
fn take_pushes(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = linear(id, groups);
    if (b >= params.movable) {
        return;
    }
    let total = partials[params.chunks * params.movable + b];
    let impulse = total.impulse.xyz;
    let moment = total.moment.xyz;
    if (all(impulse == vec3<f32>(0.0)) && all(moment == vec3<f32>(0.0))) {
        return;
    }
    shift(b, impulse, moment);
}
