//! The particle engine's force generators acting on rigid bodies.

use crate::common;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{Buoyancy, Drag, Explosion, MutualGravity, PhysicsError, Wind, World};

const WATER: f64 = 1000.0;

fn floating(shape: Shape, density_ratio: f64, pose: Pose) -> (World, inertia_physics::BodyHandle) {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    // Equilibrium is approached slowly under heavy fluid drag: keep the body
    // awake so the test measures where it floats, not where it fell asleep.
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = false;
    w.set_solver_config(cfg).unwrap();
    w.add_body_force(Buoyancy {
        surface_height: 0.0,
        up: DVec3::Y,
        fluid_density: WATER,
        gravity: 9.81,
        fluid_drag: 400.0,
    })
    .unwrap();
    let h = w
        .add_body(&RigidBodyDesc::dynamic(shape, density_ratio * WATER, pose).unwrap())
        .unwrap();
    common::run(&mut w, 1.0 / 60.0, 60 * 40);
    (w, h)
}

#[test]
fn boxes_float_at_the_depth_archimedes_predicts() {
    for ratio in [0.25, 0.5, 0.75] {
        let half = DVec3::new(0.5, 0.25, 0.4);
        let (w, h) = floating(
            Shape::cuboid(half).unwrap(),
            ratio,
            Pose::from_translation(DVec3::Y * 1.0),
        );
        let b = w.body(h).unwrap();
        // Submerged depth = ratio × height; the bottom is at -ratio·2·half.y.
        let expected = -ratio * 2.0 * half.y + half.y;
        let y = b.center_of_mass().y;
        assert!(
            (y - expected).abs() < 1e-3,
            "density ratio {ratio}: centre at {y}, expected {expected}"
        );
        assert!(b.linear_velocity().length() < 1e-3 && b.angular_velocity().length() < 1e-3);
    }
}

#[test]
fn a_ball_of_half_the_waters_density_floats_half_submerged() {
    let (w, h) = floating(
        Shape::sphere(0.3).unwrap(),
        0.5,
        Pose::from_translation(DVec3::Y * 2.0),
    );
    let y = w.body(h).unwrap().center_of_mass().y;
    assert!(y.abs() < 1e-3, "{y}");
}

#[test]
fn a_tilted_raft_rights_itself() {
    // A wide, flat raft dropped at 25°: the centre of buoyancy moves to the
    // low side and the torque levels it.
    let tilt = DQuat::from_rotation_x(25f64.to_radians());
    let (w, h) = floating(
        Shape::cuboid(DVec3::new(1.0, 0.1, 1.0)).unwrap(),
        0.5,
        Pose::new(DVec3::Y * 0.5, tilt),
    );
    let up = w.body(h).unwrap().pose().rotation * DVec3::Y;
    assert!(up.dot(DVec3::Y) > 0.9999, "raft still tilted: up = {up}");
}

#[test]
fn wind_pushes_on_the_area_a_body_shows() {
    let mut w = common::world();
    let wind = Wind {
        velocity: DVec3::new(10.0, 0.0, 0.0),
        air_density: 1.2,
        pressure_coefficient: 1.0,
    };
    w.add_body_force(wind).unwrap();
    let board = Shape::cuboid(DVec3::new(0.05, 1.0, 1.5)).unwrap(); // 2 × 3 m face towards the wind
    let h = w
        .add_body(&RigidBodyDesc::dynamic(board, 100.0, Pose::IDENTITY).unwrap())
        .unwrap();
    let m = w.body(h).unwrap().mass();
    let dt = 1e-4;
    w.step(dt).unwrap();
    let f = w.body(h).unwrap().linear_velocity().x * m / dt;
    let expected = 0.5 * 1.2 * 100.0 * 6.0;
    assert!((f - expected).abs() < 1e-6 * expected, "{f} vs {expected}");
    // Face-on and symmetric: no torque.
    assert!(w.body(h).unwrap().angular_velocity().length() < 1e-12);
}

#[test]
fn off_centre_wind_turns_a_weathervane() {
    // A compound: a heavy ball at the pivot and a light vane behind it; the
    // wind pushes the vane, so the body turns about its centre of mass.
    let mut w = common::world();
    w.add_body_force(Wind {
        velocity: DVec3::new(0.0, 0.0, 8.0),
        air_density: 1.2,
        pressure_coefficient: 1.0,
    })
    .unwrap();
    let vane = Shape::compound(vec![
        (Pose::IDENTITY, Shape::sphere(0.2).unwrap()),
        (
            Pose::from_translation(DVec3::new(1.0, 0.0, 0.0)),
            Shape::cuboid(DVec3::new(0.5, 0.3, 0.02)).unwrap(),
        ),
    ])
    .unwrap();
    let h = w
        .add_body(&RigidBodyDesc::dynamic(vane, 50.0, Pose::IDENTITY).unwrap())
        .unwrap();
    w.step(0.01).unwrap();
    let omega = w.body(h).unwrap().angular_velocity();
    // Force +Z applied at +X of the centre of mass: torque r × F along -Y.
    assert!(omega.y < -1e-6, "{omega}");
}

#[test]
fn body_drag_reaches_terminal_velocity() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    w.add_body_force(Drag::default()).unwrap();
    let mut d =
        RigidBodyDesc::dynamic(Shape::sphere(0.1).unwrap(), 1000.0, Pose::IDENTITY).unwrap();
    d.drag_quadratic = 0.02;
    let h = w.add_body(&d).unwrap();
    common::run(&mut w, 1.0 / 120.0, 120 * 30);
    let b = w.body(h).unwrap();
    let expected = (b.mass() * 9.81 / 0.02).sqrt();
    let v = -b.linear_velocity().y;
    assert!((v - expected).abs() / expected < 0.01, "{v} vs {expected}");
}

#[test]
fn a_blast_gives_a_body_the_impulse_on_its_shown_area() {
    let blast = Explosion {
        center: DVec3::ZERO,
        front_speed: 200.0,
        front_thickness: 0.5,
        peak_pressure: 5e4,
        max_radius: 50.0,
        ..Explosion::default()
    };
    let mut w = common::world();
    w.add_body_force(blast).unwrap();
    let crate_shape = Shape::cuboid(DVec3::splat(0.5)).unwrap(); // a 1 m cube, face-on to the blast
    let h = w
        .add_body(
            &RigidBodyDesc::dynamic(crate_shape, 200.0, Pose::from_translation(DVec3::X * 10.0))
                .unwrap(),
        )
        .unwrap();
    common::run(&mut w, 1.0 / 240.0, 40);
    let b = w.body(h).unwrap();
    let expected = blast.impulse_at(10.0, 1.0) / b.mass();
    let v = b.linear_velocity();
    assert!(
        (v.x - expected).abs() < 1e-3 * expected && v.y.abs() < 1e-12,
        "{v} vs {expected}"
    );
}

#[test]
fn mutual_gravity_between_bodies_is_refused() {
    let mut w = common::world();
    assert!(matches!(
        w.add_body_force(MutualGravity::default()),
        Err(PhysicsError::Invalid { .. })
    ));
    assert!(w
        .add_body_force(Wind {
            air_density: -1.0,
            ..Wind::default()
        })
        .is_err());
}

/// Cloth keeps out of a rigid ball and drapes over it.
#[test]
fn cloth_drapes_over_a_rigid_ball() {
    use inertia_physics::{build_cloth, ClothDesc, SystemDesc, UniformGravity};
    let mut w = common::world();
    let ball = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::sphere(0.5).unwrap(),
            Pose::IDENTITY,
        ))
        .unwrap();
    let radius = 0.02;
    let sys = w.add_system(SystemDesc {
        collision_radius: radius,
        collision_friction: 0.5,
        ..SystemDesc::default()
    });
    w.add_force(sys, UniformGravity::earth()).unwrap();
    let cloth = build_cloth(
        &mut w,
        sys,
        &ClothDesc {
            origin: DVec3::new(-1.0, 1.0, 1.0),
            nu: 24,
            nv: 24,
            width: 2.0,
            height: 2.0,
            drag_linear: 0.002,
            ..ClothDesc::default()
        },
    )
    .unwrap();
    common::run(&mut w, 1.0 / 60.0, 180);
    let s = w.system(sys).unwrap();
    let worst = s
        .positions()
        .iter()
        .map(|p| p.length())
        .fold(f64::INFINITY, f64::min);
    assert!(
        worst > 0.5 + radius - 1e-3,
        "a particle is inside the ball: {worst}"
    );
    // The middle of the cloth rests on top of the ball.
    let mid = w.particle(cloth.particles[12 * 24 + 12]).unwrap().position;
    assert!(mid.y > 0.5 && mid.y < 0.6 && mid.x.abs() < 0.1, "{mid}");
    // And the edges hang below it.
    let corner = w.particle(cloth.particles[0]).unwrap().position;
    assert!(corner.y < 0.2, "{corner}");
    assert!(w.body(ball).unwrap().linear_velocity() == DVec3::ZERO);
}

/// A stream of heavy particles hits a free box in empty space: the box
/// takes the momentum the particles lose, and the total is conserved.
#[test]
fn particles_and_bodies_exchange_momentum() {
    use inertia_physics::{ParticleDesc, SystemDesc};
    let mut w = common::world();
    let cube = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                100.0,
                Pose::IDENTITY,
            )
            .unwrap(),
        )
        .unwrap();
    let sys = w.add_system(SystemDesc {
        collision_radius: 0.05,
        collision_friction: 0.3,
        ..SystemDesc::default()
    });
    let mut rng = common::Rng(11);
    for _ in 0..60 {
        let p = DVec3::new(
            rng.range(-4.0, -1.0),
            rng.range(-0.6, 0.6),
            rng.range(-0.6, 0.6),
        );
        w.add_particle(
            sys,
            ParticleDesc {
                velocity: DVec3::new(10.0, rng.range(-1.0, 1.0), 0.0),
                ..ParticleDesc::at(p, 1.0)
            },
        )
        .unwrap();
    }
    let momentum = |w: &World| {
        let s = w.system(sys).unwrap();
        let particles: DVec3 = s
            .velocities()
            .iter()
            .zip(s.inverse_masses())
            .map(|(v, im)| *v / *im)
            .sum();
        particles + w.body(cube).unwrap().linear_momentum()
    };
    let before = momentum(&w);
    common::run(&mut w, 1.0 / 60.0, 90);
    let after = momentum(&w);
    let error = (after - before).length() / before.length();
    eprintln!(
        "momentum before {before}, after {after}: relative error {error:.2e}; box now at {} m/s",
        w.body(cube).unwrap().linear_velocity()
    );
    assert!(error < 1e-9, "momentum changed by {error}");
    assert!(
        w.body(cube).unwrap().linear_velocity().x > 0.5,
        "the box was not pushed"
    );
}

/// Particles resting on a box weigh on it: the ground carries the box and
/// the particles.
#[test]
fn particles_resting_on_a_body_weigh_on_it() {
    use inertia_physics::{ParticleDesc, SystemDesc};
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(5.0, 0.5, 5.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))
    .unwrap();
    let mut desc = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::splat(0.5)).unwrap(),
        100.0,
        Pose::from_translation(DVec3::Y * 0.5),
    )
    .unwrap();
    desc.contact_force_threshold = 0.0;
    let cube = w.add_body(&desc).unwrap();
    let sys = w.add_system(SystemDesc {
        collision_radius: 0.05,
        collision_friction: 0.5,
        ..SystemDesc::default()
    });
    let (n, m) = (25, 2.0);
    for i in 0..n {
        let p = DVec3::new((i % 5) as f64 * 0.2 - 0.4, 1.1, (i / 5) as f64 * 0.2 - 0.4);
        w.add_particle(sys, ParticleDesc::at(p, m)).unwrap();
    }
    let mut load = 0.0;
    let steps = 60;
    common::run(&mut w, 1.0 / 60.0, 120);
    for _ in 0..steps {
        let report = w.step(1.0 / 60.0).unwrap();
        load += report
            .contact_forces
            .iter()
            .filter(|f| f.a == cube || f.b == cube)
            .map(|f| f.force)
            .sum::<f64>();
    }
    load /= f64::from(steps);
    let expected = (100.0 + f64::from(n) * m) * 9.81;
    eprintln!("ground carries {load:.1} N; box and particles weigh {expected:.1} N");
    assert!(
        (load - expected).abs() < 0.05 * expected,
        "ground carries {load} N, expected {expected} N"
    );
    let top = w
        .system(sys)
        .unwrap()
        .positions()
        .iter()
        .map(|p| p.y)
        .fold(f64::INFINITY, f64::min);
    assert!(
        top > 1.0 + 0.05 - 2e-3,
        "a particle sank into the box: {top}"
    );
}

/// A particle hangs from a body by a spring, and a body hangs from a pinned
/// particle: each end pulls the other.
#[test]
fn springs_join_particles_and_bodies_both_ways() {
    use inertia_physics::{ParticleDesc, SpringParams, SystemDesc, UniformGravity};
    let (k, rest) = (200.0, 1.0);
    let params = SpringParams {
        rest_length: rest,
        stiffness: k,
        damping: 5.0,
    };
    // A 2 kg particle under a fixed beam settles mg/k below the rest length.
    let mut w = common::world();
    let beam = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(DVec3::new(1.0, 0.1, 0.1)).unwrap(),
            Pose::from_translation(DVec3::Y * 3.0),
        ))
        .unwrap();
    let sys = w.add_system(SystemDesc::default());
    w.add_force(sys, UniformGravity::earth()).unwrap();
    let p = w
        .add_particle(sys, ParticleDesc::at(DVec3::new(0.5, 2.0, 0.0), 2.0))
        .unwrap();
    w.attach_particle(p, beam, DVec3::new(0.5, -0.1, 0.0), params)
        .unwrap();
    common::run(&mut w, 1.0 / 120.0, 120 * 10);
    let y = w.particle(p).unwrap().position.y;
    let expected = 2.9 - rest - 2.0 * 9.81 / k;
    assert!(
        (y - expected).abs() < 1e-3,
        "particle at {y}, expected {expected}"
    );

    // A 4 kg ball hanging from a pinned particle settles too, and the spring
    // that holds it is the only thing that does.
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let sys = w.add_system(SystemDesc::default());
    let hook = w
        .add_particle(
            sys,
            ParticleDesc {
                pinned: true,
                ..ParticleDesc::at(DVec3::Y * 5.0, 1.0)
            },
        )
        .unwrap();
    let ball = Shape::sphere(0.1).unwrap();
    let density = 4.0 / ball.volume().unwrap();
    let b = w
        .add_body(
            &RigidBodyDesc::dynamic(ball, density, Pose::from_translation(DVec3::Y * 4.0)).unwrap(),
        )
        .unwrap();
    let h = w.attach_particle(hook, b, DVec3::ZERO, params).unwrap();
    common::run(&mut w, 1.0 / 120.0, 120 * 10);
    let y = w.body(b).unwrap().center_of_mass().y;
    let expected = 5.0 - rest - 4.0 * 9.81 / k;
    assert!(
        (y - expected).abs() < 1e-3,
        "ball at {y}, expected {expected}"
    );
    // Removing the spring drops the ball; a stale handle is refused.
    w.detach_particle(h).unwrap();
    assert!(w.detach_particle(h).is_err());
    common::run(&mut w, 1.0 / 120.0, 60);
    assert!(w.body(b).unwrap().center_of_mass().y < expected - 0.5);
}
