//! Stepping one CPU particle system: the interaction-force pass and the
//! integration kernels of every [`Integrator`].
//!
//! Single-evaluation methods (forward and symplectic Euler) run *fused*: one
//! pass reads each particle once, adds its field forces to the precomputed
//! interaction force, integrates and checks the result is finite; kinetic
//! and gravitational energy are then summed over the chunk while it is still
//! in cache. That pass is what the memory-bandwidth target in
//! `inertia-bench particles` measures.
//! Multi-stage methods evaluate accelerations into a buffer per stage.
//!
//! A particle whose new position or velocity is not finite is quarantined:
//! its last finite position is kept, its velocity zeroed, and it is flagged
//! so that no force reads it again (springs to it go slack, it drops out of
//! mutual gravity). Neighbours only ever saw its finite values.

use glam::DVec3;

use crate::forces::barnes_hut::Octree;
use crate::forces::mutual_gravity::exact_forces;
use crate::forces::{FieldForces, Force, GravityMethod, MutualGravity, PerParticle};
use crate::integrator::Integrator;
use crate::parallel::{par_map_chunks, par_map_chunks3, par_map_chunks4, CHUNK};
use crate::particle_system::{ParticleSystem, FLAG_QUARANTINED};
use crate::spring::SpringTopology;

/// Transient flag: quarantined during the current step (cleared when reported).
pub(crate) const FLAG_NEW_QUARANTINE: u32 = 4;

/// What one chunk of an integration pass reports.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct ChunkOut {
    pub(crate) kinetic: f64,
    pub(crate) gravity: f64,
    pub(crate) quarantined: u32,
}

impl ChunkOut {
    /// Adds chunk results in chunk order. `commit` accumulates `m v²`; the
    /// ½ is applied here, once.
    fn sum(parts: &[ChunkOut]) -> ChunkOut {
        let total = parts.iter().fold(ChunkOut::default(), |a, b| ChunkOut {
            kinetic: a.kinetic + b.kinetic,
            gravity: a.gravity + b.gravity,
            quarantined: a.quarantined + b.quarantined,
        });
        ChunkOut {
            kinetic: 0.5 * total.kinetic,
            ..total
        }
    }
}

/// Scratch buffers a system reuses from step to step; not part of the state.
#[derive(Debug, Default, Clone)]
pub(crate) struct Scratch {
    force: Vec<DVec3>,
    acc: Vec<DVec3>,
    x1: Vec<DVec3>,
    v1: Vec<DVec3>,
    sx: Vec<DVec3>,
    sv: Vec<DVec3>,
    mass: Vec<f64>,
}

/// Wall time spent per stage, s (profiling only; never read by the simulation).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct StageTimes {
    pub(crate) forces: f64,
    pub(crate) integrate: f64,
}

/// Interaction forces (springs, mutual gravity) of a system, evaluated at
/// arbitrary stage states.
struct Interactions<'a> {
    topology: &'a mut SpringTopology,
    gravity: Vec<MutualGravity>,
    inv_mass: &'a [f64],
}

impl Interactions<'_> {
    fn any(&self) -> bool {
        !self.topology.is_empty() || !self.gravity.is_empty()
    }

    /// Overwrites `out` with the interaction force on each particle, N.
    fn eval(
        &mut self,
        x: &[DVec3],
        v: &[DVec3],
        flags: &[u32],
        mass: &mut Vec<f64>,
        out: &mut [DVec3],
    ) {
        out.fill(DVec3::ZERO);
        if !self.topology.is_empty() {
            self.topology.accumulate(x, v, flags, FLAG_QUARANTINED, out);
        }
        if !self.gravity.is_empty() {
            fill_masses(self.inv_mass, flags, mass);
            for g in &self.gravity {
                let eps2 = g.softening * g.softening;
                match g.method {
                    GravityMethod::Exact => exact_forces(x, mass, g.g_constant, eps2, out),
                    GravityMethod::BarnesHut { theta } => {
                        Octree::build(x, mass).forces(x, mass, g.g_constant, eps2, theta, out)
                    }
                }
            }
        }
    }
}

/// Masses for mutual gravity: quarantined particles get 0 (take no part).
pub(crate) fn fill_masses(inv_mass: &[f64], flags: &[u32], mass: &mut Vec<f64>) {
    mass.clear();
    mass.extend(inv_mass.iter().zip(flags).map(|(&im, &f)| {
        if f & FLAG_QUARANTINED != 0 {
            0.0
        } else {
            1.0 / im
        }
    }));
}

/// Advances `sys` by `dt` from time `t`. Returns the energy partials and how
/// many particles were quarantined; those carry `FLAG_NEW_QUARANTINE`.
pub(crate) fn step_system(
    sys: &mut ParticleSystem,
    scratch: &mut Scratch,
    t: f64,
    dt: f64,
) -> (ChunkOut, StageTimes) {
    let mut times = StageTimes::default();
    sys.refresh_topology();
    let field = FieldForces::compile(sys, t, dt);
    let n = sys.position.len();
    let ParticleSystem {
        integrator,
        position,
        velocity,
        prev_position,
        inv_mass,
        drag_linear,
        drag_quadratic,
        area,
        volume,
        flags,
        group,
        control,
        control_active,
        group_control,
        forces,
        topology,
        verlet_dt,
        ..
    } = sys;
    let gravity: Vec<MutualGravity> = forces
        .iter()
        .filter_map(|(_, _, e)| match e.force {
            Force::MutualGravity(g) => Some(g),
            _ => None,
        })
        .collect();
    let props = PerParticle {
        inv_mass,
        drag_linear,
        drag_quadratic,
        area,
        volume,
        group,
        control: control_active.then_some(control.as_slice()),
        group_control: (!group_control.is_empty()).then_some(group_control.as_slice()),
    };
    let mut inter = Interactions {
        topology,
        gravity,
        inv_mass,
    };
    let has_inter = inter.any();
    scratch.force.resize(n, DVec3::ZERO);

    let out = match *integrator {
        Integrator::ForwardEuler | Integrator::SymplecticEuler => {
            if has_inter {
                let t0 = std::time::Instant::now();
                inter.eval(
                    position,
                    velocity,
                    flags,
                    &mut scratch.mass,
                    &mut scratch.force,
                );
                times.forces += t0.elapsed().as_secs_f64();
            }
            let t0 = std::time::Instant::now();
            let ext = has_inter.then_some(scratch.force.as_slice());
            let parts = if *integrator == Integrator::SymplecticEuler {
                euler_pass::<true>(position, velocity, flags, &props, &field, ext, dt)
            } else {
                euler_pass::<false>(position, velocity, flags, &props, &field, ext, dt)
            };
            times.integrate += t0.elapsed().as_secs_f64();
            ChunkOut::sum(&parts)
        }
        Integrator::Leapfrog => {
            let mut ev = Evaluator {
                inter: &mut inter,
                props: &props,
                field: &field,
                times: &mut times,
            };
            scratch.acc.resize(n, DVec3::ZERO);
            ev.accel(
                position,
                velocity,
                &mut scratch.force,
                &mut scratch.mass,
                flags,
                &mut scratch.acc,
            );
            let t0 = std::time::Instant::now();
            let acc = &scratch.acc;
            let q1 = par_map_chunks3(position, velocity, flags, CHUNK, |base, xs, vs, fs| {
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
            });
            ev.times.integrate += t0.elapsed().as_secs_f64();
            ev.accel(
                position,
                velocity,
                &mut scratch.force,
                &mut scratch.mass,
                flags,
                &mut scratch.acc,
            );
            let t0 = std::time::Instant::now();
            let acc = &scratch.acc;
            let parts = par_map_chunks3(position, velocity, flags, CHUNK, |base, xs, vs, fs| {
                let mut o = ChunkOut::default();
                for k in 0..xs.len() {
                    let i = base + k;
                    let nv = if fs[k] == 0 {
                        vs[k] + acc[i] * (0.5 * dt)
                    } else {
                        vs[k]
                    };
                    commit(k, i, xs[k], nv, xs, vs, fs, props.inv_mass, &field, &mut o);
                }
                o
            });
            times.integrate += t0.elapsed().as_secs_f64();
            let mut o = ChunkOut::sum(&parts);
            o.quarantined += q1.iter().sum::<u32>();
            o
        }
        Integrator::Verlet => {
            if prev_position.len() != n {
                prev_position.resize(n, DVec3::ZERO);
                *verlet_dt = 0.0;
            }
            let mut ev = Evaluator {
                inter: &mut inter,
                props: &props,
                field: &field,
                times: &mut times,
            };
            scratch.acc.resize(n, DVec3::ZERO);
            ev.accel(
                position,
                velocity,
                &mut scratch.force,
                &mut scratch.mass,
                flags,
                &mut scratch.acc,
            );
            let t0 = std::time::Instant::now();
            let acc = &scratch.acc;
            let prime = *verlet_dt != dt;
            // Positions: x' = 2x - x_prev + a dt².
            let q = par_map_chunks4(
                position,
                velocity,
                flags,
                prev_position,
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
                        // Provisional velocity for velocity-dependent forces in
                        // the evaluation below.
                        let nv = (nx - x) / dt + a * (0.5 * dt);
                        if !(nx.is_finite() && nv.is_finite()) {
                            quarantine(&mut fs[k], &mut vs[k]);
                            ps[k] = x;
                            q += 1;
                            continue;
                        }
                        ps[k] = x;
                        xs[k] = nx;
                        vs[k] = nv;
                    }
                    q
                },
            );
            *verlet_dt = dt;
            times.integrate += t0.elapsed().as_secs_f64();
            // Velocities: v' = (x' - x)/dt + ½ a(x') dt, second order and
            // matching the positions, so the reported energy is that of a
            // consistent state.
            let mut ev = Evaluator {
                inter: &mut inter,
                props: &props,
                field: &field,
                times: &mut times,
            };
            ev.accel(
                position,
                velocity,
                &mut scratch.force,
                &mut scratch.mass,
                flags,
                &mut scratch.acc,
            );
            let t0 = std::time::Instant::now();
            let acc = &scratch.acc;
            let parts = par_map_chunks4(
                position,
                velocity,
                flags,
                prev_position,
                CHUNK,
                |base, xs, vs, fs, ps| {
                    let mut o = ChunkOut::default();
                    for k in 0..xs.len() {
                        let i = base + k;
                        let nv = if fs[k] == 0 {
                            (xs[k] - ps[k]) / dt + acc[i] * (0.5 * dt)
                        } else {
                            vs[k]
                        };
                        commit(k, i, xs[k], nv, xs, vs, fs, props.inv_mass, &field, &mut o);
                    }
                    o
                },
            );
            times.integrate += t0.elapsed().as_secs_f64();
            let mut o = ChunkOut::sum(&parts);
            o.quarantined += q.iter().sum::<u32>();
            o
        }
        Integrator::Rk4 => {
            for b in [
                &mut scratch.acc,
                &mut scratch.x1,
                &mut scratch.v1,
                &mut scratch.sx,
                &mut scratch.sv,
            ] {
                b.resize(n, DVec3::ZERO);
            }
            let Scratch {
                force,
                acc,
                x1,
                v1,
                sx,
                sv,
                mass,
            } = scratch;
            let mut ev = Evaluator {
                inter: &mut inter,
                props: &props,
                field: &field,
                times: &mut times,
            };
            let (x, v) = (&*position, &*velocity);
            let mut q = 0u32;
            // Stage 1.
            ev.accel(x, v, force, mass, flags, acc);
            let t0 = std::time::Instant::now();
            q += rk4_stage(x, v, acc, x1, v1, sx, sv, flags, 0.5 * dt, 1.0, true);
            ev.times.integrate += t0.elapsed().as_secs_f64();
            // Stages 2 and 3.
            for h in [0.5 * dt, dt] {
                ev.accel(x1, v1, force, mass, flags, acc);
                let t0 = std::time::Instant::now();
                q += rk4_stage(x, v, acc, x1, v1, sx, sv, flags, h, 2.0, false);
                ev.times.integrate += t0.elapsed().as_secs_f64();
            }
            // Stage 4 and the update.
            ev.accel(x1, v1, force, mass, flags, acc);
            let t0 = std::time::Instant::now();
            let (acc, v1, sx, sv) = (&*acc, &*v1, &*sx, &*sv);
            let parts = par_map_chunks3(position, velocity, flags, CHUNK, |base, xs, vs, fs| {
                let mut o = ChunkOut::default();
                for k in 0..xs.len() {
                    let i = base + k;
                    if fs[k] != 0 {
                        commit(
                            k,
                            i,
                            xs[k],
                            vs[k],
                            xs,
                            vs,
                            fs,
                            props.inv_mass,
                            &field,
                            &mut o,
                        );
                        continue;
                    }
                    let nx = xs[k] + (sx[i] + v1[i]) * (dt / 6.0);
                    let nv = vs[k] + (sv[i] + acc[i]) * (dt / 6.0);
                    commit(k, i, nx, nv, xs, vs, fs, props.inv_mass, &field, &mut o);
                }
                o
            });
            times.integrate += t0.elapsed().as_secs_f64();
            let mut o = ChunkOut::sum(&parts);
            o.quarantined += q;
            o
        }
    };
    (out, times)
}

/// Stores a candidate `(nx, nv)` for particle `k` of the chunk (dense `i`),
/// or quarantines it if not finite, and adds its energy.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn commit(
    k: usize,
    i: usize,
    nx: DVec3,
    nv: DVec3,
    xs: &mut [DVec3],
    vs: &mut [DVec3],
    fs: &mut [u32],
    inv_mass: &[f64],
    field: &FieldForces,
    o: &mut ChunkOut,
) {
    // One add chain decides the common case: the sum of finite numbers is
    // finite unless it overflows, and any NaN or infinity poisons it.
    let sum = nx.x + nx.y + nx.z + nv.x + nv.y + nv.z;
    if sum.is_finite() || (nx.is_finite() && nv.is_finite()) {
        xs[k] = nx;
        vs[k] = nv;
    } else {
        quarantine(&mut fs[k], &mut vs[k]);
        o.quarantined += 1;
    }
    let m = 1.0 / inv_mass[i];
    o.kinetic += m * vs[k].length_squared();
    o.gravity -= m * field.gravity.dot(xs[k]);
}

#[inline]
fn quarantine(flag: &mut u32, v: &mut DVec3) {
    *flag |= FLAG_QUARANTINED | FLAG_NEW_QUARANTINE;
    *v = DVec3::ZERO;
}

/// The fused forward / symplectic Euler pass.
fn euler_pass<const SYMPLECTIC: bool>(
    position: &mut [DVec3],
    velocity: &mut [DVec3],
    flags: &mut [u32],
    props: &PerParticle<'_>,
    field: &FieldForces,
    interaction: Option<&[DVec3]>,
    dt: f64,
) -> Vec<ChunkOut> {
    par_map_chunks3(position, velocity, flags, CHUNK, |base, xs, vs, fs| {
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
        // Energy in a second, branch-free sweep while the chunk is still in
        // cache: four independent partial sums, so it vectorises and the add
        // chains overlap (the summation order is fixed, hence deterministic).
        let (kinetic, gravity) = chunk_energy(xs, vs, props.inv_mass, field.gravity);
        ChunkOut {
            kinetic,
            gravity,
            quarantined,
        }
    })
}

/// Stores `(nx, nv)` for particle `k`, or quarantines it if not finite.
/// Returns whether it was quarantined.
#[inline(always)]
fn store_if_finite(
    k: usize,
    nx: DVec3,
    nv: DVec3,
    xs: &mut [DVec3],
    vs: &mut [DVec3],
    fs: &mut [u32],
) -> bool {
    // One add chain decides the common case: the sum of finite numbers is
    // finite unless it overflows, and any NaN or infinity poisons it.
    let sum = nx.x + nx.y + nx.z + nv.x + nv.y + nv.z;
    if sum.is_finite() || (nx.is_finite() && nv.is_finite()) {
        xs[k] = nx;
        vs[k] = nv;
        false
    } else {
        quarantine(&mut fs[k], &mut vs[k]);
        true
    }
}

/// `(Σ m v², -Σ m (g · x))` over a chunk (the ½ is applied by
/// [`ChunkOut::sum`]), in four interleaved partial sums.
fn chunk_energy(xs: &[DVec3], vs: &[DVec3], inv_mass: &[f64], g: DVec3) -> (f64, f64) {
    let mut ke = [0.0f64; 4];
    let mut pe = [0.0f64; 4];
    let n4 = xs.len() / 4 * 4;
    for b in (0..n4).step_by(4) {
        for l in 0..4 {
            let m = 1.0 / inv_mass[b + l];
            ke[l] += m * vs[b + l].length_squared();
            pe[l] -= m * g.dot(xs[b + l]);
        }
    }
    for k in n4..xs.len() {
        let m = 1.0 / inv_mass[k];
        ke[0] += m * vs[k].length_squared();
        pe[0] -= m * g.dot(xs[k]);
    }
    (
        (ke[0] + ke[1]) + (ke[2] + ke[3]),
        (pe[0] + pe[1]) + (pe[2] + pe[3]),
    )
}

/// One RK4 stage update: accumulate `weight * (v1, acc)` into `(sx, sv)` and
/// set the next stage state `x1 = x + v_stage h`, `v1 = v + acc h`.
#[allow(clippy::too_many_arguments)]
fn rk4_stage(
    x: &[DVec3],
    v: &[DVec3],
    acc: &[DVec3],
    x1: &mut [DVec3],
    v1: &mut [DVec3],
    sx: &mut [DVec3],
    sv: &mut [DVec3],
    flags: &mut [u32],
    h: f64,
    weight: f64,
    first: bool,
) -> u32 {
    let parts = par_map_chunks4(x1, v1, sx, sv, CHUNK, |base, x1, v1, sx, sv| {
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
    });
    drop(parts);
    // A stage value that is not finite would poison neighbours in the next
    // evaluation: quarantine the particle now and pin its stage state.
    let mut q = 0;
    for i in 0..x.len() {
        if flags[i] == 0
            && !(x1[i].is_finite() && v1[i].is_finite() && sx[i].is_finite() && sv[i].is_finite())
        {
            flags[i] |= FLAG_QUARANTINED | FLAG_NEW_QUARANTINE;
            x1[i] = x[i];
            v1[i] = DVec3::ZERO;
            q += 1;
        }
    }
    q
}

/// Evaluates accelerations for multi-stage integrators.
struct Evaluator<'a, 'b> {
    inter: &'a mut Interactions<'b>,
    props: &'a PerParticle<'a>,
    field: &'a FieldForces,
    times: &'a mut StageTimes,
}

impl Evaluator<'_, '_> {
    /// `acc[i] = (interaction + field force) / m + g`, zero for flagged particles.
    fn accel(
        &mut self,
        x: &[DVec3],
        v: &[DVec3],
        force: &mut Vec<DVec3>,
        mass: &mut Vec<f64>,
        flags: &[u32],
        acc: &mut [DVec3],
    ) {
        let t0 = std::time::Instant::now();
        let has_inter = self.inter.any();
        if has_inter {
            self.inter.eval(x, v, flags, mass, force);
        }
        let (props, field) = (self.props, self.field);
        let force = &*force;
        par_map_chunks(acc, CHUNK, |base, chunk| {
            for (k, a) in chunk.iter_mut().enumerate() {
                let i = base + k;
                *a = if flags[i] != 0 {
                    DVec3::ZERO
                } else {
                    let mut f = field.force(props, i, x[i], v[i]);
                    if has_inter {
                        f += force[i];
                    }
                    f * props.inv_mass[i] + field.gravity
                };
            }
        });
        self.times.forces += t0.elapsed().as_secs_f64();
    }
}
