//! Forward and symplectic Euler: one force evaluation, one fused pass.

use super::{chunk_energy, store_if_finite, ChunkOut, Evaluator, State};
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
            for k in 0..xs.len() {
                if fs[k] != 0 {
                    continue;
                }
                let (x, v) = (xs[k], vs[k]);
                let mut f = field.force(&props, k, x, v);
                if let Some(ext) = interaction {
                    f += ext[k];
                }
                let a = f * props.inv_mass[k] + field.gravity;
                let (nx, nv) = if SYMPLECTIC {
                    let nv = v + a * dt;
                    (x + nv * dt, nv)
                } else {
                    (x + v * dt, v + a * dt)
                };
                if store_if_finite(k, nx, nv, xs, vs, fs) {
                    quarantined += 1;
                }
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
