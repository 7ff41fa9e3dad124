//! `inertia-bench nbody` (also the `nbody_1e4` case of `particles`): mutual
//! gravity between 10^4 bodies, exact all-pairs against Barnes–Hut.
//!
//! The bodies are a Plummer sphere (scale radius 1, total mass 1, `G = 1`,
//! softening 0.01, truncated at 10 scale radii), drawn from a fixed
//! SplitMix64 seed, at rest.
//!
//! * `ms_per_step`: median wall time of one `World::step` (symplectic Euler,
//!   energy accounting off, so the step is the force evaluation plus one
//!   integration pass) at the given thread count.
//! * `rms_rel_force_error`, `max_rel_force_error`: with `a_i` the exact
//!   acceleration and `b_i` the Barnes–Hut one (both from
//!   `inertia_physics::forces::mutual_gravity::accelerations`), the relative
//!   error is `|b_i - a_i| / |a_i|`; RMS and maximum over all bodies. 0 for
//!   the exact method.
//! * `rms_error_bound`: `inertia_physics::forces::barnes_hut::rms_error_bound(θ)`,
//!   the engine's documented bound, and `within_bound` whether the measured
//!   RMS error is below it.

use std::time::Instant;

use inertia_physics::forces::barnes_hut::rms_error_bound;
use inertia_physics::forces::mutual_gravity::accelerations;
use inertia_physics::glam::DVec3;
use inertia_physics::{
    GravityMethod, Integrator, MutualGravity, ParticleDesc, SystemDesc, World, WorldConfig,
};

use crate::report::{median, note, progress, Measurement, Sink, SplitMix64, Suspended};
use crate::report::{sci, thread_counts};
use crate::{BenchError, Opts};

/// Plummer softening length (scale radius 1).
pub const SOFTENING: f64 = 0.01;
/// Barnes–Hut opening angles measured.
pub const THETAS: [f64; 3] = [0.3, 0.5, 0.7];
/// Time step of the timed steps (irrelevant to the timing), s.
const DT: f64 = 1e-3;

/// `n` positions of a Plummer sphere (scale radius 1), truncated at radius 10.
pub fn plummer(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = SplitMix64(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        // Inverse of the cumulative mass M(r) = r³ / (1 + r²)^{3/2}.
        let u = rng.uniform().max(1e-12);
        let r = 1.0 / (u.powf(-2.0 / 3.0) - 1.0).sqrt();
        if !(r.is_finite() && r < 10.0) {
            continue;
        }
        // A uniform direction.
        let z = rng.range(-1.0, 1.0);
        let phi = rng.range(0.0, std::f64::consts::TAU);
        let s = (1.0 - z * z).sqrt();
        out.push(r * DVec3::new(s * phi.cos(), s * phi.sin(), z));
    }
    out
}

fn gravity(method: GravityMethod) -> MutualGravity {
    MutualGravity {
        g_constant: 1.0,
        softening: SOFTENING,
        method,
    }
}

/// RMS and maximum relative error of `b` against `a`.
pub fn relative_errors(a: &[DVec3], b: &[DVec3]) -> (f64, f64) {
    let (mut sum2, mut max) = (0.0f64, 0.0f64);
    let mut n = 0usize;
    for (x, y) in a.iter().zip(b) {
        let norm = x.length();
        if norm == 0.0 {
            continue;
        }
        let e = (*y - *x).length() / norm;
        sum2 += e * e;
        max = max.max(e);
        n += 1;
    }
    ((sum2 / n.max(1) as f64).sqrt(), max)
}

/// Median time of one world step, s.
fn time_steps(
    positions: &[DVec3],
    method: GravityMethod,
    threads: usize,
    reps: usize,
) -> Result<f64, BenchError> {
    let mut w = World::new(WorldConfig {
        threads,
        energy_accounting: false,
        gpu_readback_every_step: true,
        ..WorldConfig::default()
    })?;
    let sys = w.add_system(SystemDesc {
        integrator: Integrator::SymplecticEuler,
        ..SystemDesc::default()
    });
    w.add_force(sys, gravity(method))?;
    let m = 1.0 / positions.len() as f64;
    let descs: Vec<ParticleDesc> = positions.iter().map(|&x| ParticleDesc::at(x, m)).collect();
    w.add_particles(sys, &descs)?;
    w.step(DT)?; // warm-up: allocations, page faults
    let mut times = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t0 = Instant::now();
        w.step(DT)?;
        times.push(t0.elapsed().as_secs_f64());
    }
    Ok(median(&times))
}

fn bodies(opts: &Opts) -> usize {
    if opts.quick {
        1_000
    } else {
        10_000
    }
}

/// The case name, `nbody_1e4` (`nbody_1e3` with `--quick`).
pub fn case_name(opts: &Opts) -> String {
    format!("nbody_{}", sci(bodies(opts)))
}

/// Runs the n-body cases (shared by the `nbody` and `particles` suites).
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let n = bodies(opts);
    let (exact_reps, bh_reps) = if opts.quick { (1, 2) } else { (3, 7) };
    let case = case_name(opts);
    let positions = plummer(n, 0x00B0_D1E5);
    let masses = vec![1.0 / n as f64; n];
    let threads = thread_counts();
    let pb = progress((threads.len() * (1 + THETAS.len())) as u64, "nbody");
    let mut out = Suspended::new(&pb, sink);
    let sink: &mut dyn Sink = &mut out;

    let t0 = Instant::now();
    let exact = accelerations(&positions, &masses, &gravity(GravityMethod::Exact));
    note(
        &pb,
        &format!(
            "nbody: exact reference accelerations in {:.2} s",
            t0.elapsed().as_secs_f64()
        ),
    );
    let errors: Vec<(f64, f64)> = THETAS
        .iter()
        .map(|&theta| {
            let b = accelerations(
                &positions,
                &masses,
                &gravity(GravityMethod::BarnesHut { theta }),
            );
            relative_errors(&exact, &b)
        })
        .collect();

    for &t in &threads {
        pb.set_message(format!("exact threads={t}"));
        let exact_s = time_steps(&positions, GravityMethod::Exact, t, exact_reps)?;
        sink.record(
            Measurement::new()
                .field("case", case.clone())
                .field("method", "exact")
                .field("theta", serde_json::Value::Null)
                .field("bodies", n)
                .field("threads", t)
                .num("ms_per_step", exact_s * 1e3)
                .num("rms_rel_force_error", 0.0)
                .num("max_rel_force_error", 0.0)
                .num("softening", SOFTENING),
        );
        pb.inc(1);
        for (&theta, &(rms, max)) in THETAS.iter().zip(&errors) {
            pb.set_message(format!("barnes_hut theta={theta} threads={t}"));
            let s = time_steps(&positions, GravityMethod::BarnesHut { theta }, t, bh_reps)?;
            let bound = rms_error_bound(theta);
            sink.record(
                Measurement::new()
                    .field("case", case.clone())
                    .field("method", "barnes_hut")
                    .num("theta", theta)
                    .field("bodies", n)
                    .field("threads", t)
                    .num("ms_per_step", s * 1e3)
                    .num("speedup_vs_exact", exact_s / s)
                    .num("rms_rel_force_error", rms)
                    .num("max_rel_force_error", max)
                    .num("rms_error_bound", bound)
                    .field("within_bound", rms <= bound)
                    .num("softening", SOFTENING),
            );
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plummer_is_reproducible_and_bounded() {
        let a = plummer(500, 3);
        assert_eq!(a, plummer(500, 3));
        assert!(a.iter().all(|x| x.length() < 10.0));
        // Half the mass of a Plummer sphere lies within r ≈ 1.305.
        let inside = a.iter().filter(|x| x.length() < 1.305).count();
        assert!((200..300).contains(&inside), "{inside}");
    }

    #[test]
    fn relative_errors_of_identical_fields_are_zero() {
        let a = vec![DVec3::X, DVec3::Y];
        assert_eq!(relative_errors(&a, &a), (0.0, 0.0));
        let b = vec![DVec3::X * 1.1, DVec3::Y];
        let (rms, max) = relative_errors(&a, &b);
        assert!((max - 0.1).abs() < 1e-12 && (rms - 0.1 / 2f64.sqrt()).abs() < 1e-12);
    }
}
