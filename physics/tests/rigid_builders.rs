//! The body builder's methods: a mass given outright, materials set by
//! chaining, bad values refused with typed errors.

use crate::common;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::PhysicsError;

fn crate_of(density: f64) -> RigidBodyDesc {
    RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::new(0.5, 0.25, 1.0)).unwrap(),
        density,
        Pose::from_translation(DVec3::Y),
    )
    .unwrap()
}

#[test]
fn a_body_given_a_mass_weighs_that_much_with_its_shape_s_inertia() {
    let mut w = common::world();
    let light = crate_of(10.0);
    let heavy = crate_of(10.0).with_mass(80.0).unwrap();
    let (hl, hh) = (w.add_body(&light).unwrap(), w.add_body(&heavy).unwrap());
    let (l, h) = (w.body(hl).unwrap(), w.body(hh).unwrap());
    assert!((h.mass() - 80.0).abs() < 1e-9);
    // Same shape, same distribution: inertia in proportion to the mass.
    let ratio = h.mass() / l.mass();
    assert!((h.principal_inertia() - l.principal_inertia() * ratio).length() < 1e-9);
    assert_eq!(h.center_of_mass(), l.center_of_mass());
}

#[test]
fn materials_chain_onto_the_builder() {
    let desc = crate_of(100.0)
        .with_friction(0.9)
        .with_restitution(0.3)
        .with_damping(0.1, 0.2)
        .with_gravity_scale(0.5)
        .with_ccd(true)
        .with_can_sleep(false);
    assert_eq!((desc.friction_static, desc.friction_dynamic), (0.9, 0.9));
    let desc = desc.with_friction_coefficients(0.7, 0.4);
    assert_eq!((desc.friction_static, desc.friction_dynamic), (0.7, 0.4));
    assert_eq!(desc.restitution, 0.3);
    assert_eq!((desc.linear_damping, desc.angular_damping), (0.1, 0.2));
    assert_eq!(desc.gravity_scale, 0.5);
    assert!(desc.ccd && !desc.can_sleep && !desc.sensor);
    assert!(desc.as_sensor().sensor);
}

#[test]
fn bad_masses_are_refused_and_change_nothing() {
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e30] {
        assert!(crate_of(10.0).with_mass(bad).is_err(), "{bad} kg accepted");
    }
    let fixed = RigidBodyDesc::fixed(Shape::sphere(1.0).unwrap(), Pose::IDENTITY);
    assert!(matches!(
        fixed.with_mass(5.0),
        Err(PhysicsError::Invalid { .. })
    ));
    // A bad restitution set by chaining is refused when the body is added.
    let mut w = common::world();
    let before = w.state_hash();
    assert!(w
        .add_body(&crate_of(10.0).with_restitution(f64::NAN))
        .is_err());
    assert_eq!(w.state_hash(), before);
}
