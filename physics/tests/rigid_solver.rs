//! Contacts end to end: bounce, friction on a slope, stacking, momentum.

use crate::common;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::{CombineRule, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, World};

const G: f64 = 9.81;

fn world_with_ground(friction: f64, restitution: f64) -> World {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let mut ground = RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    );
    ground.friction_static = friction;
    ground.friction_dynamic = friction;
    ground.restitution = restitution;
    w.add_body(&ground).unwrap();
    w
}

#[test]
fn a_ball_bounces_to_e_squared_h() {
    for e in [0.5, 0.8] {
        let ratio = common::bounce_ratio(e, 2.0, 120.0);
        assert!((ratio - 1.0).abs() < 0.03, "e={e}: apex {ratio} of e² h");
    }
}

/// A box on a slope tilted `deg` degrees: its displacement along the slope
/// and its speed after `t` seconds.
fn slide(deg: f64, mu_s: f64, mu_k: f64, t: f64) -> (f64, f64, f64) {
    let same = (mu_s, mu_k, CombineRule::GeometricMean);
    slide_on(deg, same, same, t)
}

/// [`slide`] with the slope's and the block's (static, dynamic, rule).
fn slide_on(
    deg: f64,
    slope_material: (f64, f64, CombineRule),
    block_material: (f64, f64, CombineRule),
    t: f64,
) -> (f64, f64, f64) {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let tilt = DQuat::from_rotation_z(deg.to_radians());
    let mut slope = RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(30.0, 0.5, 5.0)).unwrap(),
        Pose::new(tilt * (DVec3::NEG_Y * 0.5), tilt),
    );
    (
        slope.friction_static,
        slope.friction_dynamic,
        slope.friction_combine,
    ) = slope_material;
    w.add_body(&slope).unwrap();
    let mut block = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::splat(0.25)).unwrap(),
        500.0,
        Pose::new(tilt * (DVec3::Y * 0.25), tilt),
    )
    .unwrap();
    (
        block.friction_static,
        block.friction_dynamic,
        block.friction_combine,
    ) = block_material;
    let b = w.add_body(&block).unwrap();
    let down = tilt * DVec3::NEG_X;
    let x0 = w.body(b).unwrap().center_of_mass();
    let dt = 1.0 / 120.0;
    let steps = (t / dt).round() as usize;
    let mut v_half = 0.0;
    for k in 0..steps {
        w.step(dt).unwrap();
        if k + 1 == steps / 2 {
            v_half = w.body(b).unwrap().linear_velocity().dot(down);
        }
    }
    let body = w.body(b).unwrap();
    let v = body.linear_velocity().dot(down);
    (
        (body.center_of_mass() - x0).dot(down),
        v,
        (v - v_half) / (t / 2.0),
    )
}

#[test]
fn a_box_sticks_below_the_friction_angle_and_slides_above_it() {
    let mu_s: f64 = 0.6;
    let angle = mu_s.atan().to_degrees();
    let (d, v, _) = slide(angle - 2.0, mu_s, 0.4, 2.0);
    assert!(
        d.abs() < 2e-3 && v.abs() < 1e-3,
        "below the friction angle it moved {d} m at {v} m/s"
    );
    let (d, v, _) = slide(angle + 2.0, mu_s, 0.4, 2.0);
    assert!(
        d > 0.1 && v > 0.1,
        "above the friction angle it stayed ({d} m, {v} m/s)"
    );
}

/// Friction combine rules: a block of μ = 0.2 slides down a slope of
/// μ = 0.8 with the acceleration the chosen rule's coefficient gives (the
/// higher-priority rule of the two wins).
#[test]
fn friction_combines_by_the_stronger_rule() {
    let deg: f64 = 45.0;
    let th = deg.to_radians();
    for (rule, mu) in [
        (CombineRule::Average, 0.5),
        (CombineRule::GeometricMean, 0.4),
        (CombineRule::Min, 0.2),
        (CombineRule::Multiply, 0.16),
        (CombineRule::Max, 0.8),
    ] {
        // The slope asks for the lowest-priority rule; the block's wins
        // (or ties).
        let (_, _, a) = slide_on(deg, (0.8, 0.8, CombineRule::Average), (0.2, 0.2, rule), 1.0);
        let expected = G * (th.sin() - mu * th.cos());
        eprintln!("{rule:?}: a = {a:.4} m/s², expected {expected:.4}");
        assert!(
            (a - expected).abs() < 0.02 * expected,
            "{rule:?}: a = {a}, expected {expected}"
        );
    }
    assert_eq!(
        CombineRule::combine((0.3, CombineRule::Max), (0.9, CombineRule::Min)),
        0.9
    );
    assert_eq!(
        CombineRule::combine((0.3, CombineRule::Min), (0.9, CombineRule::Average)),
        0.3
    );
}

#[test]
fn sliding_acceleration_is_g_sin_minus_mu_k_cos() {
    let (mu_s, mu_k, deg): (f64, f64, f64) = (0.5, 0.3, 35.0);
    let (_, _, a) = slide(deg, mu_s, mu_k, 1.0);
    let th = deg.to_radians();
    let expected = G * (th.sin() - mu_k * th.cos());
    assert!(
        (a - expected).abs() < 0.02 * expected,
        "a = {a}, expected {expected}"
    );
}

fn stack_drift(sleep: bool) -> (f64, f64) {
    let mu = 0.6;
    let mut w = world_with_ground(mu, 0.0);
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = sleep;
    w.set_solver_config(cfg).unwrap();
    let boxes: Vec<BodyHandle> = (0..10)
        .map(|i| {
            let p = Pose::from_translation(DVec3::new(0.0, 0.5 + i as f64 * 1.0, 0.0));
            let mut d = RigidBodyDesc::dynamic(Shape::cuboid(DVec3::splat(0.5)).unwrap(), 300.0, p)
                .unwrap();
            d.friction_static = mu;
            d.friction_dynamic = mu;
            w.add_body(&d).unwrap()
        })
        .collect();
    let placed: Vec<DVec3> = boxes
        .iter()
        .map(|h| w.body(*h).unwrap().center_of_mass())
        .collect();
    // One second to settle: soft contacts carry load with a small standing
    // overlap, about g / (2π f)² per box above (f = contact stiffness, 30 Hz).
    common::run(&mut w, 1.0 / 60.0, 60);
    let settled: Vec<DVec3> = boxes
        .iter()
        .map(|h| w.body(*h).unwrap().center_of_mass())
        .collect();
    let sag = (placed[9] - settled[9]).length();
    common::run(&mut w, 1.0 / 60.0, 600);
    let drift = boxes
        .iter()
        .zip(&settled)
        .map(|(h, s)| (w.body(*h).unwrap().center_of_mass() - *s).length())
        .fold(0.0, f64::max);
    (sag, drift)
}

#[test]
fn a_stack_of_ten_boxes_stands_still() {
    // As a game runs it: the settled stack falls asleep and stays put.
    let (sag, drift) = stack_drift(true);
    eprintln!("asleep: sag {sag:.2e} m while settling, drift {drift:.2e} m in 10 s");
    assert!(sag < 0.03, "the stack compressed by {sag} m while settling");
    assert!(drift < 1e-3, "a box drifted {drift} m in 10 s");
    // Kept awake the whole time (the block solve of each manifold's points
    // keeps their impulses even, so the stack does not rock).
    let (_, drift) = stack_drift(false);
    eprintln!("awake: drift {drift:.2e} m in 10 s");
    assert!(drift < 1e-3, "awake, a box drifted {drift} m in 10 s");
}

#[test]
fn a_twenty_row_pyramid_stands_and_sleeps_within_five_seconds() {
    let mut w = world_with_ground(0.6, 0.0);
    let mut boxes = Vec::new();
    for row in 0..20 {
        for i in 0..(20 - row) {
            let x = (i as f64 - (20 - row) as f64 / 2.0) * 1.05;
            let p = Pose::from_translation(DVec3::new(x, 0.5 + row as f64, 0.0));
            boxes.push(
                w.add_body(
                    &RigidBodyDesc::dynamic(Shape::cuboid(DVec3::splat(0.5)).unwrap(), 300.0, p)
                        .unwrap(),
                )
                .unwrap(),
            );
        }
    }
    assert_eq!(boxes.len(), 210);
    let top = *boxes.last().unwrap();
    let start = w.body(top).unwrap().center_of_mass();
    common::run(&mut w, 1.0 / 60.0, 300);
    let asleep = boxes
        .iter()
        .filter(|h| w.body(**h).unwrap().is_sleeping())
        .count();
    assert_eq!(asleep, boxes.len(), "{asleep} of 210 asleep after 5 s");
    let sag = (w.body(top).unwrap().center_of_mass() - start).length();
    assert!(sag < 0.05, "the top sagged {sag} m");
}

#[test]
fn a_sleeping_box_wakes_when_hit() {
    let mut w = world_with_ground(0.6, 0.0);
    let target = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                100.0,
                Pose::from_translation(DVec3::Y * 0.5),
            )
            .unwrap(),
        )
        .unwrap();
    common::run(&mut w, 1.0 / 60.0, 120);
    assert!(w.body(target).unwrap().is_sleeping());
    let ball = RigidBodyDesc::dynamic(
        Shape::sphere(0.3).unwrap(),
        2000.0,
        Pose::from_translation(DVec3::new(-3.0, 0.5, 0.0)),
    )
    .unwrap()
    .with_velocity(DVec3::X * 8.0, DVec3::ZERO);
    w.add_body(&ball).unwrap();
    common::run(&mut w, 1.0 / 60.0, 60);
    let t = w.body(target).unwrap();
    assert!(
        t.center_of_mass().x > 0.2,
        "the box was not pushed: {}",
        t.center_of_mass()
    );
}

#[test]
fn free_collisions_conserve_momentum() {
    let mut w = common::world();
    let ball = |p: DVec3, v: DVec3| {
        RigidBodyDesc::dynamic(
            Shape::sphere(0.5).unwrap(),
            800.0,
            Pose::from_translation(p),
        )
        .unwrap()
        .with_velocity(v, DVec3::ZERO)
    };
    let a = w
        .add_body(&ball(DVec3::new(-2.0, 0.1, 0.0), DVec3::new(3.0, 0.0, 0.0)))
        .unwrap();
    let c = w
        .add_body(&ball(
            DVec3::new(2.0, -0.1, 0.05),
            DVec3::new(-1.0, 0.2, 0.0),
        ))
        .unwrap();
    let p = |w: &World| w.body(a).unwrap().linear_momentum() + w.body(c).unwrap().linear_momentum();
    let p0 = p(&w);
    let mut touched = false;
    for _ in 0..120 {
        w.step(1.0 / 60.0).unwrap();
        touched |= w.contact_count() > 0;
    }
    assert!(touched, "the balls never met");
    let rel = (p(&w) - p0).length() / p0.length();
    assert!(rel < 1e-4, "momentum changed by {rel}");
}

/// A pile of mixed bodies landing on the ground.
fn pile(threads: usize) -> World {
    let mut w = World::new(inertia_physics::WorldConfig {
        threads,
        ..Default::default()
    })
    .unwrap();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))
    .unwrap();
    let mut rng = common::Rng(17);
    for i in 0..24 {
        let p = DVec3::new(
            rng.f64() * 3.0 - 1.5,
            0.6 + i as f64 * 0.7,
            rng.f64() * 3.0 - 1.5,
        );
        let q = DQuat::from_rotation_y(rng.f64() * 3.0) * DQuat::from_rotation_x(rng.f64() * 0.5);
        let shape = match i % 3 {
            0 => Shape::cuboid(DVec3::new(0.3, 0.2, 0.25)).unwrap(),
            1 => Shape::sphere(0.25).unwrap(),
            _ => Shape::capsule(0.2, 0.15).unwrap(),
        };
        w.add_body(&RigidBodyDesc::dynamic(shape, 400.0, Pose::new(p, q)).unwrap())
            .unwrap();
    }
    w
}

fn hashes(w: &mut World, n: usize) -> Vec<u64> {
    (0..n)
        .map(|_| {
            w.step(1.0 / 60.0).unwrap();
            w.state_hash()
        })
        .collect()
}

#[test]
fn contact_scenes_are_deterministic_across_threads_and_restore() {
    let mut one = pile(1);
    let mut two = pile(2);
    let a = hashes(&mut one, 90);
    assert_eq!(a, hashes(&mut two, 90), "1 and 2 threads differ");
    assert!(
        one.contact_count() > 10,
        "the pile should be touching ({} manifolds)",
        one.contact_count()
    );
    let saved = one.save();
    let expected = hashes(&mut one, 60);
    let mut restored = pile(2);
    restored.restore(&saved).unwrap();
    assert_eq!(restored.save(), saved);
    assert_eq!(
        hashes(&mut restored, 60),
        expected,
        "restore-then-step differs (warm-start cache?)"
    );
    // Nothing fell through the ground or blew up.
    for (_, b) in one
        .bodies()
        .filter(|(_, b)| b.kind() == inertia_physics::rigid::body::BodyKind::Dynamic)
    {
        assert!(
            b.center_of_mass().is_finite() && b.center_of_mass().y > 0.0,
            "{:?}",
            b.center_of_mass()
        );
    }
}

#[test]
fn contact_begin_and_end_events() {
    use inertia_physics::rigid::ContactEventKind;
    let mut w = world_with_ground(0.5, 0.9);
    let mut ball = RigidBodyDesc::dynamic(
        Shape::sphere(0.2).unwrap(),
        500.0,
        Pose::from_translation(DVec3::Y * 1.2),
    )
    .unwrap();
    ball.restitution = 0.9;
    let b = w.add_body(&ball).unwrap();
    let ground = w.bodies().next().unwrap().0;
    let mut kinds = Vec::new();
    for _ in 0..120 {
        for e in w.step(1.0 / 120.0).unwrap().contact_events {
            assert!(e.a == ground && e.b == b && !e.sensor);
            kinds.push(e.kind);
        }
    }
    assert!(kinds.len() >= 2, "{kinds:?}");
    assert_eq!(kinds[0], ContactEventKind::Begin);
    assert_eq!(
        kinds[1],
        ContactEventKind::End,
        "the ball bounces off again"
    );
}

#[test]
fn sensors_report_overlaps_without_pushing() {
    let mut w = common::world();
    let mut zone = RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(1.0, 1.0, 1.0)).unwrap(),
        Pose::IDENTITY,
    );
    zone.sensor = true;
    let z = w.add_body(&zone).unwrap();
    let ball = RigidBodyDesc::dynamic(
        Shape::sphere(0.2).unwrap(),
        100.0,
        Pose::from_translation(DVec3::X * -3.0),
    )
    .unwrap()
    .with_velocity(DVec3::X * 4.0, DVec3::ZERO);
    let b = w.add_body(&ball).unwrap();
    let mut events = Vec::new();
    for _ in 0..120 {
        events.extend(w.step(1.0 / 60.0).unwrap().contact_events);
    }
    assert_eq!(events.len(), 2, "{events:?}");
    assert!(events.iter().all(|e| e.sensor && e.a == z && e.b == b));
    assert_eq!(
        w.body(b).unwrap().linear_velocity(),
        DVec3::X * 4.0,
        "a sensor must not push"
    );
}

#[test]
fn contact_force_events_report_the_weight() {
    let mut w = world_with_ground(0.5, 0.0);
    let mut crate_desc = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::splat(0.5)).unwrap(),
        200.0,
        Pose::from_translation(DVec3::Y * 0.5),
    )
    .unwrap();
    crate_desc.contact_force_threshold = 100.0;
    let c = w.add_body(&crate_desc).unwrap();
    let weight = w.body(c).unwrap().mass() * G;
    // (Once the crate falls asleep its contact is no longer solved and no
    // more force events come: keep the last one seen.)
    let mut last = None;
    for _ in 0..120 {
        if let Some(e) = w.step(1.0 / 60.0).unwrap().contact_forces.first() {
            last = Some(*e);
        }
    }
    let e = last.expect("a 200 kg crate presses harder than 100 N");
    assert!(
        (e.force - weight).abs() < 0.01 * weight,
        "{} vs {weight}",
        e.force
    );
    assert!((e.normal - DVec3::Y).length() < 1e-9);
}

#[test]
fn bodies_leaving_the_world_bounds_are_removed_and_reported() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    w.set_body_bounds(Some(inertia_physics::rigid::aabb::Aabb::new(
        DVec3::splat(-10.0),
        DVec3::splat(10.0),
    )))
    .unwrap();
    let b = w
        .add_body(
            &RigidBodyDesc::dynamic(Shape::sphere(0.2).unwrap(), 100.0, Pose::IDENTITY).unwrap(),
        )
        .unwrap();
    let mut removed = Vec::new();
    for _ in 0..180 {
        removed.extend(w.step(1.0 / 60.0).unwrap().removed_bodies);
    }
    assert_eq!(removed, vec![b]);
    assert!(w.body(b).is_none());
    assert!(w
        .set_body_bounds(Some(inertia_physics::rigid::aabb::Aabb::new(
            DVec3::ONE,
            DVec3::ZERO
        )))
        .is_err());
}

/// Speculative contacts reach as far as a body can move in a step, so a
/// small fast body cannot pass through a thin wall between two steps.
#[test]
fn a_thin_wall_stops_a_small_body_at_300_m_per_s() {
    for shape in [
        Shape::sphere(0.05).unwrap(),
        Shape::cuboid(DVec3::splat(0.04)).unwrap(),
    ] {
        let mut w = common::world();
        let wall = Shape::cuboid(DVec3::new(0.005, 2.0, 2.0)).unwrap(); // 1 cm thick
        w.add_body(&RigidBodyDesc::fixed(
            wall,
            Pose::from_translation(DVec3::X * 10.0),
        ))
        .unwrap();
        let mut d = RigidBodyDesc::dynamic(shape, 2000.0, Pose::IDENTITY)
            .unwrap()
            .with_velocity(DVec3::X * 300.0, DVec3::ZERO);
        d.ccd = true;
        let b = w.add_body(&d).unwrap();
        for _ in 0..60 {
            w.step(1.0 / 60.0).unwrap();
        }
        let x = w.body(b).unwrap().center_of_mass().x;
        assert!(x < 10.0, "the body went through the wall: x = {x}");
    }
}

/// A light box carrying one a hundred times heavier stays put (soft
/// contacts with substeps handle large mass ratios).
#[test]
fn a_one_to_a_hundred_mass_ratio_stack_holds() {
    for sleep in [true, false] {
        let mut w = world_with_ground(0.6, 0.0);
        let mut cfg = *w.solver_config();
        cfg.sleep.enabled = sleep;
        w.set_solver_config(cfg).unwrap();
        let light = w
            .add_body(
                &RigidBodyDesc::dynamic(
                    Shape::cuboid(DVec3::splat(0.25)).unwrap(),
                    8.0,
                    Pose::from_translation(DVec3::Y * 0.25),
                )
                .unwrap(),
            )
            .unwrap();
        let heavy = w
            .add_body(
                &RigidBodyDesc::dynamic(
                    Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                    100.0,
                    Pose::from_translation(DVec3::Y * 1.0),
                )
                .unwrap(),
            )
            .unwrap();
        let ratio = w.body(heavy).unwrap().mass() / w.body(light).unwrap().mass();
        assert!((ratio - 100.0).abs() < 1e-9);
        common::run(&mut w, 1.0 / 60.0, 60);
        let settled = w.body(heavy).unwrap().center_of_mass();
        common::run(&mut w, 1.0 / 60.0, 600);
        let drift = (w.body(heavy).unwrap().center_of_mass() - settled).length();
        let top = w.body(heavy).unwrap().center_of_mass().y;
        // Asleep or awake, it holds still.
        eprintln!(
            "sleep={sleep}: the heavy box drifted {drift:.2e} m in 10 s, rests at {top:.4} m"
        );
        assert!(
            drift < 1e-3,
            "sleep={sleep}: the heavy box drifted {drift} m"
        );
        assert!(
            top > 0.9,
            "sleep={sleep}: the light box was crushed (heavy box at {top})"
        );
    }
}
