//! Stability defects found by trying the engine as a new user would, each
//! pinned by a test named after it.

use crate::common;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, World};

const G: f64 = 9.81;
const DT: f64 = 1.0 / 60.0;

fn world_with_ground() -> World {
    ground_world(1)
}

/// Gravity and a static ground whose top is at `y = 0`, stepped on
/// `threads` threads.
fn ground_world(threads: usize) -> World {
    let mut w = World::new(inertia_physics::WorldConfig {
        threads,
        ..Default::default()
    })
    .unwrap();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let ground = RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    );
    w.add_body(&ground).unwrap();
    w
}

fn cube(w: &mut World, half: f64, at: DVec3, rotation: DQuat) -> BodyHandle {
    let pose = Pose::new(at, rotation);
    w.add_body(
        &RigidBodyDesc::dynamic(Shape::cuboid(DVec3::splat(half)).unwrap(), 500.0, pose).unwrap(),
    )
    .unwrap()
}

fn asleep(w: &World, bodies: &[BodyHandle]) -> usize {
    bodies
        .iter()
        .filter(|h| w.body(**h).unwrap().is_sleeping())
        .count()
}

/// Four layers of 5 × 5 boxes, a little apart and a little turned (by the
/// generator seeded `seed`), so that they land on each other unevenly and
/// settle as a heap: when every box sleeps, s (`None` within 30 s), and
/// how many sleep then.
fn heap_sleeps(seed: u64) -> (Option<f64>, usize) {
    let mut w = world_with_ground();
    let mut r = common::Rng(seed);
    let mut boxes = Vec::new();
    for layer in 0..4 {
        for i in 0..5 {
            for k in 0..5 {
                let at = DVec3::new(
                    (i as f64 - 2.0) * 0.55 + r.range(-0.1, 0.1),
                    0.3 + layer as f64 * 0.6 + r.range(0.0, 0.1),
                    (k as f64 - 2.0) * 0.55 + r.range(-0.1, 0.1),
                );
                let turn = DQuat::from_euler(
                    inertia_physics::glam::EulerRot::XYZ,
                    r.range(-0.3, 0.3),
                    r.range(-0.8, 0.8),
                    r.range(-0.3, 0.3),
                );
                boxes.push(cube(&mut w, 0.25, at, turn));
            }
        }
    }
    assert_eq!(boxes.len(), 100);
    for step in 0..(30.0 / DT) as usize {
        w.step(DT).unwrap();
        if asleep(&w, &boxes) == boxes.len() {
            return (Some(step as f64 * DT), boxes.len());
        }
    }
    (None, asleep(&w, &boxes))
}

#[test]
fn issue_13_a_settled_heap_of_a_hundred_boxes_sleeps() {
    let (all_asleep_at, asleep) = heap_sleeps(13);
    assert!(
        all_asleep_at.is_some_and(|t| t < 15.0),
        "{asleep} of 100 asleep after 30 s"
    );
}

/// Heaps in which a box rests beside the heap, its kept contact with a
/// heap box a hair apart while the shapes collided afresh just touch:
/// each time the heap fell asleep, the resting box woke it (taken for a
/// body about to hit it), and the heap stayed awake for ever (two of 400
/// seeds; a third never sleeps for another reason, a box that keeps
/// rocking on the heap's edge).
#[test]
fn issue_13_a_heap_and_a_box_resting_against_it_do_not_wake_each_other() {
    for seed in [49, 99] {
        let (all_asleep_at, asleep) = heap_sleeps(seed);
        assert!(
            all_asleep_at.is_some_and(|t| t < 15.0),
            "heap {seed}: {asleep} of 100 asleep after 30 s"
        );
    }
}

#[test]
fn issue_13_resting_neighbours_a_centimetre_apart_fall_asleep() {
    // Two boxes side by side on the ground, 1 cm apart, the second put
    // down a little later: each rests, neither touches the other. The
    // first fell asleep before the second; the second, resting, must not
    // wake it (it did, and then the first woke the second in turn, for
    // ever).
    let mut w = world_with_ground();
    let first = cube(&mut w, 0.25, DVec3::new(0.0, 0.25, 0.0), DQuat::IDENTITY);
    common::run(&mut w, DT, 45);
    let second = cube(&mut w, 0.25, DVec3::new(0.51, 0.26, 0.0), DQuat::IDENTITY);
    let mut woken = 0;
    let mut was_asleep = w.body(first).unwrap().is_sleeping();
    for _ in 0..(5.0 / DT) as usize {
        w.step(DT).unwrap();
        let asleep_now = w.body(first).unwrap().is_sleeping();
        woken += usize::from(was_asleep && !asleep_now);
        was_asleep = asleep_now;
    }
    assert_eq!(woken, 0, "the first box was woken {woken} times");
    assert_eq!(asleep(&w, &[first, second]), 2, "both asleep after 5 s");
}

#[test]
fn issue_13_a_resting_box_keeps_its_contact_points_when_it_barely_moves() {
    use inertia_physics::rigid::narrow::collide;
    // B turned 45° about the vertical on A (their faces overlap in an
    // octagon: eight clipped points, four kept) and tipped 1° about x, so
    // that two of the points are equally deep. A turn of a ten-millionth
    // of a radian either way makes one or the other the deepest; the
    // points kept must not change with it.
    let cube = Shape::cuboid(DVec3::splat(0.25)).unwrap();
    let turned = |eps: f64, y: f64| {
        let rotation = DQuat::from_rotation_z(eps)
            * DQuat::from_rotation_x(1f64.to_radians())
            * DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        Pose::new(DVec3::new(0.0, y, 0.0), rotation)
    };
    let probe = collide(&cube, &Pose::IDENTITY, &cube, &turned(0.0, 0.5), 0.05).unwrap();
    // Down until the deepest point is 1 mm in.
    let y = 0.5 - probe.min_separation().unwrap() - 0.001;
    let ids = |eps: f64| {
        let m = collide(&cube, &Pose::IDENTITY, &cube, &turned(eps, y), 0.02).unwrap();
        let mut ids: Vec<u32> = m.points.iter().map(|p| p.id).collect();
        ids.sort_unstable();
        ids
    };
    let (left, right) = (ids(-1e-7), ids(1e-7));
    assert_eq!(left.len(), 4);
    assert_eq!(left, right, "the points kept swapped");
}

#[test]
fn issue_13_a_bounce_at_60_hz_rises_to_e_squared_h() {
    // Restitution answered the speed at the start of the step in which the
    // ball met the ground, not the speed it met it at, and launched it
    // from where it stopped: at 60 Hz the first bounce of a drop from
    // half a metre rose 13 % short of e² h. What is left is the
    // integrator's: a flight integrated in substeps of h rises about
    // v·h/2 short of v²/2g.
    for (e, h) in [(0.5, 0.5), (0.8, 0.5), (0.5, 2.0), (0.8, 2.0)] {
        let ratio = common::bounce_ratio(e, h, 60.0);
        assert!(
            (0.95..=1.01).contains(&ratio),
            "e={e}, h={h}: apex {ratio} of e² h"
        );
    }
}

#[test]
fn issue_13_a_box_pushed_out_of_the_ground_does_not_sleep_inside_it() {
    // Push-out moves a body out of an overlap without giving it velocity:
    // a box put into the ground counted as resting from its first step and
    // fell asleep after half a second wherever the push had got it (5.6 mm
    // deep from 45 cm). It rests at the ground's surface (a third of a
    // millimetre in, where the soft contact holds it) before it sleeps.
    for depth in [0.1, 0.2, 0.45, 0.6] {
        let mut w = world_with_ground();
        let b = cube(&mut w, 0.25, DVec3::Y * (0.25 - depth), DQuat::IDENTITY);
        let mut asleep_with_bottom_at = None;
        for _ in 0..(10.0 / DT) as usize {
            w.step(DT).unwrap();
            let body = w.body(b).unwrap();
            if body.is_sleeping() {
                asleep_with_bottom_at = Some(body.center_of_mass().y - 0.25);
                break;
            }
        }
        let bottom = asleep_with_bottom_at.expect("asleep within 10 s");
        assert!(
            bottom > -0.001,
            "{depth} m deep: asleep with its bottom at {bottom} m"
        );
    }
}

/// The speed along `down` and the rolling speed `ω r` of a body of radius
/// `r` m rolling about its z axis after `seconds`, launched at `v0` m/s
/// along x on ground tilted by `angle` rad about z, at 60 Hz.
fn roll(shape: Shape, r: f64, turn: DQuat, v0: f64, angle: f64, seconds: f64) -> (f64, f64) {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -G, 0.0)).unwrap();
    let tilt = DQuat::from_rotation_z(-angle);
    let ground = RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(60.0, 0.5, 5.0)).unwrap(),
        Pose::new(tilt * (DVec3::NEG_Y * 0.5), tilt),
    );
    w.add_body(&ground).unwrap();
    let down = tilt * DVec3::X;
    let desc = RigidBodyDesc::dynamic(shape, 1000.0, Pose::new(tilt * (DVec3::Y * r), turn))
        .unwrap()
        .with_velocity(down * v0, DVec3::ZERO);
    let b = w.add_body(&desc).unwrap();
    common::run(&mut w, DT, (seconds / DT) as usize);
    let body = w.body(b).unwrap();
    (
        body.linear_velocity().dot(down),
        -body.angular_velocity().z * r,
    )
}

#[test]
fn issue_13_rolling_bodies_roll_without_slipping() {
    // Reported slipping about 2 % at the contact point; measured here, a
    // rolling sphere, capsule and cylinder keep v = ω r to a part in a
    // thousand, on flat ground (at the speed theory gives once sliding
    // friction has brought them to roll) and down a 20° slope (at the
    // acceleration theory gives).
    let r = 0.5;
    let side = DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2);
    let cases = [
        (
            "sphere",
            Shape::sphere(r).unwrap(),
            DQuat::IDENTITY,
            2.0 / 5.0,
        ),
        ("capsule", Shape::capsule(r, r).unwrap(), side, f64::NAN),
        ("cylinder", Shape::cylinder(r, r).unwrap(), side, 1.0 / 2.0),
    ];
    for (name, shape, turn, k) in cases {
        // Flat, launched sliding at 5 m/s: rolls at 5 / (1 + k).
        let (v, wr) = roll(shape.clone(), r, turn, 5.0, 0.0, 2.0);
        assert!(
            (v - wr).abs() < 1e-3 * v,
            "{name} on the flat: v {v}, ω r {wr}"
        );
        if k.is_finite() {
            let expected = 5.0 / (1.0 + k);
            assert!(
                (v - expected).abs() < 1e-3 * expected,
                "{name}: {v} m/s, theory {expected}"
            );
        }
        // Down a 20° slope from rest: v = g sin θ t / (1 + k).
        let angle = 20f64.to_radians();
        let (v, wr) = roll(shape, r, turn, 0.0, angle, 1.5);
        assert!(
            (v - wr).abs() < 1e-3 * v,
            "{name} on the slope: v {v}, ω r {wr}"
        );
        if k.is_finite() {
            let expected = G * angle.sin() * 1.5 / (1.0 + k);
            assert!(
                (v - expected).abs() < 2e-3 * expected,
                "{name}: {v} m/s, theory {expected}"
            );
        }
    }
}

/// A world at rest reuses what it worked out while nothing changed (it
/// does not look at every body each step), and still answers every change:
/// a teleport, a push, new gravity.
#[test]
fn a_world_at_rest_answers_every_change() {
    let mut w = world_with_ground();
    let b = cube(&mut w, 0.25, DVec3::new(0.0, 0.25, 0.0), DQuat::IDENTITY);
    let mut steps = 0;
    while !w.body(b).unwrap().is_sleeping() {
        w.step(DT).unwrap();
        steps += 1;
        assert!(steps < 600, "the box never fell asleep");
    }
    let mass = w.body(b).unwrap().mass();
    let height = |w: &World| w.body(b).unwrap().center_of_mass().y;
    for _ in 0..3 {
        w.step(DT).unwrap();
    }
    let e = w.energy();
    assert_eq!(e.kinetic, 0.0);
    let expected = mass * G * height(&w);
    assert!((e.gravity_uniform - expected).abs() < 1e-9 * expected);

    // Teleported (asleep, at rest): the energy follows.
    let pose = Pose::from_translation(DVec3::new(0.0, 2.0, 0.0));
    w.set_body_pose(b, pose).unwrap();
    w.step(DT).unwrap();
    let expected = mass * G * height(&w);
    assert!(height(&w) > 1.9);
    assert!((w.energy().gravity_uniform - expected).abs() < 1e-9 * expected);

    // Stronger gravity: the energy follows, and the box falls.
    for _ in 0..240 {
        w.step(DT).unwrap();
    }
    assert!(height(&w) < 0.3, "the box did not fall: {}", height(&w));
    w.set_gravity(DVec3::new(0.0, -2.0 * G, 0.0)).unwrap();
    while !w.body(b).unwrap().is_sleeping() {
        w.step(DT).unwrap();
    }
    w.step(DT).unwrap();
    let expected = mass * 2.0 * G * height(&w);
    assert!((w.energy().gravity_uniform - expected).abs() < 1e-9 * expected);

    // Pushed while the world is at rest: it moves.
    let before = w.body(b).unwrap().center_of_mass();
    w.set_body_velocity(b, DVec3::new(3.0, 0.0, 0.0), DVec3::ZERO)
        .unwrap();
    for _ in 0..10 {
        w.step(DT).unwrap();
    }
    assert!(w.body(b).unwrap().center_of_mass().x > before.x + 0.2);
}

/// Stacks where each box is ten (or a thousand) times heavier than the one
/// under it: the soft contacts under a light box gave way in proportion to
/// the mass ratio (a 1 : 1000 pair sank 28 cm into each other and the
/// ground, a 1 : 10 : 100 : 1000 stack 70 cm), and a five-box stack
/// collapsed through the ground.
#[test]
fn issue_13_heavy_boxes_on_light_ones_do_not_sink_through() {
    for (boxes, ratio) in [(2usize, 1000.0f64), (4, 10.0), (5, 10.0)] {
        for hz in [60.0, 120.0] {
            let mut w = world_with_ground();
            let stack: Vec<BodyHandle> = (0..boxes)
                .map(|i| {
                    let density = 10.0 * ratio.powi(i as i32);
                    let pose = Pose::from_translation(DVec3::Y * (0.5 + i as f64));
                    let desc = RigidBodyDesc::dynamic(
                        Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                        density,
                        pose,
                    )
                    .unwrap();
                    w.add_body(&desc).unwrap()
                })
                .collect();
            let centre = |w: &World, i: usize| w.body(stack[i]).unwrap().center_of_mass();
            common::run(&mut w, 1.0 / hz, (2.0 * hz) as usize);
            let settled: Vec<DVec3> = (0..boxes).map(|i| centre(&w, i)).collect();
            let mut deepest = 0.0f64;
            for _ in 0..(2.0 * hz) as usize {
                w.step(1.0 / hz).unwrap();
                for i in 0..boxes {
                    let floor = if i == 0 {
                        0.0
                    } else {
                        centre(&w, i - 1).y + 0.5
                    };
                    deepest = deepest.max(floor - (centre(&w, i).y - 0.5));
                }
            }
            let drift = (0..boxes)
                .map(|i| (centre(&w, i) - settled[i]).length())
                .fold(0.0, f64::max);
            assert!(
                deepest < 0.01,
                "{boxes} boxes at 1 : {ratio} a level, {hz} Hz: {:.1} mm deep",
                deepest * 1e3
            );
            assert!(
                drift < 1e-3,
                "{boxes} boxes at 1 : {ratio} a level, {hz} Hz: drifted {:.2} mm",
                drift * 1e3
            );
        }
    }
}

/// A heavy plank (3 t) across two light boxes (1.25 kg each): the soft
/// contacts under the boxes gave way in proportion to the load they
/// carried over the boxes' own mass, and the boxes sank into the ground
/// (25 cm, all the way, before shock propagation; 17 cm with it, until
/// those contacts measured their give from the load they carried).
#[test]
fn issue_13_a_heavy_plank_does_not_press_light_boxes_into_the_ground() {
    let mut w = world_with_ground();
    let light = |x: f64| {
        RigidBodyDesc::dynamic(
            Shape::cuboid(DVec3::splat(0.25)).unwrap(),
            10.0,
            Pose::from_translation(DVec3::new(x, 0.25, 0.0)),
        )
        .unwrap()
    };
    let boxes = [
        w.add_body(&light(-1.0)).unwrap(),
        w.add_body(&light(1.0)).unwrap(),
    ];
    let plank = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::new(1.5, 0.1, 0.5)).unwrap(),
                5000.0,
                Pose::from_translation(DVec3::Y * 0.6),
            )
            .unwrap(),
        )
        .unwrap();
    common::run(&mut w, DT, 300);
    for b in boxes {
        let y = w.body(b).unwrap().center_of_mass().y;
        assert!(
            (y - 0.25).abs() < 2e-3,
            "a light box rests at {y} m, not 0.25"
        );
    }
    let top = w.body(plank).unwrap().center_of_mass();
    assert!((top.y - 0.6).abs() < 3e-3, "the plank rests at {top}");
    assert!(
        top.x.abs() < 0.01 && top.z.abs() < 0.01,
        "the plank slid to {top}"
    );
}

/// A box a hundred times heavier dropped 2 m onto a light one: the light
/// one was driven into the ground and thrown out at 9 m/s.
#[test]
fn issue_13_a_heavy_box_dropped_on_a_light_one_does_not_drive_it_into_the_ground() {
    let mut w = world_with_ground();
    let cube = |density: f64, y: f64| {
        RigidBodyDesc::dynamic(
            Shape::cuboid(DVec3::splat(0.5)).unwrap(),
            density,
            Pose::from_translation(DVec3::Y * y),
        )
        .unwrap()
    };
    let light = w.add_body(&cube(10.0, 0.5)).unwrap();
    let heavy = w.add_body(&cube(1000.0, 3.5)).unwrap();
    let mut fastest = 0.0f64;
    for _ in 0..300 {
        w.step(DT).unwrap();
        fastest = fastest.max(w.body(light).unwrap().linear_velocity().length());
    }
    assert!(fastest < 6.0, "the light box was thrown at {fastest} m/s");
    for (name, h) in [("light", light), ("heavy", heavy)] {
        let y = w.body(h).unwrap().center_of_mass().y;
        assert!(
            y > 0.495,
            "the {name} box ends {:.1} mm into the ground",
            (0.5 - y) * 1e3
        );
    }
}

/// The shock pass (heavy bodies over light ones) keeps the step exact: the
/// same bits on 1 and 2 threads, and after a save and restore.
#[test]
fn heavy_over_light_stacks_step_identically_on_any_thread_count_and_after_a_restore() {
    let build = |threads: usize| {
        let mut w = ground_world(threads);
        // Ten stacks of four, each box ten times the one under it, a little
        // off centre so that they lean and touch their neighbours.
        for s in 0..10 {
            for i in 0..4 {
                let at = DVec3::new(s as f64 * 1.02 + 0.03 * i as f64, 0.5 + i as f64, 0.0);
                let desc = RigidBodyDesc::dynamic(
                    Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                    10.0 * 10f64.powi(i),
                    Pose::from_translation(at),
                )
                .unwrap();
                w.add_body(&desc).unwrap();
            }
        }
        w
    };
    let hashes = |w: &mut World, n: usize| common::state_hashes(w, DT, n);
    let (mut one, mut two) = (build(1), build(2));
    assert_eq!(
        hashes(&mut one, 60),
        hashes(&mut two, 60),
        "1 and 2 threads differ"
    );
    let saved = one.save();
    let expected = hashes(&mut one, 60);
    let mut restored = build(2);
    restored.restore(&saved).unwrap();
    assert_eq!(
        hashes(&mut restored, 60),
        expected,
        "restore-then-step differs"
    );
}
