//! Contact recycling: a pair's manifold is used again while its bodies
//! barely move relative to each other, and collided afresh once they do.

use crate::common;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::contact::ManifoldCount;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, World};

const DT: f64 = 1.0 / 60.0;

/// A world with gravity, a ground slab whose top is at y = 0, and sleeping
/// off (so that bodies at rest keep being stepped).
fn world_with_ground() -> World {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let mut cfg = *w.solver_config();
    cfg.sleep.enabled = false;
    w.set_solver_config(cfg).unwrap();
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(20.0, 0.5, 20.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))
    .unwrap();
    w
}

fn cuboid(w: &mut World, half: DVec3, at: DVec3) -> BodyHandle {
    w.add_body(
        &RigidBodyDesc::dynamic(
            Shape::cuboid(half).unwrap(),
            500.0,
            Pose::from_translation(at),
        )
        .unwrap(),
    )
    .unwrap()
}

/// The manifold counts summed over `steps` steps.
fn run(w: &mut World, steps: usize) -> ManifoldCount {
    let mut sum = ManifoldCount::default();
    for _ in 0..steps {
        sum += w.step(DT).unwrap().manifolds;
    }
    sum
}

#[test]
fn a_resting_stack_uses_its_manifolds_again_and_stays_put() {
    let mut w = world_with_ground();
    let boxes: Vec<BodyHandle> = (0..5)
        .map(|i| {
            cuboid(
                &mut w,
                DVec3::splat(0.5),
                DVec3::new(0.0, 0.5 + i as f64, 0.0),
            )
        })
        .collect();
    run(&mut w, 120);
    let settled: Vec<DVec3> = boxes
        .iter()
        .map(|h| w.body(*h).unwrap().center_of_mass())
        .collect();
    let count = run(&mut w, 240);
    // Five manifolds a step (box on ground, four box on box): at rest
    // almost all of them are the last step's.
    let total = count.collided + count.recycled;
    assert!(total >= 5 * 240, "{count:?}");
    assert!(
        count.recycled * 10 >= total * 9,
        "at rest, at least 90 % of manifolds are used again: {count:?}"
    );
    // And the stack stands as it did.
    for (h, before) in boxes.iter().zip(&settled) {
        let now = w.body(*h).unwrap().center_of_mass();
        assert!((now - *before).length() < 1e-3, "{before} -> {now}");
    }
    let top = w.body(boxes[4]).unwrap().center_of_mass();
    assert!((top.y - 4.5).abs() < 0.01 && top.x.abs() < 1e-3, "{top}");
}

#[test]
fn a_turned_body_does_not_keep_its_old_contacts() {
    // A plank resting across two pillars; turned a quarter turn about the
    // vertical through its centre, it no longer reaches them and must fall
    // between them, although its centre has not moved.
    let mut w = world_with_ground();
    for x in [-1.5, 1.5] {
        w.add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(DVec3::new(0.25, 0.5, 0.25)).unwrap(),
            Pose::from_translation(DVec3::new(x, 0.5, 0.0)),
        ))
        .unwrap();
    }
    let plank = cuboid(&mut w, DVec3::new(2.0, 0.1, 0.2), DVec3::new(0.0, 1.1, 0.0));
    let resting = run(&mut w, 60);
    assert!(
        resting.recycled > 0,
        "the plank's contacts are recycled: {resting:?}"
    );
    let y = w.body(plank).unwrap().center_of_mass().y;
    assert!(
        (y - 1.1).abs() < 0.01,
        "the plank rests on the pillars: {y}"
    );

    let pose = w.body(plank).unwrap().pose();
    let turned = Pose::new(
        pose.translation,
        DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2) * pose.rotation,
    );
    w.set_body_pose(plank, turned).unwrap();
    run(&mut w, 60);
    let y = w.body(plank).unwrap().center_of_mass().y;
    assert!(y < 0.2, "the turned plank fell to the ground: y = {y}");
}

#[test]
fn a_body_teleported_off_its_support_falls() {
    let mut w = world_with_ground();
    let shelf = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(DVec3::new(0.5, 0.5, 0.5)).unwrap(),
            Pose::from_translation(DVec3::new(0.0, 0.5, 0.0)),
        ))
        .unwrap();
    let cube = cuboid(&mut w, DVec3::splat(0.2), DVec3::new(0.0, 1.2, 0.0));
    assert!(run(&mut w, 60).recycled > 0);
    let shelf_top = w.body(shelf).unwrap().center_of_mass().y + 0.5;
    let y = w.body(cube).unwrap().center_of_mass().y;
    assert!((y - (shelf_top + 0.2)).abs() < 0.01, "{y}");

    // A tenth of a millimetre beyond the edge is enough: the cube's
    // contacts are found again and it falls past the shelf.
    let pose = w.body(cube).unwrap().pose();
    w.set_body_pose(
        cube,
        Pose::new(
            pose.translation + DVec3::new(0.7001, 0.0, 0.0),
            pose.rotation,
        ),
    )
    .unwrap();
    run(&mut w, 60);
    let y = w.body(cube).unwrap().center_of_mass().y;
    assert!(y < 0.5, "the cube fell off the shelf: y = {y}");
}

#[test]
fn a_sliding_box_is_collided_again_as_it_goes() {
    // A box sliding across the ground moves more than the recycling drift
    // every step, so every step collides its shapes afresh.
    let mut w = world_with_ground();
    let b = cuboid(&mut w, DVec3::splat(0.25), DVec3::new(0.0, 0.25, 0.0));
    run(&mut w, 10);
    w.set_body_velocity(b, DVec3::new(3.0, 0.0, 0.0), DVec3::ZERO)
        .unwrap();
    let sliding = run(&mut w, 10);
    assert_eq!(sliding.recycled, 0, "{sliding:?}");
    assert!(sliding.collided >= 10, "{sliding:?}");
}
