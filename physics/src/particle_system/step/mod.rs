//! Stepping one CPU particle system.
//!
//! [`step_system`] splits the system into the *state* the integrator writes
//! (positions, velocities, flags, Verlet history) and an [`Evaluator`] that
//! computes accelerations from any stage state: interaction forces
//! (springs, mutual gravity) into a buffer, then field forces per particle.
//! Each integrator is one file in this folder.
//!
//! Single-evaluation methods (forward and symplectic Euler) run *fused*: one
//! pass reads each particle once, adds its field forces to the precomputed
//! interaction force, integrates and checks the result is finite; kinetic
//! and gravitational energy are then summed over the chunk while it is still
//! in cache. That pass is what the memory-bandwidth target in
//! `inertia-bench particles` measures. Multi-stage methods evaluate
//! accelerations into a buffer per stage.
//!
//! A particle whose new position or velocity is not finite is quarantined:
//! its last finite position is kept, its velocity zeroed, and it is flagged
//! so that no force reads it again (springs to it go slack, it drops out of
//! mutual gravity). Neighbours only ever saw its finite values.

mod euler;
mod leapfrog;
mod rk4;
mod verlet;

use std::time::Instant;

use glam::DVec3;

use crate::forces::barnes_hut::Octree;
use crate::forces::mutual_gravity::exact_forces;
use crate::forces::{FieldForces, Force, GravityMethod, MutualGravity, PerParticle};
use crate::integrator::Integrator;
use crate::parallel::{par_map_chunks, CHUNK};
use crate::particle_system::{ParticleSystem, FLAG_QUARANTINED};
use crate::spring::SpringTopology;

/// Transient flag: quarantined during the current step (cleared when reported).
pub(crate) const FLAG_NEW_QUARANTINE: u32 = 4;

/// What an integration pass reports, per chunk and in total.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct ChunkOut {
    /// Kinetic energy, J (per chunk: `Σ m v²`, halved by [`ChunkOut::sum`]).
    pub(crate) kinetic: f64,
    /// Uniform-gravity potential energy, J.
    pub(crate) gravity: f64,
    /// Particles quarantined.
    pub(crate) quarantined: u32,
}

impl ChunkOut {
    /// Adds chunk results in chunk order; applies the ½ of the kinetic energy once.
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

/// Buffers a system reuses from step to step; not part of the state.
#[derive(Debug, Default, Clone)]
pub(crate) struct Scratch {
    eval: EvalBuffers,
    rk4: rk4::Rk4Buffers,
}

/// Wall time spent per stage, s (profiling only; never read by the simulation).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct StageTimes {
    pub(crate) forces: f64,
    pub(crate) integrate: f64,
}

/// What an integrator writes.
pub(crate) struct State<'a> {
    pub(crate) position: &'a mut [DVec3],
    pub(crate) velocity: &'a mut [DVec3],
    pub(crate) flags: &'a mut [u32],
    /// Verlet only: previous positions, and the `dt` they were taken at.
    pub(crate) prev_position: &'a mut Vec<DVec3>,
    pub(crate) verlet_dt: &'a mut f64,
}

/// Advances `sys` by `dt` from time `t` under the world's `gravity`
/// (m/s²). Returns the energy of the new state and how many particles were
/// quarantined (they carry `FLAG_NEW_QUARANTINE`).
pub(crate) fn step_system(
    sys: &mut ParticleSystem,
    scratch: &mut Scratch,
    gravity: DVec3,
    t: f64,
    dt: f64,
) -> (ChunkOut, StageTimes) {
    sys.refresh_topology();
    let field = sys.field_forces(gravity, t, dt);
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
        coupling,
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
    scratch.eval.resize(n);
    let mut ev = Evaluator {
        inter: Interactions {
            topology,
            gravity,
            coupling,
        },
        props,
        field,
        buf: &mut scratch.eval,
        times: StageTimes::default(),
    };
    let mut state = State {
        position,
        velocity,
        flags,
        prev_position,
        verlet_dt,
    };
    let out = match *integrator {
        Integrator::ForwardEuler => euler::step::<false>(&mut state, &mut ev, dt),
        Integrator::SymplecticEuler => euler::step::<true>(&mut state, &mut ev, dt),
        Integrator::Leapfrog => leapfrog::step(&mut state, &mut ev, dt),
        Integrator::Verlet => verlet::step(&mut state, &mut ev, dt),
        Integrator::Rk4 => rk4::step(&mut state, &mut ev, &mut scratch.rk4, dt),
    };
    (out, ev.times)
}

/// Interaction forces (springs, mutual gravity) of a system.
struct Interactions<'a> {
    topology: &'a mut SpringTopology,
    gravity: Vec<MutualGravity>,
    /// Attachment forces to rigid bodies: (dense index, N).
    coupling: &'a [(u32, DVec3)],
}

impl Interactions<'_> {
    fn any(&self) -> bool {
        !self.topology.is_empty() || !self.gravity.is_empty() || !self.coupling.is_empty()
    }
}

/// Buffers of the acceleration evaluation.
#[derive(Debug, Default, Clone)]
struct EvalBuffers {
    /// Interaction force per particle, N.
    force: Vec<DVec3>,
    /// Acceleration per particle, m/s² (multi-stage methods).
    acc: Vec<DVec3>,
    /// Mass per particle for mutual gravity, kg (0 = takes no part).
    mass: Vec<f64>,
}

impl EvalBuffers {
    fn resize(&mut self, n: usize) {
        self.force.resize(n, DVec3::ZERO);
        self.acc.resize(n, DVec3::ZERO);
    }
}

/// Evaluates forces and accelerations at any stage state.
pub(crate) struct Evaluator<'a> {
    inter: Interactions<'a>,
    props: PerParticle<'a>,
    field: FieldForces,
    buf: &'a mut EvalBuffers,
    times: StageTimes,
}

impl Evaluator<'_> {
    /// Overwrites the interaction-force buffer for state `(x, v)`; returns
    /// whether the system has any interaction forces at all.
    fn interactions(&mut self, x: &[DVec3], v: &[DVec3], flags: &[u32]) -> bool {
        if !self.inter.any() {
            return false;
        }
        let t0 = Instant::now();
        let out = &mut self.buf.force;
        out.fill(DVec3::ZERO);
        if !self.inter.topology.is_empty() {
            self.inter
                .topology
                .accumulate(x, v, flags, FLAG_QUARANTINED, out);
        }
        if !self.inter.gravity.is_empty() {
            let mass = &mut self.buf.mass;
            fill_masses(self.props.inv_mass, flags, mass);
            for g in &self.inter.gravity {
                let eps2 = g.softening * g.softening;
                match g.method {
                    GravityMethod::Exact => exact_forces(x, mass, g.g_constant, eps2, out),
                    GravityMethod::BarnesHut { theta } => {
                        Octree::build(x, mass).forces(x, mass, g.g_constant, eps2, theta, out)
                    }
                }
            }
        }
        for &(i, f) in self.inter.coupling {
            if flags[i as usize] & FLAG_QUARANTINED == 0 {
                out[i as usize] += f;
            }
        }
        self.times.forces += t0.elapsed().as_secs_f64();
        true
    }

    /// Fills `self.buf.acc` with `(interaction + field force) / m + g` at
    /// state `(x, v)`; zero for pinned and quarantined particles.
    fn accel(&mut self, x: &[DVec3], v: &[DVec3], flags: &[u32]) {
        let has_inter = self.interactions(x, v, flags);
        let t0 = Instant::now();
        let (props, field, force) = (&self.props, &self.field, &self.buf.force);
        par_map_chunks(&mut self.buf.acc, CHUNK, |base, chunk| {
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

    /// The accelerations of the last [`Evaluator::accel`].
    fn acc(&self) -> &[DVec3] {
        &self.buf.acc
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

#[inline]
fn quarantine(flag: &mut u32, v: &mut DVec3) {
    *flag |= FLAG_QUARANTINED | FLAG_NEW_QUARANTINE;
    *v = DVec3::ZERO;
}

/// `(Σ m v², -Σ m (g · x))` over a chunk (the ½ is applied by
/// [`ChunkOut::sum`]), in four interleaved partial sums so the sweep
/// vectorises and the add chains overlap; the order is fixed, so the result
/// is deterministic.
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

/// The final pass every multi-stage method ends with: per chunk, let
/// `update(i, x, v, flags)` give the new `(x, v)` of each unflagged particle,
/// store it (or quarantine), and sum the energy.
fn finish<F>(state: &mut State<'_>, inv_mass: &[f64], gravity: DVec3, update: F) -> ChunkOut
where
    F: Fn(usize, DVec3, DVec3) -> (DVec3, DVec3) + Sync + Send,
{
    let parts = crate::parallel::par_map_chunks3(
        state.position,
        state.velocity,
        state.flags,
        CHUNK,
        |base, xs, vs, fs| {
            let mut quarantined = 0;
            for k in 0..xs.len() {
                if fs[k] != 0 {
                    continue;
                }
                let (nx, nv) = update(base + k, xs[k], vs[k]);
                if store_if_finite(k, nx, nv, xs, vs, fs) {
                    quarantined += 1;
                }
            }
            let (kinetic, gravity) =
                chunk_energy(xs, vs, &inv_mass[base..base + xs.len()], gravity);
            ChunkOut {
                kinetic,
                gravity,
                quarantined,
            }
        },
    );
    ChunkOut::sum(&parts)
}
