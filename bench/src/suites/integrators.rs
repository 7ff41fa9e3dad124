//! `inertia-bench integrators`: the measured order of convergence of every
//! integrator on two problems with known solutions, and its long-run energy
//! drift.
//!
//! * **Oscillator**: a particle of mass `m` on a Hooke spring (stiffness
//!   `k`, rest length `L0`) to a pinned anchor, released at rest from
//!   `L0 + A`. The motion stays on the spring's axis, so the closed form
//!   `x(t) = L0 + A cos(ω t)`, `ω = sqrt(k/m)`, is exact.
//! * **Kepler**: a particle around a pinned unit mass with `MutualGravity`
//!   (`G = 1`, exact summation, no softening): a one-body Kepler problem with
//!   `μ = 1`. Orbit: semi-major axis 1, eccentricity 0.5, released at
//!   periapsis; the reference position comes from solving Kepler's equation
//!   `E - e sin E = n t` by Newton's method.
//!
//! Each problem is run over a fixed simulated time at `dt`, `dt/2` and
//! `dt/4`; the error of a run is the largest distance from the reference
//! over the instants the three runs share (every step of the coarsest run),
//! which does not depend on where a single end point happens to fall in the
//! error's oscillation. The reported order is `log2(err(dt/2) / err(dt/4))`,
//! the finest pair, where the asymptotic regime holds best. Base steps are
//! chosen per method so that the errors are small enough to be asymptotic
//! (forward Euler's amplitude growth stays below a few per cent) and large
//! enough to stay clear of rounding (RK4's finest error is above 1e-10).
//!
//! **Energy drift**: `|E(end) - E(0)| / |E(0)|` for the undamped oscillator
//! after 10^6 steps at `ω dt = 0.05`, where `E` is the world's energy
//! accounting (kinetic plus spring). The largest drift seen at any step is
//! reported too, because symplectic methods' energy error oscillates (it is
//! bounded, not zero). Forward Euler's energy grows by `1 + (ω dt)²` per
//! step and overflows long before 10^6 steps: the particle is quarantined,
//! `energy_drift` is `null`, `energy_blew_up_at_step` says when, and
//! `energy_growth_per_step` is the measured `(E_k / E_0)^(1/k) - 1` at the
//! last finite step `k` (theory: `(ω dt)² = 0.0025`).

use std::time::Instant;

use inertia_physics::glam::DVec3;
use inertia_physics::{
    GravityMethod, Integrator, MutualGravity, ParticleDesc, ParticleHandle, SpringParams,
    SystemDesc, World, WorldConfig,
};

use crate::report::{note, progress, Measurement, Sink, Suspended};
use crate::{BenchError, Opts};

// Oscillator.
const MASS: f64 = 2.0;
const STIFFNESS: f64 = 8.0; // ω = 2 rad/s
const REST: f64 = 1.0;
const AMPLITUDE: f64 = 0.5;
const OSC_TIME: f64 = 5.0; // s, about 1.6 periods

// Kepler orbit, μ = G M = 1.
const ECC: f64 = 0.5;
const SEMI_MAJOR: f64 = 1.0;
const KEPLER_TIME: f64 = 2.0 * std::f64::consts::PI; // one period

fn omega() -> f64 {
    (STIFFNESS / MASS).sqrt()
}

/// Base steps `(oscillator, kepler)` for a method, s.
fn base_dt(integrator: Integrator) -> (f64, f64) {
    match integrator.order() {
        1 => (2.5e-3, 1e-4),
        2 => (2e-2, 2e-3),
        _ => (5e-2, 1e-2),
    }
}

fn world(
    integrator: Integrator,
    energy: bool,
) -> Result<(World, inertia_physics::SystemHandle), BenchError> {
    let mut w = World::new(WorldConfig {
        // 0 = no pool of our own: two particles fit one chunk and run inline.
        threads: 0,
        energy_accounting: energy,
        gpu_readback_every_step: true,
        ..WorldConfig::default()
    })?;
    // One pass per step: the method is measured at exactly `dt`, never
    // substepped.
    let sys = w.add_system(SystemDesc {
        integrator,
        max_substeps: 1,
        ..SystemDesc::default()
    });
    Ok((w, sys))
}

fn oscillator(integrator: Integrator, energy: bool) -> Result<(World, ParticleHandle), BenchError> {
    let (mut w, sys) = world(integrator, energy)?;
    let anchor = w.add_particle(
        sys,
        ParticleDesc {
            pinned: true,
            ..ParticleDesc::at(DVec3::ZERO, 1.0)
        },
    )?;
    let p = w.add_particle(
        sys,
        ParticleDesc::at(DVec3::new(REST + AMPLITUDE, 0.0, 0.0), MASS),
    )?;
    w.add_spring(
        anchor,
        p,
        SpringParams {
            rest_length: REST,
            stiffness: STIFFNESS,
            damping: 0.0,
        },
    )?;
    Ok((w, p))
}

fn oscillator_exact(t: f64) -> DVec3 {
    DVec3::new(REST + AMPLITUDE * (omega() * t).cos(), 0.0, 0.0)
}

fn kepler(integrator: Integrator) -> Result<(World, ParticleHandle), BenchError> {
    let (mut w, sys) = world(integrator, false)?;
    w.add_force(
        sys,
        MutualGravity {
            g_constant: 1.0,
            softening: 0.0,
            method: GravityMethod::Exact,
        },
    )?;
    w.add_particle(
        sys,
        ParticleDesc {
            pinned: true,
            ..ParticleDesc::at(DVec3::ZERO, 1.0)
        },
    )?;
    let r_peri = SEMI_MAJOR * (1.0 - ECC);
    let v_peri = ((1.0 + ECC) / r_peri).sqrt(); // vis-viva with μ = 1
    let p = w.add_particle(
        sys,
        ParticleDesc::at(DVec3::new(r_peri, 0.0, 0.0), 1.0)
            .with_velocity(DVec3::new(0.0, v_peri, 0.0)),
    )?;
    Ok((w, p))
}

/// Position on the reference orbit at time `t` after periapsis.
pub fn kepler_exact(t: f64) -> DVec3 {
    let n = (1.0 / SEMI_MAJOR.powi(3)).sqrt();
    let m = n * t;
    let mut e = if ECC > 0.8 { std::f64::consts::PI } else { m };
    for _ in 0..50 {
        let f = e - ECC * e.sin() - m;
        let step = f / (1.0 - ECC * e.cos());
        e -= step;
        if step.abs() < 1e-15 {
            break;
        }
    }
    let b = SEMI_MAJOR * (1.0 - ECC * ECC).sqrt();
    DVec3::new(SEMI_MAJOR * (e.cos() - ECC), b * e.sin(), 0.0)
}

/// Largest distance from `exact` over every `every`-th step of a run of
/// `steps` steps of `dt`.
fn max_error(
    (mut w, p): (World, ParticleHandle),
    dt: f64,
    steps: usize,
    every: usize,
    exact: fn(f64) -> DVec3,
) -> Result<f64, BenchError> {
    let mut err: f64 = 0.0;
    for k in 1..=steps {
        w.step(dt)?;
        if k % every == 0 {
            let x = w.particle(p).ok_or("particle vanished")?.position;
            err = err.max((x - exact(k as f64 * dt)).length());
        }
    }
    Ok(err)
}

/// Errors at `dt`, `dt/2`, `dt/4` over `time` seconds.
fn errors(
    make: &dyn Fn() -> Result<(World, ParticleHandle), BenchError>,
    dt: f64,
    time: f64,
    exact: fn(f64) -> DVec3,
) -> Result<[f64; 3], BenchError> {
    let n = (time / dt).round() as usize;
    let mut out = [0.0; 3];
    for (level, e) in out.iter_mut().enumerate() {
        let f = 1usize << level;
        *e = max_error(make()?, dt / f as f64, n * f, f, exact)?;
    }
    Ok(out)
}

fn order(e: &[f64; 3]) -> f64 {
    (e[1] / e[2]).log2()
}

/// What the energy-drift run found.
#[derive(Debug, Clone, Copy)]
struct Drift {
    end: Option<f64>,
    max: f64,
    /// `(E_k / E_0)^(1/k) - 1` at the last step `k` before a blow-up.
    growth_per_step: Option<f64>,
    blew_up_at: Option<u64>,
    seconds: f64,
}

fn energy_drift(integrator: Integrator, steps: u64) -> Result<Drift, BenchError> {
    let (mut w, _) = oscillator(integrator, true)?;
    let dt = 0.05 / omega();
    let e0 = w.compute_energy().total();
    let mut max: f64 = 0.0;
    let mut blew_up_at = None;
    let mut last_finite = (0u64, e0);
    let t0 = Instant::now();
    for k in 1..=steps {
        let r = w.step(dt)?;
        if blew_up_at.is_none() {
            let e = r.energy.total();
            let d = ((e - e0) / e0).abs();
            if !r.quarantined.is_empty() || !d.is_finite() {
                blew_up_at = Some(k);
            } else {
                max = max.max(d);
                last_finite = (k, e);
            }
        }
    }
    let growth_per_step = blew_up_at.map(|_| {
        let (k, e) = last_finite;
        ((e / e0).ln() / k.max(1) as f64).exp_m1()
    });
    let seconds = t0.elapsed().as_secs_f64();
    let end = ((w.energy().total() - e0) / e0).abs();
    Ok(Drift {
        end: (blew_up_at.is_none() && end.is_finite()).then_some(end),
        max,
        growth_per_step,
        blew_up_at,
        seconds,
    })
}

/// Runs the suite.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let drift_steps: u64 = if opts.quick { 10_000 } else { 1_000_000 };
    let pb = progress(Integrator::ALL.len() as u64, "integrators");
    let mut out = Suspended::new(&pb, sink);
    let sink: &mut dyn Sink = &mut out;
    for integrator in Integrator::ALL {
        if !opts.wants(integrator.name()) {
            pb.inc(1);
            continue;
        }
        pb.set_message(integrator.name());
        let (dt_osc, dt_kep) = base_dt(integrator);
        let osc = errors(
            &|| oscillator(integrator, false),
            dt_osc,
            OSC_TIME,
            oscillator_exact,
        )?;
        let kep = errors(&|| kepler(integrator), dt_kep, KEPLER_TIME, kepler_exact)?;
        let drift = energy_drift(integrator, drift_steps)?;
        note(
            &pb,
            &format!(
                "integrators: {} energy run, {drift_steps} steps in {:.3} s ({:.0} ns/step)",
                integrator.name(),
                drift.seconds,
                drift.seconds * 1e9 / drift_steps as f64
            ),
        );
        let mut r = Measurement::new()
            .field("integrator", integrator.name())
            .field("threads", 1)
            .field("expected_order", integrator.order())
            .num("order_oscillator", order(&osc))
            .num("order_kepler", order(&kep))
            .field("dt_oscillator", vec![dt_osc, dt_osc / 2.0, dt_osc / 4.0])
            .field("errors_oscillator", osc.to_vec())
            .field("dt_kepler", vec![dt_kep, dt_kep / 2.0, dt_kep / 4.0])
            .field("errors_kepler", kep.to_vec());
        r = match drift.end {
            Some(d) => r.num("energy_drift", d),
            None => r.field("energy_drift", serde_json::Value::Null),
        };
        r = r
            .num("energy_drift_max", drift.max)
            .field("energy_steps", drift_steps)
            .num("omega_dt", 0.05)
            .num("energy_wall_s", drift.seconds)
            .num("ns_per_step", drift.seconds * 1e9 / drift_steps as f64);
        if let (Some(k), Some(g)) = (drift.blew_up_at, drift.growth_per_step) {
            r = r
                .field("energy_blew_up_at_step", k)
                .num("energy_growth_per_step", g);
        }
        sink.record(r);
        pb.inc(1);
    }
    pb.finish_and_clear();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kepler_reference_closes_the_orbit() {
        let a = kepler_exact(0.0);
        let b = kepler_exact(KEPLER_TIME);
        assert!((a - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12);
        assert!((a - b).length() < 1e-12);
        // Apoapsis at half a period.
        assert!((kepler_exact(0.5 * KEPLER_TIME) - DVec3::new(-1.5, 0.0, 0.0)).length() < 1e-12);
    }
}
