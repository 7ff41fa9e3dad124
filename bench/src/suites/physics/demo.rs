//! The `demo` case: the server's built-in demo scene (a box pyramid,
//! ragdolls, a rope bridge, a cloth flag, a pool with floating crates,
//! bouncing balls), stepped by our engine alone, as the server steps it:
//! the world built by `inertia_server::scene::demo::demo_scene` with the
//! server's world configuration at `threads` physics threads, one
//! `World::step` per tick of `1 / DEFAULT_TICK_HZ` s. Rapier has no
//! counterpart to cloth, ropes or water, so there is no ratio: the figure
//! is our milliseconds per tick.

use std::time::Instant;

use inertia_physics::WorldConfig;
use inertia_server::config::DEFAULT_TICK_HZ;
use inertia_server::scene::demo::demo_scene;

use inertia_physics::ProfileTotals;
use serde_json::Value;

use super::{per_step_ms, percentile, stage_means};
use crate::report::{median, Measurement};
use crate::BenchError;

/// The case's name (what `--only` matches).
pub const NAME: &str = "demo";

/// Timed ticks (30 s of simulated time).
pub const STEPS: usize = 1800;
/// Timed ticks with `--quick`.
pub const STEPS_QUICK: usize = 30;

/// Steps the demo world `warmup` ticks, then times `steps` ticks one by
/// one, at `threads` physics threads (the world's own pool, as the
/// server's `--physics-threads` gives it).
pub fn measure(threads: usize, warmup: usize, steps: usize) -> Result<Measurement, BenchError> {
    let scene = demo_scene()?;
    let mut built = scene.build_with(WorldConfig {
        threads,
        ..WorldConfig::default()
    })?;
    let world = &mut built.world;
    let dt = 1.0 / f64::from(DEFAULT_TICK_HZ);
    let bodies = world.bodies().count();
    let particles: usize = world.systems().map(|s| s.len()).sum();
    let mut times_ms = Vec::with_capacity(steps);
    let mut before = *world.profile_totals();
    let mut quarantined = 0;
    for k in 0..warmup + steps {
        if k == warmup {
            before = *world.profile_totals();
        }
        let t0 = Instant::now();
        let report = world.step(dt)?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        quarantined += report.quarantined_bodies.len();
        if k >= warmup {
            times_ms.push(ms);
        }
    }
    let stages = stage_means(&before, world.profile_totals());
    let particle_stages = particle_stage_means(&before, world.profile_totals());
    Ok(Measurement::new()
        .field("scene", NAME)
        .field("bodies", bodies)
        .field("particles", particles)
        .field("threads", threads)
        .field("steps", steps)
        .field("warmup_steps", warmup)
        .num("dt", dt)
        .num("ours_ms_median", median(&times_ms))
        .num("ours_ms_p99", percentile(&times_ms, 99.0))
        .field("ours_stage_ms", stages)
        .field("ours_particle_stage_ms", particle_stages)
        .field("ours_quarantined", quarantined)
        .build_flags())
}

/// Mean wall time per timed tick of the particle stages (ropes, cloth,
/// water), ms: the parts of `StepProfile` outside the rigid step.
fn particle_stage_means(before: &ProfileTotals, after: &ProfileTotals) -> Value {
    let ms = per_step_ms(before, after);
    let (a, b) = (&after.sum, &before.sum);
    serde_json::json!({
        "prepare": ms(a.prepare, b.prepare),
        "forces": ms(a.forces, b.forces),
        "integrate": ms(a.integrate, b.integrate),
        "gpu": ms(a.gpu, b.gpu),
        "bodies": ms(a.bodies, b.bodies),
    })
}
