//! `inertia-bench particles`: stepping throughput of large particle systems
//! and a cloth, on the CPU at 1 and 2 threads and on the GPU, against a
//! plain memory copy measured in the same process, interleaved.
//!
//! ## Cases
//!
//! * `particles_1e5`, `particles_1e6`: free particles under `UniformGravity`,
//!   `Drag` and `Wind`, every particle with its own mass, drag coefficients
//!   and area; symplectic Euler; default energy accounting (on).
//! * `cloth_256`: `build_cloth` 256 × 256 (65 536 particles, 390 658
//!   springs: structural, shear, bend), two corners pinned, under gravity and
//!   wind; symplectic Euler; energy accounting **off** (its spring-potential
//!   pass is bookkeeping, not stepping; the record says so).
//! * `nbody_1e4`: see [`super::nbody`], run here too.
//!
//! `--quick` shrinks them to 1e4 / 1e5 particles, a 64 × 64 cloth and 1e3
//! bodies, and the case names say so.
//!
//! ## Bytes per particle step
//!
//! The traffic a step *must* move: every array element the step reads or
//! writes, counted once per pass that touches it (gathers of neighbours
//! counted once per particle, as if they hit cache). Checked against
//! `physics/src/step.rs`, `forces/*.rs` and `spring.rs`.
//!
//! Free particles, the fused symplectic-Euler pass with gravity + drag +
//! wind (no interaction forces, so no force buffer):
//!
//! | array | read | written |
//! |---|---|---|
//! | position (DVec3) | 24 | 24 |
//! | velocity (DVec3) | 24 | 24 |
//! | inv_mass (f64) | 8 | |
//! | drag_linear, drag_quadratic (f64) | 16 | |
//! | area (f64) | 8 | |
//! | flags (u32) | 4 | (only on quarantine) |
//!
//! = 84 read + 48 written = **132 B** per particle step. Gravity is a
//! constant; wind reads only `area`; `volume`, `group` and `control` are
//! not touched without buoyancy, explosions or control forces. The energy
//! accounting of kinetic and gravity energy is done inside the same pass from
//! the values already loaded; with no springs or mutual gravity the energy
//! stage reads nothing.
//!
//! Cloth (per particle `N`, per spring `S`; no drag force, so the drag
//! arrays are not read):
//!
//! * force buffer cleared: 24 N written;
//! * spring pass: endpoints `a`, `b` (8) and params (24) read, spring force
//!   (24) written = 56 S; endpoint position, velocity, flags read = 52 N;
//! * gather pass: offsets 4 N, adjacency 8 S and spring forces 24 S read,
//!   force buffer 24 N read and 24 N written;
//! * fused Euler pass: position 24, velocity 24, flags 4, inv_mass 8, area 8
//!   and force buffer 24 read, position and velocity 48 written = 140 N.
//!
//! = **88 B per spring + 268 B per particle**.
//!
//! Both are per pass: a step the engine cuts into `n` substeps (its
//! stability plan, `World::substeps_for`) moves `n` times as much. The
//! scenes here are tuned to need one.
//!
//! The GPU records use the same byte counts (the CPU's `f64` layout), so
//! their `bytes_per_s` compare with the CPU records and the copy; the GPU's
//! own `f32` buffers move fewer bytes.

use std::time::Instant;

use inertia_physics::glam::DVec3;
use inertia_physics::{
    build_cloth, Backend, ClothDesc, Drag, Integrator, ParticleDesc, SpringStiffness, SystemDesc,
    SystemHandle, UniformGravity, Wind, World, WorldConfig,
};

use crate::copy::CopyBench;
use crate::report::{
    logical_cores, median, note, progress, sci, thread_counts, Measurement, Sink, SplitMix64,
    Suspended,
};
use crate::{BenchError, Opts};

/// Simulation step, s: a 60 Hz game tick.
pub const DT: f64 = 1.0 / 60.0;

/// Bytes per particle step of the free-particle case (see the module docs).
pub const PARTICLE_BYTES: f64 = 132.0;
/// Bytes per particle step of the cloth, per particle.
pub const CLOTH_BYTES_PER_PARTICLE: f64 = 268.0;
/// Bytes per particle step of the cloth, per spring.
pub const CLOTH_BYTES_PER_SPRING: f64 = 88.0;

/// A scene to step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParticleScene {
    /// `n` free particles under gravity, drag and wind.
    Particles(usize),
    /// An `n` × `n` cloth under gravity and wind.
    Cloth(usize),
}

impl ParticleScene {
    /// The case name, e.g. `particles_1e6` or `cloth_256`.
    pub fn name(self) -> String {
        match self {
            ParticleScene::Particles(n) => format!("particles_{}", sci(n)),
            ParticleScene::Cloth(n) => format!("cloth_{n}"),
        }
    }

    /// Whether the world keeps energy accounting on for this case.
    pub fn energy_accounting(self) -> bool {
        matches!(self, ParticleScene::Particles(_))
    }

    /// Builds the scene in a new world.
    pub fn build(self, config: WorldConfig) -> Result<Built, BenchError> {
        let mut w = World::new(config)?;
        let sys = w.add_system(SystemDesc {
            integrator: Integrator::SymplecticEuler,
            ..SystemDesc::default()
        });
        w.add_force(sys, UniformGravity::earth())?;
        w.add_force(
            sys,
            Wind {
                velocity: DVec3::new(6.0, 0.0, 2.0),
                ..Wind::default()
            },
        )?;
        let springs = match self {
            ParticleScene::Particles(n) => {
                w.add_force(sys, Drag::default())?;
                let mut rng = SplitMix64(0x1E27_1A00 ^ n as u64);
                let descs: Vec<ParticleDesc> = (0..n)
                    .map(|_| {
                        let position = DVec3::new(
                            rng.range(-100.0, 100.0),
                            rng.range(0.0, 200.0),
                            rng.range(-100.0, 100.0),
                        );
                        let velocity = DVec3::new(
                            rng.range(-5.0, 5.0),
                            rng.range(0.0, 10.0),
                            rng.range(-5.0, 5.0),
                        );
                        ParticleDesc {
                            drag_linear: rng.range(0.01, 0.05),
                            drag_quadratic: rng.range(0.001, 0.01),
                            area: rng.range(0.005, 0.02),
                            ..ParticleDesc::at(position, rng.range(0.05, 0.2))
                                .with_velocity(velocity)
                        }
                    })
                    .collect();
                w.add_particles(sys, &descs)?;
                0
            }
            ParticleScene::Cloth(n) => {
                // 10 cm spacing, 10 g per particle; stiffnesses soft enough
                // that the engine's stability bound (Gershgorin, `ω_max dt
                // <= 1`) needs no substep at 60 Hz: 2·(4·2.5 + 4·1 + 4·0.5)
                // / 0.01 = 3200 rad²/s², ω_max dt = 0.94.
                let c = build_cloth(
                    &mut w,
                    sys,
                    &ClothDesc {
                        origin: DVec3::new(0.0, 30.0, 0.0),
                        width: 0.1 * (n - 1) as f64,
                        height: 0.1 * (n - 1) as f64,
                        nu: n,
                        nv: n,
                        mass: 0.01 * (n * n) as f64,
                        structural: SpringStiffness {
                            stiffness: 2.5,
                            damping: 0.02,
                        },
                        shear: SpringStiffness {
                            stiffness: 1.0,
                            damping: 0.01,
                        },
                        bend: SpringStiffness {
                            stiffness: 0.5,
                            damping: 0.005,
                        },
                        drag_linear: 0.0,
                        pinned: vec![(0, 0), (n - 1, 0)],
                        ..ClothDesc::default()
                    },
                )?;
                c.spring_counts.iter().sum()
            }
        };
        let particles = w.system(sys).ok_or("system vanished")?.len();
        let substeps = w.substeps_for(sys, DT);
        Ok(Built {
            world: w,
            sys,
            particles,
            springs,
            substeps,
        })
    }
}

/// A scene built in a world.
#[derive(Debug)]
pub struct Built {
    /// The world holding the scene.
    pub world: World,
    /// Its one particle system.
    pub sys: SystemHandle,
    /// Number of particles.
    pub particles: usize,
    /// Number of springs.
    pub springs: usize,
    /// Passes the engine cuts one step of [`DT`] into (its stability plan).
    pub substeps: u32,
}

impl Built {
    /// Bytes one step must move: the per-pass traffic of the module docs
    /// times the number of substeps.
    pub fn bytes_per_step(&self, scene: ParticleScene) -> f64 {
        let pass = match scene {
            ParticleScene::Particles(_) => PARTICLE_BYTES * self.particles as f64,
            ParticleScene::Cloth(_) => {
                CLOTH_BYTES_PER_PARTICLE * self.particles as f64
                    + CLOTH_BYTES_PER_SPRING * self.springs as f64
            }
        };
        pass * f64::from(self.substeps)
    }
}

/// Sizes and repetitions.
#[derive(Debug, Clone, Copy)]
struct SizePlan {
    reps: usize,
    /// Wall time one timed burst of steps (or copies) aims at, s.
    burst_s: f64,
    warmup: usize,
    /// Steps compared between CPU and GPU.
    compare_steps: usize,
}

impl SizePlan {
    fn new(opts: &Opts) -> Self {
        if opts.quick {
            SizePlan {
                reps: 3,
                burst_s: 0.002,
                warmup: 1,
                compare_steps: 3,
            }
        } else {
            SizePlan {
                reps: 21,
                burst_s: 0.02,
                warmup: 3,
                compare_steps: 20,
            }
        }
    }
}

/// The scenes of the suite.
pub fn scenes(opts: &Opts) -> Vec<ParticleScene> {
    if opts.quick {
        vec![
            ParticleScene::Particles(10_000),
            ParticleScene::Particles(100_000),
            ParticleScene::Cloth(64),
        ]
    } else {
        vec![
            ParticleScene::Particles(100_000),
            ParticleScene::Particles(1_000_000),
            ParticleScene::Cloth(256),
        ]
    }
}

/// Medians of interleaved copy and step bursts, s per copy and per step.
struct Timing {
    step_s: f64,
    copy_s: f64,
    copy_bytes: f64,
}

/// Alternates `reps` bursts of copies and of `step` calls (the order flips
/// every repetition, so neither always runs on a cache the other warmed),
/// and returns the median time of one of each.
fn interleaved(
    plan: &SizePlan,
    copy: &mut CopyBench,
    mut step: impl FnMut() -> Result<(), BenchError>,
) -> Result<Timing, BenchError> {
    let mut est_step: f64 = 0.0;
    for _ in 0..plan.warmup.max(1) {
        let t0 = Instant::now();
        step()?;
        est_step = t0.elapsed().as_secs_f64();
    }
    let est_copy = copy.run();
    let step_burst = ((plan.burst_s / est_step.max(1e-9)).ceil() as usize).max(1);
    let copy_burst = ((plan.burst_s / est_copy.max(1e-9)).ceil() as usize).max(1);
    let (mut steps, mut copies) = (Vec::new(), Vec::new());
    for r in 0..plan.reps {
        let mut time_copy = |copies: &mut Vec<f64>| {
            let s: f64 = (0..copy_burst).map(|_| copy.run()).sum();
            copies.push(s / copy_burst as f64);
        };
        if r % 2 == 0 {
            time_copy(&mut copies);
        }
        let t0 = Instant::now();
        for _ in 0..step_burst {
            step()?;
        }
        steps.push(t0.elapsed().as_secs_f64() / step_burst as f64);
        if r % 2 == 1 {
            time_copy(&mut copies);
        }
    }
    Ok(Timing {
        step_s: median(&steps),
        copy_s: median(&copies),
        copy_bytes: copy.counted_bytes() as f64,
    })
}

fn throughput_record(
    scene: ParticleScene,
    built: &Built,
    backend: &str,
    threads: usize,
    t: &Timing,
) -> Measurement {
    let (particles, springs) = (built.particles, built.springs);
    let bytes = built.bytes_per_step(scene);
    let bytes_per_s = bytes / t.step_s;
    let copy_bytes_per_s = t.copy_bytes / t.copy_s;
    let mut r = Measurement::new()
        .field("case", scene.name())
        .field("backend", backend)
        .field("threads", threads)
        .field("particles", particles);
    if springs > 0 {
        r = r.field("springs", springs);
    }
    r.field("substeps", built.substeps)
        .num("ns_per_particle_step", t.step_s * 1e9 / particles as f64)
        .num("ms_per_step", t.step_s * 1e3)
        .num("bytes_per_particle_step", bytes / particles as f64)
        .num("bytes_per_s", bytes_per_s)
        .num("copy_bytes_per_s", copy_bytes_per_s)
        .num("fraction_of_copy", bytes_per_s / copy_bytes_per_s)
        .field("energy_accounting", scene.energy_accounting())
}

/// A world of `threads` workers (0: one a core), pinned as `opts` says.
fn config(opts: &Opts, threads: usize, energy: bool, gpu_readback_every_step: bool) -> WorldConfig {
    WorldConfig {
        threads,
        energy_accounting: energy,
        gpu_readback_every_step,
        pin_threads: opts.pin_threads,
        ..WorldConfig::default()
    }
}

/// Measures one scene on the CPU with `threads` workers.
pub fn cpu_case(
    opts: &Opts,
    scene: ParticleScene,
    threads: usize,
    sink: &mut dyn Sink,
) -> Result<(), BenchError> {
    let plan = SizePlan::new(opts);
    let mut b = scene.build(config(opts, threads, scene.energy_accounting(), true))?;
    let mut copy = CopyBench::new(b.bytes_per_step(scene) as usize, threads);
    let w = &mut b.world;
    let t = interleaved(&plan, &mut copy, || {
        w.step(DT)?;
        Ok(())
    })?;
    let w = &b.world;
    let quarantined = w
        .system(b.sys)
        .ok_or("system vanished")?
        .quarantined_count();
    let p = w.profile_totals();
    let integrate_share = p.sum.integrate.as_secs_f64() / p.sum.total.as_secs_f64().max(1e-12);
    let steps = w.tick();
    sink.record(
        throughput_record(scene, &b, "cpu", threads, &t)
            .field("steps", steps)
            .field("pinned", w.pinned_cores().is_some())
            .field("quarantined", quarantined)
            .num("integrate_share", integrate_share),
    );
    Ok(())
}

/// Measures one scene on the GPU: correctness against the CPU first, then
/// throughput with no readback per step (each timed burst ends with one
/// `sync_gpu`, so the work is really done). If the GPU backend is not
/// available the record carries an `error` field instead of figures.
pub fn gpu_case(opts: &Opts, scene: ParticleScene, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let plan = SizePlan::new(opts);
    let threads = logical_cores();
    let energy = scene.energy_accounting();
    let mut gb = scene.build(config(opts, 0, energy, false))?;
    let base = Measurement::new()
        .field("case", scene.name())
        .field("backend", "gpu")
        .field("threads", threads)
        .field("particles", gb.particles);
    let gsys = gb.sys;
    if let Err(e) = gb.world.set_backend(gsys, Backend::Gpu) {
        sink.record(
            base.field("error", e.to_string())
                .field("energy_accounting", energy),
        );
        return Ok(());
    }
    let mut run = || -> Result<Measurement, BenchError> {
        let mut cb = scene.build(config(opts, 0, energy, true))?;
        let (g, c, csys) = (&mut gb.world, &mut cb.world, cb.sys);
        for _ in 0..plan.compare_steps {
            g.step(DT)?;
            c.step(DT)?;
        }
        g.sync_gpu()?;
        let gp = g.system(gsys).ok_or("system vanished")?.positions();
        let cp = c.system(csys).ok_or("system vanished")?.positions();
        let max_abs_diff = gp
            .iter()
            .zip(cp)
            .map(|(a, b)| (*a - *b).abs().max_element())
            .fold(0.0f64, f64::max);
        let mut copy = CopyBench::new(gb.bytes_per_step(scene) as usize, threads);
        let g = &mut gb.world;
        // One burst = `k` steps + one sync; `interleaved` times bursts of
        // this closure, so per-step time includes the amortized readback.
        let k = if opts.quick { 2 } else { 10 };
        let t = interleaved(&plan, &mut copy, || {
            for _ in 0..k {
                g.step(DT)?;
            }
            g.sync_gpu()?;
            Ok(())
        })?;
        let t = Timing {
            step_s: t.step_s / k as f64,
            ..t
        };
        Ok(throughput_record(scene, &gb, "gpu", threads, &t)
            .num("max_abs_diff_vs_cpu", max_abs_diff)
            .field("compare_steps", plan.compare_steps))
    };
    match run() {
        Ok(r) => sink.record(r),
        Err(e) => sink.record(
            base.field("error", format!("GPU run failed: {e}"))
                .field("energy_accounting", energy),
        ),
    }
    Ok(())
}

/// Runs the suite: every scene on the CPU at each thread count and on the
/// GPU, then the n-body case.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let scenes: Vec<ParticleScene> = scenes(opts)
        .into_iter()
        .filter(|s| opts.wants(&s.name()))
        .collect();
    let threads = thread_counts();
    let pb = progress((scenes.len() * (threads.len() + 1)) as u64, "particles");
    let mut out = Suspended::new(&pb, sink);
    for scene in scenes {
        for &t in &threads {
            pb.set_message(format!("{} cpu threads={t}", scene.name()));
            let t0 = Instant::now();
            cpu_case(opts, scene, t, &mut out)?;
            note(
                &pb,
                &format!(
                    "particles: {} cpu threads={t} measured in {:.1} s",
                    scene.name(),
                    t0.elapsed().as_secs_f64()
                ),
            );
            pb.inc(1);
        }
        pb.set_message(format!("{} gpu", scene.name()));
        gpu_case(opts, scene, &mut out)?;
        pb.inc(1);
    }
    pb.finish_and_clear();
    if opts.wants(&super::nbody::case_name(opts)) {
        super::nbody::run(opts, sink)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn case_names() {
        assert_eq!(sci(1_000_000), "1e6");
        assert_eq!(sci(100_000), "1e5");
        assert_eq!(sci(65_536), "65536");
        assert_eq!(ParticleScene::Cloth(256).name(), "cloth_256");
    }

    #[test]
    fn cloth_springs_match_the_byte_model_count() {
        let b = ParticleScene::Cloth(16)
            .build(WorldConfig::default())
            .unwrap();
        assert_eq!(b.world.system(b.sys).unwrap().spring_count(), b.springs);
        // 2·15·16 structural + 2·15·15 shear + 2·14·16 bend.
        assert_eq!(b.springs, 480 + 450 + 448);
        // Tuned to need no substep at 60 Hz, so no spring is softened.
        assert_eq!(b.substeps, 1);
        assert_eq!(
            ParticleScene::Particles(10)
                .build(WorldConfig::default())
                .unwrap()
                .substeps,
            1
        );
    }
}
