//! Bit-determinism: thread counts, save/restore, and the state hash.

use crate::common;

use inertia_physics::glam::DVec3;
use inertia_physics::{
    build_cloth, build_rope, Buoyancy, ClothDesc, Drag, Explosion, GravityMethod, Integrator,
    MutualGravity, ParticleDesc, RopeDesc, SystemDesc, UniformGravity, Wind, World, WorldConfig,
};

/// A scene that touches every force, every integrator and the parallel
/// paths (systems larger than one work chunk).
fn scene(threads: usize) -> World {
    let mut w = World::new(WorldConfig {
        threads,
        ..WorldConfig::default()
    })
    .unwrap();
    let mut rng = common::Rng(42);

    // A large particle cloud: gravity, drag, wind, buoyancy, an explosion, control.
    let cloud = w.add_system(SystemDesc::with_integrator(Integrator::SymplecticEuler));
    w.add_force(cloud, UniformGravity::earth()).unwrap();
    w.add_force(cloud, Drag::default()).unwrap();
    w.add_force(
        cloud,
        Wind {
            velocity: DVec3::new(4.0, 0.0, 1.0),
            ..Wind::default()
        },
    )
    .unwrap();
    w.add_force(
        cloud,
        Buoyancy {
            surface_height: -2.0,
            fluid_drag: 2.0,
            ..Buoyancy::default()
        },
    )
    .unwrap();
    w.add_force(
        cloud,
        Explosion {
            center: DVec3::new(0.0, 1.0, 0.0),
            start_time: 0.05,
            front_speed: 60.0,
            max_radius: 20.0,
            ..Explosion::default()
        },
    )
    .unwrap();
    let descs: Vec<ParticleDesc> = (0..10_000)
        .map(|i| ParticleDesc {
            position: rng.in_ball(5.0) + DVec3::new(0.0, 3.0, 0.0),
            velocity: rng.in_ball(2.0),
            mass: 0.1 + rng.f64(),
            drag_linear: 0.05 * rng.f64(),
            drag_quadratic: 0.01 * rng.f64(),
            area: 0.01 + 0.02 * rng.f64(),
            volume: 0.001 * rng.f64(),
            group: (i % 3) as u32,
            pinned: i % 997 == 0,
        })
        .collect();
    let hs = w.add_particles(cloud, &descs).unwrap();
    w.set_group_control(cloud, 1, DVec3::new(0.0, 0.5, 0.0))
        .unwrap();
    w.set_control_force(hs[5], DVec3::new(1.0, 0.0, 0.0))
        .unwrap();

    // Cloth under gravity and wind, leapfrog.
    let cloth_sys = w.add_system(SystemDesc::with_integrator(Integrator::Leapfrog));
    w.add_force(cloth_sys, UniformGravity::earth()).unwrap();
    w.add_force(cloth_sys, Wind::default()).unwrap();
    build_cloth(
        &mut w,
        cloth_sys,
        &ClothDesc {
            nu: 70,
            nv: 70,
            pinned: vec![(0, 0), (69, 0)],
            ..ClothDesc::default()
        },
    )
    .unwrap();

    // A rope on Verlet, a Barnes–Hut cluster on RK4, an exact cluster on forward Euler.
    let rope_sys = w.add_system(SystemDesc::with_integrator(Integrator::Verlet));
    w.add_force(rope_sys, UniformGravity::earth()).unwrap();
    build_rope(
        &mut w,
        rope_sys,
        &RopeDesc {
            segments: 30,
            ..RopeDesc::default()
        },
    )
    .unwrap();
    for (integrator, method, n) in [
        (
            Integrator::Rk4,
            GravityMethod::BarnesHut { theta: 0.6 },
            5000,
        ),
        (Integrator::ForwardEuler, GravityMethod::Exact, 300),
    ] {
        let s = w.add_system(SystemDesc::with_integrator(integrator));
        w.add_force(
            s,
            MutualGravity {
                g_constant: 1e-3,
                softening: 0.05,
                method,
            },
        )
        .unwrap();
        let d: Vec<_> = (0..n)
            .map(|_| ParticleDesc::at(rng.in_ball(3.0), 1.0).with_velocity(rng.in_ball(0.1)))
            .collect();
        w.add_particles(s, &d).unwrap();
    }
    w
}

fn run_hashes(w: &mut World, steps: usize) -> Vec<u64> {
    (0..steps)
        .map(|_| {
            w.step(1.0 / 60.0).unwrap();
            w.state_hash()
        })
        .collect()
}

#[test]
fn one_and_two_threads_are_bit_identical() {
    let a = run_hashes(&mut scene(1), 12);
    let b = run_hashes(&mut scene(2), 12);
    assert_eq!(a, b);
    // The scene really moves: every step changes the hash.
    for w in a.windows(2) {
        assert_ne!(w[0], w[1]);
    }
}

#[test]
fn restore_then_step_equals_never_saved_then_step() {
    let mut reference = scene(2);
    run_hashes(&mut reference, 5);
    let saved = reference.save();
    let hash_at_save = reference.state_hash();
    let expected = run_hashes(&mut reference, 8);

    let mut restored = World::new(WorldConfig {
        threads: 1,
        ..WorldConfig::default()
    })
    .unwrap();
    restored.restore(&saved).unwrap();
    assert_eq!(restored.state_hash(), hash_at_save);
    assert_eq!(restored.save(), saved, "save(restore(x)) == x");
    assert_eq!(run_hashes(&mut restored, 8), expected);
}

#[test]
fn restore_in_place_rewinds() {
    let mut w = scene(1);
    let saved = w.save();
    let h0 = w.state_hash();
    let first = run_hashes(&mut w, 4);
    w.restore(&saved).unwrap();
    assert_eq!(w.state_hash(), h0);
    assert_eq!(w.tick(), 0);
    assert_eq!(run_hashes(&mut w, 4), first);
}

#[test]
fn every_bit_of_state_is_in_the_hash() {
    let w = scene(1);
    let h = w.state_hash();
    let mut w2 = scene(1);
    assert_eq!(w2.state_hash(), h);
    let p = w2
        .systems()
        .next()
        .unwrap()
        .particle_handles()
        .nth(17)
        .unwrap();
    let pos = w2.particle(p).unwrap().position;
    w2.set_position(
        p,
        DVec3::new(pos.x, pos.y, f64::from_bits(pos.z.to_bits() ^ 1)),
    )
    .unwrap();
    assert_ne!(w2.state_hash(), h);
}

#[test]
fn saved_state_is_compact() {
    let w = scene(1);
    let particles: usize = w.systems().map(|s| s.len()).sum();
    let bytes = w.save().len();
    // 12 f64 + 2 u32 per particle plus slots and springs; no per-particle framing.
    assert!(
        bytes < particles * 200,
        "{bytes} bytes for {particles} particles"
    );
}

/// The fused Euler pass takes particles four at a time where it can; a
/// particle stepped alone (scalar path) must end with the same bits.
#[test]
fn four_wide_and_scalar_paths_agree_bit_for_bit() {
    for integrator in [Integrator::ForwardEuler, Integrator::SymplecticEuler] {
        let mut rng = common::Rng(9);
        let descs: Vec<ParticleDesc> = (0..64)
            .map(|i| ParticleDesc {
                position: rng.in_ball(3.0),
                velocity: rng.in_ball(4.0),
                mass: 0.2 + rng.f64(),
                drag_linear: 0.1 * rng.f64(),
                drag_quadratic: 0.05 * rng.f64(),
                area: 0.1 * rng.f64(),
                group: (i % 2) as u32,
                ..ParticleDesc::default()
            })
            .collect();
        let setup = |w: &mut World, s| {
            w.add_force(s, UniformGravity::earth()).unwrap();
            w.add_force(s, Drag::default()).unwrap();
            w.add_force(
                s,
                Wind {
                    velocity: DVec3::new(3.0, 0.5, -1.0),
                    ..Wind::default()
                },
            )
            .unwrap();
            w.add_force(
                s,
                Wind {
                    velocity: DVec3::new(-1.0, 0.0, 2.0),
                    ..Wind::default()
                },
            )
            .unwrap();
            w.set_group_control(s, 1, DVec3::new(0.1, 0.2, 0.3))
                .unwrap();
        };
        // All together: blocks of four.
        let mut together = common::world();
        let s = together.add_system(SystemDesc::with_integrator(integrator));
        setup(&mut together, s);
        let hs = together.add_particles(s, &descs).unwrap();
        together
            .set_control_force(hs[6], DVec3::new(0.5, 0.0, 0.0))
            .unwrap();
        // One system per particle: the scalar path.
        let mut alone = common::world();
        let singles: Vec<_> = descs
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let s = alone.add_system(SystemDesc::with_integrator(integrator));
                setup(&mut alone, s);
                let h = alone.add_particle(s, *d).unwrap();
                if i == 6 {
                    alone
                        .set_control_force(h, DVec3::new(0.5, 0.0, 0.0))
                        .unwrap();
                }
                h
            })
            .collect();
        for _ in 0..50 {
            together.step(1.0 / 60.0).unwrap();
            alone.step(1.0 / 60.0).unwrap();
        }
        for (a, b) in hs.iter().zip(&singles) {
            let (pa, pb) = (together.particle(*a).unwrap(), alone.particle(*b).unwrap());
            assert_eq!(
                pa.position.to_array().map(f64::to_bits),
                pb.position.to_array().map(f64::to_bits)
            );
            assert_eq!(
                pa.velocity.to_array().map(f64::to_bits),
                pb.velocity.to_array().map(f64::to_bits)
            );
        }
    }
}
