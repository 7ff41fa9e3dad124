//! Forward and symplectic Euler: one force evaluation, one fused pass.
//!
//! The pass takes particles four at a time when the system's field forces
//! are the common ones (gravity, drag, wind, scripted control): each
//! quantity is held as four lanes, so the compiler emits packed arithmetic
//! instead of one scalar operation per vector component. The lanes perform
//! exactly the operations of the scalar path in the same order, so both give
//! the same bits; buoyancy and explosions, flagged particles and the tail of
//! a chunk take the scalar path.

use glam::DVec3;

use super::{chunk_energy, store_if_finite, ChunkOut, Evaluator, State};
use crate::forces::{FieldForces, PerParticle};
use crate::parallel::{par_map_chunks3, CHUNK};

/// One step; `SYMPLECTIC` picks the velocity-first update.
pub(super) fn step<const SYMPLECTIC: bool>(
    state: &mut State<'_>,
    ev: &mut Evaluator<'_>,
    dt: f64,
) -> ChunkOut {
    let has_inter = ev.interactions(state.position, state.velocity, state.flags);
    let t0 = std::time::Instant::now();
    let (props, field) = (&ev.props, &ev.field);
    let interaction = has_inter.then_some(ev.buf.force.as_slice());
    let lanes = field.buoyancy.is_empty() && field.explosions.is_empty();
    let parts = par_map_chunks3(
        state.position,
        state.velocity,
        state.flags,
        CHUNK,
        |base, xs, vs, fs| {
            // Chunk-local views: the loop indexes them from 0 without bounds surprises.
            let props = props.chunk(base, xs.len());
            let interaction = interaction.map(|e| &e[base..base + xs.len()]);
            let mut quarantined = 0;
            let mut k = 0;
            while k < xs.len() {
                if lanes && k + 4 <= xs.len() && fs[k..k + 4] == [0; 4] {
                    quarantined +=
                        four::<SYMPLECTIC>(k, xs, vs, fs, &props, field, interaction, dt);
                    k += 4;
                    continue;
                }
                if fs[k] == 0 {
                    let (x, v) = (xs[k], vs[k]);
                    let mut f = field.force(&props, k, x, v);
                    if let Some(ext) = interaction {
                        f += ext[k];
                    }
                    let (nx, nv) =
                        integrate::<SYMPLECTIC>(x, v, f * props.inv_mass[k] + field.gravity, dt);
                    quarantined += u32::from(store_if_finite(k, nx, nv, xs, vs, fs));
                }
                k += 1;
            }
            // Energy in a second, branch-free sweep while the chunk is in cache.
            let (kinetic, gravity) = chunk_energy(xs, vs, props.inv_mass, field.gravity);
            ChunkOut {
                kinetic,
                gravity,
                quarantined,
            }
        },
    );
    ev.times.integrate += t0.elapsed().as_secs_f64();
    ChunkOut::sum(&parts)
}

#[inline(always)]
fn integrate<const SYMPLECTIC: bool>(x: DVec3, v: DVec3, a: DVec3, dt: f64) -> (DVec3, DVec3) {
    if SYMPLECTIC {
        let nv = v + a * dt;
        (x + nv * dt, nv)
    } else {
        (x + v * dt, v + a * dt)
    }
}

/// Four lanes of one quantity per vector component.
type Lanes = [[f64; 4]; 3];

/// Particles `k..k + 4` (all unflagged), lane-wise, mirroring
/// [`FieldForces::force`] and [`integrate`] operation for operation.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn four<const SYMPLECTIC: bool>(
    k: usize,
    xs: &mut [DVec3],
    vs: &mut [DVec3],
    fs: &mut [u32],
    props: &PerParticle<'_>,
    field: &FieldForces,
    interaction: Option<&[DVec3]>,
    dt: f64,
) -> u32 {
    let load = |a: &[DVec3]| -> Lanes {
        let mut o = [[0.0; 4]; 3];
        for l in 0..4 {
            let p = a[k + l];
            o[0][l] = p.x;
            o[1][l] = p.y;
            o[2][l] = p.z;
        }
        o
    };
    let (x, v) = (load(xs), load(vs));
    let mut f: Lanes = [[0.0; 4]; 3];
    if let Some(d) = &field.drag {
        for l in 0..4 {
            let speed = (v[0][l] * v[0][l] + v[1][l] * v[1][l] + v[2][l] * v[2][l]).sqrt();
            let c = -(d.linear_scale * props.drag_linear[k + l]
                + d.quadratic_scale * props.drag_quadratic[k + l] * speed);
            for (fc, vc) in f.iter_mut().zip(&v) {
                fc[l] += c * vc[l];
            }
        }
    }
    for w in &field.winds {
        let dir = w.dir.to_array();
        for l in 0..4 {
            let along = v[0][l] * dir[0] + v[1][l] * dir[1] + v[2][l] * dir[2];
            let s = (w.speed - along).max(0.0);
            let m = w.half_rho_c * s * s * props.area[k + l];
            for c in 0..3 {
                f[c][l] += m * dir[c];
            }
        }
    }
    let mut add = |g: DVec3, l: usize| {
        f[0][l] += g.x;
        f[1][l] += g.y;
        f[2][l] += g.z;
    };
    for l in 0..4 {
        if let Some(c) = props.control {
            add(c[k + l], l);
        }
        if let Some(g) = props.group_control {
            if let Some(gf) = g.get(props.group[k + l] as usize) {
                add(*gf, l);
            }
        }
        if let Some(ext) = interaction {
            add(ext[k + l], l);
        }
    }
    let g = field.gravity.to_array();
    let im: [f64; 4] = std::array::from_fn(|l| props.inv_mass[k + l]);
    let (mut nx, mut nv): (Lanes, Lanes) = ([[0.0; 4]; 3], [[0.0; 4]; 3]);
    let mut sum = 0.0;
    for c in 0..3 {
        for l in 0..4 {
            let a = f[c][l] * im[l] + g[c];
            if SYMPLECTIC {
                nv[c][l] = v[c][l] + a * dt;
                nx[c][l] = x[c][l] + nv[c][l] * dt;
            } else {
                nx[c][l] = x[c][l] + v[c][l] * dt;
                nv[c][l] = v[c][l] + a * dt;
            }
            sum += nx[c][l] + nv[c][l];
        }
    }
    let lane = |q: &Lanes, l: usize| DVec3::new(q[0][l], q[1][l], q[2][l]);
    if sum.is_finite() {
        // Every lane is finite (see `store_if_finite`).
        for l in 0..4 {
            xs[k + l] = lane(&nx, l);
            vs[k + l] = lane(&nv, l);
        }
        return 0;
    }
    let mut quarantined = 0;
    for l in 0..4 {
        quarantined += u32::from(store_if_finite(
            k + l,
            lane(&nx, l),
            lane(&nv, l),
            xs,
            vs,
            fs,
        ));
    }
    quarantined
}
