//! Soft bodies on the GPU (feature `gpu`) follow the CPU within
//! `SOFT_GPU_TOLERANCE`; what the GPU path does not run is refused.
//!
//! Run: `cargo test -p inertia-physics --features gpu --test integration issue_16_gpu_soft::`.
//! Without a GPU these run on Mesa lavapipe; with no adapter at all they
//! are skipped when `INERTIA_SKIP_GPU_TESTS=1`.
#![cfg(feature = "gpu")]

use inertia_physics::glam::DVec3;
use inertia_physics::gpu::SOFT_GPU_TOLERANCE;
use inertia_physics::{
    Backend, PhysicsError, SoftBodyHandle, SoftCloth, SoftMaterial, SoftSolid, SolidShape, World,
    WorldConfig,
};

const DT: f64 = 1.0 / 60.0;

fn skip() -> bool {
    std::env::var("INERTIA_SKIP_GPU_TESTS").is_ok_and(|v| v == "1")
}

fn scene(w: &mut World) -> (SoftBodyHandle, SoftBodyHandle) {
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let cloth = SoftCloth {
        corner: DVec3::new(-1.0, 3.0, 0.0),
        across: DVec3::new(2.0, 0.0, 0.0),
        down: DVec3::new(0.0, 0.0, 2.0),
        rows: 32,
        cols: 32,
        pinned: vec![[0, 0], [0, 31]],
        tethers: true,
        ..SoftCloth::default()
    };
    let c = w.add_soft_body(&cloth.build().unwrap()).unwrap();
    let mut jelly = SoftSolid {
        shape: SolidShape::Box {
            half_extents: DVec3::new(0.3, 0.2, 0.2),
        },
        position: DVec3::new(3.0, 2.0, 0.0),
        cell: 0.1,
        edge_compliance: 1e-4,
        material: SoftMaterial::default(),
        ..SoftSolid::default()
    }
    .build()
    .unwrap();
    // Pin one end, so it sags as a cantilever.
    for (k, p) in jelly.positions.clone().iter().enumerate() {
        if p.x < 2.75 {
            jelly.masses[k] = 0.0;
        }
    }
    let j = w.add_soft_body(&jelly).unwrap();
    (c, j)
}

#[test]
fn issue_16_soft_bodies_on_the_gpu_follow_the_cpu() {
    if skip() {
        return;
    }
    let mut cpu = World::new(WorldConfig::default()).unwrap();
    let mut gpu = World::new(WorldConfig::default()).unwrap();
    let (c, j) = scene(&mut cpu);
    scene(&mut gpu);
    gpu.set_soft_backend(c, Backend::Gpu).unwrap();
    gpu.set_soft_backend(j, Backend::Gpu).unwrap();
    println!("on {}", gpu.gpu_context().unwrap().description());
    for _ in 0..60 {
        cpu.step(DT).unwrap();
        gpu.step(DT).unwrap();
    }
    for h in [c, j] {
        let (a, b) = (cpu.soft_body(h).unwrap(), gpu.soft_body(h).unwrap());
        assert_eq!(b.backend(), Backend::Gpu);
        let worst = a
            .positions()
            .iter()
            .zip(b.positions())
            .map(|(p, q)| (*p - *q).length())
            .fold(0.0f32, f32::max);
        let moved = a
            .positions()
            .iter()
            .zip(b.velocities())
            .map(|(_, v)| v.length())
            .fold(0.0f32, f32::max);
        println!(
            "{h:?}: the GPU stands at most {worst:.2e} m from the CPU (fastest {moved:.2} m/s)"
        );
        assert!(worst < SOFT_GPU_TOLERANCE, "{worst}");
    }
    // Back on the CPU, it carries on from where the GPU left it.
    let before = gpu.soft_body(c).unwrap().positions().to_vec();
    gpu.set_soft_backend(c, Backend::Cpu).unwrap();
    assert_eq!(gpu.soft_body(c).unwrap().positions(), before.as_slice());
    gpu.step(DT).unwrap();
    assert!(gpu
        .soft_body(c)
        .unwrap()
        .positions()
        .iter()
        .all(|p| p.is_finite()));
}

#[test]
fn issue_16_what_the_gpu_does_not_run_is_refused() {
    if skip() {
        return;
    }
    let mut w = World::new(WorldConfig::default()).unwrap();
    let cloth = SoftCloth {
        material: SoftMaterial {
            collision_radius: 0.01,
            ..SoftMaterial::default()
        },
        ..SoftCloth::default()
    };
    let h = w.add_soft_body(&cloth.build().unwrap()).unwrap();
    assert!(matches!(
        w.set_soft_backend(h, Backend::Gpu),
        Err(PhysicsError::Gpu(m)) if m.contains("contacts")
    ));
    assert_eq!(w.soft_body(h).unwrap().backend(), Backend::Cpu);
}
