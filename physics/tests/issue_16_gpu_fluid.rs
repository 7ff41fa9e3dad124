//! Fluids on the GPU (feature `gpu`) follow the CPU within
//! `FLUID_GPU_TOLERANCE`, repeat bit for bit, save and restore, and what
//! the GPU path does not run is refused.
//!
//! Run: `cargo test -p inertia-physics --features gpu --test integration issue_16_gpu_fluid::`.
//! Without a GPU these run on Mesa lavapipe; with no adapter at all they
//! say so and pass (and are skipped outright when
//! `INERTIA_SKIP_GPU_TESTS=1`).
#![cfg(feature = "gpu")]

use inertia_physics::glam::{DVec3, Vec3};
use inertia_physics::gpu::{GpuContext, FLUID_GPU_MEDIAN_TOLERANCE, FLUID_GPU_TOLERANCE};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{
    Backend, FluidDesc, FluidEmitter, FluidHandle, PhysicsError, World, WorldConfig,
};

use crate::common;

use common::{at, tank};

const DT: f64 = 1.0 / 60.0;
/// Steps of the parity run: 0.4 s of a dam break, its front across the
/// tank and onto the far wall.
const STEPS: usize = 24;

/// Whether to skip: asked to, or no adapter at all (said on stdout).
fn skip() -> bool {
    if std::env::var("INERTIA_SKIP_GPU_TESTS").is_ok_and(|v| v == "1") {
        return true;
    }
    match GpuContext::new() {
        Err(PhysicsError::Gpu(e)) if e.starts_with("no GPU adapter") => {
            println!("skipped: {e}");
            true
        }
        Err(e) => panic!("{e}"),
        Ok(_) => false,
    }
}

fn world(readback: bool) -> World {
    let mut w = World::new(WorldConfig {
        threads: 1,
        gpu_readback_every_step: readback,
        ..WorldConfig::default()
    })
    .unwrap();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    w
}

/// A dam of 16 × 12 × 10 particles 5 cm apart at one end of a static tank
/// twice as long (1920 particles).
fn dam(w: &mut World) -> FluidHandle {
    tank(w, DVec3::ZERO, DVec3::new(1.6, 1.2, 0.5));
    let block = FluidDesc::block(DVec3::ZERO, DVec3::new(0.8, 0.6, 0.5), 0.05).unwrap();
    w.add_fluid(block).unwrap()
}

/// The largest and the median distance between the particles of `a` and
/// `b`, m.
fn distances(a: &[Vec3], b: &[Vec3]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let mut d: Vec<f32> = a.iter().zip(b).map(|(p, q)| (*p - *q).length()).collect();
    d.sort_by(f32::total_cmp);
    (d[d.len() - 1], d[d.len() / 2])
}

#[test]
fn issue_16_a_dam_break_on_the_gpu_follows_the_cpu_and_repeats() {
    if skip() {
        return;
    }
    let mut cpu = world(true);
    let h = dam(&mut cpu);
    let mut gpu = world(true);
    dam(&mut gpu);
    gpu.set_fluid_backend(h, Backend::Gpu).unwrap();
    // The same steps without a readback each step, read back at the end.
    let mut again = world(false);
    dam(&mut again);
    again.set_fluid_backend(h, Backend::Gpu).unwrap();
    println!("on {}", gpu.gpu_context().unwrap().description());
    for _ in 0..STEPS {
        cpu.step(DT).unwrap();
        gpu.step(DT).unwrap();
        again.step(DT).unwrap();
    }
    again.sync_gpu().unwrap();
    let (a, b) = (cpu.fluid(h).unwrap(), gpu.fluid(h).unwrap());
    assert_eq!(b.backend(), Backend::Gpu);
    let (far, median) = distances(a.positions(), b.positions());
    let fastest = a
        .velocities()
        .iter()
        .map(|v| v.length())
        .fold(0.0f32, f32::max);
    let mean = |d: &[f32]| d.iter().map(|x| f64::from(*x)).sum::<f64>() / d.len() as f64;
    println!(
        "{} particles, {STEPS} steps: the GPU stands at most {far:.2e} m from the CPU, \
         the median particle {median:.2e} m (fastest {fastest:.2} m/s); \
         mean density {:.2} (CPU) and {:.2} (GPU) kg/m³",
        a.len(),
        mean(a.densities()),
        mean(b.densities())
    );
    assert!(far < FLUID_GPU_TOLERANCE, "{far}");
    assert!(median < FLUID_GPU_MEDIAN_TOLERANCE, "{median}");
    assert!(fastest > 0.5, "the dam broke ({fastest} m/s)");
    // Deterministic: a second GPU run gives the same bits.
    let c = again.fluid(h).unwrap();
    let same = |x: &[Vec3], y: &[Vec3]| {
        x.iter()
            .zip(y)
            .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
    };
    assert!(same(b.positions(), c.positions()));
    assert!(same(b.velocities(), c.velocities()));
    // Back on the CPU, it carries on from where the GPU left it.
    let before = b.positions().to_vec();
    gpu.set_fluid_backend(h, Backend::Cpu).unwrap();
    assert_eq!(gpu.fluid(h).unwrap().positions(), before.as_slice());
    gpu.step(DT).unwrap();
    assert!(gpu
        .fluid(h)
        .unwrap()
        .positions()
        .iter()
        .all(|p| p.is_finite() && p.y > -0.05));
}

#[test]
fn issue_16_what_the_gpu_fluid_does_not_run_is_refused() {
    if skip() {
        return;
    }
    // A dynamic body: the GPU does not push bodies back.
    let mut w = world(true);
    let h = dam(&mut w);
    let crate_ = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::splat(0.1)).unwrap(),
        500.0,
        at(DVec3::new(1.2, 0.5, 0.25)),
    )
    .unwrap();
    let body = w.add_body(&crate_).unwrap();
    assert!(matches!(
        w.set_fluid_backend(h, Backend::Gpu),
        Err(PhysicsError::Gpu(m)) if m.contains("dynamic")
    ));
    assert_eq!(w.fluid(h).unwrap().backend(), Backend::Cpu);
    // A shape the shader does not project onto.
    w.remove_body(body).unwrap();
    let post = RigidBodyDesc::fixed(
        Shape::cylinder(0.2, 0.05).unwrap(),
        at(DVec3::new(1.2, 0.2, 0.25)),
    );
    let post = w.add_body(&post).unwrap();
    assert!(matches!(
        w.set_fluid_backend(h, Backend::Gpu),
        Err(PhysicsError::Gpu(m)) if m.contains("cylinder")
    ));
    assert_eq!(w.fluid(h).unwrap().backend(), Backend::Cpu);
    // A dynamic body added to a fluid on the GPU: the step says so.
    w.remove_body(post).unwrap();
    w.set_fluid_backend(h, Backend::Gpu).unwrap();
    w.step(DT).unwrap();
    w.add_body(&crate_).unwrap();
    assert!(matches!(w.step(DT), Err(PhysicsError::Gpu(m)) if m.contains("dynamic")));
}

#[test]
fn issue_16_a_gpu_fluid_saves_restores_and_emits() {
    if skip() {
        return;
    }
    let mut w = world(false);
    let h = dam(&mut w);
    w.add_fluid_emitter(
        h,
        FluidEmitter {
            radius: 0.1,
            ..FluidEmitter::new(DVec3::new(1.2, 0.9, 0.25), DVec3::new(0.0, -1.0, 0.0))
        },
    )
    .unwrap();
    let n0 = w.fluid(h).unwrap().len();
    w.set_fluid_backend(h, Backend::Gpu).unwrap();
    for _ in 0..6 {
        w.step(DT).unwrap();
    }
    // The emitter fired on the host between GPU steps.
    let grown = w.fluid(h).unwrap().len();
    assert!(grown > n0, "{grown} particles, {n0} before");
    w.sync_gpu().unwrap();
    let saved = w.save();
    let mirror = w.fluid(h).unwrap().positions().to_vec();
    let mut back = World::from_saved(
        WorldConfig {
            threads: 1,
            ..WorldConfig::default()
        },
        &saved,
    )
    .unwrap();
    let f = back.fluid(h).unwrap();
    // The backend is not saved: the restored fluid steps on the CPU.
    assert_eq!(f.backend(), Backend::Cpu);
    assert_eq!(f.positions(), mirror.as_slice());
    // Moved to the GPU again, it steps on from the saved state.
    back.set_fluid_backend(h, Backend::Gpu).unwrap();
    back.step(DT).unwrap();
    w.step(DT).unwrap();
    w.sync_gpu().unwrap();
    assert_eq!(
        back.fluid(h).unwrap().positions(),
        w.fluid(h).unwrap().positions()
    );
}

#[test]
fn issue_16_vorticity_and_the_tensile_correction_on_the_gpu_follow_the_cpu() {
    if skip() {
        return;
    }
    let run = |on_gpu: bool| {
        let mut w = world(true);
        tank(&mut w, DVec3::ZERO, DVec3::new(1.6, 1.2, 0.5));
        let mut block = FluidDesc::block(DVec3::ZERO, DVec3::new(0.8, 0.6, 0.5), 0.05).unwrap();
        block.vorticity = 0.05;
        block.tensile_k = 0.1;
        block.friction = 0.3;
        let h = w.add_fluid(block).unwrap();
        if on_gpu {
            w.set_fluid_backend(h, Backend::Gpu).unwrap();
        }
        for _ in 0..8 {
            w.step(DT).unwrap();
        }
        w.fluid(h).unwrap().positions().to_vec()
    };
    let (far, median) = distances(&run(false), &run(true));
    println!("8 steps with vorticity, tensile correction and friction: at most {far:.2e} m, median {median:.2e} m");
    assert!(far < 1e-3, "{far}");
    assert!(median < FLUID_GPU_MEDIAN_TOLERANCE, "{median}");
}
