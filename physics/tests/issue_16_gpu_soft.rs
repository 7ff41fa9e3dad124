//! Soft bodies on the GPU (feature `gpu`) follow the CPU within
//! `SOFT_GPU_TOLERANCE`, touch rigid bodies and push them back as the CPU
//! does; what the GPU path does not run is refused.
//!
//! Run: `cargo test -p inertia-physics --features gpu --test integration issue_16_gpu_soft::`.
//! Without a GPU these run on Mesa lavapipe; with no adapter at all they
//! are skipped when `INERTIA_SKIP_GPU_TESTS=1`.
#![cfg(feature = "gpu")]

use inertia_physics::glam::DVec3;
use inertia_physics::gpu::SOFT_GPU_TOLERANCE;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{
    Backend, BodyHandle, PhysicsError, SoftBodyHandle, SoftCloth, SoftMaterial, SoftSolid,
    SolidShape, World, WorldConfig,
};

use crate::common::at;

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

/// A hammock (`common::hammock`, 10 substeps) with its crate above it,
/// in a world that reads the GPU back every step (or not).
fn hammock(readback: bool) -> (World, SoftBodyHandle, BodyHandle) {
    let mut w = World::new(WorldConfig {
        gpu_readback_every_step: readback,
        ..WorldConfig::default()
    })
    .unwrap();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let (h, b) = crate::common::hammock(&mut w, 10);
    (w, h, b)
}

/// Contacts on the GPU: the cloth slows a falling crate down as it does
/// on the CPU (the crate takes the cloth's impulses, summed on the GPU in
/// a fixed order), and a second run repeats the first bit for bit.
#[test]
fn issue_16_a_cloth_on_the_gpu_catches_a_crate_as_the_cpu_does() {
    if skip() {
        return;
    }
    let (mut cpu, h, b) = hammock(true);
    let (mut gpu, _, _) = hammock(true);
    let (mut again, _, _) = hammock(false);
    gpu.set_soft_backend(h, Backend::Gpu).unwrap();
    again.set_soft_backend(h, Backend::Gpu).unwrap();
    // Half a second: the crate falls onto the cloth and the cloth slows
    // it down (past it, the crate bounces on the cloth and the runs part,
    // as two runs of a bouncing crate part for any rounding).
    let steps = 30;
    for _ in 0..steps {
        cpu.step(DT).unwrap();
        gpu.step(DT).unwrap();
        again.step(DT).unwrap();
    }
    again.sync_gpu().unwrap();
    let (a, g) = (cpu.body(b).unwrap(), gpu.body(b).unwrap());
    let (ya, yg) = (a.center_of_mass().y, g.center_of_mass().y);
    let cloth = |w: &World| w.soft_body(h).unwrap().positions().to_vec();
    let (ca, cg) = (cloth(&cpu), cloth(&gpu));
    let worst = ca
        .iter()
        .zip(&cg)
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0f32, f32::max);
    let lowest = cg.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    println!(
        "after {steps} steps the crate stands at y = {ya:.4} m on the CPU, {yg:.4} m on the GPU \
         ({:.2e} m apart, speed {:.2e} and {:.2e} m/s); the cloth's particles stand at most \
         {worst:.2e} m apart, its lowest at {lowest:.3} m",
        (a.center_of_mass() - g.center_of_mass()).length(),
        a.linear_velocity().length(),
        g.linear_velocity().length()
    );
    // Slowed by the cloth (falling freely it would go at 4.9 m/s), as on
    // the CPU.
    let free_fall = 9.81 * steps as f64 * DT;
    assert!(
        g.linear_velocity().length() < 0.7 * free_fall,
        "the cloth slows the crate"
    );
    assert!((a.center_of_mass() - g.center_of_mass()).length() < 5e-3);
    assert!((a.linear_velocity() - g.linear_velocity()).length() < 0.05);
    assert!(worst < 0.01, "{worst}");
    let c = again.body(b).unwrap();
    assert_eq!(
        g.center_of_mass().to_array().map(f64::to_bits),
        c.center_of_mass().to_array().map(f64::to_bits)
    );
    assert_eq!(
        cloth(&again)
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>(),
        cg.iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    );
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
            self_collision: true,
            ..SoftMaterial::default()
        },
        ..SoftCloth::default()
    };
    let h = w.add_soft_body(&cloth.build().unwrap()).unwrap();
    assert!(matches!(
        w.set_soft_backend(h, Backend::Gpu),
        Err(PhysicsError::Gpu(m)) if m.contains("self-collision")
    ));
    assert_eq!(w.soft_body(h).unwrap().backend(), Backend::Cpu);
}

/// A body of a shape the GPU does not project onto, near a cloth with
/// contacts: moving the cloth to the GPU is refused; one that comes near
/// later moves it back to the CPU for the step, which the report says.
#[test]
fn issue_16_a_body_the_gpu_cannot_take_moves_a_soft_body_to_the_cpu() {
    if skip() {
        return;
    }
    let (mut w, h, _) = hammock(true);
    let post = RigidBodyDesc::fixed(
        Shape::cylinder(0.2, 0.05).unwrap(),
        at(DVec3::new(0.5, 0.9, 0.5)),
    );
    let post = w.add_body(&post).unwrap();
    assert!(matches!(
        w.set_soft_backend(h, Backend::Gpu),
        Err(PhysicsError::Gpu(m)) if m.contains("cylinder")
    ));
    w.remove_body(post).unwrap();
    w.set_soft_backend(h, Backend::Gpu).unwrap();
    assert!(w.step(DT).unwrap().soft_bodies_to_cpu.is_empty());
    let post = RigidBodyDesc::fixed(
        Shape::cylinder(0.2, 0.05).unwrap(),
        at(DVec3::new(0.5, 0.9, 0.5)),
    );
    w.add_body(&post).unwrap();
    let report = w.step(DT).unwrap();
    assert!(matches!(
        &report.soft_bodies_to_cpu[..],
        [(s, PhysicsError::Gpu(m))] if *s == h && m.contains("cylinder")
    ));
    assert_eq!(w.soft_body(h).unwrap().backend(), Backend::Cpu);
    assert!(w
        .soft_body(h)
        .unwrap()
        .positions()
        .iter()
        .all(|p| p.is_finite()));
}
