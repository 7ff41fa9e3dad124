//! Ballistic prediction: the closed-form path against a fine numerical
//! integration, the aiming formulas against the path they predict, and
//! `World::predict_landing` against the closed form and the engine itself.

use crate::common;

use inertia_physics::glam::{DMat3, DQuat, DVec3};
use inertia_physics::rigid::ballistic::{
    launch_velocities, launch_velocity_for_time, min_speed_to_reach, time_of_flight, Trajectory,
};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::mass::MassProperties;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::rigid::solver::SolverConfig;
use inertia_physics::{BodyHandle, PhysicsError, World};

// ---------------------------------------------------------------- helpers

const G: DVec3 = DVec3::new(0.0, -9.81, 0.0);

fn at(x: f64, y: f64, z: f64) -> Pose {
    Pose::from_translation(DVec3::new(x, y, z))
}

/// `dp/dt = v`, `dv/dt = g − k v` by classical RK4 with `n` steps over
/// `[0, t]`.
fn rk4(p0: DVec3, v0: DVec3, g: DVec3, k: f64, t: f64, n: usize) -> (DVec3, DVec3) {
    let h = t / n as f64;
    let f = |v: DVec3| g - v * k;
    let (mut p, mut v) = (p0, v0);
    for _ in 0..n {
        let (k1p, k1v) = (v, f(v));
        let v2 = v + k1v * (0.5 * h);
        let (k2p, k2v) = (v2, f(v2));
        let v3 = v + k2v * (0.5 * h);
        let (k3p, k3v) = (v3, f(v3));
        let v4 = v + k3v * h;
        let (k4p, k4v) = (v4, f(v4));
        p += (k1p + 2.0 * k2p + 2.0 * k3p + k4p) * (h / 6.0);
        v += (k1v + 2.0 * k2v + 2.0 * k3v + k4v) * (h / 6.0);
    }
    (p, v)
}

fn rel(err: f64, scale: f64) -> f64 {
    err / scale.max(1.0)
}

/// A world with gravity `G` and a static slab whose top is the plane y = 0.
fn ground_world() -> (World, BodyHandle) {
    let mut w = common::world();
    w.set_gravity(G).unwrap();
    let slab = Shape::cuboid(DVec3::new(50.0, 0.5, 50.0)).unwrap();
    let ground = w
        .add_body(&RigidBodyDesc::fixed(slab, at(0.0, -0.5, 0.0)))
        .unwrap();
    (w, ground)
}

fn ball(w: &mut World, radius: f64, pose: Pose, v: DVec3) -> BodyHandle {
    let desc = RigidBodyDesc::dynamic(Shape::sphere(radius).unwrap(), 1000.0, pose)
        .unwrap()
        .with_velocity(v, DVec3::ZERO);
    w.add_body(&desc).unwrap()
}

/// When `y0 + vy t − ½ g t² = y` on the way down.
fn fall_time(y0: f64, vy: f64, y: f64) -> f64 {
    let g = -G.y;
    (vy + (vy * vy + 2.0 * g * (y0 - y)).sqrt()) / g
}

// ------------------------------------------------------------- trajectory

#[test]
fn trajectory_matches_fine_integration_with_and_without_drag() {
    let p0 = DVec3::new(1.0, 2.0, -3.0);
    let v0 = DVec3::new(4.0, 7.0, 1.5);
    let g = DVec3::new(0.3, -9.81, 0.2);
    for k in [0.0, 0.5] {
        let path = Trajectory::new(p0, v0, g, k).unwrap();
        let (mut worst_p, mut worst_v) = (0.0_f64, 0.0_f64);
        // t = 0.5 puts k t on the series switch (0.25) for k = 0.5.
        for t in [0.01, 0.3, 0.5, 0.5000001, 1.0, 2.0, 3.0] {
            let (p, v) = rk4(p0, v0, g, k, t, 20_000);
            let ep = rel(path.position(t).distance(p), p.length());
            let ev = rel(path.velocity(t).distance(v), v.length());
            worst_p = worst_p.max(ep);
            worst_v = worst_v.max(ev);
        }
        eprintln!("k = {k}: relative error position {worst_p:.2e}, velocity {worst_v:.2e}");
        assert!(worst_p < 1e-9 && worst_v < 1e-9);
    }
}

#[test]
fn tiny_drag_matches_drag_free_formula() {
    let p0 = DVec3::new(0.0, 1.0, 0.0);
    let v0 = DVec3::new(5.0, 8.0, -2.0);
    let k = 1e-9;
    let path = Trajectory::new(p0, v0, G, k).unwrap();
    // The drag itself changes the velocity by about k t relative (1e-9
    // after 1 s), so the plain k = 0 formula is compared over the first
    // half second, and the formula to first order in k (exact to
    // O(k²) ~ 1e-18) over 5 s.
    let (mut plain, mut first_order) = (0.0_f64, 0.0_f64);
    for i in 0..=50 {
        let t = 0.1 * i as f64;
        let x = k * t;
        let p = p0 + v0 * t + 0.5 * G * t * t;
        let v = v0 + G * t;
        let p1 = p0 + v0 * (t * (1.0 - 0.5 * x)) + G * (t * t * (0.5 - x / 6.0));
        let v1 = v0 * (1.0 - x) + G * (t * (1.0 - 0.5 * x));
        let e1 = rel(path.position(t).distance(p1), p1.length())
            .max(rel(path.velocity(t).distance(v1), v1.length()));
        first_order = first_order.max(e1);
        if t <= 0.5 {
            let e = rel(path.position(t).distance(p), p.length())
                .max(rel(path.velocity(t).distance(v), v.length()));
            plain = plain.max(e);
        }
    }
    eprintln!(
        "k = 1e-9: relative error against the k = 0 formula (t <= 0.5 s) {plain:.2e}, \
         against its first-order form (t <= 5 s) {first_order:.2e}"
    );
    assert!(plain < 1e-9);
    assert!(first_order < 1e-14);
    // Continuity across the series switch (k t = 1/4).
    let path = Trajectory::new(p0, v0, G, 0.5).unwrap();
    let (a, b) = (path.position(0.5 - 1e-12), path.position(0.5 + 1e-12));
    eprintln!("jump across the series switch: {:.2e} m", a.distance(b));
    assert!(a.distance(b) < 1e-10);
}

#[test]
fn apex_is_where_the_rise_stops() {
    let v0 = DVec3::new(3.0, 12.0, 1.0);
    for k in [0.0, 1e-9, 0.5, 2.0] {
        let path = Trajectory::new(DVec3::ZERO, v0, G, k).unwrap();
        let apex = path.apex().unwrap();
        let vy = path.velocity(apex.time).y;
        let dt = 1e-4;
        let (before, after) = (path.position(apex.time - dt), path.position(apex.time + dt));
        eprintln!("k = {k}: apex t = {:.9} s, v·up there {vy:.1e}", apex.time);
        assert!(vy.abs() < 1e-12);
        assert!(apex.point.y > before.y && apex.point.y > after.y);
        assert_eq!(apex.point, path.position(apex.time));
    }
    let plain = Trajectory::new(DVec3::ZERO, v0, G, 0.0)
        .unwrap()
        .apex()
        .unwrap();
    assert!((plain.time - 12.0 / 9.81).abs() < 1e-15);
    assert!((plain.point.y - 144.0 / (2.0 * 9.81)).abs() < 1e-12);
    // Falling already, or no gravity: no apex.
    let down = Trajectory::new(DVec3::ZERO, -DVec3::Y, G, 0.0).unwrap();
    assert!(down.apex().is_none());
    let free = Trajectory::new(DVec3::ZERO, DVec3::Y, DVec3::ZERO, 0.0).unwrap();
    assert!(free.apex().is_none());
}

// ---------------------------------------------------------------- aiming

#[test]
fn both_arcs_hit_targets_above_below_and_straight_up() {
    let from = DVec3::new(1.0, 2.0, -1.0);
    let tilted = DVec3::new(2.0, -9.0, 1.5);
    let cases = [
        (DVec3::new(20.0, 2.0, 5.0), G),
        (DVec3::new(10.0, 8.0, 3.0), G),
        (DVec3::new(8.0, -15.0, 2.0), G),
        (DVec3::new(1.0, 12.0, -1.0), G),
        (DVec3::new(1.0, -10.0, -1.0), G),
        (DVec3::new(-6.0, 4.0, 9.0), tilted),
        (from - tilted * 0.7, tilted),
        (DVec3::new(30.0, 0.0, 0.0), DVec3::ZERO),
    ];
    let mut worst = 0.0_f64;
    for (to, g) in cases {
        let speed = 1.3 * min_speed_to_reach(from, to, g).unwrap() + 1.0;
        let arcs = launch_velocities(from, to, speed, g).unwrap().unwrap();
        let times = time_of_flight(from, to, speed, g).unwrap().unwrap();
        assert!(times[0] <= times[1]);
        for (v, t) in arcs.into_iter().zip(times) {
            assert!((v.length() - speed).abs() < 1e-12 * speed, "{v} {speed}");
            let path = Trajectory::new(from, v, g, 0.0).unwrap();
            let miss = path.position(t).distance(to);
            let (p, _) = rk4(from, v, g, 0.0, t, 1000);
            let miss_rk4 = p.distance(to);
            worst = worst.max(miss).max(miss_rk4);
            assert!(miss < 1e-9 && miss_rk4 < 1e-9, "{to}: {miss} {miss_rk4}");
        }
        // Out of reach below the least speed (a target below is reached
        // at any speed).
        let min = min_speed_to_reach(from, to, g).unwrap();
        if min > 0.0 {
            assert!(launch_velocities(from, to, 0.5 * min, g).unwrap().is_none());
            assert!(time_of_flight(from, to, 0.5 * min, g).unwrap().is_none());
        }
    }
    eprintln!("worst arc miss: {worst:.2e} m");
    // Straight up: both shots vertical, reaching it rising and falling.
    let up = DVec3::new(1.0, 12.0, -1.0);
    let [low, high] = launch_velocities(from, up, 20.0, G).unwrap().unwrap();
    assert!(low.cross(DVec3::Y).length() < 1e-12 && high.cross(DVec3::Y).length() < 1e-12);
    let [t_low, t_high] = time_of_flight(from, up, 20.0, G).unwrap().unwrap();
    let path = Trajectory::new(from, low, G, 0.0).unwrap();
    assert!(path.velocity(t_low).y > 0.0 && path.velocity(t_high).y < 0.0);
    // Straight down: one shot down, one up and back.
    let down = DVec3::new(1.0, -10.0, -1.0);
    let [low, high] = launch_velocities(from, down, 5.0, G).unwrap().unwrap();
    assert!(low.y < 0.0 && high.y > 0.0);
}

#[test]
fn min_speed_is_the_reach_boundary() {
    let from = DVec3::new(0.0, 1.0, 0.0);
    let tilted = DVec3::new(-1.0, -8.0, 3.0);
    for (to, g) in [
        (DVec3::new(15.0, 1.0, 0.0), G),
        (DVec3::new(6.0, 9.0, -4.0), G),
        (DVec3::new(12.0, -20.0, 3.0), G),
        (DVec3::new(0.0, 7.0, 0.0), G),
        (DVec3::new(5.0, 2.0, 8.0), tilted),
    ] {
        let min = min_speed_to_reach(from, to, g).unwrap();
        let d = to - from;
        let classic = (9.81 * (d.y + d.length())).sqrt();
        if g == G {
            assert!((min - classic).abs() < 1e-12 * classic);
        }
        let above = launch_velocities(from, to, min * (1.0 + 1e-9), g).unwrap();
        let below = launch_velocities(from, to, min * (1.0 - 1e-9), g).unwrap();
        assert!(above.is_some() && below.is_none(), "{to}: {min}");
        // Just above it, the two arcs nearly merge and still hit.
        let [low, high] = above.unwrap();
        let [t_low, t_high] = time_of_flight(from, to, min * (1.0 + 1e-9), g)
            .unwrap()
            .unwrap();
        let miss = Trajectory::new(from, low, g, 0.0)
            .unwrap()
            .position(t_low)
            .distance(to)
            .max(
                Trajectory::new(from, high, g, 0.0)
                    .unwrap()
                    .position(t_high)
                    .distance(to),
            );
        eprintln!(
            "{to}: least speed {min:.9} m/s, arcs {:.2e} rad apart, miss {miss:.2e} m",
            low.angle_between(high)
        );
        assert!(miss < 1e-9);
    }
    // Straight below, zero gravity, no distance: 0.
    assert_eq!(min_speed_to_reach(from, from - DVec3::Y, G).unwrap(), 0.0);
    assert_eq!(
        min_speed_to_reach(from, from + DVec3::X, DVec3::ZERO).unwrap(),
        0.0
    );
    assert_eq!(min_speed_to_reach(from, from, G).unwrap(), 0.0);
}

#[test]
fn launch_for_time_arrives_on_time() {
    let from = DVec3::new(-2.0, 0.5, 3.0);
    for (to, t) in [
        (DVec3::new(10.0, 0.5, 3.0), 1.2),
        (DVec3::new(4.0, 6.0, -1.0), 0.4),
        (DVec3::new(-2.0, -3.0, 3.0), 2.5),
        (from, 1.0),
    ] {
        let v = launch_velocity_for_time(from, to, t, G).unwrap();
        let miss = Trajectory::new(from, v, G, 0.0)
            .unwrap()
            .position(t)
            .distance(to);
        assert!(miss < 1e-12, "{miss}");
    }
    // The same target and time from the speed of an arc gives that arc.
    let to = DVec3::new(9.0, 3.0, 1.0);
    let [low, _] = launch_velocities(from, to, 14.0, G).unwrap().unwrap();
    let [t_low, _] = time_of_flight(from, to, 14.0, G).unwrap().unwrap();
    let v = launch_velocity_for_time(from, to, t_low, G).unwrap();
    assert!(v.distance(low) < 1e-12);
}

// ------------------------------------------------------- predict_landing

#[test]
fn landing_on_flat_ground_matches_closed_form() {
    let (mut w, ground) = ground_world();
    let r = 0.2;
    let v = DVec3::new(4.0, 3.0, -1.0);
    let b = ball(&mut w, r, at(0.0, 2.0, 0.0), v);
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    let t = fall_time(2.0, v.y, r);
    let expected = DVec3::new(v.x * t, 0.0, v.z * t);
    let err = landing.point.distance(expected);
    eprintln!(
        "flat ground: t {:.6} s (closed form {t:.6}), point error {err:.2e} m",
        landing.time
    );
    assert_eq!(landing.body, ground);
    assert!(err < 0.01);
    assert!((landing.time - t).abs() < 1e-3);
    assert!(landing.normal.distance(DVec3::Y) < 1e-9);
    assert!(landing
        .center_of_mass
        .distance(expected + DVec3::Y * r)
        .lt(&0.01));
    assert!(landing.velocity.distance(v + G * landing.time) < 1e-12);
    // Deterministic.
    assert_eq!(w.predict_landing(b, 5.0).unwrap(), Some(landing));
}

#[test]
fn engine_first_touches_ground_where_predicted() {
    let (mut w, ground) = ground_world();
    w.set_solver_config(SolverConfig {
        substeps: 4,
        ..SolverConfig::default()
    })
    .unwrap();
    let r = 0.2;
    let b = ball(&mut w, r, at(0.0, 2.0, 0.0), DVec3::new(4.0, 3.0, 1.0));
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    assert_eq!(landing.body, ground);
    let dt = 1.0 / 60.0;
    let mut prev = (
        w.body(b).unwrap().center_of_mass(),
        w.body(b).unwrap().linear_velocity(),
    );
    let path = w.body_trajectory(b).unwrap();
    let mut drift = 0.0_f64;
    for n in 1..=300 {
        w.step(dt).unwrap();
        let body = w.body(b).unwrap();
        let (p, v) = (body.center_of_mass(), body.linear_velocity());
        if v.distance(prev.1 + G * dt) > 1e-9 {
            // A contact acted in this step: the free flight from the last
            // free state touches y = r after τ.
            let (p0, v0) = prev;
            let g = -G.y;
            let tau = (v0.y + (v0.y * v0.y + 2.0 * g * (p0.y - r)).sqrt()) / g;
            let t_touch = (n - 1) as f64 * dt + tau;
            let touch = p0 + v0 * tau + 0.5 * G * tau * tau;
            let dist = touch.distance(landing.center_of_mass);
            eprintln!(
                "engine touches at t {t_touch:.4} s (step {n}), predicted {:.4} s; \
                 centre {dist:.4} m apart; free-flight drift before touch {drift:.4} m",
                landing.time
            );
            assert!((t_touch - landing.time).abs() <= dt);
            assert!(dist <= 0.02);
            return;
        }
        drift = drift.max(p.distance(path.position(n as f64 * dt)));
        prev = (p, v);
    }
    panic!("the ball never touched the ground");
}

#[test]
fn ball_thrown_at_wall_hits_the_wall() {
    let (mut w, ground) = ground_world();
    let slab = Shape::cuboid(DVec3::new(0.25, 3.0, 5.0)).unwrap();
    let wall = w
        .add_body(&RigidBodyDesc::fixed(slab, at(4.0, 3.0, 0.0)))
        .unwrap();
    let r = 0.2;
    let b = ball(&mut w, r, at(0.0, 1.0, 0.0), DVec3::new(8.0, 4.0, 0.0));
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    let t = (3.75 - r) / 8.0;
    eprintln!(
        "wall: hit at t {:.6} s (expected {t:.6}), point {}",
        landing.time, landing.point
    );
    assert_eq!(landing.body, wall);
    assert_ne!(landing.body, ground);
    assert!(landing.normal.distance(-DVec3::X) < 1e-9);
    assert!((landing.point.x - 3.75).abs() < 1e-3);
    assert!((landing.time - t).abs() < 1e-3);
    let y = 1.0 + 4.0 * t + 0.5 * G.y * t * t;
    assert!((landing.point.y - y).abs() < 1e-3);
    // Without the wall it comes down on the ground beyond it.
    w.remove_body(wall).unwrap();
    let beyond = w.predict_landing(b, 5.0).unwrap().unwrap();
    assert_eq!(beyond.body, ground);
    assert!(beyond.point.x > 3.75);
}

#[test]
fn throw_into_empty_space_lands_only_in_time() {
    let (mut w, ground) = ground_world();
    let b = ball(&mut w, 0.2, at(0.0, 10.0, 0.0), DVec3::new(0.0, 5.0, 0.0));
    assert!(w.predict_landing(b, 1.0).unwrap().is_none());
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    assert_eq!(landing.body, ground);
    let t = fall_time(10.0, 5.0, 0.2);
    assert!((landing.time - t).abs() < 1e-3);
    // A very long horizon needs chords far longer than the flight; the hit
    // chord is halved down to the same landing.
    let far = w.predict_landing(b, 1e6).unwrap().unwrap();
    eprintln!(
        "max_time 1e6 s: t {:.6} s against {:.6} s",
        far.time, landing.time
    );
    assert_eq!(far.body, ground);
    assert!((far.time - t).abs() < 1e-3);
    // One that overflows the path ends it quietly.
    assert!(w.predict_landing(b, 1e300).is_ok());
    // Alone in the world: nothing to land on.
    let mut alone = common::world();
    alone.set_gravity(G).unwrap();
    let b = ball(&mut alone, 0.2, at(0.0, 10.0, 0.0), DVec3::X);
    assert!(alone.predict_landing(b, 100.0).unwrap().is_none());
}

#[test]
fn thrown_from_the_ground_lands_back_on_it() {
    let (mut w, ground) = ground_world();
    let r = 0.3;
    let v = DVec3::new(2.0, 4.0, 0.0);
    let b = ball(&mut w, r, at(0.0, r, 0.0), v);
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    let t = 2.0 * v.y / -G.y;
    eprintln!("hop: lands at t {:.6} s (expected {t:.6})", landing.time);
    assert_eq!(landing.body, ground);
    assert!((landing.time - t).abs() < 1e-3);
    assert!(landing.point.distance(DVec3::new(v.x * t, 0.0, 0.0)) < 0.01);
    // At rest on it: it has already landed.
    let rest = ball(&mut w, r, at(5.0, r, 0.0), DVec3::ZERO);
    let landing = w.predict_landing(rest, 5.0).unwrap().unwrap();
    assert_eq!((landing.body, landing.time), (ground, 0.0));
    assert!(landing.point.distance(DVec3::new(5.0, 0.0, 0.0)) < 1e-6);
}

#[test]
fn drag_and_gravity_scale_shape_the_landing() {
    let (mut w, ground) = ground_world();
    let r = 0.2;
    let v = DVec3::new(6.0, 5.0, 0.0);
    let desc = RigidBodyDesc {
        linear_damping: 0.5,
        gravity_scale: 0.5,
        ..RigidBodyDesc::dynamic(Shape::sphere(r).unwrap(), 1000.0, at(0.0, 3.0, 0.0))
            .unwrap()
            .with_velocity(v, DVec3::ZERO)
    };
    let b = w.add_body(&desc).unwrap();
    let landing = w.predict_landing(b, 10.0).unwrap().unwrap();
    // Reference: bisect the height of the analytic path (itself checked
    // against RK4 above).
    let path = Trajectory::new(DVec3::new(0.0, 3.0, 0.0), v, G * 0.5, 0.5).unwrap();
    assert_eq!(w.body_trajectory(b).unwrap(), path);
    let apex = path.apex().unwrap().time;
    let (mut lo, mut hi) = (apex, 10.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if path.position(mid).y > r {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let expected = path.position(lo);
    let err = landing.center_of_mass.distance(expected);
    eprintln!(
        "drag 0.5 /s, gravity ×0.5: t {:.6} s (reference {lo:.6}), centre error {err:.2e} m",
        landing.time
    );
    assert_eq!(landing.body, ground);
    assert!(err < 1e-3);
}

#[test]
fn box_lands_flat_and_compound_lands_on_its_lowest_part() {
    let (mut w, ground) = ground_world();
    let h = DVec3::new(0.5, 0.25, 0.4);
    let desc = RigidBodyDesc::dynamic(Shape::cuboid(h).unwrap(), 500.0, at(1.0, 2.0, -1.0))
        .unwrap()
        .with_velocity(DVec3::new(2.0, 0.0, 0.0), DVec3::ZERO);
    let b = w.add_body(&desc).unwrap();
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    let t = fall_time(2.0, 0.0, h.y);
    let expected = DVec3::new(1.0 + 2.0 * t, 0.0, -1.0);
    eprintln!(
        "box: lands at t {:.6} s, face centre {:.2e} m off",
        landing.time,
        landing.point.distance(expected)
    );
    assert_eq!(landing.body, ground);
    assert!(landing.point.distance(expected) < 0.01);
    assert!(landing.normal.distance(DVec3::Y) < 1e-9);
    // Two balls one above the other: the lower one touches first.
    let pair = Shape::compound(vec![
        (at(0.0, 0.5, 0.0), Shape::sphere(0.2).unwrap()),
        (at(0.0, -0.5, 0.0), Shape::sphere(0.2).unwrap()),
    ])
    .unwrap();
    let desc = RigidBodyDesc::dynamic(pair, 1000.0, at(-3.0, 4.0, 0.0)).unwrap();
    let c = w.add_body(&desc).unwrap();
    let landing = w.predict_landing(c, 5.0).unwrap().unwrap();
    let t = fall_time(4.0, 0.0, 0.7);
    assert_eq!(landing.body, ground);
    assert!((landing.time - t).abs() < 1e-3);
    assert!(landing.point.distance(DVec3::new(-3.0, 0.0, 0.0)) < 1e-3);
}

#[test]
fn shapeless_body_traces_its_centre_and_others_are_reported() {
    let (mut w, _) = ground_world();
    let desc = RigidBodyDesc {
        shape: None,
        mass_properties: MassProperties {
            mass: 1.0,
            center_of_mass: DVec3::ZERO,
            inertia: DMat3::IDENTITY,
        },
        ..RigidBodyDesc::dynamic(Shape::sphere(1.0).unwrap(), 1.0, at(0.0, 5.0, 0.0))
            .unwrap()
            .with_velocity(DVec3::new(1.0, 0.0, 0.0), DVec3::ZERO)
    };
    let point = w.add_body(&desc).unwrap();
    // A dynamic ball resting on the ground and a kinematic paddle in its way:
    // the first one the path meets is reported.
    let crate_ = ball(&mut w, 0.5, at(1.0, 0.5, 0.0), DVec3::ZERO);
    let paddle = w
        .add_body(&RigidBodyDesc::kinematic(
            Shape::cuboid(DVec3::new(0.5, 0.1, 0.5)).unwrap(),
            at(0.6, 3.0, 0.0),
        ))
        .unwrap();
    let landing = w.predict_landing(point, 5.0).unwrap().unwrap();
    assert_eq!(landing.body, paddle);
    let t = fall_time(5.0, 0.0, 3.1);
    assert!((landing.time - t).abs() < 1e-5, "{} {t}", landing.time);
    assert!(landing.point.distance(landing.center_of_mass) < 1e-5);
    assert!(landing.normal.distance(DVec3::Y) < 1e-9);
    w.remove_body(paddle).unwrap();
    let landing = w.predict_landing(point, 5.0).unwrap().unwrap();
    assert_eq!(landing.body, crate_);
    // A turned box lands on a corner, under the centre of mass when it
    // falls straight.
    let (mut w, ground) = ground_world();
    let turned = Pose::new(
        DVec3::new(0.0, 3.0, 0.0),
        DQuat::from_rotation_z(0.6) * DQuat::from_rotation_x(0.4),
    );
    let desc =
        RigidBodyDesc::dynamic(Shape::cuboid(DVec3::splat(0.3)).unwrap(), 1.0, turned).unwrap();
    let b = w.add_body(&desc).unwrap();
    let landing = w.predict_landing(b, 5.0).unwrap().unwrap();
    assert_eq!(landing.body, ground);
    assert!(landing.point.y.abs() < 1e-3);
    let lowest = (0..8)
        .map(|k| {
            let c = DVec3::new(
                if k & 1 == 0 { -0.3 } else { 0.3 },
                if k & 2 == 0 { -0.3 } else { 0.3 },
                if k & 4 == 0 { -0.3 } else { 0.3 },
            );
            turned.rotation * c
        })
        .min_by(|a, b| a.y.total_cmp(&b.y))
        .unwrap();
    let expected = DVec3::new(lowest.x, 0.0, lowest.z);
    assert!(landing.point.distance(expected) < 1e-3, "{}", landing.point);
}

// ------------------------------------------------------------ bad input

#[test]
fn bad_input_gives_typed_errors() {
    let (mut w, _) = ground_world();
    let b = ball(&mut w, 0.2, at(0.0, 2.0, 0.0), DVec3::X);
    assert!(matches!(
        w.predict_landing(b, f64::NAN),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        w.predict_landing(b, f64::INFINITY),
        Err(PhysicsError::NonFinite { .. })
    ));
    for t in [0.0, -1.0] {
        assert!(matches!(
            w.predict_landing(b, t),
            Err(PhysicsError::NotPositive { .. })
        ));
    }
    let gone = ball(&mut w, 0.2, at(3.0, 2.0, 0.0), DVec3::X);
    w.remove_body(gone).unwrap();
    assert_eq!(
        w.predict_landing(gone, 1.0),
        Err(PhysicsError::UnknownBody(gone))
    );
    assert_eq!(
        w.body_trajectory(gone),
        Err(PhysicsError::UnknownBody(gone))
    );
    let mesh = Shape::trimesh(vec![DVec3::ZERO, DVec3::Z, DVec3::X], vec![[0, 1, 2]]).unwrap();
    let sheet = w
        .add_body(&RigidBodyDesc::kinematic(mesh, at(0.0, 5.0, 0.0)))
        .unwrap();
    assert!(matches!(
        w.predict_landing(sheet, 1.0),
        Err(PhysicsError::Invalid { .. })
    ));

    let nan = DVec3::new(f64::NAN, 0.0, 0.0);
    assert!(matches!(
        Trajectory::new(nan, DVec3::X, G, 0.0),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        Trajectory::new(DVec3::ZERO, DVec3::X, G, -1.0),
        Err(PhysicsError::Negative { .. })
    ));
    assert!(matches!(
        Trajectory::new(DVec3::ZERO, DVec3::X, G, f64::NAN),
        Err(PhysicsError::NonFinite { .. })
    ));
    let to = DVec3::new(5.0, 1.0, 0.0);
    for speed in [0.0, -3.0] {
        assert!(matches!(
            launch_velocities(DVec3::ZERO, to, speed, G),
            Err(PhysicsError::NotPositive { .. })
        ));
        assert!(matches!(
            time_of_flight(DVec3::ZERO, to, speed, G),
            Err(PhysicsError::NotPositive { .. })
        ));
    }
    assert!(matches!(
        launch_velocities(DVec3::ZERO, to, f64::NAN, G),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        launch_velocities(nan, to, 10.0, G),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        launch_velocities(DVec3::ZERO, to, 10.0, nan),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        launch_velocities(to, to, 10.0, G),
        Err(PhysicsError::Invalid { .. })
    ));
    assert!(matches!(
        min_speed_to_reach(DVec3::ZERO, nan, G),
        Err(PhysicsError::NonFinite { .. })
    ));
    for t in [0.0, -1.0] {
        assert!(matches!(
            launch_velocity_for_time(DVec3::ZERO, to, t, G),
            Err(PhysicsError::NotPositive { .. })
        ));
    }
    assert!(matches!(
        launch_velocity_for_time(DVec3::ZERO, to, f64::NAN, G),
        Err(PhysicsError::NonFinite { .. })
    ));
}
