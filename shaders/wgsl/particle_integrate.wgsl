// Particle integration, pass 3 of a GPU particle step: one invocation per
// particle adds its field forces (drag, wind, buoyancy, explosions, control)
// to the interaction force of pass 2, integrates with forward or symplectic
// Euler, and writes back only its own body. The formulas and the order of
// the sum are those of physics/src/forces/*.rs and step.rs:
//
//   f = drag + winds + buoyancies + explosions + control + group control
//       + interaction
//   a = f / m + g
//   forward:    x' = x + v dt,  v' = v + a dt
//   symplectic: v' = v + a dt,  x' = x + v' dt
//
// Pinned and quarantined particles do not move. A particle whose new state
// is not finite is quarantined: it keeps its last finite position, its
// velocity is zeroed, and it is flagged (QUARANTINED | NEW_QUARANTINE) so no
// force reads it again. NEW_QUARANTINE is cleared in the first substep of
// the next world step (the CPU reports and clears it after a readback). Units: m, m/s, kg, N, s.
//
// Field force records in `params.fields`, in this order:
//   winds      [0, n_wind):              a = (dir, speed), b.x = 1/2 rho C
//   buoyancies [n_wind, +n_buoyancy):    a = (up, surface height),
//                                        b = (fluid density, g, fluid drag, -)
//   explosions [.., +n_explosion):       a = (center, t - start time),
//                                        b = (front speed, thickness, peak
//                                        pressure, reference radius),
//                                        c.x = max radius

const WORKGROUP_SIZE: u32 = 64u;
const MAX_FIELD_FORCES: u32 = 64u;
const MAX_MUTUAL_GRAVITY: u32 = 4u;
const FLAG_PINNED: u32 = 1u;
const FLAG_QUARANTINED: u32 = 2u;
const FLAG_NEW_QUARANTINE: u32 = 4u;

// ---- shared layout (identical in every particle_*.wgsl; checked by a test) ----
struct FieldForce {
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
}

struct Params {
    gravity: vec4<f32>,
    spring_scale: vec4<f32>,
    n: u32,
    n_springs: u32,
    symplectic: u32,
    has_interaction: u32,
    dt: f32,
    drag_linear_scale: f32,
    drag_quadratic_scale: f32,
    has_drag: u32,
    n_wind: u32,
    n_buoyancy: u32,
    n_explosion: u32,
    n_mutual: u32,
    particle_control: u32,
    n_groups: u32,
    group_base: u32,
    first_substep: u32,
    mutual: array<vec4<f32>, MAX_MUTUAL_GRAVITY>,
    fields: array<FieldForce, MAX_FIELD_FORCES>,
}

struct Body {
    pos: vec3<f32>,
    flags: u32,
    vel: vec3<f32>,
    pad0: u32,
}
// ---- end of shared layout ----

struct Props {
    inv_mass: f32,
    mass: f32,
    drag_linear: f32,
    drag_quadratic: f32,
    area: f32,
    volume: f32,
    radius: f32,
    group: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> bodies: array<Body>;
@group(0) @binding(2) var<storage, read> props: array<Props>;
@group(0) @binding(3) var<storage, read> control: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> forces: array<vec4<f32>>;

fn is_finite(x: f32) -> bool {
    // Exponent bits all ones = inf or NaN. Bit test, so no compiler can
    // assume it away under fast-math rules.
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite3(v: vec3<f32>) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

// Fraction (0..=1) of a sphere of radius r (m) whose centre is `height` m
// above the surface that lies below it: cap volume / sphere volume.
fn submerged_fraction(height: f32, r: f32) -> f32 {
    let h = clamp(r - height, 0.0, 2.0 * r);
    return h * h * (3.0 * r - h) / (4.0 * r * r * r);
}

fn field_force(p: Props, x: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    var f = vec3<f32>(0.0);
    if params.has_drag != 0u {
        let speed = length(v);
        f += -(params.drag_linear_scale * p.drag_linear
            + params.drag_quadratic_scale * p.drag_quadratic * speed) * v;
    }
    var k = 0u;
    for (; k < params.n_wind; k++) {
        let w = params.fields[k];
        let s = max(w.a.w - dot(v, w.a.xyz), 0.0);
        f += (w.b.x * s * s * p.area) * w.a.xyz;
    }
    let buoyancy_end = params.n_wind + params.n_buoyancy;
    for (; k < buoyancy_end; k++) {
        let b = params.fields[k];
        if p.volume > 0.0 {
            let fraction = submerged_fraction(dot(x, b.a.xyz) - b.a.w, p.radius);
            if fraction > 0.0 {
                f += (b.b.x * p.volume * fraction * b.b.y) * b.a.xyz - (b.b.z * fraction) * v;
            }
        }
    }
    let explosion_end = buoyancy_end + params.n_explosion;
    for (; k < explosion_end; k++) {
        let e = params.fields[k];
        if p.area > 0.0 {
            let d = x - e.a.xyz;
            let r = length(d);
            if r <= e.c.x && r > 0.0 {
                // Overlap of the step [s, s + dt] with the front's passage
                // [r / c, (r + w) / c], times relative to the start time.
                let s = e.a.w;
                let enter = r / e.b.x;
                let leave = (r + e.b.y) / e.b.x;
                let overlap = max(min(leave, s + params.dt) - max(enter, s), 0.0);
                if overlap > 0.0 {
                    let ratio = e.b.w / max(r, e.b.w);
                    let pressure = e.b.z * ratio * ratio;
                    f += (pressure * p.area * overlap / (params.dt * r)) * d;
                }
            }
        }
    }
    return f;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = gid.x + gid.y * groups.x * WORKGROUP_SIZE;
    if i >= params.n {
        return;
    }
    var body = bodies[i];
    var flags = body.flags;
    if params.first_substep != 0u {
        flags &= ~FLAG_NEW_QUARANTINE;
    }
    if (flags & (FLAG_PINNED | FLAG_QUARANTINED)) != 0u {
        // Pinned or quarantined: stays where it is.
        body.flags = flags;
        bodies[i] = body;
        return;
    }
    let p = props[i];
    let x = body.pos;
    let v = body.vel;
    var f = field_force(p, x, v);
    if params.particle_control != 0u {
        f += control[i].xyz;
    }
    if p.group < params.n_groups {
        f += control[params.group_base + p.group].xyz;
    }
    if params.has_interaction != 0u {
        f += forces[i].xyz;
    }
    let a = f * p.inv_mass + params.gravity.xyz;
    let dt = params.dt;
    var nx: vec3<f32>;
    var nv: vec3<f32>;
    if params.symplectic != 0u {
        nv = v + a * dt;
        nx = x + nv * dt;
    } else {
        nx = x + v * dt;
        nv = v + a * dt;
    }
    if is_finite3(nx) && is_finite3(nv) {
        body.pos = nx;
        body.vel = nv;
    } else {
        body.vel = vec3<f32>(0.0);
        body.flags = flags | FLAG_QUARANTINED | FLAG_NEW_QUARANTINE;
    }
    bodies[i] = body;
}
