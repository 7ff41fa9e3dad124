//! Prismatic (slider) joints: holding the line and the rotation, limits,
//! the motor and its force cap, breaking, save/restore, bad input.

use crate::common;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::joint::{JointDesc, JointKind};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, PhysicsError, World};

const G: f64 = 9.81;
const DT: f64 = 1.0 / 60.0;

/// A world with gravity along -y and sleeping off, a fixed base at the
/// origin and a 0.4 m box (500 kg/m³, 32 kg) with its centre at `at`,
/// joined by a prismatic joint along `axis` from the base's origin to the
/// box's top face.
fn slider(
    at: DVec3,
    axis: DVec3,
    limits: Option<(f64, f64)>,
    motor: Option<(f64, f64)>,
) -> (World, BodyHandle) {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = false;
    w.set_solver_config(cfg).unwrap();
    let base = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::sphere(0.05).unwrap(),
            Pose::IDENTITY,
        ))
        .unwrap();
    let cart = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.2)).unwrap(),
                500.0,
                Pose::from_translation(at),
            )
            .unwrap(),
        )
        .unwrap();
    w.add_joint(JointDesc {
        a: base,
        b: cart,
        anchor_a: DVec3::ZERO,
        anchor_b: DVec3::new(0.0, 0.2, 0.0),
        kind: JointKind::Prismatic {
            axis_a: axis,
            limits,
            motor,
        },
        break_force: f64::MAX,
    })
    .unwrap();
    (w, cart)
}

/// Distance of the box's anchor (top face centre) from the y axis, m, and
/// its rotation from the start, rad.
fn off_axis(w: &World, cart: BodyHandle) -> (f64, f64) {
    let b = w.body(cart).unwrap();
    let p = b.pose().transform_point(DVec3::new(0.0, 0.2, 0.0));
    (
        p.x.hypot(p.z),
        b.pose().rotation.angle_between(DQuat::IDENTITY),
    )
}

#[test]
fn a_vertical_slider_falls_to_its_lower_limit_and_stays_on_the_axis() {
    let (lo, hi) = (-1.0, 0.5);
    let (mut w, cart) = slider(DVec3::new(0.0, -0.2, 0.0), DVec3::Y, Some((lo, hi)), None);
    let m = w.body(cart).unwrap().mass();
    let (mut worst_off, mut worst_turn) = (0.0f64, 0.0f64);
    for step in 0..240 {
        // Shoves across the axis, away from the centre of mass (so they
        // also twist and tip the box): once while it falls, once at rest on
        // the limit, each 0.5 m/s worth of momentum.
        if step == 15 || step == 150 {
            let at = w.body(cart).unwrap().center_of_mass() + DVec3::new(0.0, -0.15, 0.1);
            w.apply_body_impulse(cart, DVec3::new(0.4, 0.0, -0.3) * m, at)
                .unwrap();
        }
        w.step(DT).unwrap();
        let (off, turn) = off_axis(&w, cart);
        worst_off = worst_off.max(off);
        worst_turn = worst_turn.max(turn);
    }
    let b = w.body(cart).unwrap();
    let translation = b.pose().transform_point(DVec3::new(0.0, 0.2, 0.0)).y;
    eprintln!(
        "vertical slider: rests at {translation:.6} m (limit {lo}), off by {:.3e} m; \
         worst off the axis {worst_off:.3e} m, worst turn {worst_turn:.3e} rad; \
         speed at the end {:.3e} m/s",
        (translation - lo).abs(),
        b.linear_velocity().length()
    );
    assert!(
        (translation - lo).abs() < 0.01,
        "stopped at {translation} m, lower limit {lo} m"
    );
    assert!(worst_off < 1e-3, "left the axis by {worst_off} m");
    assert!(worst_turn < 1e-3, "turned by {worst_turn} rad");
    assert!(b.linear_velocity().length() < 1e-3);
}

#[test]
fn an_upper_limit_stops_a_slider_pushed_up() {
    let (lo, hi) = (-1.0, 0.3);
    let (mut w, cart) = slider(DVec3::new(0.0, -0.2, 0.0), DVec3::Y, Some((lo, hi)), None);
    let m = w.body(cart).unwrap().mass();
    w.set_body_velocity(cart, DVec3::new(0.0, 4.0, 0.0), DVec3::ZERO)
        .unwrap();
    let mut highest = f64::MIN;
    for _ in 0..30 {
        w.step(DT).unwrap();
        let y = w
            .body(cart)
            .unwrap()
            .pose()
            .transform_point(DVec3::new(0.0, 0.2, 0.0))
            .y;
        highest = highest.max(y);
    }
    eprintln!("upper limit {hi} m: highest {highest:.6} m ({m} kg thrown up at 4 m/s)");
    assert!(
        highest <= hi + 0.01 && highest > hi - 0.01,
        "highest {highest} m, upper limit {hi} m"
    );
}

#[test]
fn a_motor_drives_a_horizontal_slider_at_its_speed() {
    let (mut w, cart) = slider(
        DVec3::new(0.0, -0.2, 0.0),
        DVec3::X,
        None,
        Some((1.0, 10_000.0)),
    );
    let x0 = w.body(cart).unwrap().center_of_mass().x;
    common::run(&mut w, DT, 6);
    let v = w.body(cart).unwrap().linear_velocity().x;
    common::run(&mut w, DT, 54);
    let b = w.body(cart).unwrap();
    let travelled = b.center_of_mass().x - x0;
    // Gravity pulls across this axis: how far the anchor sagged off it.
    let p = b.pose().transform_point(DVec3::new(0.0, 0.2, 0.0));
    let sag = p.y.hypot(p.z);
    let turn = b.pose().rotation.angle_between(DQuat::IDENTITY);
    eprintln!(
        "motor 1 m/s: speed after 0.1 s {v:.6} m/s, travelled in 1 s {travelled:.6} m, \
         speed at 1 s {:.6} m/s, sag {sag:.3e} m, turn {turn:.3e} rad",
        b.linear_velocity().x,
    );
    assert!(sag < 1e-3 && turn < 1e-3);
    assert!((v - 1.0).abs() < 0.02, "speed {v} m/s");
    assert!((travelled - 1.0).abs() < 0.02, "travelled {travelled} m");
    assert!((b.linear_velocity().x - 1.0).abs() < 0.02);
}

#[test]
fn a_motor_too_weak_for_its_load_lets_it_accelerate_at_the_difference() {
    // Holding still with at most half the weight: it falls at (mg - F)/m.
    let m = 500.0 * 0.4f64.powi(3);
    let f = 0.5 * m * G;
    let (mut w2, cart2) = slider(DVec3::new(0.0, -0.2, 0.0), DVec3::Y, None, Some((0.0, f)));
    assert!((w2.body(cart2).unwrap().mass() - m).abs() < 1e-9);
    common::run(&mut w2, DT, 30);
    let v0 = w2.body(cart2).unwrap().linear_velocity().y;
    common::run(&mut w2, DT, 60);
    let v1 = w2.body(cart2).unwrap().linear_velocity().y;
    let measured = -(v1 - v0) / (60.0 * DT);
    let expected = (m * G - f) / m;
    let rel = (measured - expected).abs() / expected;
    eprintln!(
        "motor capped at {f:.3} N holding {:.3} N: accelerates at {measured:.6} m/s², \
         expected {expected:.6} ({rel:.2e})",
        m * G
    );
    assert!(rel < 0.03, "{measured} m/s², expected {expected}");
}

/// Steps a weight (m g = 657 N) hanging on a vertical slider whose lower
/// limit or motor carries it, with a break force of `break_weights` × m g;
/// the step at which it broke.
fn steps_to_break(
    limits: Option<(f64, f64)>,
    motor: Option<(f64, f64)>,
    break_weights: f64,
) -> Option<usize> {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let base = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::sphere(0.05).unwrap(),
            Pose::IDENTITY,
        ))
        .unwrap();
    let weight = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::sphere(0.2).unwrap(),
                2000.0,
                Pose::from_translation(DVec3::NEG_Y),
            )
            .unwrap(),
        )
        .unwrap();
    let m = w.body(weight).unwrap().mass();
    // Only the rows along the axis carry the weight: nothing across it.
    let j = w
        .add_joint(JointDesc {
            a: base,
            b: weight,
            anchor_a: DVec3::ZERO,
            anchor_b: DVec3::ZERO,
            kind: JointKind::Prismatic {
                axis_a: DVec3::Y,
                limits,
                motor: motor.map(|(v, f)| (v, f * m * G)),
            },
            break_force: break_weights * m * G,
        })
        .unwrap();
    for step in 0..60 {
        if !w.step(DT).unwrap().broken_joints.is_empty() {
            assert!(w.joint(j).is_none());
            return Some(step);
        }
    }
    None
}

#[test]
fn the_limit_and_motor_rows_count_towards_breaking() {
    let on_limit = Some((-1.0, 1.0));
    let holding = Some((0.0, 2.0));
    let results = [
        steps_to_break(on_limit, None, 0.5),
        steps_to_break(on_limit, None, 1.5),
        steps_to_break(None, holding, 0.5),
        steps_to_break(None, holding, 1.5),
    ];
    eprintln!(
        "prismatic breaking (step it broke at): limit at 0.5 mg {:?}, at 1.5 mg {:?}; \
         motor at 0.5 mg {:?}, at 1.5 mg {:?}",
        results[0], results[1], results[2], results[3]
    );
    assert!(results[0].is_some() && results[1].is_none());
    assert!(results[2].is_some() && results[3].is_none());
}

#[test]
fn two_free_bodies_on_a_driven_slider_keep_their_momentum() {
    // No gravity: a spinning frame and a cart driven out along it. Every
    // joint impulse acts equally and oppositely at one point, so linear and
    // angular momentum (about the origin) stay as they were.
    let mut w = common::world();
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = false;
    w.set_solver_config(cfg).unwrap();
    let frame = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::new(1.0, 0.1, 0.1)).unwrap(),
                800.0,
                Pose::new(DVec3::ZERO, DQuat::from_rotation_z(0.3)),
            )
            .unwrap()
            .with_velocity(DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.2, 0.5, 1.0)),
        )
        .unwrap();
    let cart = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.15)).unwrap(),
                300.0,
                Pose::new(DVec3::new(0.2, 0.3, 0.0), DQuat::from_rotation_y(0.4)),
            )
            .unwrap(),
        )
        .unwrap();
    w.add_joint(JointDesc {
        a: frame,
        b: cart,
        anchor_a: DVec3::new(0.0, 0.25, 0.0),
        anchor_b: DVec3::ZERO,
        kind: JointKind::Prismatic {
            axis_a: DVec3::X,
            limits: Some((-0.8, 0.8)),
            motor: Some((0.5, 200.0)),
        },
        break_force: f64::MAX,
    })
    .unwrap();
    let momentum = |w: &World| {
        [frame, cart]
            .iter()
            .fold((DVec3::ZERO, DVec3::ZERO), |(p, l), &h| {
                let b = w.body(h).unwrap();
                (
                    p + b.linear_momentum(),
                    l + b.center_of_mass().cross(b.linear_momentum()) + b.angular_momentum(),
                )
            })
    };
    let (p0, l0) = momentum(&w);
    let (mut dp, mut dl) = (0.0f64, 0.0f64);
    for _ in 0..120 {
        w.step(DT).unwrap();
        let (p, l) = momentum(&w);
        dp = dp.max((p - p0).length() / p0.length());
        dl = dl.max((l - l0).length() / l0.length());
    }
    eprintln!("free slider: momentum drift {dp:.3e}, angular momentum drift {dl:.3e} (relative)");
    assert!(dp < 1e-9, "linear momentum drifted by {dp}");
    assert!(dl < 1e-2, "angular momentum drifted by {dl}");
}

#[test]
fn a_prismatic_joint_is_saved_and_restored_bit_for_bit() {
    // Two dynamic bodies, a tilted axis, limits and a motor, all mid-motion.
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = false;
    w.set_solver_config(cfg).unwrap();
    let frame = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::new(1.0, 0.1, 0.1)).unwrap(),
                800.0,
                Pose::new(DVec3::ZERO, DQuat::from_rotation_z(0.3)),
            )
            .unwrap(),
        )
        .unwrap();
    let cart = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.15)).unwrap(),
                300.0,
                Pose::new(DVec3::new(0.2, 0.3, 0.0), DQuat::from_rotation_y(0.4)),
            )
            .unwrap(),
        )
        .unwrap();
    w.add_joint(JointDesc {
        a: frame,
        b: cart,
        anchor_a: DVec3::new(0.0, 0.25, 0.0),
        anchor_b: DVec3::ZERO,
        kind: JointKind::Prismatic {
            axis_a: DVec3::X,
            limits: Some((-0.6, 0.6)),
            motor: Some((0.8, 40.0)),
        },
        break_force: f64::MAX,
    })
    .unwrap();
    common::run(&mut w, DT, 25);
    let saved = w.save();
    let expected: Vec<u64> = (0..40)
        .map(|_| {
            w.step(DT).unwrap();
            w.state_hash()
        })
        .collect();
    let mut r = common::world();
    r.restore(&saved).unwrap();
    assert_eq!(r.save(), saved);
    let got: Vec<u64> = (0..40)
        .map(|_| {
            r.step(DT).unwrap();
            r.state_hash()
        })
        .collect();
    eprintln!(
        "prismatic save/restore: {} bytes, {} of {} step hashes equal",
        saved.len(),
        got.iter().zip(&expected).filter(|(a, b)| a == b).count(),
        expected.len()
    );
    assert_eq!(got, expected);
    assert_eq!(r.save(), w.save());
}

#[test]
fn every_prismatic_setting_is_in_the_state_hash() {
    let hash = |axis: DVec3, limits, motor| {
        let (w, _) = slider(DVec3::new(0.0, -0.2, 0.0), axis, limits, motor);
        w.state_hash()
    };
    let base = hash(DVec3::Y, Some((-1.0, 0.5)), Some((0.5, 10.0)));
    for other in [
        hash(DVec3::X, Some((-1.0, 0.5)), Some((0.5, 10.0))),
        hash(DVec3::Y, None, Some((0.5, 10.0))),
        hash(DVec3::Y, Some((-1.0, 0.6)), Some((0.5, 10.0))),
        hash(DVec3::Y, Some((-1.0, 0.5)), None),
        hash(DVec3::Y, Some((-1.0, 0.5)), Some((0.5, 11.0))),
        hash(DVec3::Y, Some((-1.1, 0.5)), Some((0.5, 10.0))),
        hash(DVec3::Y, Some((-1.0, 0.5)), Some((0.4, 10.0))),
    ] {
        assert_ne!(other, base);
    }
}

#[test]
fn bad_prismatic_joints_are_refused_and_change_nothing() {
    let (mut w, cart) = slider(DVec3::new(0.0, -0.2, 0.0), DVec3::Y, None, None);
    let base = w.bodies().map(|(h, _)| h).find(|&h| h != cart).unwrap();
    let before = (w.save(), w.state_hash());
    let desc = |axis_a, limits, motor| JointDesc {
        a: base,
        b: cart,
        anchor_a: DVec3::ZERO,
        anchor_b: DVec3::ZERO,
        kind: JointKind::Prismatic {
            axis_a,
            limits,
            motor,
        },
        break_force: f64::MAX,
    };
    let cases = [
        (desc(DVec3::ZERO, None, None), "zero axis"),
        (desc(DVec3::new(f64::NAN, 1.0, 0.0), None, None), "NaN axis"),
        (
            desc(DVec3::new(0.0, f64::INFINITY, 0.0), None, None),
            "infinite axis",
        ),
        (desc(DVec3::Y, Some((0.5, -0.5)), None), "lower > upper"),
        (desc(DVec3::Y, Some((f64::NAN, 0.5)), None), "NaN limit"),
        (
            desc(DVec3::Y, Some((-0.5, f64::INFINITY)), None),
            "infinite limit",
        ),
        (desc(DVec3::Y, None, Some((f64::NAN, 1.0))), "NaN speed"),
        (desc(DVec3::Y, None, Some((1.0, -1.0))), "negative force"),
        (
            desc(DVec3::Y, None, Some((1.0, f64::INFINITY))),
            "infinite force",
        ),
    ];
    for (d, why) in cases {
        let e = w.add_joint(d).expect_err(why);
        let typed = match why {
            "zero axis" => matches!(e, PhysicsError::ZeroDirection(_)),
            "lower > upper" => matches!(e, PhysicsError::Invalid { what: "joint", .. }),
            "negative force" => matches!(e, PhysicsError::Negative { .. }),
            _ => matches!(e, PhysicsError::NonFinite { .. }),
        };
        assert!(typed, "{why}: {e:?}");
        assert_eq!(
            (w.save(), w.state_hash()),
            before,
            "{why} changed the world"
        );
    }
    eprintln!("prismatic: {} bad descriptions refused", cases.len());
    // A good one is kept with its axis normalised; equal limits and a zero
    // force are allowed.
    let j = w
        .add_joint(desc(
            DVec3::new(0.0, 3.0, 0.0),
            Some((0.2, 0.2)),
            Some((1.0, 0.0)),
        ))
        .unwrap();
    match w.joint(j).unwrap().desc().kind {
        JointKind::Prismatic { axis_a, .. } => assert_eq!(axis_a, DVec3::Y),
        k => panic!("kind changed to {k:?}"),
    }
}
