//! Classic fourth-order Runge–Kutta on the first-order system `(x, v)`:
//! four force evaluations per step, at `t`, `t + dt/2` (twice) and `t + dt`.

use glam::DVec3;

use super::{finish, ChunkOut, Evaluator, State, FLAG_NEW_QUARANTINE};
use crate::parallel::{par_map_chunks4, CHUNK};
use crate::particle_system::FLAG_QUARANTINED;

/// Stage state and the running weighted sums.
#[derive(Debug, Default, Clone)]
pub(super) struct Rk4Buffers {
    x1: Vec<DVec3>,
    v1: Vec<DVec3>,
    sx: Vec<DVec3>,
    sv: Vec<DVec3>,
}

pub(super) fn step(
    state: &mut State<'_>,
    ev: &mut Evaluator<'_>,
    b: &mut Rk4Buffers,
    dt: f64,
) -> ChunkOut {
    let n = state.position.len();
    for buf in [&mut b.x1, &mut b.v1, &mut b.sx, &mut b.sv] {
        buf.resize(n, DVec3::ZERO);
    }
    let mut q = 0u32;
    // Stage 1 at (x, v); stages 2 and 3 at the half step; stage 4 at the end.
    ev.accel(state.position, state.velocity, state.flags);
    q += stage(state, ev, b, 0.5 * dt, 1.0, true);
    for h in [0.5 * dt, dt] {
        ev.accel(&b.x1, &b.v1, state.flags);
        q += stage(state, ev, b, h, 2.0, false);
    }
    ev.accel(&b.x1, &b.v1, state.flags);
    let t0 = std::time::Instant::now();
    let (acc, v1, sx, sv) = (ev.acc(), &b.v1, &b.sx, &b.sv);
    let mut out = finish(state, ev.props.inv_mass, ev.field.gravity, |i, x, v| {
        (
            x + (sx[i] + v1[i]) * (dt / 6.0),
            v + (sv[i] + acc[i]) * (dt / 6.0),
        )
    });
    ev.times.integrate += t0.elapsed().as_secs_f64();
    out.quarantined += q;
    out
}

/// One stage update: add `weight * (v_stage, acc)` to `(sx, sv)` and set the
/// next stage state `x1 = x + v_stage h`, `v1 = v + acc h`. Returns how many
/// particles it quarantined.
fn stage(
    state: &mut State<'_>,
    ev: &mut Evaluator<'_>,
    b: &mut Rk4Buffers,
    h: f64,
    weight: f64,
    first: bool,
) -> u32 {
    let t0 = std::time::Instant::now();
    let (x, v, acc) = (&*state.position, &*state.velocity, ev.acc());
    par_map_chunks4(
        &mut b.x1,
        &mut b.v1,
        &mut b.sx,
        &mut b.sv,
        CHUNK,
        |base, x1, v1, sx, sv| {
            for k in 0..x1.len() {
                let i = base + k;
                let stage_v = if first { v[i] } else { v1[k] };
                let (dx, dv) = (weight * stage_v, weight * acc[i]);
                if first {
                    sx[k] = dx;
                    sv[k] = dv;
                } else {
                    sx[k] += dx;
                    sv[k] += dv;
                }
                x1[k] = x[i] + stage_v * h;
                v1[k] = v[i] + acc[i] * h;
            }
        },
    );
    // A stage value that is not finite would poison neighbours in the next
    // evaluation: quarantine the particle now and pin its stage state.
    let mut q = 0;
    for i in 0..b.x1.len() {
        let bad = !(b.x1[i].is_finite()
            && b.v1[i].is_finite()
            && b.sx[i].is_finite()
            && b.sv[i].is_finite());
        if state.flags[i] == 0 && bad {
            state.flags[i] |= FLAG_QUARANTINED | FLAG_NEW_QUARANTINE;
            state.velocity[i] = DVec3::ZERO;
            b.x1[i] = state.position[i];
            b.v1[i] = DVec3::ZERO;
            q += 1;
        }
    }
    ev.times.integrate += t0.elapsed().as_secs_f64();
    q
}
