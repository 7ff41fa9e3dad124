// Particle interactions, pass 2 of a GPU particle step: the total
// interaction force on each particle, one invocation per particle, written
// to `forces[i]` (its own slot; nothing is shared, no atomics):
//
// 1. springs: the per-spring forces of pass 1 (`forces[n + s]`) gathered over
//    the particle's CSR adjacency, in adjacency order (+F for end a, -F for
//    end b), exactly like SpringTopology::accumulate on the CPU;
// 2. exact mutual gravity, tiled: each workgroup walks all particles in
//    tiles of WORKGROUP_SIZE, staging each tile's positions and masses in
//    workgroup memory, and every invocation sums its partners in index
//    order (j = 0, 1, ..., n - 1), the CPU's order:
//    F_i = G m_i sum_j m_j (x_j - x_i) / (|x_j - x_i|^2 + eps^2)^(3/2).
//    Quarantined particles have mass 0 and take no part.
//
// `csr` holds `offsets[0..=n]` followed by the adjacency entries
// `(spring << 1) | is_b`. Units: m, kg, N.

const WORKGROUP_SIZE: u32 = 64u;
const MAX_FIELD_FORCES: u32 = 64u;
const MAX_MUTUAL_GRAVITY: u32 = 4u;
const FLAG_QUARANTINED: u32 = 2u;

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
@group(0) @binding(1) var<storage, read> bodies: array<Body>;
@group(0) @binding(2) var<storage, read> props: array<Props>;
@group(0) @binding(3) var<storage, read> csr: array<u32>;
@group(0) @binding(4) var<storage, read_write> forces: array<vec4<f32>>;

var<workgroup> tile: array<vec4<f32>, WORKGROUP_SIZE>;

// Position (xyz, m) and gravitating mass (w, kg; 0 = takes no part) of particle j.
fn source(j: u32) -> vec4<f32> {
    if j >= params.n {
        return vec4<f32>(0.0);
    }
    let b = bodies[j];
    let m = select(props[j].mass, 0.0, (b.flags & FLAG_QUARANTINED) != 0u);
    return vec4<f32>(b.pos, m);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = (wid.x + wid.y * groups.x) * WORKGROUP_SIZE + lid;
    let live = i < params.n;
    var f = vec3<f32>(0.0);

    if live && params.n_springs > 0u {
        let base = params.n + 1u;
        let end = csr[i + 1u];
        for (var e = csr[i]; e < end; e++) {
            let code = csr[base + e];
            let sf = forces[params.n + (code >> 1u)].xyz;
            f += select(sf, -sf, (code & 1u) != 0u);
        }
    }

    // Every invocation, live or not, takes part in the tile loads and the
    // barriers: the loop bounds come from the uniform buffer, so control
    // flow stays uniform across the workgroup.
    let me = source(i);
    let tiles = (params.n + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE;
    for (var k = 0u; k < params.n_mutual; k++) {
        let g = params.mutual[k];
        var acc = vec3<f32>(0.0);
        for (var t = 0u; t < tiles; t++) {
            tile[lid] = source(t * WORKGROUP_SIZE + lid);
            workgroupBarrier();
            for (var q = 0u; q < WORKGROUP_SIZE; q++) {
                let other = tile[q];
                if other.w != 0.0 && t * WORKGROUP_SIZE + q != i {
                    let d = other.xyz - me.xyz;
                    let r2 = dot(d, d) + g.y;
                    let inv_r = 1.0 / sqrt(r2);
                    acc += (other.w * inv_r * inv_r * inv_r) * d;
                }
            }
            workgroupBarrier();
        }
        if me.w != 0.0 {
            f += (g.x * me.w) * acc;
        }
    }

    if live {
        forces[i] = vec4<f32>(f, 0.0);
    }
}
