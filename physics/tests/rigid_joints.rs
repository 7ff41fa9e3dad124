//! Joints: pendulum period, holding, limits, motors, springs, breaking.

use crate::common;

use std::f64::consts::PI;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::joint::{JointDesc, JointKind};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, World};

const G: f64 = 9.81;

fn anchor(w: &mut World) -> BodyHandle {
    w.add_body(&RigidBodyDesc::fixed(
        Shape::sphere(0.05).unwrap(),
        Pose::IDENTITY,
    ))
    .unwrap()
}

/// A small dense ball on a massless rod of length `l` from a fixed pivot,
/// released at `theta0` from the vertical.
fn pendulum(kind: JointKind, l: f64, r: f64, theta0: f64) -> (World, BodyHandle) {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = false;
    w.set_solver_config(cfg).unwrap();
    let pivot = anchor(&mut w);
    let p = DVec3::new(l * theta0.sin(), -l * theta0.cos(), 0.0);
    let bob = w
        .add_body(
            &RigidBodyDesc::dynamic(Shape::sphere(r).unwrap(), 7800.0, Pose::from_translation(p))
                .unwrap(),
        )
        .unwrap();
    w.add_joint(JointDesc {
        a: pivot,
        b: bob,
        anchor_a: DVec3::ZERO,
        anchor_b: -p,
        kind,
        break_force: f64::MAX,
    })
    .unwrap();
    (w, bob)
}

fn period(w: &mut World, bob: BodyHandle, dt: f64, periods: usize) -> f64 {
    let mut crossings = Vec::new();
    let mut prev = w.body(bob).unwrap().center_of_mass().x;
    let mut t = 0.0;
    while crossings.len() < periods + 1 && t < 60.0 {
        w.step(dt).unwrap();
        t += dt;
        let x = w.body(bob).unwrap().center_of_mass().x;
        if prev < 0.0 && x >= 0.0 {
            crossings.push(t - dt * x / (x - prev));
        }
        prev = x;
    }
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

#[test]
fn a_hinge_pendulum_swings_at_two_pi_root_l_over_g() {
    let (l, r) = (1.0, 0.02);
    let hinge = JointKind::Hinge {
        axis_a: DVec3::Z,
        axis_b: DVec3::Z,
        limits: None,
        motor: None,
    };
    let (mut w, bob) = pendulum(hinge, l, r, 5f64.to_radians());
    // A compound pendulum: I about the pivot is m (l² + 2r²/5); small angle.
    let expected = 2.0 * PI * ((l * l + 0.4 * r * r) / (G * l)).sqrt();
    let measured = period(&mut w, bob, 1.0 / 240.0, 5);
    let rel = (measured - expected).abs() / expected;
    assert!(
        rel < 5e-3,
        "period {measured} s, expected {expected} s ({rel})"
    );
    // The rod keeps its length and the swing stays in its plane.
    let b = w.body(bob).unwrap();
    assert!((b.center_of_mass().length() - l).abs() < 1e-3);
    assert!(b.center_of_mass().z.abs() < 1e-9);
}

#[test]
fn a_ball_joint_pendulum_too() {
    let (l, r) = (2.0, 0.03);
    let (mut w, bob) = pendulum(JointKind::Ball, l, r, 4f64.to_radians());
    let expected = 2.0 * PI * ((l * l + 0.4 * r * r) / (G * l)).sqrt();
    let measured = period(&mut w, bob, 1.0 / 240.0, 3);
    assert!(
        (measured - expected).abs() / expected < 5e-3,
        "{measured} vs {expected}"
    );
}

#[test]
fn a_fixed_joint_holds_a_cantilever() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let wall = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(DVec3::splat(0.5)).unwrap(),
            Pose::IDENTITY,
        ))
        .unwrap();
    let beam_pose = Pose::from_translation(DVec3::new(1.5, 0.0, 0.0));
    let beam = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::new(1.0, 0.1, 0.1)).unwrap(),
                500.0,
                beam_pose,
            )
            .unwrap(),
        )
        .unwrap();
    w.add_joint(JointDesc {
        a: wall,
        b: beam,
        anchor_a: DVec3::new(0.5, 0.0, 0.0),
        anchor_b: DVec3::new(-1.0, 0.0, 0.0),
        kind: JointKind::Fixed,
        break_force: f64::MAX,
    })
    .unwrap();
    common::run(&mut w, 1.0 / 60.0, 180);
    let b = w.body(beam).unwrap();
    let droop = (b.center_of_mass() - beam_pose.translation).length();
    let tilt = b.pose().rotation.angle_between(DQuat::IDENTITY);
    assert!(
        droop < 0.01 && tilt < 0.01,
        "the beam sagged {droop} m and tilted {tilt} rad"
    );
}

#[test]
fn hinge_limits_and_motor() {
    let mut w = common::world();
    let base = anchor(&mut w);
    let door = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::new(0.5, 1.0, 0.05)).unwrap(),
                100.0,
                Pose::from_translation(DVec3::X * 0.5),
            )
            .unwrap(),
        )
        .unwrap();
    let hinge = JointKind::Hinge {
        axis_a: DVec3::Y,
        axis_b: DVec3::Y,
        limits: Some((-0.5, 0.8)),
        motor: Some((2.0, 500.0)),
    };
    w.add_joint(JointDesc {
        a: base,
        b: door,
        anchor_a: DVec3::ZERO,
        anchor_b: DVec3::X * -0.5,
        kind: hinge,
        break_force: f64::MAX,
    })
    .unwrap();
    // The motor drives the door at 2 rad/s until the upper limit stops it.
    common::run(&mut w, 1.0 / 60.0, 15);
    let w_mid = w.body(door).unwrap().angular_velocity().y;
    assert!((w_mid - 2.0).abs() < 0.05, "motor speed {w_mid}");
    common::run(&mut w, 1.0 / 60.0, 120);
    let angle = {
        let q = w.body(door).unwrap().pose().rotation;
        2.0 * q.y.atan2(q.w)
    };
    assert!(
        (angle - 0.8).abs() < 0.02,
        "stopped at {angle} rad, limit 0.8"
    );
}

#[test]
fn a_distance_joint_with_a_spring_bounces_and_a_weak_joint_breaks() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let top = anchor(&mut w);
    let weight = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::sphere(0.1).unwrap(),
                1000.0,
                Pose::from_translation(DVec3::NEG_Y),
            )
            .unwrap(),
        )
        .unwrap();
    let spring = JointKind::Distance {
        min: 0.0,
        max: 3.0,
        spring: Some((1.0, 1.0, 0.0)),
    };
    w.add_joint(JointDesc {
        a: top,
        b: weight,
        anchor_a: DVec3::ZERO,
        anchor_b: DVec3::ZERO,
        kind: spring,
        break_force: f64::MAX,
    })
    .unwrap();
    let mut lowest = 0.0f64;
    for _ in 0..120 {
        w.step(1.0 / 120.0).unwrap();
        lowest = lowest.min(w.body(weight).unwrap().center_of_mass().y);
    }
    assert!(
        lowest < -1.1 && lowest > -3.0,
        "the weight should stretch the spring: lowest {lowest}"
    );

    let mut w2 = common::world();
    w2.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let top = anchor(&mut w2);
    let heavy = w2
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::sphere(0.2).unwrap(),
                5000.0,
                Pose::from_translation(DVec3::NEG_Y),
            )
            .unwrap(),
        )
        .unwrap();
    let m = w2.body(heavy).unwrap().mass();
    let j = w2
        .add_joint(JointDesc {
            a: top,
            b: heavy,
            anchor_a: DVec3::ZERO,
            anchor_b: DVec3::Y,
            kind: JointKind::Ball,
            break_force: 0.5 * m * G,
        })
        .unwrap();
    let broken: Vec<_> = (0..10)
        .flat_map(|_| w2.step(1.0 / 60.0).unwrap().broken_joints)
        .collect();
    assert_eq!(broken, vec![j]);
    assert!(w2.joint(j).is_none());
}

#[test]
fn joints_are_saved_and_restored() {
    let hinge = JointKind::Hinge {
        axis_a: DVec3::Z,
        axis_b: DVec3::Z,
        limits: Some((-1.0, 1.0)),
        motor: None,
    };
    let (mut w, _) = pendulum(hinge, 1.0, 0.05, 0.7);
    common::run(&mut w, 1.0 / 60.0, 20);
    let saved = w.save();
    let expected: Vec<u64> = (0..20)
        .map(|_| {
            w.step(1.0 / 60.0).unwrap();
            w.state_hash()
        })
        .collect();
    let mut r = common::world();
    r.restore(&saved).unwrap();
    assert_eq!(r.save(), saved);
    let got: Vec<u64> = (0..20)
        .map(|_| {
            r.step(1.0 / 60.0).unwrap();
            r.state_hash()
        })
        .collect();
    assert_eq!(got, expected);
}

#[test]
fn a_swing_twist_joint_holds_its_cone() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let top = anchor(&mut w);
    // A rod hanging from the anchor, pushed sideways hard: the cone stops it at 0.4 rad.
    let rod = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::capsule(0.4, 0.05).unwrap(),
                500.0,
                Pose::from_translation(DVec3::new(0.0, -0.5, 0.0)),
            )
            .unwrap(),
        )
        .unwrap();
    let kind = JointKind::SwingTwist {
        axis_a: DVec3::NEG_Y,
        axis_b: DVec3::NEG_Y,
        swing_limit: 0.4,
        twist_limits: (-0.2, 0.2),
    };
    w.add_joint(JointDesc {
        a: top,
        b: rod,
        anchor_a: DVec3::ZERO,
        anchor_b: DVec3::new(0.0, 0.5, 0.0),
        kind,
        break_force: f64::MAX,
    })
    .unwrap();
    w.set_body_control(rod, DVec3::new(200.0, 0.0, 0.0), DVec3::new(0.0, 30.0, 0.0))
        .unwrap();
    let mut worst_swing = 0.0f64;
    let mut worst_twist = 0.0f64;
    for _ in 0..180 {
        w.step(1.0 / 60.0).unwrap();
        let q = w.body(rod).unwrap().pose().rotation;
        worst_swing = worst_swing.max((q * DVec3::NEG_Y).angle_between(DVec3::NEG_Y));
        let twist = 2.0 * (q.y).atan2(q.w);
        worst_twist = worst_twist.max(twist.abs());
    }
    assert!(
        worst_swing < 0.43,
        "swing {worst_swing} rad past the 0.4 cone"
    );
    assert!(
        worst_swing > 0.35,
        "the push should reach the cone ({worst_swing})"
    );
    assert!(worst_twist < 0.45, "twist {worst_twist}");
}

#[test]
fn a_ragdoll_falls_down_stairs_and_comes_to_rest_in_one_piece() {
    for (lean, turn) in [(0.6, 0.3), (0.9, -0.7), (0.4, 1.5)] {
        ragdoll_down_stairs(lean, turn);
    }
}

fn ragdoll_down_stairs(lean: f64, turn: f64) {
    use inertia_physics::ragdoll::{build_ragdoll, RagdollDesc};
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    // Six steps climbing towards -z (0.2 m rise, 0.4 m run) above a floor.
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(4.0, 0.5, 6.0)).unwrap(),
        Pose::from_translation(DVec3::new(0.0, -0.5, 0.0)),
    ))
    .unwrap();
    for k in 0..6 {
        let step = Shape::cuboid(DVec3::new(2.0, 0.1 * (k + 1) as f64, 0.2)).unwrap();
        w.add_body(&RigidBodyDesc::fixed(
            step,
            Pose::from_translation(DVec3::new(0.0, 0.1 * (k + 1) as f64, -0.4 * k as f64)),
        ))
        .unwrap();
    }
    // Standing on the top step, leaning forward down the stairs.
    let pose = Pose::new(
        DVec3::new(0.0, 1.25, -2.0),
        DQuat::from_rotation_x(lean) * DQuat::from_rotation_y(turn),
    );
    let doll = build_ragdoll(
        &mut w,
        &RagdollDesc {
            pose,
            ..RagdollDesc::default()
        },
    )
    .unwrap();
    let start = w.body(doll.bodies[0].1).unwrap().center_of_mass();
    assert_eq!((doll.bodies.len(), doll.joints.len()), (11, 10));
    let mut quarantined = 0;
    for _ in 0..480 {
        quarantined += w.step(1.0 / 60.0).unwrap().quarantined_bodies.len();
    }
    assert_eq!(quarantined, 0);
    // Every joint's two anchors still coincide (within 1 cm) and nothing flies off.
    for j in &doll.joints {
        let d = *w.joint(*j).unwrap().desc();
        let (a, b) = (w.body(d.a).unwrap(), w.body(d.b).unwrap());
        let gap =
            (a.pose().transform_point(d.anchor_a) - b.pose().transform_point(d.anchor_b)).length();
        assert!(gap < 0.01, "joint separated by {gap} m");
    }
    let kinetic: f64 = doll
        .bodies
        .iter()
        .map(|(_, h)| w.body(*h).unwrap().kinetic_energy())
        .sum();
    assert!(kinetic < 1.0, "still moving: {kinetic} J");
    for (name, h) in &doll.bodies {
        let p = w.body(*h).unwrap().center_of_mass();
        assert!(
            p.is_finite() && p.y > 0.0 && p.length() < 20.0,
            "{name} at {p}"
        );
    }
    // It really went down the stairs.
    let end = w.body(doll.bodies[0].1).unwrap().center_of_mass();
    assert!(
        end.y < start.y - 0.5 && end.z > start.z + 0.5,
        "from {start} to {end}"
    );
}
