//! Free rigid-body motion: gravity, damping, control, impulses, and the
//! rotation of spinning bodies (angular momentum, the intermediate-axis
//! instability).

use crate::common;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::{BodyKind, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, PhysicsError, World};

fn pose(p: DVec3) -> Pose {
    Pose {
        translation: p,
        rotation: DQuat::IDENTITY,
    }
}

/// A 1 × 2 × 3 m box of density 1000: principal moments all different.
fn brick(world: &mut World, omega: DVec3) -> BodyHandle {
    let shape = Shape::cuboid(DVec3::new(0.5, 1.0, 1.5)).unwrap();
    let desc = RigidBodyDesc::dynamic(shape, 1000.0, pose(DVec3::ZERO))
        .unwrap()
        .with_velocity(DVec3::ZERO, omega);
    world.add_body(&desc).unwrap()
}

#[test]
fn free_fall_follows_symplectic_euler_over_the_substeps_exactly() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let ball = Shape::sphere(0.5).unwrap();
    let h = w
        .add_body(&RigidBodyDesc::dynamic(ball, 500.0, pose(DVec3::new(0.0, 100.0, 0.0))).unwrap())
        .unwrap();
    let dt = 1.0 / 60.0;
    for _ in 0..60 {
        w.step(dt).unwrap();
    }
    // Symplectic Euler at the substep h = dt / substeps.
    let sub = f64::from(w.solver_config().substeps);
    let (n, hs) = (60.0 * sub, dt / sub);
    let expected = 100.0 - 9.81 * hs * hs * n * (n + 1.0) / 2.0;
    let b = w.body(h).unwrap();
    assert!(
        (b.center_of_mass().y - expected).abs() < 1e-9,
        "{} vs {expected}",
        b.center_of_mass().y
    );
    assert!((b.linear_velocity().y + 9.81).abs() < 1e-9);
}

#[test]
fn torque_free_spin_conserves_angular_momentum_and_energy() {
    let mut w = common::world();
    let h = brick(&mut w, DVec3::new(0.3, 2.0, -1.1));
    let (l0, e0) = {
        let b = w.body(h).unwrap();
        (b.angular_momentum(), b.kinetic_energy())
    };
    let mut worst_energy = 0.0f64;
    for _ in 0..20_000 {
        w.step(1.0 / 120.0).unwrap();
        let b = w.body(h).unwrap();
        let dl = (b.angular_momentum() - l0).length() / l0.length();
        assert!(dl < 1e-10, "angular momentum drift {dl}");
        worst_energy = worst_energy.max((b.kinetic_energy() - e0).abs() / e0);
    }
    assert!(worst_energy < 1e-3, "energy error {worst_energy}");
}

/// The tennis-racket theorem: spin about the axes of least and greatest
/// inertia is stable, about the intermediate axis it is not.
#[test]
fn spin_about_the_intermediate_axis_is_unstable_the_others_stable() {
    // Principal axes of the brick are its edges: I_x > I_y > I_z? For a box
    // of half extents (a, b, c): I_x ∝ b² + c², so with (0.5, 1, 1.5) the
    // largest is X, the intermediate Y, the smallest Z.
    let perturb = DVec3::splat(1e-3);
    for (axis, stable) in [(DVec3::X, true), (DVec3::Y, false), (DVec3::Z, true)] {
        let mut w = common::world();
        let h = brick(&mut w, axis * 3.0 + perturb);
        let mut min_alignment = 1.0f64;
        for _ in 0..6000 {
            w.step(1.0 / 200.0).unwrap();
            let b = w.body(h).unwrap();
            let body_axis = b.pose().rotation * axis;
            let l = b.angular_momentum().normalize();
            min_alignment = min_alignment.min(body_axis.dot(l));
        }
        if stable {
            assert!(
                min_alignment > 0.999,
                "{axis}: axis wandered from L (cos = {min_alignment})"
            );
        } else {
            assert!(
                min_alignment < -0.9,
                "{axis}: expected the body to flip (min cos = {min_alignment})"
            );
        }
    }
}

#[test]
fn control_torque_spins_up_as_tau_t_over_i() {
    let mut w = common::world();
    let h = brick(&mut w, DVec3::ZERO);
    let iz = w.body(h).unwrap().inertia_world().z_axis.z;
    let tau = 50.0;
    w.set_body_control(h, DVec3::ZERO, DVec3::new(0.0, 0.0, tau))
        .unwrap();
    for _ in 0..100 {
        w.step(0.01).unwrap();
    }
    let omega = w.body(h).unwrap().angular_velocity();
    assert!(
        (omega.z - tau * 1.0 / iz).abs() < 1e-9 * omega.z.abs(),
        "{omega} vs {}",
        tau / iz
    );
    assert!(omega.x.abs() < 1e-12 && omega.y.abs() < 1e-12);
}

#[test]
fn damping_scales_velocity_by_one_over_one_plus_c_h_per_substep() {
    let mut w = common::world();
    let shape = Shape::sphere(0.5).unwrap();
    let mut d = RigidBodyDesc::dynamic(shape, 100.0, pose(DVec3::ZERO))
        .unwrap()
        .with_velocity(DVec3::X * 4.0, DVec3::Y * 2.0);
    d.linear_damping = 0.5;
    d.angular_damping = 2.0;
    let h = w.add_body(&d).unwrap();
    for _ in 0..30 {
        w.step(0.1).unwrap();
    }
    let b = w.body(h).unwrap();
    // Per substep of h = 0.1 / 4: factors 1 / (1 + 0.5 h) and 1 / (1 + 2 h).
    let n = 30 * w.solver_config().substeps as i32;
    let hs = 0.1 / f64::from(w.solver_config().substeps);
    assert!((b.linear_velocity().x - 4.0 / (1.0 + 0.5 * hs).powi(n)).abs() < 1e-12);
    assert!((b.angular_velocity().y - 2.0 / (1.0 + 2.0 * hs).powi(n)).abs() < 1e-12);
}

#[test]
fn impulse_at_a_point_changes_linear_and_angular_velocity() {
    let mut w = common::world();
    let h = brick(&mut w, DVec3::ZERO);
    let (m, inv_i) = {
        let b = w.body(h).unwrap();
        (b.mass(), b.inverse_inertia_world())
    };
    let j = DVec3::new(0.0, 0.0, 30.0);
    let r = DVec3::new(0.5, 0.0, 0.0);
    w.apply_body_impulse(h, j, r).unwrap();
    let b = w.body(h).unwrap();
    assert!((b.linear_velocity() - j / m).length() < 1e-12);
    assert!((b.angular_velocity() - inv_i * r.cross(j)).length() < 1e-12);
}

#[test]
fn static_and_kinematic_bodies() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let ground = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(DVec3::new(10.0, 0.5, 10.0)).unwrap(),
            pose(DVec3::ZERO),
        ))
        .unwrap();
    let platform = w
        .add_body(
            &RigidBodyDesc::kinematic(Shape::cuboid(DVec3::ONE).unwrap(), pose(DVec3::Y * 3.0))
                .with_velocity(DVec3::X, DVec3::Y * 0.5),
        )
        .unwrap();
    assert!(w.set_body_velocity(ground, DVec3::X, DVec3::ZERO).is_err());
    for _ in 0..100 {
        w.step(0.01).unwrap();
    }
    assert_eq!(w.body(ground).unwrap().pose().translation, DVec3::ZERO);
    let p = w.body(platform).unwrap();
    assert_eq!(p.kind(), BodyKind::Kinematic);
    assert!(
        (p.pose().translation - DVec3::new(1.0, 3.0, 0.0)).length() < 1e-12,
        "{}",
        p.pose().translation
    );
    let angle = p.pose().rotation.angle_between(DQuat::IDENTITY);
    assert!((angle - 0.5).abs() < 1e-9, "{angle}");
    assert_eq!(p.mass(), f64::INFINITY);
}

#[test]
fn bad_body_input_is_refused_and_changes_nothing() {
    let mut w = common::world();
    let h = brick(&mut w, DVec3::ZERO);
    let h0 = w.state_hash();
    let good =
        RigidBodyDesc::dynamic(Shape::sphere(1.0).unwrap(), 10.0, pose(DVec3::ZERO)).unwrap();
    let mut bad = good.clone();
    bad.pose.translation.x = f64::NAN;
    assert!(w.add_body(&bad).is_err());
    let mut bad = good.clone();
    bad.pose.rotation = DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0);
    assert!(w.add_body(&bad).is_err());
    let mut bad = good.clone();
    bad.linear_damping = -1.0;
    assert!(w.add_body(&bad).is_err());
    let mut bad = good.clone();
    bad.mass_properties.mass = 0.0;
    assert!(matches!(
        w.add_body(&bad),
        Err(PhysicsError::NonPositiveMass(_))
    ));
    assert!(RigidBodyDesc::dynamic(Shape::sphere(1.0).unwrap(), -5.0, pose(DVec3::ZERO)).is_err());
    assert!(w
        .set_body_velocity(h, DVec3::splat(f64::INFINITY), DVec3::ZERO)
        .is_err());
    assert!(w
        .set_body_control(h, DVec3::ZERO, DVec3::splat(f64::NAN))
        .is_err());
    assert!(w.set_gravity(DVec3::splat(f64::NAN)).is_err());
    assert_eq!(w.state_hash(), h0);
    w.remove_body(h).unwrap();
    assert!(w.body(h).is_none());
    assert!(matches!(
        w.remove_body(h),
        Err(PhysicsError::UnknownBody(_))
    ));
    assert!(matches!(
        w.set_body_velocity(h, DVec3::X, DVec3::ZERO),
        Err(PhysicsError::UnknownBody(_))
    ));
}

#[test]
fn a_body_that_blows_up_is_quarantined_alone() {
    // A light pebble (a few grams) under the largest finite force: its
    // acceleration overflows.
    let pebble = || {
        RigidBodyDesc::dynamic(Shape::sphere(0.01).unwrap(), 1.0, pose(DVec3::X * 10.0)).unwrap()
    };
    let mut w = common::world();
    let bomb = w.add_body(&pebble()).unwrap();
    let calm = brick(&mut w, DVec3::new(0.0, 1.0, 0.0));
    let mut twin = common::world();
    twin.add_body(&pebble()).unwrap();
    let calm2 = brick(&mut twin, DVec3::new(0.0, 1.0, 0.0));
    w.set_body_control(bomb, DVec3::new(f64::MAX, 0.0, 0.0), DVec3::ZERO)
        .unwrap();
    let r = w.step(1.0).unwrap();
    twin.step(1.0).unwrap();
    assert_eq!(r.quarantined_bodies, vec![bomb]);
    let b = w.body(bomb).unwrap();
    assert!(
        b.is_quarantined()
            && b.linear_velocity() == DVec3::ZERO
            && b.pose().translation == DVec3::X * 10.0
    );
    assert_eq!(w.body(calm).unwrap(), twin.body(calm2).unwrap());
    assert!(w.step(1.0).unwrap().quarantined_bodies.is_empty());
    assert!(w.energy().total().is_finite());
}

#[test]
fn bodies_are_saved_restored_and_hashed() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    brick(&mut w, DVec3::new(0.1, 2.0, 0.3));
    let hull = Shape::convex_hull(&[
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.4, 0.4, 0.4),
    ])
    .unwrap();
    w.add_body(
        &RigidBodyDesc::dynamic(hull, 700.0, pose(DVec3::X * 3.0))
            .unwrap()
            .with_velocity(DVec3::Y, DVec3::Z),
    )
    .unwrap();
    for _ in 0..10 {
        w.step(0.01).unwrap();
    }
    let saved = w.save();
    let expected: Vec<u64> = (0..10)
        .map(|_| {
            w.step(0.01).unwrap();
            w.state_hash()
        })
        .collect();
    let mut r = common::world();
    r.restore(&saved).unwrap();
    assert_eq!(r.save(), saved);
    let got: Vec<u64> = (0..10)
        .map(|_| {
            r.step(0.01).unwrap();
            r.state_hash()
        })
        .collect();
    assert_eq!(got, expected);
}
