//! `inertia-bench soft`: soft bodies and fluids on XPBD small steps, on
//! the CPU at 1 and 2 threads (interleaved: one world per thread count,
//! stepped in turn, so machine noise falls on both alike).
//!
//! ## Cases
//!
//! * `cloth_64`, `cloth_128`, `cloth_387`: [`SoftCloth`] `n` × `n`, 2 cm
//!   spacing, inextensible stretch, stiff shear, bending, tethers to its
//!   pins (every eighth particle of its top edge and its far corner, like
//!   a curtain's rings), 10 substeps, let go level so it swings down and
//!   hangs (387² ≈ 150k
//!   particles is the cloth of Macklin et al., "Small Steps in Physics
//!   Simulation", 2019: 13.5 ms a frame on their GPU).
//! * `jelly_20`: a [`SoftSolid`] box of 20³ cells (six tetrahedra a cell)
//!   resting on the ground, 10 substeps.
//! * `fluid_10k`, `fluid_100k`: a dam of about that many particles 5 cm
//!   apart breaking from one end of a tank four times as long
//!   (position-based fluids, 4 substeps, the walls static boxes).
//! * On the GPU (feature `gpu`), after the CPU cases: the cloths (up to
//!   128² on a CPU adapter) and the jelly (with `max_abs_diff_vs_cpu`),
//!   `fluid_10k` and `fluid_100k` (with
//!   `max_abs_diff_vs_cpu` and `median_abs_diff_vs_cpu`, against the
//!   one-thread CPU world after the same steps) and `fluid_1m` (GPU only).
//!   On a CPU adapter fluids past 10k particles run only with
//!   `--gpu-large`.
//!
//! Each record: `particles`, `constraints` (projected each substep),
//! `substeps`, `ms_per_step` (median over the timed steps), `max_strain`
//! (the largest strain of a distance constraint at the end; cloth),
//! `volume_kept` (jelly) or `density_error` (fluid: mean density over rest
//! density, minus one, at the end), and the share of the step in the soft
//! stage.
//!
//! `--quick` shrinks the cases (`cloth_32`, `jelly_6`, `fluid_2k`) and
//! the steps.

use std::time::Instant;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{
    FluidDesc, FluidHandle, SoftBodyHandle, SoftCloth, SoftMaterial, SoftSolid, SolidShape,
    ThreadPinning, World, WorldConfig,
};

use crate::report::{median, note, progress, Measurement, Sink, Suspended};
use crate::{BenchError, Opts};

/// A 60 Hz tick, s.
const DT: f64 = 1.0 / 60.0;

/// A scene of the suite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SoftScene {
    /// An `n` × `n` cloth hanging from rings along its top edge.
    Cloth(u32),
    /// A jelly of `n`³ cells on the ground.
    Jelly(u32),
    /// About `n` fluid particles breaking from one end of a tank.
    Fluid(u32),
}

impl SoftScene {
    fn name(self) -> String {
        match self {
            SoftScene::Cloth(n) => format!("cloth_{n}"),
            SoftScene::Jelly(n) => format!("jelly_{n}"),
            SoftScene::Fluid(n) if n % 1_000_000 == 0 => format!("fluid_{}m", n / 1_000_000),
            SoftScene::Fluid(n) if n % 1000 == 0 => format!("fluid_{}k", n / 1000),
            SoftScene::Fluid(n) => format!("fluid_{n}"),
        }
    }

    /// The scene's world at `threads` threads; `readback`: a GPU system
    /// is read back every step.
    fn build(
        self,
        threads: usize,
        pin_threads: ThreadPinning,
        readback: bool,
    ) -> Result<(World, Handle), BenchError> {
        let mut w = World::new(WorldConfig {
            threads,
            pin_threads,
            energy_accounting: false,
            gpu_readback_every_step: readback,
            ..WorldConfig::default()
        })?;
        w.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
        let material = SoftMaterial {
            substeps: 10,
            ..SoftMaterial::default()
        };
        let h = match self {
            SoftScene::Cloth(n) => {
                let side = 0.02 * f64::from(n - 1);
                let cloth = SoftCloth {
                    corner: DVec3::new(-side / 2.0, side + 1.0, 0.0),
                    across: DVec3::new(side, 0.0, 0.0),
                    down: DVec3::new(0.0, 0.0, side),
                    rows: n,
                    cols: n,
                    mass: 0.1 * side * side,
                    stretch_compliance: 0.0,
                    shear_compliance: 1e-6,
                    bend_compliance: 1.0,
                    pinned: (0..n).step_by(8).chain([n - 1]).map(|c| [0, c]).collect(),
                    tethers: true,
                    material,
                };
                Handle::Soft(w.add_soft_body(&cloth.build()?)?)
            }
            SoftScene::Jelly(n) => {
                w.add_body(&RigidBodyDesc::fixed(
                    Shape::cuboid(DVec3::new(10.0, 0.5, 10.0))?,
                    Pose {
                        translation: DVec3::new(0.0, -0.5, 0.0),
                        rotation: DQuat::IDENTITY,
                    },
                ))?;
                let solid = SoftSolid {
                    shape: SolidShape::Box {
                        half_extents: DVec3::splat(0.5),
                    },
                    position: DVec3::new(0.0, 0.52, 0.0),
                    cell: 1.0 / f64::from(n),
                    edge_compliance: 1e-4,
                    material: SoftMaterial {
                        collision_radius: 0.01,
                        ..material
                    },
                    ..SoftSolid::default()
                };
                Handle::Soft(w.add_soft_body(&solid.build()?)?)
            }
            SoftScene::Fluid(n) => {
                // A dam of 2s × s × s particles 5 cm apart (2 s³ ≈ n) at
                // one end of a tank four times as long.
                let s = (f64::from(n) / 2.0).cbrt().round();
                let spacing = 0.05;
                let block = DVec3::new(2.0 * s, s, s) * spacing;
                let inside = DVec3::new(8.0 * s, 3.0 * s, s) * spacing;
                tank(&mut w, inside)?;
                Handle::Fluid(w.add_fluid(FluidDesc::block(DVec3::ZERO, block, spacing)?)?)
            }
        };
        Ok((w, h))
    }
}

/// What a scene steps: a soft body or a fluid.
#[derive(Debug, Clone, Copy)]
enum Handle {
    Soft(SoftBodyHandle),
    Fluid(FluidHandle),
}

/// A tank open at the top, inside from the origin to `inside` (m): a
/// floor and four walls of static boxes.
fn tank(w: &mut World, inside: DVec3) -> Result<(), BenchError> {
    let t = 0.2;
    let c = inside * 0.5;
    let mut add = |centre: DVec3, half: DVec3| -> Result<(), BenchError> {
        w.add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(half)?,
            Pose {
                translation: centre,
                rotation: DQuat::IDENTITY,
            },
        ))?;
        Ok(())
    };
    add(
        DVec3::new(c.x, -t / 2.0, c.z),
        DVec3::new(c.x + t, t / 2.0, c.z + t),
    )?;
    for side in [-1.0, 1.0] {
        add(
            DVec3::new(c.x + side * (c.x + t / 2.0), c.y, c.z),
            DVec3::new(t / 2.0, c.y, c.z + t),
        )?;
        add(
            DVec3::new(c.x, c.y, c.z + side * (c.z + t / 2.0)),
            DVec3::new(c.x, c.y, t / 2.0),
        )?;
    }
    Ok(())
}

fn scenes(opts: &Opts) -> Vec<SoftScene> {
    if opts.quick {
        vec![
            SoftScene::Cloth(32),
            SoftScene::Jelly(6),
            SoftScene::Fluid(2000),
        ]
    } else {
        vec![
            SoftScene::Cloth(64),
            SoftScene::Cloth(128),
            SoftScene::Cloth(387),
            SoftScene::Jelly(20),
            SoftScene::Fluid(10_000),
            SoftScene::Fluid(100_000),
        ]
    }
}

/// Runs the suite.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let scenes: Vec<SoftScene> = scenes(opts)
        .into_iter()
        .filter(|s| opts.wants(&s.name()))
        .collect();
    let (warmup, steps) = if opts.quick { (2, 6) } else { (30, 120) };
    // One thread, and two pinned as asked (by default where the process
    // owns its cores).
    let threads = [(1usize, ThreadPinning::Auto), (2, opts.pin_threads)];
    let pb = progress(scenes.len() as u64, "soft");
    let mut sink = Suspended::new(&pb, sink);
    // Soft-body cases to run on the GPU, with the one-thread CPU world
    // each is compared with.
    #[cfg(feature = "gpu")]
    let mut on_gpu = Vec::new();
    // Fluid cases likewise.
    #[cfg(feature = "gpu")]
    let mut fluids_on_gpu = Vec::new();
    for scene in scenes {
        pb.set_message(scene.name());
        let mut worlds = Vec::new();
        for &(t, pin) in &threads {
            worlds.push(scene.build(t, pin, true)?);
        }
        for _ in 0..warmup {
            for (w, _) in &mut worlds {
                w.step(DT)?;
            }
        }
        let mut times = vec![Vec::with_capacity(steps); threads.len()];
        let mut soft = vec![0.0; threads.len()];
        for s in 0..steps {
            // Alternate which thread count goes first.
            for k in 0..threads.len() {
                let k = if s % 2 == 0 { k } else { threads.len() - 1 - k };
                let (w, _) = &mut worlds[k];
                let t0 = Instant::now();
                w.step(DT)?;
                times[k].push(t0.elapsed().as_secs_f64());
                soft[k] += w.profile().soft.as_secs_f64();
            }
        }
        let hashes: Vec<u64> = worlds.iter().map(|(w, _)| w.state_hash()).collect();
        if hashes.windows(2).any(|h| h[0] != h[1]) {
            note(
                &pb,
                &format!("{}: the thread counts disagree", scene.name()),
            );
        }
        for (k, (w, h)) in worlds.iter().enumerate() {
            let total: f64 = times[k].iter().sum();
            let r = Measurement::new()
                .field("case", scene.name())
                .field("backend", "cpu")
                .field("threads", threads[k].0)
                .field("pinned", w.pinned_cores().is_some())
                .build_flags();
            let r = match *h {
                Handle::Soft(h) => {
                    let b = w.soft_body(h).ok_or("soft body vanished")?;
                    let r = r
                        .field("particles", b.len())
                        .field("constraints", b.constraints())
                        .field("substeps", b.material().substeps);
                    match scene {
                        SoftScene::Jelly(_) => {
                            r.num("volume_kept", f64::from(b.volume() / b.rest_volume()))
                        }
                        _ => r.num("max_strain", f64::from(b.max_strain())),
                    }
                }
                Handle::Fluid(h) => {
                    let f = w.fluid(h).ok_or("fluid vanished")?;
                    let n = f.len().max(1) as f64;
                    let mean = f.densities().iter().map(|d| f64::from(*d)).sum::<f64>() / n;
                    r.field("particles", f.len())
                        .field("constraints", f.len())
                        .field("substeps", f.params().substeps)
                        .num("density_error", mean / f64::from(f.rest_density()) - 1.0)
                }
            };
            sink.record(
                r.num("ms_per_step", median(&times[k]) * 1e3)
                    .num("soft_share", soft[k] / total.max(1e-12))
                    .field(
                        "same_bits_on_1_and_2_threads",
                        hashes.windows(2).all(|h| h[0] == h[1]),
                    ),
            );
        }
        #[cfg(feature = "gpu")]
        if let (SoftScene::Cloth(_) | SoftScene::Jelly(_), Handle::Soft(h)) = (scene, worlds[0].1) {
            let (cpu, _) = worlds.swap_remove(0);
            on_gpu.push((scene, cpu, h));
        } else if let (SoftScene::Fluid(_), Handle::Fluid(h)) = (scene, worlds[0].1) {
            let (cpu, _) = worlds.swap_remove(0);
            fluids_on_gpu.push((scene, Some((cpu, h))));
        }
        pb.inc(1);
    }
    // A million particles on the GPU alone: the CPU would take minutes.
    #[cfg(feature = "gpu")]
    if !opts.quick && opts.wants(&SoftScene::Fluid(1_000_000).name()) {
        fluids_on_gpu.push((SoftScene::Fluid(1_000_000), None));
    }
    // The GPU cases last: a CPU adapter's worker threads would otherwise
    // share the cores with the CPU cases after them.
    #[cfg(feature = "gpu")]
    for (scene, cpu, h) in on_gpu {
        gpu_case(scene, warmup, steps, &cpu, h, &mut sink, &pb)?;
    }
    #[cfg(feature = "gpu")]
    for (scene, cpu) in fluids_on_gpu {
        let run = FluidRun {
            scene,
            warmup,
            steps,
            large: opts.gpu_large,
        };
        fluid_gpu_case(run, cpu.as_ref(), &mut sink, &pb)?;
    }
    pb.finish_and_clear();
    Ok(())
}

/// Wall time of each of `steps` steps of `w` after `warmup` more, s,
/// each waited for on the GPU.
fn gpu_step_times(w: &mut World, warmup: usize, steps: usize) -> Result<Vec<f64>, BenchError> {
    let mut times = Vec::with_capacity(steps);
    for k in 0..warmup + steps {
        let t0 = Instant::now();
        w.step(DT)?;
        w.gpu_context()?.finish()?;
        if k >= warmup {
            times.push(t0.elapsed().as_secs_f64());
        }
    }
    Ok(times)
}

/// Most particles of a soft body stepped on a CPU adapter (a 128² cloth).
#[cfg(feature = "gpu")]
const MOST_ON_A_CPU_ADAPTER: usize = 128 * 128;

/// A cloth or the jelly on the GPU (feature `gpu`): stepped as many times
/// as the CPU worlds, each step waited for; `max_abs_diff_vs_cpu` against
/// the one-thread CPU world `cpu` at the end. On a CPU adapter (Mesa's
/// lavapipe) bodies larger than a 128² cloth are skipped: it runs the
/// shaders on the cores the CPU rows measure.
#[cfg(feature = "gpu")]
fn gpu_case(
    scene: SoftScene,
    warmup: usize,
    steps: usize,
    cpu: &World,
    h: SoftBodyHandle,
    sink: &mut dyn Sink,
    pb: &indicatif::ProgressBar,
) -> Result<(), BenchError> {
    use inertia_physics::Backend;
    let base = Measurement::new()
        .field("case", scene.name())
        .field("backend", "gpu")
        .field("threads", crate::report::logical_cores());
    let (mut w, _) = scene.build(1, ThreadPinning::Auto, true)?;
    let adapter = match w.gpu_context() {
        Ok(ctx) => (ctx.description(), ctx.is_cpu_adapter()),
        Err(e) => {
            sink.record(base.field("error", e.to_string()));
            return Ok(());
        }
    };
    let particles = w.soft_body(h).ok_or("soft body vanished")?.len();
    if adapter.1 && particles > MOST_ON_A_CPU_ADAPTER {
        note(
            pb,
            &format!("{}: skipped on the CPU adapter {}", scene.name(), adapter.0),
        );
        return Ok(());
    }
    if let Err(e) = w.set_soft_backend(h, Backend::Gpu) {
        sink.record(base.field("error", e.to_string()));
        return Ok(());
    }
    let times = gpu_step_times(&mut w, warmup, steps)?;
    let b = w.soft_body(h).ok_or("soft body vanished")?;
    let c = cpu.soft_body(h).ok_or("soft body vanished")?;
    let diff = b
        .positions()
        .iter()
        .zip(c.positions())
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0f32, f32::max);
    let r = base
        .field("adapter", adapter.0)
        .field("particles", b.len())
        .field("constraints", b.constraints())
        .field("substeps", b.material().substeps);
    let r = match scene {
        SoftScene::Jelly(_) => r.num("volume_kept", f64::from(b.volume() / b.rest_volume())),
        _ => r.num("max_strain", f64::from(b.max_strain())),
    };
    sink.record(
        r.num("ms_per_step", median(&times) * 1e3)
            .num("max_abs_diff_vs_cpu", f64::from(diff)),
    );
    Ok(())
}

/// A fluid case to run on the GPU.
#[cfg(feature = "gpu")]
#[derive(Debug, Clone, Copy)]
struct FluidRun {
    scene: SoftScene,
    warmup: usize,
    steps: usize,
    /// Run a case sized for a real GPU on a CPU adapter too.
    large: bool,
}

/// The fluid on the GPU (feature `gpu`): stepped as many times as the CPU
/// worlds without a readback, each step waited for, read back at the end;
/// `max_abs_diff_vs_cpu` and `median_abs_diff_vs_cpu` against the
/// one-thread CPU world and its fluid `cpu` (none for `fluid_1m`). On a CPU adapter
/// (Mesa's lavapipe, about half a second a step of `fluid_10k` on two
/// cores) fluids above 10k particles are skipped unless `large`.
#[cfg(feature = "gpu")]
fn fluid_gpu_case(
    run: FluidRun,
    cpu: Option<&(World, FluidHandle)>,
    sink: &mut dyn Sink,
    pb: &indicatif::ProgressBar,
) -> Result<(), BenchError> {
    use inertia_physics::Backend;
    let FluidRun {
        scene,
        warmup,
        steps,
        large,
    } = run;
    let SoftScene::Fluid(n) = scene else {
        return Err("not a fluid".into());
    };
    let base = Measurement::new()
        .field("case", scene.name())
        .field("backend", "gpu")
        .field("threads", crate::report::logical_cores());
    let adapter = match inertia_physics::gpu::GpuContext::new() {
        Ok(ctx) => (ctx.description(), ctx.is_cpu_adapter()),
        Err(e) => {
            sink.record(base.field("error", e.to_string()));
            return Ok(());
        }
    };
    if adapter.1 && n > 10_000 && !large {
        note(
            pb,
            &format!(
                "{}: skipped on the CPU adapter {} (--gpu-large runs it)",
                scene.name(),
                adapter.0
            ),
        );
        return Ok(());
    }
    let (mut w, Handle::Fluid(h)) = scene.build(1, ThreadPinning::Auto, false)? else {
        return Err("not a fluid".into());
    };
    if let Err(e) = w.set_fluid_backend(h, Backend::Gpu) {
        sink.record(base.field("error", e.to_string()));
        return Ok(());
    }
    let times = gpu_step_times(&mut w, warmup, steps)?;
    w.sync_gpu()?;
    let f = w.fluid(h).ok_or("fluid vanished")?;
    let count = f.len().max(1) as f64;
    let mean = f.densities().iter().map(|d| f64::from(*d)).sum::<f64>() / count;
    let mut r = base
        .field("adapter", adapter.0)
        .field("particles", f.len())
        .field("constraints", f.len())
        .field("substeps", f.params().substeps)
        .field("readback_every_step", false)
        .num("density_error", mean / f64::from(f.rest_density()) - 1.0)
        .num("ms_per_step", median(&times) * 1e3);
    if let Some((cpu, ch)) = cpu {
        let c = cpu.fluid(*ch).ok_or("fluid vanished")?;
        let mut d: Vec<f64> = f
            .positions()
            .iter()
            .zip(c.positions())
            .map(|(p, q)| f64::from((*p - *q).length()))
            .collect();
        d.sort_by(f64::total_cmp);
        let worst = d.last().copied().unwrap_or(0.0);
        r = r
            .num("max_abs_diff_vs_cpu", worst)
            .num("median_abs_diff_vs_cpu", median(&d));
    }
    sink.record(r);
    Ok(())
}
