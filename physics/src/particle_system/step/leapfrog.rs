//! Leapfrog, kick-drift-kick: `v½ = v + a dt/2`, `x' = x + v½ dt`,
//! `v' = v½ + a(x', v½) dt/2`. Two force evaluations per step.

use super::{finish, quarantine, ChunkOut, Evaluator, State};
use crate::parallel::{par_map_chunks3, CHUNK};

pub(super) fn step(state: &mut State<'_>, ev: &mut Evaluator<'_>, dt: f64) -> ChunkOut {
    // Kick and drift.
    ev.accel(state.position, state.velocity, state.flags);
    let t0 = std::time::Instant::now();
    let acc = ev.acc();
    let q = par_map_chunks3(
        state.position,
        state.velocity,
        state.flags,
        CHUNK,
        |base, xs, vs, fs| {
            let mut q = 0;
            for k in 0..xs.len() {
                if fs[k] != 0 {
                    continue;
                }
                let vh = vs[k] + acc[base + k] * (0.5 * dt);
                let nx = xs[k] + vh * dt;
                if !(vh.is_finite() && nx.is_finite()) {
                    quarantine(&mut fs[k], &mut vs[k]);
                    q += 1;
                    continue;
                }
                vs[k] = vh;
                xs[k] = nx;
            }
            q
        },
    );
    ev.times.integrate += t0.elapsed().as_secs_f64();

    // Second kick at the new positions (velocity-dependent forces see v½).
    ev.accel(state.position, state.velocity, state.flags);
    let t0 = std::time::Instant::now();
    let acc = ev.acc();
    let mut out = finish(state, ev.props.inv_mass, ev.field.gravity, |i, x, v| {
        (x, v + acc[i] * (0.5 * dt))
    });
    ev.times.integrate += t0.elapsed().as_secs_f64();
    out.quarantined += q.iter().sum::<u32>();
    out
}
