//! The contact state in a saved world: small enough that a recording's
//! keyframes and a replay's checkpoints stay within their budgets, and a
//! state saved before it was made small still restores.

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, World};

const DT: f64 = 1.0 / 60.0;

fn ground_world() -> World {
    let mut w = World::new(Default::default()).unwrap();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))
    .unwrap();
    w
}

/// A pyramid of 55 crates and a heap of 40 balls, settled on the ground
/// (185 manifolds).
fn settled_pile() -> World {
    let mut w = ground_world();
    let cube = Shape::cuboid(DVec3::splat(0.5)).unwrap();
    for row in 0..10 {
        for i in 0..10 - row {
            let x = i as f64 - (9 - row) as f64 * 0.5;
            let pose = Pose::from_translation(DVec3::new(x, 0.5 + row as f64, 0.0));
            w.add_body(&RigidBodyDesc::dynamic(cube.clone(), 200.0, pose).unwrap())
                .unwrap();
        }
    }
    let ball = Shape::sphere(0.4).unwrap();
    for i in 0..40 {
        let at = DVec3::new(
            (i % 5) as f64 * 0.85 - 1.7,
            0.4 + (i / 20) as f64 * 0.85,
            4.0 + ((i / 5) % 4) as f64 * 0.85,
        );
        let pose = Pose::new(at, DQuat::from_rotation_y(0.1 * i as f64));
        w.add_body(&RigidBodyDesc::dynamic(ball.clone(), 300.0, pose).unwrap())
            .unwrap();
    }
    for _ in 0..120 {
        w.step(DT).unwrap();
    }
    w
}

/// A saved pile holds its bodies and about two manifolds of contacts a
/// body. With the contact cache in double precision and each pair's
/// query figures kept beside it (format 5), this pile saved 1 295 bytes
/// a body; in format 6, 838.
#[test]
fn issue_13_a_settled_pile_saves_under_a_kilobyte_a_body() {
    let w = settled_pile();
    let bodies = w.bodies().count();
    assert!(
        w.contact_count() >= bodies,
        "the pile should rest on itself ({} manifolds, {bodies} bodies)",
        w.contact_count()
    );
    let per_body = w.save().len() / bodies;
    assert!(per_body <= 950, "{per_body} bytes a body");
    // And what is saved is still all there is: restore, step, compare.
    let mut again = ground_world();
    again.restore(&w.save()).unwrap();
    let mut w = w;
    for _ in 0..30 {
        w.step(DT).unwrap();
        again.step(DT).unwrap();
    }
    assert_eq!(w.state_hash(), again.state_hash());
}

/// A world saved by the build before (format 5: the contact cache in
/// double precision, the rules' pair figures kept by pair) restores; its
/// pair queries report what that build reported (to single precision; a
/// pair of several manifolds, the dumbbell on the ground, included), and it
/// steps on as a format 6 world.
#[test]
fn issue_13_a_state_saved_in_format_5_restores_with_its_pair_contacts() {
    let bytes = include_bytes!("data/world_format_5.bin");
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 5);
    let mut w = World::new(Default::default()).unwrap();
    w.restore(bytes).unwrap();
    let handles: Vec<BodyHandle> = w.bodies().map(|(h, _)| h).collect();
    let at = |h: BodyHandle| handles.iter().position(|x| *x == h).unwrap();
    let mut found = Vec::new();
    for &h in &handles {
        for p in w.contacts_of(h) {
            if at(p.a) < at(p.b) {
                found.push(p);
            }
        }
    }
    let expected = include_str!("data/world_format_5.pairs");
    assert_eq!(found.len(), expected.lines().count());
    for (p, line) in found.iter().zip(expected.lines()) {
        let v: Vec<f64> = line.split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!((at(p.a), at(p.b)), (v[0] as usize, v[1] as usize), "{line}");
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * y.abs().max(1e-3);
        assert!(close(p.impulse, v[2]), "impulse {} in {line}", p.impulse);
        assert!(
            close(p.separation, v[3]),
            "separation {} in {line}",
            p.separation
        );
        assert_eq!(p.points, v[4] as usize, "{line}");
        let normal = DVec3::new(v[5], v[6], v[7]);
        assert!(
            p.normal.distance(normal) < 1e-5,
            "normal {} in {line}",
            p.normal
        );
    }
    let heights: Vec<f64> = w.bodies().map(|(_, b)| b.center_of_mass().y).collect();
    for _ in 0..60 {
        w.step(DT).unwrap();
    }
    for ((_, b), y) in w.bodies().zip(heights) {
        assert!(
            (b.center_of_mass().y - y).abs() < 0.01,
            "a resting body moved from {y} to {}",
            b.center_of_mass().y
        );
    }
    let saved = w.save();
    assert_eq!(
        u32::from_le_bytes(saved[8..12].try_into().unwrap()),
        inertia_physics::saved_state::FORMAT_VERSION
    );
}

/// A format 5 state whose pair impulse lies beyond single precision is
/// refused: kept, it would become an infinity in the contact cache, and
/// the world could no longer be saved and restored.
#[test]
fn issue_13_a_format_5_figure_beyond_single_precision_is_refused() {
    let mut bytes = include_bytes!("data/world_format_5.bin").to_vec();
    let last = include_str!("data/world_format_5.pairs")
        .lines()
        .last()
        .unwrap();
    let impulse: f64 = last.split(' ').nth(2).unwrap().parse().unwrap();
    let at = bytes
        .windows(8)
        .position(|w| w == impulse.to_bits().to_le_bytes())
        .expect("the last pair's impulse");
    bytes[at..at + 8].copy_from_slice(&1e300f64.to_bits().to_le_bytes());
    assert!(inertia_physics::saved_state::reseal(&mut bytes));
    let mut w = ground_world();
    let before = w.state_hash();
    let err = w.restore(&bytes).unwrap_err();
    assert!(err.to_string().contains("beyond single precision"), "{err}");
    assert_eq!(w.state_hash(), before, "a refused restore changes nothing");
}
