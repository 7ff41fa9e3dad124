//! Scene queries: rays against every shape at analytic hits, point
//! projection, overlap and shape casts, and the World query API.

use crate::common;

use common::Rng;
use std::f64::consts::{FRAC_PI_4, FRAC_PI_6};

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::{RigidBody, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::query::{
    cast_shape, overlap, project_point_shape, ray_cast_shape, RayHit,
};
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, PhysicsError, World, WorldConfig};

// ---------------------------------------------------------------- helpers

const EPS: f64 = 1e-9;

fn at(x: f64, y: f64, z: f64) -> Pose {
    Pose::from_translation(DVec3::new(x, y, z))
}

fn hit(shape: &Shape, pose: Pose, origin: DVec3, dir: DVec3) -> RayHit {
    ray_cast_shape(shape, &pose, origin, dir, 1e3)
        .unwrap_or_else(|| panic!("ray {origin} {dir} missed {shape:?}"))
}

fn assert_hit(h: RayHit, t: f64, normal: DVec3, origin: DVec3, dir: DVec3) {
    assert!((h.t - t).abs() < EPS, "t {} != {t}", h.t);
    assert!(
        h.normal.distance(normal) < 1e-9,
        "normal {} != {normal}",
        h.normal
    );
    assert!(h.point.distance(origin + dir * t) < 1e-9);
}

fn world() -> World {
    World::new(WorldConfig::default()).unwrap()
}

fn add(w: &mut World, shape: Shape, pose: Pose) -> BodyHandle {
    w.add_body(&RigidBodyDesc::fixed(shape, pose)).unwrap()
}

fn box_corners(h: DVec3) -> Vec<DVec3> {
    let mut v = Vec::new();
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                v.push(h * DVec3::new(sx, sy, sz));
            }
        }
    }
    v
}

/// The same triangles as a heightfield's, as a mesh (the brute-force
/// reference for the grid walk).
fn heightfield_as_mesh(heights: &[f64], rows: usize, cols: usize, scale: DVec3) -> Shape {
    let mut v = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            v.push(DVec3::new(
                (c as f64 / (cols - 1) as f64 - 0.5) * scale.x,
                heights[r * cols + c] * scale.y,
                (r as f64 / (rows - 1) as f64 - 0.5) * scale.z,
            ));
        }
    }
    let mut t = Vec::new();
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let i = |r: usize, c: usize| (r * cols + c) as u32;
            t.push([i(r, c), i(r + 1, c), i(r, c + 1)]);
            t.push([i(r, c + 1), i(r + 1, c), i(r + 1, c + 1)]);
        }
    }
    Shape::trimesh(v, t).unwrap()
}

// ------------------------------------------------------------ ray: shapes

#[test]
fn ray_sphere_hits_at_analytic_t_and_normal() {
    let s = Shape::sphere(1.0).unwrap();
    let pose = at(3.0, 0.0, 0.0);
    let (o, d) = (DVec3::new(-2.0, 0.0, 0.0), DVec3::X);
    assert_hit(hit(&s, pose, o, d), 4.0, -DVec3::X, o, d);
    // Off-centre: enters at x = 3 − √(1 − 0.6²) = 2.2.
    let o = DVec3::new(-2.0, 0.6, 0.0);
    assert_hit(hit(&s, pose, o, d), 4.2, DVec3::new(-0.8, 0.6, 0.0), o, d);
    // t is in units of |dir|.
    let d2 = DVec3::new(2.0, 0.0, 0.0);
    let h = hit(&s, pose, DVec3::new(-2.0, 0.0, 0.0), d2);
    assert!((h.t - 2.0).abs() < EPS);
    assert!(h.point.distance(DVec3::new(2.0, 0.0, 0.0)) < EPS);
}

#[test]
fn ray_box_hits_each_face() {
    let h = DVec3::new(1.0, 2.0, 3.0);
    let s = Shape::cuboid(h).unwrap();
    let pose = at(1.0, -1.0, 0.5);
    for i in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut n = DVec3::ZERO;
            n[i] = sign;
            let mut off = DVec3::splat(0.1);
            off[i] = 0.0;
            let o = pose.translation + n * 10.0 + off;
            let d = -n;
            assert_hit(hit(&s, pose, o, d), 10.0 - h[i], n, o, d);
        }
    }
}

#[test]
fn ray_rotated_box_hits_face_along_its_normal() {
    let h = DVec3::new(1.0, 0.5, 2.0);
    let s = Shape::cuboid(h).unwrap();
    let rot = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 0.7);
    let pose = Pose::new(DVec3::new(-2.0, 3.0, 1.0), rot);
    for i in 0..3 {
        let mut local = DVec3::ZERO;
        local[i] = 1.0;
        let n = rot * local;
        let mut off = DVec3::splat(0.05);
        off[i] = 0.0;
        let o = pose.transform_point(local * 7.0 + off);
        assert_hit(hit(&s, pose, o, -n), 7.0 - h[i], n, o, -n);
    }
    // A ray at 45° onto the rotated top face: t = gap · √2.
    let n = rot * DVec3::Y;
    let tangent = rot * DVec3::X;
    let d = (-n + tangent).normalize();
    let o = pose.transform_point(DVec3::new(-3.0, 0.5 + 3.0, 0.0));
    assert_hit(hit(&s, pose, o, d), 3.0 * 2f64.sqrt(), n, o, d);
}

#[test]
fn ray_capsule_side_and_caps() {
    let s = Shape::capsule(1.0, 0.5).unwrap();
    let pose = at(0.0, 0.0, 0.0);
    let (o, d) = (DVec3::new(-5.0, 0.5, 0.0), DVec3::X);
    assert_hit(hit(&s, pose, o, d), 4.5, -DVec3::X, o, d);
    let (o, d) = (DVec3::new(0.0, 5.0, 0.0), -DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 3.5, DVec3::Y, o, d);
    // Off-axis onto the lower cap: y = −1 − √(0.25 − 0.09) = −1.4.
    let (o, d) = (DVec3::new(0.3, -5.0, 0.0), DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 3.6, DVec3::new(0.6, -0.8, 0.0), o, d);
    // Lying along X (rotated 90° about Z): the cap faces −X.
    let pose = Pose::from_rotation(DQuat::from_rotation_z(-std::f64::consts::FRAC_PI_2));
    let (o, d) = (DVec3::new(-5.0, 0.0, 0.0), DVec3::X);
    assert_hit(hit(&s, pose, o, d), 3.5, -DVec3::X, o, d);
}

#[test]
fn ray_cylinder_side_and_caps() {
    let s = Shape::cylinder(1.0, 0.5).unwrap();
    let pose = at(2.0, 0.0, 0.0);
    let (o, d) = (DVec3::new(-5.0, 0.9, 0.0), DVec3::X);
    assert_hit(hit(&s, pose, o, d), 6.5, -DVec3::X, o, d);
    let (o, d) = (DVec3::new(2.3, 5.0, 0.0), -DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 4.0, DVec3::Y, o, d);
    let (o, d) = (DVec3::new(2.3, -5.0, 0.2), DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 4.0, -DVec3::Y, o, d);
    // Just above the top rim, a horizontal ray misses; a slanted ray onto
    // the cap edge region hits the cap.
    assert!(ray_cast_shape(&s, &pose, DVec3::new(-5.0, 1.01, 0.0), DVec3::X, 100.0).is_none());
    let d = DVec3::new(1.0, -1.0, 0.0).normalize();
    let o = DVec3::new(2.0 - 0.4 - 1.0, 2.0, 0.0);
    assert_hit(hit(&s, pose, o, d), 2f64.sqrt(), DVec3::Y, o, d);
    // Side at a slant: from (−5, 0, 0) towards (1.5, 0.5, 0).
    let d = DVec3::new(6.5, 0.5, 0.0).normalize();
    let o = DVec3::new(-5.0, 0.0, 0.0);
    assert_hit(hit(&s, pose, o, d), 6.5f64.hypot(0.5), -DVec3::X, o, d);
}

#[test]
fn ray_hull_of_box_corners_matches_cuboid() {
    let h = DVec3::new(0.5, 1.0, 1.5);
    let cuboid = Shape::cuboid(h).unwrap();
    let hull = Shape::convex_hull(&box_corners(h)).unwrap();
    let pose = Pose::new(
        DVec3::new(0.3, -1.0, 2.0),
        DQuat::from_euler(inertia_physics::glam::EulerRot::XYZ, 0.3, -0.8, 1.1),
    );
    let mut rng = Rng(7);
    let mut hits = 0;
    for _ in 0..500 {
        let o = pose.translation + rng.in_cube(6.0);
        let target = pose.translation + rng.in_cube(1.5);
        let d = (target - o).normalize();
        let a = ray_cast_shape(&cuboid, &pose, o, d, 20.0);
        let b = ray_cast_shape(&hull, &pose, o, d, 20.0);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a.t - b.t).abs() < 1e-9, "{a:?} {b:?}");
                // Normals agree except on (measure-zero) edges.
                assert!(a.normal.distance(b.normal) < 1e-9, "{a:?} {b:?}");
            }
            _ => panic!("cuboid {a:?} vs hull {b:?} for {o} {d}"),
        }
    }
    assert!(hits > 150, "{hits}");
}

#[test]
fn ray_trimesh_triangle_both_sides() {
    let s = Shape::trimesh(
        vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 0.0),
        ],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let pose = at(0.0, 1.0, 0.0);
    let (o, d) = (DVec3::new(0.2, 4.0, 0.2), -DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 3.0, DVec3::Y, o, d);
    let (o, d) = (DVec3::new(0.2, -1.0, 0.2), DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 2.0, -DVec3::Y, o, d);
    assert!(ray_cast_shape(&s, &pose, DVec3::new(0.8, 4.0, 0.8), -DVec3::Y, 10.0).is_none());
    // Surfaces have no inside: a ray from the plane's far side going away
    // misses.
    assert!(ray_cast_shape(&s, &pose, DVec3::new(0.2, 0.5, 0.2), -DVec3::Y, 10.0).is_none());
}

#[test]
fn ray_heightfield_bump() {
    // 3 × 3 grid over [−1, 1]², centre sample raised to 1.
    let heights = vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    let scale = DVec3::new(2.0, 1.0, 2.0);
    let s = Shape::heightfield(heights.clone(), 3, 3, scale).unwrap();
    let pose = Pose::IDENTITY;
    // The peak.
    let (o, d) = (DVec3::new(0.0, 5.0, 0.0), -DVec3::Y);
    assert!((hit(&s, pose, o, d).t - 4.0).abs() < EPS);
    // On the facet y = 1 − x − z (cell x, z ∈ [0, 1]).
    let (o, d) = (DVec3::new(0.5, 5.0, 0.25), -DVec3::Y);
    assert_hit(hit(&s, pose, o, d), 4.75, DVec3::ONE.normalize(), o, d);
    // Horizontal rays at height 0.5 and z = 0.2: from −X the facet
    // y = x + 1 at x = −0.5, from +X the facet y = 1 − x − z at x = 0.3.
    let (o, d) = (DVec3::new(-10.0, 0.5, 0.2), DVec3::X);
    assert_hit(
        hit(&s, pose, o, d),
        9.5,
        DVec3::new(-1.0, 1.0, 0.0).normalize(),
        o,
        d,
    );
    let (o, d) = (DVec3::new(10.0, 0.5, 0.2), -DVec3::X);
    assert_hit(hit(&s, pose, o, d), 9.7, DVec3::ONE.normalize(), o, d);
    // Over the field's edge and past it: a miss.
    assert!(ray_cast_shape(&s, &pose, DVec3::new(1.5, 5.0, 0.0), -DVec3::Y, 10.0).is_none());
    assert!(ray_cast_shape(&s, &pose, DVec3::new(-10.0, 1.5, 0.0), DVec3::X, 30.0).is_none());
}

#[test]
fn ray_heightfield_walk_agrees_with_all_triangles() {
    let (rows, cols) = (9, 13);
    let mut rng = Rng(3);
    let heights: Vec<f64> = (0..rows * cols).map(|_| rng.range(-1.0, 1.0)).collect();
    let scale = DVec3::new(12.0, 0.8, 8.0);
    let field = Shape::heightfield(heights.clone(), rows, cols, scale).unwrap();
    let mesh = heightfield_as_mesh(&heights, rows, cols, scale);
    let pose = Pose::new(DVec3::new(1.0, -2.0, 0.5), DQuat::from_rotation_y(0.4));
    let mut hits = 0;
    for _ in 0..2000 {
        let o = pose.transform_point(rng.in_cube(10.0));
        let d =
            (pose.transform_point(rng.in_cube(5.0) * DVec3::new(1.0, 0.2, 1.0)) - o).normalize();
        let max_t = rng.range(0.0, 25.0);
        let a = ray_cast_shape(&field, &pose, o, d, max_t);
        let b = ray_cast_shape(&mesh, &pose, o, d, max_t);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a.t - b.t).abs() < 1e-9, "{a:?} vs {b:?}");
            }
            _ => panic!("heightfield {a:?} vs mesh {b:?} for {o} {d} {max_t}"),
        }
    }
    assert!(hits > 300, "{hits}");
    // Straight down at every sample: t = 10 − height.
    for r in 0..rows {
        for c in 0..cols {
            let x = (c as f64 / (cols - 1) as f64 - 0.5) * scale.x;
            let z = (r as f64 / (rows - 1) as f64 - 0.5) * scale.z;
            let y = heights[r * cols + c] * scale.y;
            let h = ray_cast_shape(
                &field,
                &Pose::IDENTITY,
                DVec3::new(x, 10.0, z),
                -DVec3::Y,
                20.0,
            )
            .unwrap();
            assert!((h.t - (10.0 - y)).abs() < 1e-9);
        }
    }
}

#[test]
fn ray_compound_takes_nearest_child() {
    let s = Shape::compound(vec![
        (at(3.0, 0.0, 0.0), Shape::sphere(0.5).unwrap()),
        (
            at(-3.0, 0.0, 0.0),
            Shape::cuboid(DVec3::splat(0.5)).unwrap(),
        ),
    ])
    .unwrap();
    let pose = Pose::new(DVec3::new(0.0, 1.0, 0.0), DQuat::from_rotation_y(FRAC_PI_6));
    let dir = pose.transform_vector(DVec3::X);
    let o = pose.transform_point(DVec3::new(-10.0, 0.0, 0.0));
    assert_hit(hit(&s, pose, o, dir), 6.5, -dir, o, dir);
    let o = pose.transform_point(DVec3::new(10.0, 0.0, 0.0));
    assert_hit(hit(&s, pose, o, -dir), 6.5, dir, o, -dir);
}

// ------------------------------------------------ ray: conventions, limits

#[test]
fn ray_starting_inside_solid_hits_at_zero_facing_back() {
    let d = DVec3::new(0.3, -0.4, 0.5).normalize();
    let shapes = [
        Shape::sphere(1.0).unwrap(),
        Shape::cuboid(DVec3::new(1.0, 0.5, 0.7)).unwrap(),
        Shape::capsule(0.5, 0.3).unwrap(),
        Shape::cylinder(0.5, 0.3).unwrap(),
        Shape::convex_hull(&box_corners(DVec3::splat(0.4))).unwrap(),
    ];
    let pose = Pose::new(DVec3::new(1.0, 2.0, 3.0), DQuat::from_rotation_x(0.3));
    for s in &shapes {
        let o = pose.transform_point(DVec3::new(0.1, 0.1, -0.1));
        let h = ray_cast_shape(s, &pose, o, d, 10.0).unwrap();
        assert_eq!(h.t, 0.0, "{s:?}");
        assert!(h.normal.distance(-d) < EPS, "{s:?}");
        assert_eq!(h.point, o);
    }
}

#[test]
fn ray_misses_and_max_t_cut_off() {
    let s = Shape::sphere(1.0).unwrap();
    let pose = at(5.0, 0.0, 0.0);
    // Pointing away, passing beside, and too short.
    assert!(ray_cast_shape(&s, &pose, DVec3::ZERO, -DVec3::X, 100.0).is_none());
    assert!(ray_cast_shape(&s, &pose, DVec3::new(0.0, 1.01, 0.0), DVec3::X, 100.0).is_none());
    assert!(ray_cast_shape(&s, &pose, DVec3::ZERO, DVec3::X, 3.99).is_none());
    assert!(ray_cast_shape(&s, &pose, DVec3::ZERO, DVec3::X, 4.0).is_some());
    // max_t is in units of |dir| too.
    assert!(ray_cast_shape(&s, &pose, DVec3::ZERO, DVec3::X * 2.0, 1.99).is_none());
    assert!(ray_cast_shape(&s, &pose, DVec3::ZERO, DVec3::X * 2.0, 2.0).is_some());
    let b = Shape::cuboid(DVec3::ONE).unwrap();
    assert!(ray_cast_shape(&b, &pose, DVec3::ZERO, DVec3::X, 3.99).is_none());
    assert!(ray_cast_shape(&b, &pose, DVec3::ZERO, DVec3::Y, 100.0).is_none());
    // Bad input gives no hit at this level (the World reports errors).
    assert!(ray_cast_shape(&s, &pose, DVec3::ZERO, DVec3::ZERO, 10.0).is_none());
    assert!(ray_cast_shape(&s, &pose, DVec3::NAN, DVec3::X, 10.0).is_none());
}

#[test]
fn axis_parallel_rays_on_box_and_cylinder() {
    let b = Shape::cuboid(DVec3::ONE).unwrap();
    for (o, d, t, n) in [
        (DVec3::new(0.5, 0.5, -10.0), DVec3::Z, 9.0, -DVec3::Z),
        (DVec3::new(-0.99, 0.99, 10.0), -DVec3::Z, 9.0, DVec3::Z),
        (DVec3::new(10.0, -1.0, 0.0), -DVec3::X, 9.0, DVec3::X),
        (DVec3::new(1.0, -8.0, 1.0), DVec3::Y, 7.0, -DVec3::Y),
    ] {
        assert_hit(hit(&b, Pose::IDENTITY, o, d), t, n, o, d);
    }
    for o in [DVec3::new(1.5, 0.0, -10.0), DVec3::new(0.0, -1.01, -10.0)] {
        assert!(ray_cast_shape(&b, &Pose::IDENTITY, o, DVec3::Z, 100.0).is_none());
    }
    let c = Shape::cylinder(1.0, 1.0).unwrap();
    let (o, d) = (DVec3::new(0.6, -10.0, 0.6), DVec3::Y);
    assert_hit(hit(&c, Pose::IDENTITY, o, d), 9.0, -DVec3::Y, o, d);
    assert!(ray_cast_shape(&c, &Pose::IDENTITY, DVec3::new(0.8, -10.0, 0.8), d, 100.0).is_none());
}

// ------------------------------------------------------- point projection

#[test]
fn project_point_on_sphere_and_box() {
    let s = Shape::sphere(2.0).unwrap();
    let pose = at(1.0, 0.0, 0.0);
    let p = project_point_shape(&s, &pose, DVec3::new(1.0, 5.0, 0.0)).unwrap();
    assert!(!p.inside);
    assert!((p.distance - 3.0).abs() < EPS);
    assert!(p.point.distance(DVec3::new(1.0, 2.0, 0.0)) < EPS);
    let p = project_point_shape(&s, &pose, DVec3::new(1.5, 0.0, 0.0)).unwrap();
    assert!(p.inside);
    assert!((p.distance - 1.5).abs() < EPS);
    assert!(p.point.distance(DVec3::new(3.0, 0.0, 0.0)) < EPS);

    let b = Shape::cuboid(DVec3::new(1.0, 2.0, 3.0)).unwrap();
    let rot = DQuat::from_rotation_y(FRAC_PI_4);
    let pose = Pose::new(DVec3::new(0.0, 1.0, 0.0), rot);
    let cases = [
        // (local point, local projection, inside)
        (DVec3::new(3.0, 0.5, 0.5), DVec3::new(1.0, 0.5, 0.5), false),
        (DVec3::new(3.0, 4.0, 0.0), DVec3::new(1.0, 2.0, 0.0), false),
        (
            DVec3::new(-2.0, -3.0, -4.0),
            DVec3::new(-1.0, -2.0, -3.0),
            false,
        ),
        (DVec3::new(0.8, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), true),
        (DVec3::new(0.0, -1.5, 0.5), DVec3::new(0.0, -2.0, 0.5), true),
        (DVec3::new(0.1, 0.2, 2.9), DVec3::new(0.1, 0.2, 3.0), true),
    ];
    for (local, expect, inside) in cases {
        let p = project_point_shape(&b, &pose, pose.transform_point(local)).unwrap();
        assert_eq!(p.inside, inside, "{local}");
        assert!(
            p.point.distance(pose.transform_point(expect)) < EPS,
            "{local}"
        );
        assert!((p.distance - local.distance(expect)).abs() < EPS);
    }
}

#[test]
fn project_point_on_other_shapes() {
    let cap = Shape::capsule(1.0, 0.5).unwrap();
    let p = project_point_shape(&cap, &Pose::IDENTITY, DVec3::new(0.0, 3.0, 0.0)).unwrap();
    assert!(!p.inside && (p.distance - 1.5).abs() < EPS);
    let p = project_point_shape(&cap, &Pose::IDENTITY, DVec3::new(0.2, 0.3, 0.0)).unwrap();
    assert!(p.inside && (p.distance - 0.3).abs() < EPS);

    let cyl = Shape::cylinder(1.0, 0.5).unwrap();
    let p = project_point_shape(&cyl, &Pose::IDENTITY, DVec3::new(2.0, 3.0, 0.0)).unwrap();
    assert!(!p.inside);
    assert!(p.point.distance(DVec3::new(0.5, 1.0, 0.0)) < EPS);
    let p = project_point_shape(&cyl, &Pose::IDENTITY, DVec3::new(0.0, 0.9, 0.1)).unwrap();
    assert!(p.inside && (p.distance - 0.1).abs() < EPS);

    // The hull of a box agrees with the box, inside and out.
    let h = DVec3::new(0.5, 1.0, 1.5);
    let cuboid = Shape::cuboid(h).unwrap();
    let hull = Shape::convex_hull(&box_corners(h)).unwrap();
    let pose = Pose::new(DVec3::new(1.0, 0.0, -1.0), DQuat::from_rotation_z(0.5));
    let mut rng = Rng(11);
    for _ in 0..300 {
        let q = pose.translation + rng.in_cube(3.0);
        let a = project_point_shape(&cuboid, &pose, q).unwrap();
        let b = project_point_shape(&hull, &pose, q).unwrap();
        assert_eq!(a.inside, b.inside, "{q}");
        assert!((a.distance - b.distance).abs() < 1e-9, "{a:?} {b:?}");
    }

    // A mesh is a surface: never inside.
    let tri = Shape::trimesh(vec![DVec3::ZERO, DVec3::Z, DVec3::X], vec![[0, 1, 2]]).unwrap();
    let p = project_point_shape(&tri, &Pose::IDENTITY, DVec3::new(0.2, -0.5, 0.2)).unwrap();
    assert!(!p.inside && (p.distance - 0.5).abs() < EPS);
}

// ---------------------------------------------------------- overlap, cast

#[test]
fn overlap_of_shapes_and_compounds() {
    let a = Shape::sphere(1.0).unwrap();
    let b = Shape::cuboid(DVec3::ONE).unwrap();
    assert!(overlap(&a, &at(1.9, 0.0, 0.0), &b, &Pose::IDENTITY).unwrap());
    assert!(!overlap(&a, &at(2.1, 0.0, 0.0), &b, &Pose::IDENTITY).unwrap());
    // Corner: the sphere must reach √3 − … ; at (1.6, 1.6, 1.6) the gap is
    // 0.6√3 − 1 ≈ 0.039 > 0.
    assert!(!overlap(&a, &at(1.6, 1.6, 1.6), &b, &Pose::IDENTITY).unwrap());
    assert!(overlap(&a, &at(1.5, 1.5, 1.5), &b, &Pose::IDENTITY).unwrap());
    let c = Shape::compound(vec![(at(5.0, 0.0, 0.0), b.clone())]).unwrap();
    assert!(overlap(&a, &at(3.5, 0.0, 0.0), &c, &Pose::IDENTITY).unwrap());
    assert!(!overlap(&a, &Pose::IDENTITY, &c, &Pose::IDENTITY).unwrap());
}

#[test]
fn cast_sphere_towards_box_at_analytic_time() {
    let s = Shape::sphere(0.5).unwrap();
    let b = Shape::cuboid(DVec3::ONE).unwrap();
    let t = cast_shape(&s, &at(-5.0, 0.3, 0.0), DVec3::X, 10.0, &b, &Pose::IDENTITY)
        .unwrap()
        .unwrap();
    assert!((t - 3.5).abs() < 1e-3 && t <= 3.5 + 1e-9, "{t}");
    // Towards a corner region at a slant, and a miss.
    let d = DVec3::new(1.0, 1.0, 0.0);
    let t = cast_shape(&s, &at(-5.0, -5.0, 0.0), d, 10.0, &b, &Pose::IDENTITY)
        .unwrap()
        .unwrap();
    // Centre path x = y = −5 + t; touches the edge (−1, −1) when
    // √2 (4 − t) = 0.5.
    let exact = 4.0 - 0.5 / 2f64.sqrt();
    assert!(
        (t - exact).abs() < 1e-3 && t <= exact + 1e-12,
        "{t} vs {exact}"
    );
    assert!(
        cast_shape(&s, &at(-5.0, 2.0, 0.0), DVec3::X, 10.0, &b, &Pose::IDENTITY)
            .unwrap()
            .is_none()
    );
    // Too short.
    assert!(
        cast_shape(&s, &at(-5.0, 0.0, 0.0), DVec3::X, 3.4, &b, &Pose::IDENTITY)
            .unwrap()
            .is_none()
    );
    // Onto a flat heightfield (triangle by triangle): falls 4.5 m.
    let field = Shape::heightfield(vec![0.0; 16], 4, 4, DVec3::new(6.0, 1.0, 6.0)).unwrap();
    let t = cast_shape(
        &s,
        &at(0.3, 5.0, -0.7),
        -DVec3::Y,
        10.0,
        &field,
        &Pose::IDENTITY,
    )
    .unwrap()
    .unwrap();
    assert!((t - 4.5).abs() < 1e-3, "{t}");
    // Only convex shapes move.
    assert!(cast_shape(&field, &Pose::IDENTITY, DVec3::X, 1.0, &s, &Pose::IDENTITY).is_err());
}

// ------------------------------------------------------------------ World

/// Spheres of radius 0.5 at x = 2, 4, 6 (added out of order) and a box
/// off the ray's line.
fn row_of_spheres() -> (World, [BodyHandle; 3]) {
    let mut w = world();
    let s = Shape::sphere(0.5).unwrap();
    let far = add(&mut w, s.clone(), at(6.0, 0.0, 0.0));
    let near = add(&mut w, s.clone(), at(2.0, 0.0, 0.0));
    let mid = add(&mut w, s, at(4.0, 0.0, 0.0));
    add(
        &mut w,
        Shape::cuboid(DVec3::ONE).unwrap(),
        at(4.0, 5.0, 0.0),
    );
    (w, [near, mid, far])
}

#[test]
fn world_cast_ray_closest_and_all_sorted() {
    let (w, [near, mid, far]) = row_of_spheres();
    let (h, hit) = w
        .cast_ray(DVec3::ZERO, DVec3::X, 100.0, |_, _| true)
        .unwrap()
        .unwrap();
    assert_eq!(h, near);
    assert!((hit.t - 1.5).abs() < EPS);
    assert!(hit.normal.distance(-DVec3::X) < EPS);

    let all = w
        .cast_ray_all(DVec3::ZERO, DVec3::X, 100.0, |_, _| true)
        .unwrap();
    let handles: Vec<_> = all.iter().map(|(h, _)| *h).collect();
    assert_eq!(handles, vec![near, mid, far]);
    let ts: Vec<f64> = all.iter().map(|(_, h)| h.t).collect();
    for (t, e) in ts.iter().zip([1.5, 3.5, 5.5]) {
        assert!((t - e).abs() < EPS);
    }
    // max_t cuts the list; the filter skips bodies.
    let cut = w
        .cast_ray_all(DVec3::ZERO, DVec3::X, 4.0, |_, _| true)
        .unwrap();
    assert_eq!(cut.len(), 2);
    let (h, _) = w
        .cast_ray(DVec3::ZERO, DVec3::X, 100.0, |h, _| h != near)
        .unwrap()
        .unwrap();
    assert_eq!(h, mid);
    // From the far side the order reverses.
    let back = w
        .cast_ray_all(DVec3::new(10.0, 0.0, 0.0), -DVec3::X, 100.0, |_, _| true)
        .unwrap();
    assert_eq!(
        back.iter().map(|(h, _)| *h).collect::<Vec<_>>(),
        vec![far, mid, near]
    );
    assert!(w
        .cast_ray(DVec3::new(0.0, -3.0, 0.0), DVec3::X, 100.0, |_, _| true)
        .unwrap()
        .is_none());
}

#[test]
fn world_cast_ray_all_ties_sorted_by_handle() {
    let mut w = world();
    let s = Shape::sphere(1.0).unwrap();
    let a = add(&mut w, s.clone(), at(3.0, 0.0, 0.0));
    let b = add(&mut w, s, at(3.0, 0.0, 0.0));
    let all = w
        .cast_ray_all(DVec3::ZERO, DVec3::X, 10.0, |_, _| true)
        .unwrap();
    assert_eq!(
        all.iter().map(|(h, _)| *h).collect::<Vec<_>>(),
        vec![a.min(b), a.max(b)]
    );
    assert_eq!(
        w.cast_ray(DVec3::ZERO, DVec3::X, 10.0, |_, _| true)
            .unwrap()
            .unwrap()
            .0,
        a.min(b)
    );
}

#[test]
fn world_overlap_finds_exactly_intersecting_bodies() {
    let mut w = world();
    let ball = Shape::sphere(0.5).unwrap();
    let cube = Shape::cuboid(DVec3::splat(0.5)).unwrap();
    let mut expect = Vec::new();
    // Query: a unit box (half 1) at the origin rotated 45° about Y.
    let query = Shape::cuboid(DVec3::ONE).unwrap();
    let qpose = Pose::from_rotation(DQuat::from_rotation_y(FRAC_PI_4));
    // Along X the rotated box reaches √2 ≈ 1.414.
    let inside = add(&mut w, ball.clone(), at(0.0, 0.0, 0.0));
    expect.push(inside);
    expect.push(add(&mut w, ball.clone(), at(1.8, 0.0, 0.0))); // reaches 1.3 < 1.414
    add(&mut w, ball.clone(), at(2.0, 0.0, 0.0)); // reaches 1.5 - … : gap
    add(&mut w, ball.clone(), at(0.0, 1.6, 0.0)); // 1.1 > 1: apart
    expect.push(add(&mut w, ball, at(0.0, -1.4, 0.0))); // 0.9 < 1
    expect.push(add(&mut w, cube.clone(), at(0.0, 0.0, 1.85))); // 1.35 < 1.414
    add(&mut w, cube, at(1.3, 0.0, 1.3)); // its corner at 0.8, 0.8: √2·0.8 > 1 apart
    expect.sort();
    let got = w.overlap_shape(&query, qpose).unwrap();
    assert_eq!(got, expect);
}

#[test]
fn world_project_point_picks_nearest_body() {
    let (w, [near, mid, _]) = row_of_spheres();
    let (h, p) = w.project_point(DVec3::new(2.9, 0.0, 0.1)).unwrap().unwrap();
    assert_eq!(h, near);
    assert!(!p.inside);
    let (h, p) = w.project_point(DVec3::new(4.2, 0.0, 0.0)).unwrap().unwrap();
    assert_eq!(h, mid);
    assert!(p.inside && (p.distance - 0.3).abs() < EPS);
    assert!(p.point.distance(DVec3::new(4.5, 0.0, 0.0)) < EPS);
    assert!(world().project_point(DVec3::ZERO).unwrap().is_none());
}

#[test]
fn world_cast_shape_time_of_impact() {
    let mut w = world();
    let target = add(
        &mut w,
        Shape::cuboid(DVec3::ONE).unwrap(),
        at(5.0, 0.0, 0.0),
    );
    add(
        &mut w,
        Shape::cuboid(DVec3::ONE).unwrap(),
        at(9.0, 0.0, 0.0),
    );
    add(&mut w, Shape::sphere(1.0).unwrap(), at(5.0, 4.0, 0.0));
    let ball = Shape::sphere(0.5).unwrap();
    let (h, t) = w
        .cast_shape(&ball, at(0.0, 0.2, 0.0), DVec3::X, 20.0)
        .unwrap()
        .unwrap();
    assert_eq!(h, target);
    assert!((t - 3.5).abs() < 1e-3 && t <= 3.5 + 1e-9, "{t}");
    // dir of length 2 halves the time.
    let (_, t) = w
        .cast_shape(&ball, at(0.0, 0.2, 0.0), DVec3::X * 2.0, 20.0)
        .unwrap()
        .unwrap();
    assert!((t - 1.75).abs() < 1e-3, "{t}");
    // Already touching: 0. Missing: None.
    let (_, t) = w
        .cast_shape(&ball, at(4.0, 0.0, 0.0), -DVec3::X, 1.0)
        .unwrap()
        .unwrap();
    assert_eq!(t, 0.0);
    assert!(w
        .cast_shape(&ball, at(0.0, -3.0, 0.0), DVec3::X, 20.0)
        .unwrap()
        .is_none());
}

#[test]
fn world_queries_refuse_bad_input_with_typed_errors() {
    fn all(_: BodyHandle, _: &RigidBody) -> bool {
        true
    }
    let (w, _) = row_of_spheres();
    assert!(matches!(
        w.cast_ray(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::X, 1.0, all),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        w.cast_ray(DVec3::ZERO, DVec3::new(0.0, f64::INFINITY, 0.0), 1.0, all),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        w.cast_ray(DVec3::ZERO, DVec3::ZERO, 1.0, all),
        Err(PhysicsError::ZeroDirection(_))
    ));
    assert!(matches!(
        w.cast_ray_all(DVec3::ZERO, DVec3::X, -1.0, all),
        Err(PhysicsError::Negative { .. })
    ));
    assert!(matches!(
        w.cast_ray_all(DVec3::ZERO, DVec3::X, f64::NAN, all),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        w.project_point(DVec3::splat(f64::NAN)),
        Err(PhysicsError::NonFinite { .. })
    ));
    let ball = Shape::sphere(0.5).unwrap();
    assert!(matches!(
        w.overlap_shape(&ball, at(f64::INFINITY, 0.0, 0.0)),
        Err(PhysicsError::NonFinite { .. })
    ));
    assert!(matches!(
        w.cast_shape(&ball, Pose::IDENTITY, DVec3::ZERO, 1.0),
        Err(PhysicsError::ZeroDirection(_))
    ));
    assert!(matches!(
        w.cast_shape(&ball, Pose::IDENTITY, DVec3::X, -1.0),
        Err(PhysicsError::Negative { .. })
    ));
    let mesh = Shape::trimesh(vec![DVec3::ZERO, DVec3::Z, DVec3::X], vec![[0, 1, 2]]).unwrap();
    assert!(matches!(
        w.cast_shape(&mesh, Pose::IDENTITY, DVec3::X, 1.0),
        Err(PhysicsError::Invalid { .. })
    ));
}

#[test]
fn cast_sphere_at_sphere_matches_ray_on_summed_radius() {
    // A ball of radius a swept at a ball of radius b first touches when its
    // centre reaches the ball of radius a + b: a ray cast.
    let (a, b) = (0.3, 0.7);
    let mover = Shape::sphere(a).unwrap();
    let target = Shape::sphere(b).unwrap();
    let grown = Shape::sphere(a + b).unwrap();
    let tpose = at(1.0, 2.0, -1.0);
    let mut rng = Rng(5);
    let mut hits = 0;
    for _ in 0..300 {
        let start = tpose.translation + rng.in_cube(5.0);
        if start.distance(tpose.translation) <= a + b + 0.01 {
            continue;
        }
        let d = (tpose.translation + rng.in_cube(1.2) - start) * rng.range(0.5, 2.0);
        let cast = cast_shape(
            &mover,
            &at(start.x, start.y, start.z),
            d,
            3.0,
            &target,
            &tpose,
        )
        .unwrap();
        let ray = ray_cast_shape(&grown, &tpose, start, d, 3.0);
        match (cast, ray) {
            (Some(t), Some(r)) => {
                hits += 1;
                assert!(t <= r.t + 1e-9 && r.t - t < 1e-3 * d.length().recip().max(1.0));
            }
            (None, None) => {}
            // Grazing rays may end within the tolerance of the surface.
            (c, r) => {
                let t = c.or(r.map(|r| r.t)).unwrap();
                let p = start + d * t;
                assert!(
                    (p.distance(tpose.translation) - (a + b)).abs() < 1e-3,
                    "cast {c:?} vs ray {r:?}"
                );
            }
        }
    }
    assert!(hits > 100, "{hits}");
}

#[test]
fn cast_capsule_and_sphere_onto_box_and_sloped_heightfield() {
    // A capsule lying along X falls onto a box top: gap 3 − 0.3 − 0.5.
    let cap = Shape::capsule(1.0, 0.3).unwrap();
    let lying = Pose::new(
        DVec3::new(0.5, 3.0, 0.2),
        DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
    );
    let slab = Shape::cuboid(DVec3::new(2.0, 0.5, 2.0)).unwrap();
    let t = cast_shape(&cap, &lying, -DVec3::Y, 10.0, &slab, &Pose::IDENTITY)
        .unwrap()
        .unwrap();
    assert!((t - 2.2).abs() < 1e-3 && t <= 2.2 + 1e-9, "{t}");
    // A ball of radius 0.2 dropped on the bump's facet y = 1 − x − z
    // (normal (1, 1, 1)/√3) touches when its centre is at
    // y = 0.25 + 0.2 √3 above (0.5, 0.25).
    let heights = vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    let field = Shape::heightfield(heights, 3, 3, DVec3::new(2.0, 1.0, 2.0)).unwrap();
    let ball = Shape::sphere(0.2).unwrap();
    let t = cast_shape(
        &ball,
        &at(0.5, 5.0, 0.25),
        -DVec3::Y,
        10.0,
        &field,
        &Pose::IDENTITY,
    )
    .unwrap()
    .unwrap();
    let exact = 5.0 - (0.25 + 0.2 * 3f64.sqrt());
    // Along −Y the gap closes at cos = 1/√3, so the time error is up to
    // √3 times the distance tolerance.
    assert!(
        (t - exact).abs() < 1e-3 && t <= exact + 1e-9,
        "{t} vs {exact}"
    );
}

#[test]
fn world_queries_see_meshes_and_heightfields() {
    let mut w = world();
    let field = add(
        &mut w,
        Shape::heightfield(vec![0.0; 25], 5, 5, DVec3::new(8.0, 1.0, 8.0)).unwrap(),
        at(0.0, -1.0, 0.0),
    );
    let ramp = add(
        &mut w,
        Shape::trimesh(
            vec![
                DVec3::new(5.0, 0.0, -1.0),
                DVec3::new(5.0, 0.0, 1.0),
                DVec3::new(7.0, 2.0, 0.0),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap(),
        Pose::IDENTITY,
    );
    let (h, hit) = w
        .cast_ray(DVec3::new(1.0, 5.0, 1.0), -DVec3::Y, 10.0, |_, _| true)
        .unwrap()
        .unwrap();
    assert_eq!(h, field);
    assert!((hit.t - 6.0).abs() < EPS && hit.normal.distance(DVec3::Y) < EPS);
    let ball = Shape::sphere(0.5).unwrap();
    assert_eq!(
        w.overlap_shape(&ball, at(0.0, -0.6, 0.0)).unwrap(),
        vec![field]
    );
    assert!(w
        .overlap_shape(&ball, at(0.0, -0.4, 0.0))
        .unwrap()
        .is_empty());
    let (h, t) = w
        .cast_shape(&ball, at(0.0, 0.5, 0.0), DVec3::X, 10.0)
        .unwrap()
        .unwrap();
    assert_eq!(h, ramp);
    // The ramp's plane is x − y = 5 (normal (−1, 1, 0)/√2); the centre
    // (t, 0.5) touches it when (5 − t + 0.5)/√2 = 0.5.
    let exact = 5.5 - 0.5 * 2f64.sqrt();
    assert!((t - exact).abs() < 1e-3, "{t} vs {exact}");
}

#[test]
fn contacts_of_a_body_say_what_it_rests_on_and_what_rests_on_it() {
    let mut w = common::world();
    w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
    let ground = w
        .add_body(&RigidBodyDesc::fixed(
            Shape::cuboid(DVec3::new(10.0, 0.5, 10.0)).unwrap(),
            Pose::from_translation(DVec3::NEG_Y * 0.5),
        ))
        .unwrap();
    let cube = |y: f64| {
        RigidBodyDesc::dynamic(
            Shape::cuboid(DVec3::splat(0.5)).unwrap(),
            100.0,
            Pose::from_translation(DVec3::Y * y),
        )
        .unwrap()
    };
    let lower = w.add_body(&cube(0.5)).unwrap();
    let upper = w.add_body(&cube(1.5)).unwrap();
    w.step(1.0 / 60.0).unwrap();
    let mut seen: Vec<_> = w.contacts_of(lower).collect();
    seen.sort_by_key(|p| p.b);
    assert_eq!(seen.len(), 2, "{seen:?}");
    let below = w.contact_between(lower, ground).expect("on the ground");
    let above = w
        .contact_between(lower, upper)
        .expect("under the upper box");
    assert!(
        below.normal.y < -0.99 && above.normal.y > 0.99,
        "{below:?} {above:?}"
    );
    // The ground holds up both boxes, the lower box the upper one.
    let weight = 100.0 * 9.81 / 60.0;
    assert!(below.impulse > 1.5 * weight && above.impulse > 0.5 * weight);
    assert!(below.separation < 1e-3 && below.points == 4);
    // Seen from the other side: the same contact, the normal turned.
    let from_upper = w.contact_between(upper, lower).unwrap();
    assert_eq!(from_upper.normal, -above.normal);
    assert_eq!(from_upper.impulse, above.impulse);
    // Asleep, the stack still reports its contacts.
    common::run(&mut w, 1.0 / 60.0, 120);
    assert!(w.body(upper).unwrap().is_sleeping());
    assert!(w.contact_between(upper, lower).is_some());
    // A stale handle has none; a restored world reports what was saved.
    let saved = w.save();
    let before: Vec<_> = w.contacts_of(lower).collect();
    w.remove_body(upper).unwrap();
    assert_eq!(w.contacts_of(upper).count(), 0);
    w.restore(&saved).unwrap();
    assert_eq!(w.contacts_of(lower).collect::<Vec<_>>(), before);
    assert_eq!(before.len(), 2);
}
