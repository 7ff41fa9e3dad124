//! Shared by the GPU tests: a world with a GPU context (or a skip), scene
//! builders and CPU/GPU comparison.
#![allow(dead_code)]

use inertia_physics::glam::DVec3;
use inertia_physics::gpu::GPU_TOLERANCE;
use inertia_physics::{Backend, ForceHandle, SystemHandle, World, WorldConfig};

/// Set to `1` to let GPU tests pass (with a notice) on a machine without
/// any adapter. Without it a missing adapter fails the test.
pub const SKIP_ENV: &str = "INERTIA_SKIP_GPU_TESTS";

/// A world whose GPU context opened, or `None` (after a notice) when there
/// is no adapter and `INERTIA_SKIP_GPU_TESTS=1`.
pub fn gpu_world(config: WorldConfig) -> Option<World> {
    let mut world = World::new(config).expect("world");
    match world.gpu_context() {
        Ok(ctx) => {
            eprintln!("GPU tests run on: {}", ctx.description());
            Some(world)
        }
        Err(e) if std::env::var(SKIP_ENV).as_deref() == Ok("1") => {
            eprintln!("SKIPPED (no GPU adapter, {SKIP_ENV}=1): {e}");
            None
        }
        Err(e) => panic!("{e}\n(set {SKIP_ENV}=1 to skip the GPU tests on this machine)"),
    }
}

/// `gpu_world` with one worker thread and readback after every step.
pub fn default_gpu_world() -> Option<World> {
    gpu_world(cpu_config())
}

pub fn cpu_config() -> WorldConfig {
    WorldConfig {
        threads: 1,
        ..WorldConfig::default()
    }
}

/// Early-returns from a test when the GPU tests are skipped.
#[macro_export]
macro_rules! gpu_or_skip {
    ($e:expr) => {
        match $e {
            Some(w) => w,
            None => return,
        }
    };
}

/// A small deterministic generator (64-bit LCG, high bits).
pub struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }

    pub fn vec(&mut self, r: f64) -> DVec3 {
        DVec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
}

/// Largest |a - b| over every component, and the largest |b| (the scale).
pub fn max_diff(a: &[DVec3], b: &[DVec3]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let mut diff: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for (x, y) in a.iter().zip(b) {
        diff = diff.max((*x - *y).abs().max_element());
        scale = scale.max(y.abs().max_element());
    }
    (diff, scale)
}

/// A built scene: its system and the force generators it added, in order.
pub struct Scene {
    pub sys: SystemHandle,
    pub forces: Vec<ForceHandle>,
}

/// The measured differences between a GPU run and a CPU run.
#[derive(Debug, Clone, Copy)]
pub struct Agreement {
    pub position_diff: f64,
    pub position_bound: f64,
    pub velocity_diff: f64,
    pub velocity_bound: f64,
}

/// Builds the same scene twice (`build` must be deterministic), steps one
/// copy on the CPU and one on the GPU for `steps` steps of `dt`, calling
/// `between(world, scene, step)` before each step on both, and asserts every
/// position and velocity agrees within `GPU_TOLERANCE`. Returns the
/// measured differences (`None` when GPU tests are skipped).
pub fn assert_agreement(
    name: &str,
    steps: u32,
    dt: f64,
    build: impl Fn(&mut World) -> Scene,
    between: impl Fn(&mut World, &Scene, u32),
) -> Option<Agreement> {
    let mut gpu = gpu_world(cpu_config())?;
    let mut cpu = World::new(cpu_config()).unwrap();
    let scene_cpu = build(&mut cpu);
    let scene_gpu = build(&mut gpu);
    let (s_cpu, s_gpu) = (scene_cpu.sys, scene_gpu.sys);
    gpu.set_backend(s_gpu, Backend::Gpu).expect("upload");
    let mut x_scale: f64 = 0.0;
    let mut v_scale: f64 = 0.0;
    for k in 0..steps {
        between(&mut cpu, &scene_cpu, k);
        between(&mut gpu, &scene_gpu, k);
        cpu.step(dt).unwrap();
        gpu.step(dt).unwrap();
        let s = cpu.system(s_cpu).unwrap();
        x_scale = x_scale.max(max_diff(s.positions(), s.positions()).1);
        v_scale = v_scale.max(max_diff(s.velocities(), s.velocities()).1);
    }
    let (c, g) = (cpu.system(s_cpu).unwrap(), gpu.system(s_gpu).unwrap());
    assert_eq!(g.backend(), Backend::Gpu);
    assert!(!c.is_empty());
    let (dx, _) = max_diff(g.positions(), c.positions());
    let (dv, _) = max_diff(g.velocities(), c.velocities());
    let out = Agreement {
        position_diff: dx,
        position_bound: GPU_TOLERANCE.bound(steps, x_scale),
        velocity_diff: dv,
        velocity_bound: GPU_TOLERANCE.bound(steps, v_scale),
    };
    eprintln!(
        "{name}: {steps} steps, |dx| = {dx:.3e} m (bound {:.3e}, scale {x_scale:.3}), \
         |dv| = {dv:.3e} m/s (bound {:.3e}, scale {v_scale:.3})",
        out.position_bound, out.velocity_bound
    );
    assert!(
        dx <= out.position_bound,
        "{name}: positions differ by {dx:e} m > {:e}",
        out.position_bound
    );
    assert!(
        dv <= out.velocity_bound,
        "{name}: velocities differ by {dv:e} m/s > {:e}",
        out.velocity_bound
    );
    assert_eq!(g.flags(), c.flags(), "{name}: flags differ");
    Some(out)
}
