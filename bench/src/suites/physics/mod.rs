//! `inertia-bench physics`: our rigid-body engine against rapier3d on the
//! same scenes, in the same process, step by step.
//!
//! Every scene is described once, engine-neutrally ([`scene`]), and built
//! into both engines ([`ours`], [`rapier`]). Matched effort: `dt` = 1/60 s,
//! our substep count equals rapier's solver iterations (4, its default),
//! gravity −9.81 m/s² along Y in both.
//!
//! One case is a scene at a thread count with sleeping on or off. Both
//! engines step inside the same rayon pool of that many threads (rapier
//! re-exports the rayon it uses, and it is the crate our engine uses, so
//! one pool serves both). After [`WARMUP`] steps, the engines step
//! alternately — ours then rapier on even steps, rapier then ours on odd
//! ones — and each step is timed on its own. Between timed steps, outside
//! the timing, the deepest contact penetration of each engine is read.
//!
//! See `bench/README.md` (`## physics`) for every field.

pub mod demo;
pub mod ours;
pub mod rapier;
pub mod scene;

use std::time::Instant;

use inertia_physics::glam::DVec3;
use inertia_physics::ProfileTotals;
use serde_json::Value;

use crate::report::thread_counts;
use crate::report::{median, note, progress, Measurement, Sink, Suspended};
use crate::{BenchError, Opts};
use scene::NeutralScene;

/// Simulation step, s.
pub const DT: f64 = 1.0 / 60.0;
/// Our substeps per step and rapier's `num_solver_iterations`.
pub const SOLVER_ITERATIONS: usize = 4;
/// Gravity along Y, m/s².
pub const GRAVITY: f64 = -9.81;
/// Steps run before the timed ones.
pub const WARMUP: usize = 30;
/// Warm-up steps with `--quick`.
pub const WARMUP_QUICK: usize = 5;

/// One engine with a scene built in it, as the measurement sees it.
pub trait Engine {
    /// Advances by one step of [`DT`].
    fn step(&mut self) -> Result<(), BenchError>;
    /// The deepest overlap between two shapes found by the last step, m.
    fn penetration(&self) -> f64;
    /// Origins of the dynamic bodies, in scene order, m.
    fn positions(&self) -> Vec<DVec3>;
    /// Dynamic bodies not asleep.
    fn awake(&self) -> usize;
    /// Bodies the engine quarantined (went non-finite), summed over steps.
    fn quarantined(&self) -> usize;
}

/// Nearest-rank percentile `p` (0–100) of a non-empty sample.
pub fn percentile(xs: &[f64], p: f64) -> f64 {
    assert!(!xs.is_empty(), "percentile of an empty sample");
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

/// What one engine did over one case.
struct Run {
    times_ms: Vec<f64>,
    max_penetration: f64,
    /// Rapier only: the same from its (possibly recycled) manifolds.
    max_manifold_penetration: f64,
}

impl Run {
    fn new(steps: usize) -> Self {
        Self {
            times_ms: Vec::with_capacity(steps),
            max_penetration: 0.0,
            max_manifold_penetration: 0.0,
        }
    }
}

fn timed(e: &mut dyn Engine) -> Result<f64, BenchError> {
    let t0 = Instant::now();
    e.step()?;
    Ok(t0.elapsed().as_secs_f64() * 1e3)
}

/// Largest distance of a body from where it started, m (`NaN` if any
/// position is not finite).
fn drift(start: &[DVec3], end: &[DVec3]) -> f64 {
    start
        .iter()
        .zip(end)
        .map(|(a, b)| (*b - *a).length())
        .fold(0.0, |m, d| {
            if d.is_nan() || m.is_nan() {
                f64::NAN
            } else {
                m.max(d)
            }
        })
}

/// Dynamic bodies below `floor_y` or not finite.
fn fell_through(end: &[DVec3], floor_y: f64) -> usize {
    end.iter()
        .filter(|p| !p.is_finite() || p.y < floor_y)
        .count()
}

/// A stage's mean wall time per step between two readings of the totals,
/// ms, from its summed time in each (`after`, `before`).
fn per_step_ms(
    before: &ProfileTotals,
    after: &ProfileTotals,
) -> impl Fn(std::time::Duration, std::time::Duration) -> Value {
    let steps = (after.steps - before.steps).max(1) as f64;
    move |a, b| Value::from(a.saturating_sub(b).as_secs_f64() * 1e3 / steps)
}

/// Mean wall time per timed step of each stage of our rigid step, ms:
/// where our time goes (see `inertia_physics::RigidProfile`).
fn stage_means(before: &ProfileTotals, after: &ProfileTotals) -> Value {
    let ms = per_step_ms(before, after);
    let (a, b) = (&after.sum.rigid, &before.sum.rigid);
    serde_json::json!({
        "forces": ms(a.forces, b.forces),
        "broad_phase": ms(a.broad_phase, b.broad_phase),
        "narrow_phase": ms(a.narrow_phase, b.narrow_phase),
        "colouring": ms(a.colouring, b.colouring),
        "solve": ms(a.solve, b.solve),
        "finish": ms(a.finish, b.finish),
        "islands": ms(a.islands, b.islands),
        "total": ms(after.sum.total, before.sum.total),
    })
}

/// Runs one case: builds both worlds, warms up, then times `scene.steps`
/// interleaved steps of each.
pub fn measure(
    scene: &NeutralScene,
    threads: usize,
    sleeping: bool,
    warmup: usize,
) -> Result<Measurement, BenchError> {
    let pool = rapier3d::rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let mut ours = ours::Ours::build(scene, threads, sleeping, DT)?;
    let mut rapier = rapier::Rapier::build(scene, sleeping, DT)?;
    let steps = scene.steps;
    let mut after_warmup = ours.profile_totals();
    let mut manifolds_at_warmup = ours.manifolds();
    let (o, r) = pool.install(|| -> Result<(Run, Run), BenchError> {
        let (mut o, mut r) = (Run::new(steps), Run::new(steps));
        for k in 0..warmup + steps {
            if k == warmup {
                after_warmup = ours.profile_totals();
                manifolds_at_warmup = ours.manifolds();
            }
            let (to, tr) = if k % 2 == 0 {
                let to = timed(&mut ours)?;
                (to, timed(&mut rapier)?)
            } else {
                let tr = timed(&mut rapier)?;
                (timed(&mut ours)?, tr)
            };
            if k >= warmup {
                o.times_ms.push(to);
                r.times_ms.push(tr);
                o.max_penetration = o.max_penetration.max(ours.penetration());
                r.max_penetration = r.max_penetration.max(rapier.penetration());
                r.max_manifold_penetration = r
                    .max_manifold_penetration
                    .max(rapier.manifold_penetration());
            }
        }
        Ok((o, r))
    })?;
    let start: Vec<DVec3> = scene
        .bodies
        .iter()
        .filter(|b| b.kind == scene::NeutralKind::Dynamic)
        .map(|b| b.position)
        .collect();
    let (end_o, end_r) = (ours.positions(), rapier.positions());
    let drift_mm = |end: &[DVec3]| -> Value {
        let d = drift(&start, end) * 1e3;
        if scene.starts_at_rest && d.is_finite() {
            Value::from(d)
        } else {
            Value::Null
        }
    };
    let (om, rm) = (median(&o.times_ms), median(&r.times_ms));
    let stages = stage_means(&after_warmup, &ours.profile_totals());
    let recycled = {
        let (before, after) = (manifolds_at_warmup, ours.manifolds());
        let used_again = after.recycled - before.recycled;
        let all = used_again + after.collided - before.collided;
        if all == 0 {
            Value::Null
        } else {
            Value::from(used_again as f64 / all as f64)
        }
    };
    Ok(Measurement::new()
        .field("scene", scene.name.clone())
        .field("bodies", scene.dynamic_count())
        .field("static_bodies", scene.static_count())
        .field("joints", scene.joints.len())
        .field("threads", threads)
        .field("sleeping", sleeping)
        .field("steps", steps)
        .field("warmup_steps", warmup)
        .num("dt", DT)
        .field("solver_iterations", SOLVER_ITERATIONS)
        .num("ours_ms_median", om)
        .num("ours_ms_p99", percentile(&o.times_ms, 99.0))
        .num("rapier_ms_median", rm)
        .num("rapier_ms_p99", percentile(&r.times_ms, 99.0))
        .num("ratio", om / rm)
        .num("ours_max_penetration_mm", o.max_penetration * 1e3)
        .num("rapier_max_penetration_mm", r.max_penetration * 1e3)
        .num(
            "rapier_manifold_penetration_mm",
            r.max_manifold_penetration * 1e3,
        )
        .field("ours_drift_mm", drift_mm(&end_o))
        .field("rapier_drift_mm", drift_mm(&end_r))
        .field("ours_stage_ms", stages)
        .field("ours_recycled", recycled)
        .field("ours_awake_at_end", ours.awake())
        .field("rapier_awake_at_end", rapier.awake())
        .field("ours_fell_through", fell_through(&end_o, scene.floor_y))
        .field("rapier_fell_through", fell_through(&end_r, scene.floor_y))
        .field("ours_quarantined", ours.quarantined())
        .field("rapier_quarantined", rapier.quarantined())
        .build_flags())
}

/// The cases run per scene: 1 and 2 threads (and every core, if more),
/// each with sleeping off, then on.
pub fn cases() -> Vec<(usize, bool)> {
    thread_counts()
        .into_iter()
        .flat_map(|t| [(t, false), (t, true)])
        .collect()
}

/// Runs every selected scene in each of [`cases`].
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let specs: Vec<scene::SceneSpec> = scene::all(opts.quick)
        .into_iter()
        .filter(|s| opts.wants(s.name))
        .collect();
    let warmup = if opts.quick { WARMUP_QUICK } else { WARMUP };
    let cases = cases();
    let demo_cases = if opts.wants(demo::NAME) {
        thread_counts().len()
    } else {
        0
    };
    let pb = progress((specs.len() * cases.len() + demo_cases) as u64, "physics");
    let mut out = Suspended::new(&pb, sink);
    let sink: &mut dyn Sink = &mut out;
    let t_all = Instant::now();
    for spec in &specs {
        let scene = spec.build();
        for &(t, sleeping) in &cases {
            pb.set_message(format!("{} threads={t} sleeping={sleeping}", scene.name));
            let t0 = Instant::now();
            let record = measure(&scene, t, sleeping, warmup)?;
            note(
                &pb,
                &format!(
                    "physics: {} threads={t} sleeping={sleeping} in {:.1} s",
                    scene.name,
                    t0.elapsed().as_secs_f64()
                ),
            );
            sink.record(record);
            pb.inc(1);
        }
    }
    if opts.wants(demo::NAME) {
        let steps = if opts.quick {
            demo::STEPS_QUICK
        } else {
            demo::STEPS
        };
        for t in thread_counts() {
            pb.set_message(format!("{} threads={t}", demo::NAME));
            let t0 = Instant::now();
            sink.record(demo::measure(t, warmup, steps)?);
            note(
                &pb,
                &format!(
                    "physics: {} threads={t} in {:.1} s",
                    demo::NAME,
                    t0.elapsed().as_secs_f64()
                ),
            );
            pb.inc(1);
        }
    }
    note(
        &pb,
        &format!(
            "physics: all cases in {:.1} s",
            t_all.elapsed().as_secs_f64()
        ),
    );
    pb.finish_and_clear();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentile_is_nearest_rank() {
        let xs: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&xs, 99.0), 99.0);
        assert_eq!(percentile(&xs, 50.0), 50.0);
        assert_eq!(percentile(&[3.0], 99.0), 3.0);
    }

    #[test]
    fn drift_is_the_largest_displacement() {
        let a = [DVec3::ZERO, DVec3::X];
        let b = [DVec3::Y * 0.5, DVec3::X * 3.0];
        assert_eq!(drift(&a, &b), 2.0);
        assert!(drift(&a, &[DVec3::ZERO, DVec3::NAN]).is_nan());
    }

    #[test]
    fn a_tiny_pyramid_stands_in_both_engines() {
        let s = scene::pyramid(3, 20);
        let r = measure(&s, 1, false, 2).expect("measure");
        for k in ["ours_drift_mm", "rapier_drift_mm"] {
            let d = r.get(k).and_then(Value::as_f64).expect(k);
            assert!(d < 20.0, "{k} = {d} mm");
        }
        assert_eq!(r.get("ours_fell_through"), Some(&Value::from(0)));
        assert_eq!(r.get("rapier_fell_through"), Some(&Value::from(0)));
    }
}
