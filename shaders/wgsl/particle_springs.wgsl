// Particle springs, pass 1 of a GPU particle step: the damped Hooke force of
// every spring, one invocation per spring, written to its own slot of
// `forces` (after the `n` per-particle slots). No particle is written here;
// the interactions pass gathers these per particle over the CSR adjacency,
// so nothing needs atomics and the sum order is fixed.
//
// F_a = -(k (L - L0) + c (v_a - v_b) . n) n,  d = x_a - x_b, L = |d|, n = d / L
// (same formula as physics/src/spring.rs). `k` and `c` are scaled by
// `params.spring_scale` (x: stiffness, y: damping), below 1 only when the
// CPU's substep plan softens a network too stiff for its substep budget.
// Units: m, m/s, N/m, N s/m, N.

const WORKGROUP_SIZE: u32 = 64u;
const MAX_FIELD_FORCES: u32 = 64u;
const MAX_MUTUAL_GRAVITY: u32 = 4u;
const FLAG_QUARANTINED: u32 = 2u;
const MIN_POSITIVE: f32 = 1.17549435e-38;

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

struct Spring {
    a: u32,
    b: u32,
    rest_length: f32,
    stiffness: f32,
    damping: f32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> bodies: array<Body>;
@group(0) @binding(2) var<storage, read> springs: array<Spring>;
@group(0) @binding(3) var<storage, read_write> forces: array<vec4<f32>>;

fn is_finite(x: f32) -> bool {
    // Exponent bits all ones = inf or NaN. Bit test, so no compiler can
    // assume it away under fast-math rules.
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let s = gid.x + gid.y * groups.x * WORKGROUP_SIZE;
    if s >= params.n_springs {
        return;
    }
    let sp = springs[s];
    let a = bodies[sp.a];
    let b = bodies[sp.b];
    var f = vec3<f32>(0.0);
    if ((a.flags | b.flags) & FLAG_QUARANTINED) == 0u {
        let d = a.pos - b.pos;
        let len = length(d);
        // Coincident endpoints: the direction is undefined, exert nothing.
        if len > MIN_POSITIVE && is_finite(len) {
            let n = d / len;
            let k = sp.stiffness * params.spring_scale.x;
            let c = sp.damping * params.spring_scale.y;
            f = -(k * (len - sp.rest_length) + c * dot(a.vel - b.vel, n)) * n;
        }
    }
    forces[params.n + s] = vec4<f32>(f, 0.0);
}
