//! Soft bodies on the GPU (feature `gpu`) follow the CPU within
//! `SOFT_GPU_TOLERANCE`, touch rigid bodies and push them back, hang from
//! them, keep their inflated volume, flow plastically, tear and keep a
//! folded sheet's layers apart as the CPU does; a body near a shape the
//! GPU does not touch goes back to the CPU.
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
    Backend, BodyHandle, PhysicsError, SoftBalloon, SoftBody, SoftBodyHandle, SoftCloth,
    SoftMaterial, SoftRope, SoftSolid, SolidShape, World, WorldConfig,
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

/// A sheet folded in two on the ground, its upper half 3 cm above its
/// lower half (`issue_16_soft`'s scene): with self-collision on the GPU
/// the upper half rests on the lower, as on the CPU, where without it
/// falls through. Candidates come from the GPU's neighbour grid.
#[test]
fn issue_16_a_folded_cloth_on_the_gpu_keeps_its_layers_apart_as_the_cpu_does() {
    if skip() {
        return;
    }
    let run = |backend: Backend, self_collision: bool| {
        let mut w = World::new(WorldConfig {
            gpu_readback_every_step: false,
            ..WorldConfig::default()
        })
        .unwrap();
        w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
        crate::common::ground(&mut w);
        let desc = crate::common::folded_sheet(self_collision);
        let h = w.add_soft_body(&desc).unwrap();
        w.set_soft_backend(h, backend).unwrap();
        for _ in 0..90 {
            w.step(DT).unwrap();
        }
        w.sync_gpu().unwrap();
        let b = w.soft_body(h).unwrap().clone();
        assert_eq!(b.backend(), backend);
        b
    };
    let upper = crate::common::upper_half_height;
    let cpu = run(Backend::Cpu, true);
    let gpu = run(Backend::Gpu, true);
    let through = run(Backend::Gpu, false);
    println!(
        "the upper half lies {:.4} m high on the CPU, {:.4} m on the GPU, {:.4} m on the GPU \
         without self-collision; the GPU at most {:.2e} m from the CPU",
        upper(&cpu),
        upper(&gpu),
        upper(&through),
        farthest(&cpu, &gpu)
    );
    assert!(
        upper(&gpu) > 0.012 + 0.8 * 0.024,
        "it rests on the lower half"
    );
    assert!(
        upper(&through) < 0.02,
        "without self-collision it falls through"
    );
    assert!((upper(&cpu) - upper(&gpu)).abs() < 2e-3);
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

/// The particle of `a` farthest from its twin in `b`, m.
fn farthest(a: &SoftBody, b: &SoftBody) -> f32 {
    a.positions()
        .iter()
        .zip(b.positions())
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0f32, f32::max)
}

/// A rope between two pins with a crate hung from two of its particles
/// (attachments, both ways), an inflated balloon dropped on a slab
/// (pressure, contacts), and a bar bent past its yield by a kinematic
/// hand it is attached to (plasticity; the hand is a cylinder, a shape
/// the GPU does not touch but holds on to).
fn held_inflated_bent(w: &mut World) -> ([SoftBodyHandle; 3], BodyHandle, BodyHandle) {
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    crate::common::ground(w);
    let rope = SoftRope {
        start: DVec3::new(-1.0, 3.0, 5.0),
        end: DVec3::new(1.0, 3.0, 5.0),
        segments: 8,
        mass: 1.0,
        compliance: 0.0,
        pin_start: true,
        pin_end: true,
        tethers: false,
        material: SoftMaterial {
            substeps: 20,
            damping: 0.5,
            ..SoftMaterial::default()
        },
    };
    let r = w.add_soft_body(&rope.build().unwrap()).unwrap();
    let crate_ = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::new(0.3, 0.1, 0.2)).unwrap(),
        50.0,
        at(DVec3::new(0.0, 2.5, 5.0)),
    )
    .unwrap();
    let c = w.add_body(&crate_).unwrap();
    w.attach_soft_to_body(r, 3, c, DVec3::new(-0.25, 3.0, 5.0), 0.0)
        .unwrap();
    w.attach_soft_to_body(r, 5, c, DVec3::new(0.25, 3.0, 5.0), 1e-6)
        .unwrap();
    let balloon = SoftBalloon {
        centre: DVec3::new(0.0, 0.6, -3.0),
        radius: 0.4,
        subdivisions: 3,
        pressure: 1.2,
        material: SoftMaterial {
            collision_radius: 0.01,
            damping: 0.5,
            ..SoftMaterial::default()
        },
        ..SoftBalloon::default()
    };
    let b = w.add_soft_body(&balloon.build().unwrap()).unwrap();
    let (bar, _, hand) = crate::common::plastic_bar(w, 5.0, Shape::cylinder(0.05, 0.02).unwrap());
    ([r, b, bar], c, hand)
}

/// Attachments, pressure and plastic flow on the GPU: the crate hangs
/// from the rope, the balloon keeps its inflated volume on the slab and
/// the bar keeps a set, as on the CPU and within the GPU's tolerance; the
/// bar's rest lengths come back with its positions.
#[test]
fn issue_16_attachments_pressure_and_plasticity_on_the_gpu_follow_the_cpu() {
    if skip() {
        return;
    }
    let mut cpu = World::new(WorldConfig::default()).unwrap();
    let mut gpu = World::new(WorldConfig::default()).unwrap();
    let (bodies, c, hand) = held_inflated_bent(&mut cpu);
    held_inflated_bent(&mut gpu);
    for h in bodies {
        gpu.set_soft_backend(h, Backend::Gpu).unwrap();
    }
    let bend = |w: &mut World, step: usize| {
        let f = (step as f64 / 30.0).min(1.0);
        w.set_body_pose(hand, at(DVec3::new(6.0, 1.0 - 0.3 * f, 0.0)))
            .unwrap();
    };
    for step in 1..=60 {
        bend(&mut cpu, step);
        bend(&mut gpu, step);
        cpu.step(DT).unwrap();
        gpu.step(DT).unwrap();
    }
    let [rope, balloon, bar] =
        bodies.map(|h| (cpu.soft_body(h).unwrap(), gpu.soft_body(h).unwrap()));
    for (name, (a, b)) in [("rope", rope), ("balloon", balloon), ("bar", bar)] {
        assert_eq!(b.backend(), Backend::Gpu, "{name}");
        println!(
            "{name}: the GPU stands at most {:.2e} m from the CPU",
            farthest(a, b)
        );
    }
    // The crate hangs from the rope below where it was hung.
    let (ca, cg) = (cpu.body(c).unwrap(), gpu.body(c).unwrap());
    println!(
        "crate: y = {:.4} m on the CPU, {:.4} m on the GPU",
        ca.center_of_mass().y,
        cg.center_of_mass().y
    );
    assert!(cg.center_of_mass().y < 2.5 && cg.center_of_mass().y > 2.0);
    assert!((ca.center_of_mass() - cg.center_of_mass()).length() < 5e-3);
    assert!(farthest(rope.0, rope.1) < 5e-3);
    // The balloon keeps its inflated volume as on the CPU.
    let (va, vg) = (balloon.0.enclosed_volume(), balloon.1.enclosed_volume());
    println!("balloon: volume {va:.4} m³ on the CPU, {vg:.4} m³ on the GPU");
    assert!((va - vg).abs() < 0.01 * va, "{va} {vg}");
    assert!(farthest(balloon.0, balloon.1) < SOFT_GPU_TOLERANCE);
    // The bar's rest lengths flowed as on the CPU.
    let flowed = |b: &SoftBody| b.edges().filter(|e| e.2 != e.3).count();
    let rest_gap = bar
        .0
        .edges()
        .zip(bar.1.edges())
        .map(|(a, b)| (a.2 - b.2).abs())
        .fold(0.0f32, f32::max);
    println!(
        "bar: {} rest lengths flowed on the CPU, {} on the GPU, at most {rest_gap:.2e} m apart",
        flowed(bar.0),
        flowed(bar.1)
    );
    assert!(flowed(bar.1) > 0);
    assert!(rest_gap < 1e-3, "{rest_gap}");
    assert!(farthest(bar.0, bar.1) < SOFT_GPU_TOLERANCE);
    // Let go, the bar keeps its set on the GPU as on the CPU.
    for w in [&mut cpu, &mut gpu] {
        w.remove_body(hand).unwrap();
        for _ in 0..60 {
            w.step(DT).unwrap();
        }
    }
    let tip_drop = |w: &World| {
        let b = w.soft_body(bodies[2]).unwrap();
        b.positions()
            .iter()
            .map(|p| 1.0 - p.y)
            .fold(0.0f32, f32::max)
    };
    println!(
        "bar let go: its tip stays {:.4} m down on the CPU, {:.4} m on the GPU",
        tip_drop(&cpu),
        tip_drop(&gpu)
    );
    assert!(tip_drop(&gpu) > 0.05);
    assert!((tip_drop(&cpu) - tip_drop(&gpu)).abs() < 0.01);
}

/// A hanging cloth that tears on the GPU tears on the same step and at
/// the same edges as on the CPU: it is read back every step, tears on
/// the CPU, and goes up again.
#[test]
fn issue_16_a_cloth_on_the_gpu_tears_where_the_cpu_does() {
    if skip() {
        return;
    }
    let n = 20;
    let desc = crate::common::tearing_sheet(n);
    let mut worlds = [false, true].map(|_| {
        let mut w = World::new(WorldConfig {
            gpu_readback_every_step: false,
            ..WorldConfig::default()
        })
        .unwrap();
        w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
        let h = w.add_soft_body(&desc).unwrap();
        (w, h)
    });
    let h = worlds[1].1;
    worlds[1].0.set_soft_backend(h, Backend::Gpu).unwrap();
    let edges =
        |w: &World| -> Vec<[u32; 2]> { w.soft_body(h).unwrap().edges().map(|e| e.0).collect() };
    let all = edges(&worlds[0].0);
    let mut first = [None, None];
    for step in 0..600 {
        for (k, (w, _)) in worlds.iter_mut().enumerate() {
            w.step(DT).unwrap();
            if first[k].is_none() && edges(w).len() < all.len() {
                let left = edges(w);
                let torn: Vec<[u32; 2]> =
                    all.iter().filter(|e| !left.contains(e)).copied().collect();
                first[k] = Some((step, torn));
            }
        }
        if first.iter().all(Option::is_some) {
            break;
        }
    }
    let [Some(on_cpu), Some(on_gpu)] = first else {
        panic!("the cloth tore on both: {first:?}");
    };
    println!(
        "first tear on the CPU: step {} {:?}; on the GPU: step {} {:?}",
        on_cpu.0, on_cpu.1, on_gpu.0, on_gpu.1
    );
    assert_eq!(on_cpu, on_gpu);
    // It steps on, torn, on the GPU.
    assert_eq!(worlds[1].0.soft_body(h).unwrap().backend(), Backend::Gpu);
    for (w, _) in &mut worlds {
        for _ in 0..30 {
            w.step(DT).unwrap();
        }
    }
    let (a, b) = (
        worlds[0].0.soft_body(h).unwrap(),
        worlds[1].0.soft_body(h).unwrap(),
    );
    println!(
        "30 steps on: {} and {} edges left, the GPU at most {:.2e} m from the CPU",
        a.edges().count(),
        b.edges().count(),
        farthest(a, b)
    );
    assert!(b.positions().iter().all(|p| p.is_finite()));
    assert!(b.triangles().len() < desc.triangles.len());
}

/// The world keeps each soft body's GPU buffers by its handle's slot: a
/// body removed takes its buffers with it, a body added in its place (or
/// restored from a saved state) steps on the CPU exactly as in a world
/// that never used the GPU.
#[test]
fn issue_42_gpu_buffers_leave_with_their_body() {
    if skip() {
        return;
    }
    let mut gpu = World::new(WorldConfig::default()).unwrap();
    let mut cpu = World::new(WorldConfig::default()).unwrap();
    let (c, j) = scene(&mut gpu);
    scene(&mut cpu);
    gpu.set_soft_backend(c, Backend::Gpu).unwrap();
    gpu.set_soft_backend(j, Backend::Gpu).unwrap();
    gpu.step(DT).unwrap();
    let saved = cpu.save();
    gpu.remove_soft_body(c).unwrap();
    gpu.remove_soft_body(j).unwrap();
    cpu.remove_soft_body(c).unwrap();
    cpu.remove_soft_body(j).unwrap();
    let rope = SoftRope {
        start: DVec3::new(0.0, 2.0, 0.0),
        end: DVec3::new(1.0, 2.0, 0.0),
        segments: 16,
        pin_start: true,
        ..SoftRope::default()
    }
    .build()
    .unwrap();
    let in_gpu = gpu.add_soft_body(&rope).unwrap();
    let in_cpu = cpu.add_soft_body(&rope).unwrap();
    assert_eq!(in_gpu, in_cpu);
    let slot = |h: SoftBodyHandle| h.to_raw()[0];
    assert!(
        slot(in_gpu) == slot(c) || slot(in_gpu) == slot(j),
        "the new body takes a freed slot"
    );
    assert_eq!(gpu.soft_body(in_gpu).unwrap().backend(), Backend::Cpu);
    for _ in 0..10 {
        gpu.step(DT).unwrap();
        cpu.step(DT).unwrap();
    }
    assert_eq!(
        gpu.soft_body(in_gpu).unwrap().positions(),
        cpu.soft_body(in_cpu).unwrap().positions(),
        "the new body stepped on the CPU, as in a world without the GPU"
    );
    // A restored state's soft bodies step on the CPU, bit for bit.
    gpu.set_soft_backend(in_gpu, Backend::Gpu).unwrap();
    gpu.restore(&saved).unwrap();
    let mut cpu = World::from_saved(WorldConfig::default(), &saved).unwrap();
    for _ in 0..10 {
        gpu.step(DT).unwrap();
        cpu.step(DT).unwrap();
    }
    for (h, body) in cpu.soft_bodies() {
        assert_eq!(gpu.soft_body(h).unwrap().backend(), Backend::Cpu);
        assert_eq!(gpu.soft_body(h).unwrap().positions(), body.positions());
    }
}
