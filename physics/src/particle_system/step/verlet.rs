//! Position (Störmer) Verlet: `x' = 2x - x_prev + a dt²`, with the previous
//! positions as state. The history is primed from the velocities
//! (`x_prev = x - v dt + ½ a dt²`) on the first step and whenever `dt`
//! changes. The velocity reported is `(x' - x)/dt + ½ a(x') dt`, which needs
//! a second force evaluation at the new positions: with `a(x)` instead, the
//! velocity — and so the energy — would be off by `½ ȧ dt²`.

use glam::DVec3;

use super::{finish, quarantine, ChunkOut, Evaluator, State};
use crate::parallel::{par_map_chunks4, CHUNK};

pub(super) fn step(state: &mut State<'_>, ev: &mut Evaluator<'_>, dt: f64) -> ChunkOut {
    let n = state.position.len();
    if state.prev_position.len() != n {
        state.prev_position.resize(n, DVec3::ZERO);
        *state.verlet_dt = 0.0;
    }
    let prime = *state.verlet_dt != dt;

    // Positions.
    ev.accel(state.position, state.velocity, state.flags);
    let t0 = std::time::Instant::now();
    let acc = ev.acc();
    let q = par_map_chunks4(
        state.position,
        state.velocity,
        state.flags,
        state.prev_position,
        CHUNK,
        |base, xs, vs, fs, ps| {
            let mut q = 0;
            for k in 0..xs.len() {
                let x = xs[k];
                if fs[k] != 0 {
                    ps[k] = x;
                    continue;
                }
                let a = acc[base + k];
                if prime {
                    ps[k] = x - vs[k] * dt + a * (0.5 * dt * dt);
                }
                let nx = 2.0 * x - ps[k] + a * (dt * dt);
                // Provisional velocity for velocity-dependent forces below.
                let nv = (nx - x) / dt + a * (0.5 * dt);
                ps[k] = x;
                if !(nx.is_finite() && nv.is_finite()) {
                    quarantine(&mut fs[k], &mut vs[k]);
                    q += 1;
                    continue;
                }
                xs[k] = nx;
                vs[k] = nv;
            }
            q
        },
    );
    *state.verlet_dt = dt;
    ev.times.integrate += t0.elapsed().as_secs_f64();

    // Velocities, consistent with the new positions.
    ev.accel(state.position, state.velocity, state.flags);
    let t0 = std::time::Instant::now();
    // The history is moved out for the pass (no copy) so `finish` can take the state.
    let prev = std::mem::take(state.prev_position);
    let acc = ev.acc();
    let mut out = finish(state, ev.props.inv_mass, ev.field.gravity, |i, x, _| {
        (x, (x - prev[i]) / dt + acc[i] * (0.5 * dt))
    });
    *state.prev_position = prev;
    ev.times.integrate += t0.elapsed().as_secs_f64();
    out.quarantined += q.iter().sum::<u32>();
    out
}
