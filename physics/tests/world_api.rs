//! What a game's rules read and set on the world as a whole: one gravity
//! for bodies and particles, the push-out the solver gave a body, and the
//! contact pairs, which survive a save and a restore.

use crate::common;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{ParticleDesc, SystemDesc, UniformGravity, World};

const DT: f64 = 1.0 / 60.0;

fn ground(w: &mut World) -> inertia_physics::BodyHandle {
    w.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(10.0, 0.5, 10.0)).unwrap(),
        Pose::from_translation(DVec3::NEG_Y * 0.5),
    ))
    .unwrap()
}

/// The world's gravity is set once: a body and a particle dropped side by
/// side fall together; a system's gravity scale and its own gravity forces
/// scale and add to it.
#[test]
fn issue_13_gravity_is_set_once_for_bodies_and_particles() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let ball = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::sphere(0.1).unwrap(),
                1000.0,
                Pose::from_translation(DVec3::Y * 10.0),
            )
            .unwrap(),
        )
        .unwrap();
    let falls = w.add_system(SystemDesc::default());
    let floats = w.add_system(SystemDesc {
        gravity_scale: 0.0,
        ..SystemDesc::default()
    });
    let doubled = w.add_system(SystemDesc::default());
    w.add_force(doubled, UniformGravity::earth()).unwrap();
    let at = |x: f64| ParticleDesc::at(DVec3::new(x, 10.0, 0.0), 1.0);
    let p = w.add_particle(falls, at(1.0)).unwrap();
    let q = w.add_particle(floats, at(2.0)).unwrap();
    let r = w.add_particle(doubled, at(3.0)).unwrap();
    for _ in 0..60 {
        w.step(DT).unwrap();
    }
    let fall = |y: f64| 10.0 - y;
    let body = fall(w.body(ball).unwrap().pose().translation.y);
    let particle = fall(w.particle(p).unwrap().position.y);
    // g t² / 2 over one second, to the integrators' first-order error.
    assert!((body - 4.905).abs() < 0.1, "body fell {body} m");
    assert!(
        (particle - body).abs() < 0.1,
        "particle {particle} m, body {body} m"
    );
    assert_eq!(w.particle(q).unwrap().position.y, 10.0, "scale 0 floats");
    let twice = fall(w.particle(r).unwrap().position.y);
    assert!(
        (twice - 2.0 * particle).abs() < 1e-6,
        "{twice} m against {particle} m"
    );
}

/// A bad gravity is refused and changes nothing; a particle system's
/// gravity scale that is not finite is taken as 1.
#[test]
fn issue_13_bad_gravity_is_refused() {
    let mut w = common::world();
    w.set_gravity(DVec3::NEG_Y).unwrap();
    for bad in [f64::NAN, f64::INFINITY] {
        assert!(w.set_gravity(DVec3::new(0.0, bad, 0.0)).is_err());
        assert_eq!(w.gravity(), DVec3::NEG_Y);
    }
    let s = w.add_system(SystemDesc {
        gravity_scale: f64::NAN,
        ..SystemDesc::default()
    });
    let p = w
        .add_particle(s, ParticleDesc::at(DVec3::ZERO, 1.0))
        .unwrap();
    w.step(DT).unwrap();
    let y = w.particle(p).unwrap().position.y;
    assert!(y < 0.0 && y.is_finite(), "fell to {y}");
}

/// Push-out moves a body out of the ground without giving it velocity;
/// the rules read how fast it was moved from `push_velocity`, which is
/// zero for a body that falls freely or rests.
#[test]
fn issue_13_push_out_velocity_can_be_read() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    ground(&mut w);
    let sunk = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                100.0,
                Pose::from_translation(DVec3::Y * 0.3),
            )
            .unwrap(),
        )
        .unwrap();
    let falling = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::sphere(0.5).unwrap(),
                100.0,
                Pose::from_translation(DVec3::new(5.0, 8.0, 0.0)),
            )
            .unwrap(),
        )
        .unwrap();
    w.step(DT).unwrap();
    let b = w.body(sunk).unwrap();
    let push = b.push_velocity();
    // 0.2 m deep: the solver pushes out at up to its push-out speed.
    assert!(push.y > 0.1, "pushed up at {push} m/s");
    assert!(
        push.x.abs().max(push.z.abs()) < 0.05 * push.y,
        "mostly up: {push}"
    );
    assert!(
        b.linear_velocity().y < push.y,
        "the push is not in its velocity ({} m/s)",
        b.linear_velocity().y
    );
    assert!(w.body(falling).unwrap().push_velocity().length() < 1e-9);
    for _ in 0..240 {
        w.step(DT).unwrap();
    }
    let rest = w.body(sunk).unwrap();
    assert!(rest.pose().translation.y > 0.49, "pushed out");
    assert!(
        rest.push_velocity().length() < 0.01,
        "{}",
        rest.push_velocity()
    );
}

/// The contact pairs are saved: a restored world reports what the saved
/// one did, and the two go on bit for bit, queries included.
#[test]
fn issue_13_contact_pairs_survive_a_save_and_restore() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let g = ground(&mut w);
    let boxes: Vec<_> = (0..3)
        .map(|i| {
            w.add_body(
                &RigidBodyDesc::dynamic(
                    Shape::cuboid(DVec3::splat(0.5)).unwrap(),
                    100.0,
                    Pose::from_translation(DVec3::Y * (0.5 + f64::from(i))),
                )
                .unwrap(),
            )
            .unwrap()
        })
        .collect();
    for _ in 0..30 {
        w.step(DT).unwrap();
    }
    let saved = w.save();
    let mut restored = World::from_saved(*w.config(), &saved).unwrap();
    let pairs = |w: &World| -> Vec<_> { w.contacts_of(boxes[0]).collect() };
    assert_eq!(pairs(&w).len(), 2, "on the ground, under the second box");
    assert_eq!(pairs(&restored), pairs(&w));
    assert_eq!(
        restored.contact_between(boxes[0], g),
        w.contact_between(boxes[0], g)
    );
    assert_eq!(restored.state_hash(), w.state_hash());
    for _ in 0..30 {
        w.step(DT).unwrap();
        restored.step(DT).unwrap();
        assert_eq!(pairs(&restored), pairs(&w));
        assert_eq!(restored.state_hash(), w.state_hash());
    }
}
