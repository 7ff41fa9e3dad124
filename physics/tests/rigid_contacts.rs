//! Narrow phase: contact manifolds against analytic answers, symmetry,
//! invariance, GJK/EPA accuracy, random pairs and degenerate input.

use crate::common;

use common::Rng;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::contact::{ContactError, Manifold};
use inertia_physics::rigid::narrow::epa::epa;
use inertia_physics::rigid::narrow::gjk::{gjk, gjk_within, GjkResult};
use inertia_physics::rigid::narrow::{collide, distance, penetration};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;

// ---------------------------------------------------------------- helpers

fn at(x: f64, y: f64, z: f64) -> Pose {
    Pose::from_translation(DVec3::new(x, y, z))
}

fn cuboid(x: f64, y: f64, z: f64) -> Shape {
    Shape::cuboid(DVec3::new(x, y, z)).unwrap()
}

fn world_points(m: &Manifold, pa: &Pose, pb: &Pose) -> Vec<(DVec3, DVec3, f64)> {
    m.points
        .iter()
        .map(|p| {
            (
                pa.transform_point(p.local_a),
                pb.transform_point(p.local_b),
                p.separation,
            )
        })
        .collect()
}

/// Signed distance of `p` (shape frame) to the surface of a convex shape,
/// exact on the surface (which is all these tests need).
fn surface_distance(s: &Shape, p: DVec3) -> f64 {
    match s {
        Shape::Sphere { radius } => p.length() - radius,
        Shape::Cuboid { half_extents: h } => {
            let q = p.abs() - *h;
            q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
        }
        Shape::Capsule {
            half_height,
            radius,
        } => {
            let y = p.y.clamp(-half_height, *half_height);
            (p - DVec3::new(0.0, y, 0.0)).length() - radius
        }
        Shape::Cylinder {
            half_height,
            radius,
        } => {
            let d = DVec3::new(
                DVec3::new(p.x, 0.0, p.z).length() - radius,
                p.y.abs() - half_height,
                0.0,
            );
            let outside = DVec3::new(d.x.max(0.0), d.y.max(0.0), 0.0).length();
            outside + d.x.max(d.y).min(0.0)
        }
        Shape::ConvexHull(h) => h
            .faces()
            .iter()
            .map(|f| f.distance(p))
            .fold(f64::NEG_INFINITY, f64::max),
        _ => f64::NAN,
    }
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tol {tol})");
}

fn assert_vec_close(a: DVec3, b: DVec3, tol: f64, what: &str) {
    assert!(a.distance(b) <= tol, "{what}: {a} vs {b} (tol {tol})");
}

// ---------------------------------------------------------------- spheres

#[test]
fn sphere_on_box_top_one_point() {
    let ground = cuboid(2.0, 0.5, 2.0);
    let ball = Shape::sphere(0.5).unwrap();
    let m = collide(&ground, &Pose::IDENTITY, &ball, &at(0.3, 0.9, -0.2), 0.0).unwrap();
    assert_eq!(m.points.len(), 1);
    assert_vec_close(m.normal, DVec3::Y, 1e-12, "normal");
    let p = m.points[0];
    assert_close(p.separation, -0.1, 1e-12, "separation");
    assert_vec_close(p.local_a, DVec3::new(0.3, 0.5, -0.2), 1e-12, "on box");
    assert_vec_close(p.local_b, DVec3::new(0.0, -0.5, 0.0), 1e-12, "on ball");
}

#[test]
fn sphere_sphere_and_speculative() {
    let s = Shape::sphere(1.0).unwrap();
    let t = Shape::sphere(0.5).unwrap();
    let m = collide(&s, &Pose::IDENTITY, &t, &at(0.0, 0.0, 1.4), 0.0).unwrap();
    assert_eq!(m.points.len(), 1);
    assert_close(m.points[0].separation, -0.1, 1e-12, "overlap");
    assert_vec_close(m.normal, DVec3::Z, 1e-12, "normal");
    // 0.05 apart: within 0.1 of speculation, beyond 0.01.
    let m = collide(&s, &Pose::IDENTITY, &t, &at(0.0, 1.55, 0.0), 0.1).unwrap();
    assert_close(m.points[0].separation, 0.05, 1e-12, "gap");
    let m = collide(&s, &Pose::IDENTITY, &t, &at(0.0, 1.55, 0.0), 0.01).unwrap();
    assert!(m.is_empty());
}

#[test]
fn sphere_capsule_side_and_cap() {
    let cap = Shape::capsule(1.0, 0.5).unwrap();
    let ball = Shape::sphere(0.25).unwrap();
    let m = collide(&cap, &Pose::IDENTITY, &ball, &at(0.7, 0.3, 0.0), 0.0).unwrap();
    assert_close(m.points[0].separation, -0.05, 1e-12, "side");
    assert_vec_close(m.normal, DVec3::X, 1e-12, "side normal");
    let m = collide(&ball, &at(0.0, 1.7, 0.0), &cap, &Pose::IDENTITY, 0.0).unwrap();
    assert_close(m.points[0].separation, -0.05, 1e-12, "cap");
    assert_vec_close(m.normal, DVec3::NEG_Y, 1e-12, "cap normal");
}

// ---------------------------------------------------------------- capsules

#[test]
fn capsules_side_by_side_two_points_crossed_one() {
    let cap = Shape::capsule(1.0, 0.5).unwrap();
    let m = collide(&cap, &Pose::IDENTITY, &cap, &at(0.9, 0.5, 0.0), 0.0).unwrap();
    assert_eq!(m.points.len(), 2, "{m:?}");
    assert_vec_close(m.normal, DVec3::X, 1e-12, "normal");
    for p in &m.points {
        assert_close(p.separation, -0.1, 1e-12, "separation");
    }
    let ys: Vec<f64> = m.points.iter().map(|p| p.local_a.y).collect();
    assert!(
        ys.iter().any(|y| (y - 1.0).abs() < 1e-9) && ys.iter().any(|y| (y + 0.5).abs() < 1e-9),
        "{ys:?}"
    );

    let crossed = Pose::new(DVec3::new(0.0, 0.0, 0.9), DQuat::from_rotation_z(FRAC_PI_2));
    let m = collide(&cap, &Pose::IDENTITY, &cap, &crossed, 0.0).unwrap();
    assert_eq!(m.points.len(), 1);
    assert_close(m.points[0].separation, -0.1, 1e-12, "crossed");
}

#[test]
fn capsule_lying_on_box_two_points() {
    let ground = cuboid(2.0, 0.5, 2.0);
    let cap = Shape::capsule(0.75, 0.25).unwrap();
    let lying = Pose::new(
        DVec3::new(0.1, 0.74, 0.0),
        DQuat::from_rotation_z(FRAC_PI_2),
    );
    let m = collide(&ground, &Pose::IDENTITY, &cap, &lying, 0.0).unwrap();
    assert_eq!(m.points.len(), 2, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-9, "normal");
    let mut xs = Vec::new();
    for p in &m.points {
        assert_close(p.separation, -0.01, 1e-9, "separation");
        assert_close(p.local_a.y, 0.5, 1e-9, "on top face");
        xs.push(p.local_a.x);
    }
    xs.sort_by(f64::total_cmp);
    assert_close(xs[0], 0.1 - 0.75, 1e-9, "end");
    assert_close(xs[1], 0.1 + 0.75, 1e-9, "end");
    // Rolled and slid a little: the same two ids.
    let mut ids: Vec<u32> = m.points.iter().map(|p| p.id).collect();
    ids.sort_unstable();
    assert_ne!(ids[0], ids[1]);
    let nudged = Pose::new(
        DVec3::new(0.12, 0.745, 0.01),
        DQuat::from_rotation_y(0.02) * DQuat::from_rotation_z(FRAC_PI_2 + 0.001),
    );
    let m2 = collide(&ground, &Pose::IDENTITY, &cap, &nudged, 0.0).unwrap();
    let mut ids2: Vec<u32> = m2.points.iter().map(|p| p.id).collect();
    ids2.sort_unstable();
    assert_eq!(ids, ids2);
    // Deep: the capsule's axis inside the box (EPA on the cores).
    let deep = Pose::new(DVec3::new(0.0, 0.4, 0.0), DQuat::from_rotation_z(FRAC_PI_2));
    let m = collide(&ground, &Pose::IDENTITY, &cap, &deep, 0.0).unwrap();
    assert_vec_close(m.normal, DVec3::Y, 1e-9, "deep normal");
    assert_close(m.min_separation().unwrap(), -0.35, 1e-9, "deep");
}

// ---------------------------------------------------------------- boxes

#[test]
fn box_resting_flat_on_box_four_corners_stable_ids() {
    let ground = cuboid(1.0, 0.5, 1.0);
    let top = cuboid(0.5, 0.5, 0.5);
    // Overhangs in +x: overlap is x in [0.3, 1.0], z in [-0.5, 0.5].
    let pose = at(0.8, 0.99, 0.0);
    let m = collide(&ground, &Pose::IDENTITY, &top, &pose, 0.0).unwrap();
    assert_eq!(m.points.len(), 4, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-12, "normal");
    let mut corners: Vec<(f64, f64)> = m
        .points
        .iter()
        .map(|p| (p.local_a.x, p.local_a.z))
        .collect();
    corners.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let want = [(0.3, -0.5), (0.3, 0.5), (1.0, -0.5), (1.0, 0.5)];
    for (c, w) in corners.iter().zip(want) {
        assert_close(c.0, w.0, 1e-12, "corner x");
        assert_close(c.1, w.1, 1e-12, "corner z");
    }
    for p in &m.points {
        assert_close(p.separation, -0.01, 1e-12, "separation");
        assert_close(p.local_a.y, 0.5, 1e-12, "on ground top");
        assert_close(p.local_b.y, -0.5, 1e-12, "on box bottom");
    }
    let mut ids: Vec<u32> = m.points.iter().map(|p| p.id).collect();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), 4, "ids unique");
    // Nudged a little (and turned a hair): same ids.
    let nudged = Pose::new(DVec3::new(0.81, 0.985, 0.01), DQuat::from_rotation_y(0.01));
    let m2 = collide(&ground, &Pose::IDENTITY, &top, &nudged, 0.0).unwrap();
    let mut ids2: Vec<u32> = m2.points.iter().map(|p| p.id).collect();
    ids2.sort_unstable();
    assert_eq!(ids, ids2);
    // Fully on top: the top box's four corners, ids of its vertices.
    let m3 = collide(&ground, &Pose::IDENTITY, &top, &at(0.1, 0.98, 0.0), 0.0).unwrap();
    assert_eq!(m3.points.len(), 4);
    for p in &m3.points {
        assert_close(p.separation, -0.02, 1e-12, "sep");
        assert_close(p.local_b.x.abs(), 0.5, 1e-12, "corner");
        assert_close(p.local_b.z.abs(), 0.5, 1e-12, "corner");
    }
}

#[test]
fn box_on_edge_two_points() {
    let ground = cuboid(2.0, 0.5, 2.0);
    let top = cuboid(0.5, 0.5, 0.5);
    let h = 0.5 * 2f64.sqrt();
    let pose = Pose::new(
        DVec3::new(0.0, 0.5 + h - 0.02, 0.0),
        DQuat::from_rotation_z(FRAC_PI_4),
    );
    let m = collide(&ground, &Pose::IDENTITY, &top, &pose, 0.0).unwrap();
    assert_eq!(m.points.len(), 2, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-12, "normal");
    for p in &m.points {
        assert_close(p.separation, -0.02, 1e-9, "separation");
        assert_close(p.local_a.x, 0.0, 1e-9, "under the edge");
        assert_close(p.local_a.z.abs(), 0.5, 1e-9, "edge ends");
    }
}

#[test]
fn box_edge_on_edge_one_point() {
    let a = cuboid(0.5, 0.5, 0.5);
    // A rotated 45° about Z (edge up along Z), B rotated 45° about X
    // (edge down along X): the edges cross.
    let h = 0.5 * 2f64.sqrt();
    let pa = Pose::from_rotation(DQuat::from_rotation_z(FRAC_PI_4));
    let pb = Pose::new(
        DVec3::new(0.0, 2.0 * h - 0.05, 0.0),
        DQuat::from_rotation_x(FRAC_PI_4),
    );
    let m = collide(&a, &pa, &a, &pb, 0.0).unwrap();
    assert_eq!(m.points.len(), 1, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-9, "normal");
    assert_close(m.points[0].separation, -0.05, 1e-9, "separation");
}

#[test]
fn speculative_boxes() {
    let a = cuboid(0.5, 0.5, 0.5);
    let m = collide(&a, &Pose::IDENTITY, &a, &at(1.03, 0.0, 0.0), 0.05).unwrap();
    assert_eq!(m.points.len(), 4);
    for p in &m.points {
        assert_close(p.separation, 0.03, 1e-12, "gap");
    }
    let m = collide(&a, &Pose::IDENTITY, &a, &at(1.03, 0.0, 0.0), 0.02).unwrap();
    assert!(m.is_empty());
    // Corner to corner, diagonal gap: one point, exact distance.
    let m = collide(&a, &Pose::IDENTITY, &a, &at(1.1, 1.1, 1.1), 0.5).unwrap();
    let d = (3.0 * 0.1f64 * 0.1).sqrt();
    assert_close(m.min_separation().unwrap(), d, 1e-9, "corner gap");
}

// ---------------------------------------------------------------- other shapes

#[test]
fn cylinder_standing_on_box() {
    let ground = cuboid(2.0, 0.5, 2.0);
    let cyl = Shape::cylinder(0.5, 0.3).unwrap();
    let m = collide(&ground, &Pose::IDENTITY, &cyl, &at(0.0, 0.99, 0.0), 0.0).unwrap();
    assert!(m.points.len() >= 3, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-6, "normal");
    for p in &m.points {
        assert_close(p.separation, -0.01, 1e-6, "separation");
        assert_close(
            DVec3::new(p.local_b.x, 0.0, p.local_b.z).length(),
            0.3,
            1e-6,
            "rim",
        );
    }
}

#[test]
fn hull_box_on_box_matches_cuboid() {
    let corners: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 != 0 { 0.5 } else { -0.5 },
                if i & 2 != 0 { 0.5 } else { -0.5 },
                if i & 4 != 0 { 0.5 } else { -0.5 },
            )
        })
        .collect();
    let hull = Shape::convex_hull(&corners).unwrap();
    let ground = cuboid(1.0, 0.5, 1.0);
    let pose = Pose::new(DVec3::new(0.1, 0.97, 0.0), DQuat::from_rotation_y(0.3));
    let m = collide(&ground, &Pose::IDENTITY, &hull, &pose, 0.0).unwrap();
    assert_eq!(m.points.len(), 4);
    for p in &m.points {
        assert_close(p.separation, -0.03, 1e-12, "separation");
    }
}

#[test]
fn box_on_trimesh_and_sphere_on_heightfield() {
    let verts = vec![
        DVec3::new(-2.0, 0.0, -2.0),
        DVec3::new(2.0, 0.0, -2.0),
        DVec3::new(2.0, 0.0, 2.0),
        DVec3::new(-2.0, 0.0, 2.0),
    ];
    let mesh = Shape::trimesh(verts, vec![[0, 2, 1], [0, 3, 2]]).unwrap();
    let b = cuboid(0.5, 0.5, 0.5);
    let pose = Pose::new(DVec3::new(0.2, 0.49, 0.1), DQuat::from_rotation_y(0.4));
    let m = collide(&mesh, &Pose::IDENTITY, &b, &pose, 0.0).unwrap();
    assert_eq!(m.points.len(), 4, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-12, "normal");
    for p in &m.points {
        assert_close(p.separation, -0.01, 1e-12, "separation");
    }
    // Convex first, mesh second: flipped.
    let m2 = collide(&b, &pose, &mesh, &Pose::IDENTITY, 0.0).unwrap();
    assert_eq!(m2.points.len(), 4);
    assert_vec_close(m2.normal, DVec3::NEG_Y, 1e-12, "flipped normal");
    for p in &m2.points {
        assert_close(p.local_a.y, -0.5, 1e-12, "on box bottom");
    }

    let field = Shape::heightfield(vec![0.0; 25], 5, 5, DVec3::new(4.0, 1.0, 4.0)).unwrap();
    let ball = Shape::sphere(0.5).unwrap();
    let m = collide(&field, &Pose::IDENTITY, &ball, &at(0.3, 0.45, 0.7), 0.0).unwrap();
    assert_eq!(m.points.len(), 1, "{m:?}");
    assert_close(m.points[0].separation, -0.05, 1e-9, "sphere on field");
    assert_vec_close(m.normal, DVec3::Y, 1e-9, "field normal");
    let m = collide(&field, &Pose::IDENTITY, &ball, &at(0.3, 0.6, 0.7), 0.05).unwrap();
    assert!(m.is_empty());
    // Sunk below the terrain: pushed back up, not out through the bottom.
    let m = collide(&field, &Pose::IDENTITY, &ball, &at(0.3, -0.1, 0.7), 0.0).unwrap();
    assert_vec_close(m.normal, DVec3::Y, 1e-9, "sunk normal");
    assert_close(m.min_separation().unwrap(), -0.6, 1e-9, "sunk depth");
    // At the lip of a steep drop (falling 2 m over the last 1 m cell), a
    // ball resting on the flat part is not grabbed by the drop's plane,
    // whose extension lies above the ball's centre.
    let bank: Vec<f64> = (0..25)
        .map(|i| if i % 5 == 4 { -2.0 } else { 0.0 })
        .collect();
    let bank = Shape::heightfield(bank, 5, 5, DVec3::new(4.0, 1.0, 4.0)).unwrap();
    let m = collide(&bank, &Pose::IDENTITY, &ball, &at(0.6, 0.49, 0.2), 0.0).unwrap();
    assert_vec_close(m.normal, DVec3::Y, 1e-9, "lip normal");
    assert_close(m.min_separation().unwrap(), -0.01, 1e-9, "lip");
    // A box on a tilted heightfield (a ramp rising along +x).
    let ramp: Vec<f64> = (0..9).map(|i| 0.5 * (i % 3) as f64).collect();
    let ramp = Shape::heightfield(ramp, 3, 3, DVec3::new(4.0, 1.0, 4.0)).unwrap();
    let slope = DVec3::new(-0.25, 1.0, 0.0).normalize();
    let tilt = DQuat::from_rotation_arc(DVec3::Y, slope);
    let centre = slope * (0.5 - 0.01) + DVec3::new(0.0, 0.5, 0.0);
    let m = collide(&ramp, &Pose::IDENTITY, &b, &Pose::new(centre, tilt), 0.0).unwrap();
    assert_eq!(m.points.len(), 4, "{m:?}");
    assert_vec_close(m.normal, slope, 1e-9, "ramp normal");
    for p in &m.points {
        assert_close(p.separation, -0.01, 1e-9, "ramp separation");
    }
}

#[test]
fn cylinder_lying_on_box_and_stacked_on_cylinder() {
    let ground = cuboid(2.0, 0.5, 2.0);
    let cyl = Shape::cylinder(0.5, 0.3).unwrap();
    let lying = Pose::new(
        DVec3::new(0.0, 0.79, 0.0),
        DQuat::from_rotation_x(FRAC_PI_2),
    );
    let m = collide(&ground, &Pose::IDENTITY, &cyl, &lying, 0.0).unwrap();
    assert_eq!(m.points.len(), 2, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-6, "normal");
    for p in &m.points {
        assert_close(p.separation, -0.01, 1e-6, "separation");
    }
    let m = collide(&cyl, &Pose::IDENTITY, &cyl, &at(0.1, 0.98, 0.0), 0.0).unwrap();
    assert_eq!(m.points.len(), 4, "{m:?}");
    assert_vec_close(m.normal, DVec3::Y, 1e-6, "stacked normal");
    for p in &m.points {
        assert_close(p.separation, -0.02, 1e-6, "stacked separation");
    }
}

// ---------------------------------------------------------------- GJK / EPA

#[test]
fn gjk_distance_matches_known() {
    let s1 = Shape::sphere(0.5).unwrap();
    let s2 = Shape::sphere(0.25).unwrap();
    let pb = Pose::from_translation(DVec3::new(1.0, 2.0, 2.0));
    let (d, _, _) = distance(&s1, &Pose::IDENTITY, &s2, &pb).unwrap();
    assert_close(d, 3.0 - 0.75, 1e-9, "spheres");

    let b = cuboid(0.5, 0.5, 0.5);
    let (d, pa, pbp) = distance(&b, &Pose::IDENTITY, &b, &at(2.0, 0.3, -0.2)).unwrap();
    assert_close(d, 1.0, 1e-9, "boxes face");
    assert_close(pbp.x - pa.x, 1.0, 1e-9, "closest points");
    let (d, _, _) = distance(&b, &Pose::IDENTITY, &b, &at(1.5, 1.5, 1.5)).unwrap();
    assert_close(d, 3f64.sqrt() * 0.5, 1e-9, "boxes corner");
    // Rotated: B's corner points at A's face.
    let rot = DQuat::from_rotation_arc(DVec3::new(1.0, 1.0, 1.0).normalize(), DVec3::NEG_X);
    let (d, _, _) = distance(
        &b,
        &Pose::IDENTITY,
        &b,
        &Pose::new(DVec3::new(2.0, 0.1, 0.0), rot),
    )
    .unwrap();
    assert_close(d, 2.0 - 0.5 - 0.5 * 3f64.sqrt(), 1e-9, "corner on face");
    let (d, _, _) = distance(&b, &Pose::IDENTITY, &b, &at(0.5, 0.0, 0.0)).unwrap();
    assert_eq!(d, 0.0);
}

/// `gjk_within` stops early only for pairs `gjk` measures farther apart
/// than the limit, and otherwise answers exactly what `gjk` answers: the
/// narrow phase's early exit changes no contact.
#[test]
fn gjk_within_agrees_with_gjk_and_stops_only_beyond_the_limit() {
    let mut rng = Rng(5);
    let cloud: Vec<DVec3> = (0..32).map(|_| rng.in_cube(0.5)).collect();
    let hull = Shape::convex_hull(&cloud).unwrap();
    let Shape::ConvexHull(hull) = &hull else {
        unreachable!("a convex hull")
    };
    let (mut early, mut within) = (0, 0);
    for k in 0..4000 {
        let (qa, qb) = (rng.rotation(), rng.rotation());
        let offset = rng.in_cube(1.5);
        // A cylinder (curved: slow to converge) or a hull, against a hull.
        let sa = |d: DVec3| {
            let l = qa.inverse() * d;
            let p = if k % 2 == 0 {
                let y = if l.y >= 0.0 { 0.3 } else { -0.3 };
                DVec3::new(l.x, 0.0, l.z).normalize_or_zero() * 0.4 + DVec3::new(0.0, y, 0.0)
            } else {
                hull.support(l)
            };
            qa * p
        };
        let sb = |d: DVec3| offset + qb * hull.support(qb.inverse() * d);
        let limit = rng.range(0.0, 0.3);
        let full = gjk(&sa, &sb, offset, 1.0);
        match gjk_within(&sa, &sb, offset, 1.0, limit) {
            None => {
                early += 1;
                let GjkResult::Separated { distance, .. } = full else {
                    panic!("stopped early on an overlapping pair");
                };
                assert!(distance > limit, "stopped early at {distance} <= {limit}");
            }
            Some(r) => {
                within += 1;
                assert_eq!(format!("{r:?}"), format!("{full:?}"), "pair {k}");
            }
        }
    }
    assert!(
        early > 500 && within > 500,
        "early {early}, within {within}"
    );
}

#[test]
fn epa_depth_matches_analytic() {
    let h1 = DVec3::new(0.5, 0.4, 0.3);
    let h2 = DVec3::new(0.3, 0.3, 0.3);
    let c2 = DVec3::new(0.6, 0.2, 0.1);
    let sa = |d: DVec3| DVec3::select(d.cmpge(DVec3::ZERO), h1, -h1);
    let sb = |d: DVec3| c2 + DVec3::select(d.cmpge(DVec3::ZERO), h2, -h2);
    let GjkResult::Overlapping(simplex) = gjk(&sa, &sb, DVec3::X, 1.0) else {
        panic!("should overlap");
    };
    let p = epa(&sa, &sb, &simplex, 1.0).unwrap();
    // Overlaps per axis: x 0.8−0.6 = 0.2, y 0.7−0.2 = 0.5, z 0.6−0.1 = 0.5.
    assert_close(p.depth, 0.2, 1e-9, "box depth");
    assert_vec_close(p.normal, DVec3::X, 1e-9, "box normal");

    let sa = |d: DVec3| d.normalize_or(DVec3::X) * 1.0;
    let sb = |d: DVec3| DVec3::new(0.3, 0.4, 0.0) + d.normalize_or(DVec3::X) * 0.5;
    let GjkResult::Overlapping(simplex) = gjk(&sa, &sb, DVec3::X, 1.0) else {
        panic!("should overlap");
    };
    let p = epa(&sa, &sb, &simplex, 1.0).unwrap();
    assert_close(p.depth, 1.0, 1e-4, "sphere depth (curved: approximate)");

    // Through the public API: boxes and spheres.
    let b = cuboid(0.5, 0.5, 0.5);
    let (d, n) = penetration(&b, &Pose::IDENTITY, &b, &at(0.2, 0.9, 0.0)).unwrap();
    assert_close(d, 0.1, 1e-12, "api box depth");
    assert_vec_close(n, DVec3::Y, 1e-12, "api box normal");
    let s = Shape::sphere(0.5).unwrap();
    let (d, _) = penetration(&s, &Pose::IDENTITY, &s, &at(0.3, 0.4, 0.0)).unwrap();
    assert_close(d, 0.5, 1e-12, "api sphere depth");
}

// ---------------------------------------------------------------- properties

fn shapes() -> Vec<Shape> {
    let mut rng = Rng(7);
    let cloud: Vec<DVec3> = (0..20).map(|_| rng.in_cube(0.6)).collect();
    vec![
        Shape::sphere(0.4).unwrap(),
        cuboid(0.5, 0.3, 0.4),
        Shape::capsule(0.4, 0.25).unwrap(),
        Shape::cylinder(0.35, 0.3).unwrap(),
        Shape::convex_hull(&cloud).unwrap(),
    ]
}

#[test]
fn random_pairs_points_lie_on_both_surfaces() {
    let shapes = shapes();
    let mut rng = Rng(42);
    let mut checked = 0;
    // Worst error (m) per class: [flat (box, hull, sphere), capsule, cylinder].
    let mut worst = [0.0f64; 3];
    for _ in 0..40000 {
        let ia = (rng.next_u64() % shapes.len() as u64) as usize;
        let ib = (rng.next_u64() % shapes.len() as u64) as usize;
        let (a, b) = (&shapes[ia], &shapes[ib]);
        let pa = Pose::new(rng.in_cube(0.3), rng.rotation());
        let pb = Pose::new(pa.translation + rng.in_cube(0.8), rng.rotation());
        let m = collide(a, &pa, b, &pb, 0.1).unwrap();
        assert!(m.points.len() <= 4);
        if m.is_empty() {
            continue;
        }
        assert_close(m.normal.length(), 1.0, 1e-9, "unit normal");
        let class = if matches!(a, Shape::Cylinder { .. }) || matches!(b, Shape::Cylinder { .. }) {
            2
        } else if matches!(a, Shape::Capsule { .. }) || matches!(b, Shape::Capsule { .. }) {
            1
        } else {
            0
        };
        for p in &m.points {
            assert!(p.separation.is_finite());
            assert!(p.separation <= 0.1 + 1e-12);
            let wa = pa.transform_point(p.local_a);
            let wb = pb.transform_point(p.local_b);
            let err = (wa + m.normal * p.separation)
                .distance(wb)
                .max(surface_distance(a, p.local_a).abs())
                .max(surface_distance(b, p.local_b).abs());
            worst[class] = worst[class].max(err);
            checked += 1;
        }
    }
    println!(
        "worst point error: flat {:.1e} m, capsule {:.1e} m, cylinder {:.1e} m",
        worst[0], worst[1], worst[2]
    );
    assert!(checked > 20000, "{checked}");
    // Flat pairs are exact; a capsule's side counts as parallel within
    // 1.1°, so its points may sit ~2e-4 of its radius inside; cylinders go
    // through EPA on a curved difference, which converges to a tolerance.
    assert!(worst[0] < 1e-6, "{worst:?}");
    assert!(worst[1] < 1e-4, "{worst:?}");
    assert!(worst[2] < 1e-2, "{worst:?}");
}

#[test]
fn swapping_flips_normal_and_swaps_points() {
    let shapes = shapes();
    let mut rng = Rng(3);
    for _ in 0..200 {
        let ia = (rng.next_u64() % shapes.len() as u64) as usize;
        let ib = (rng.next_u64() % shapes.len() as u64) as usize;
        let (a, b) = (&shapes[ia], &shapes[ib]);
        let pa = Pose::new(rng.in_cube(0.3), rng.rotation());
        let pb = Pose::new(pa.translation + rng.in_cube(0.8), rng.rotation());
        let ab = collide(a, &pa, b, &pb, 0.05).unwrap();
        let ba = collide(b, &pb, a, &pa, 0.05).unwrap();
        if ab.is_empty() && ba.is_empty() {
            continue;
        }
        if ab.is_empty() || ba.is_empty() {
            // Only near the speculative edge may one side see nothing.
            let s = ab.min_separation().or(ba.min_separation()).unwrap_or(0.0);
            assert!(s > 0.0, "{ia}-{ib}: one-sided contact at {s}");
            continue;
        }
        let curved = matches!(a, Shape::Cylinder { .. }) || matches!(b, Shape::Cylinder { .. });
        let tol: f64 = if curved { 2e-3 } else { 1e-7 };
        assert_vec_close(
            ab.normal,
            -ba.normal,
            tol.max(1e-9) * 10.0,
            &format!("{ia}-{ib} normal"),
        );
        assert_close(
            ab.min_separation().unwrap(),
            ba.min_separation().unwrap(),
            tol,
            &format!("{ia}-{ib} depth"),
        );
        // Every point of A-B has a matching point of B-A with the roles swapped.
        let wa = world_points(&ab, &pa, &pb);
        let wb = world_points(&ba, &pb, &pa);
        if ab.points.len() == ba.points.len() && ab.points.len() == 1 {
            assert_vec_close(
                wa[0].0,
                wb[0].1,
                tol * 10.0,
                &format!("{ia}-{ib} point on A"),
            );
            assert_vec_close(
                wa[0].1,
                wb[0].0,
                tol * 10.0,
                &format!("{ia}-{ib} point on B"),
            );
        }
    }
}

#[test]
fn common_rigid_transform_keeps_separations() {
    let shapes = shapes();
    let mut rng = Rng(11);
    for _ in 0..200 {
        let ia = (rng.next_u64() % shapes.len() as u64) as usize;
        let ib = (rng.next_u64() % shapes.len() as u64) as usize;
        let (a, b) = (&shapes[ia], &shapes[ib]);
        let pa = Pose::new(rng.in_cube(0.3), rng.rotation());
        let pb = Pose::new(pa.translation + rng.in_cube(0.8), rng.rotation());
        let t = Pose::new(rng.in_cube(100.0), rng.rotation());
        let m1 = collide(a, &pa, b, &pb, 0.05).unwrap();
        let m2 = collide(a, &t.mul(&pa), b, &t.mul(&pb), 0.05).unwrap();
        if m1.points.len() != m2.points.len() {
            // Only allowed at the speculative boundary.
            let s = m1.min_separation().or(m2.min_separation()).unwrap_or(0.0);
            assert!(
                s > 0.05 - 1e-6,
                "{ia}-{ib}: {} vs {} points",
                m1.points.len(),
                m2.points.len()
            );
            continue;
        }
        let mut s1: Vec<f64> = m1.points.iter().map(|p| p.separation).collect();
        let mut s2: Vec<f64> = m2.points.iter().map(|p| p.separation).collect();
        s1.sort_by(f64::total_cmp);
        s2.sort_by(f64::total_cmp);
        // Curved shapes through EPA converge only to a tolerance.
        let curved = matches!(a, Shape::Cylinder { .. }) || matches!(b, Shape::Cylinder { .. });
        let tol = if curved { 2e-3 } else { 1e-6 };
        for (x, y) in s1.iter().zip(&s2) {
            assert_close(*x, *y, tol, &format!("{ia}-{ib} separation"));
        }
        if !m1.is_empty() {
            assert_vec_close(t.rotation * m1.normal, m2.normal, tol, "normal");
        }
    }
}

// ---------------------------------------------------------------- degenerate and bad input

#[test]
fn degenerate_cases_do_not_produce_nan() {
    let shapes = shapes();
    for a in &shapes {
        for b in &shapes {
            for pose in [
                Pose::IDENTITY,
                at(0.0, 0.0, 1e-15),
                Pose::from_rotation(DQuat::from_rotation_y(PI)),
            ] {
                let m = collide(a, &Pose::IDENTITY, b, &pose, 0.0).unwrap();
                assert!(m.normal.is_finite());
                for p in &m.points {
                    assert!(
                        p.local_a.is_finite() && p.local_b.is_finite() && p.separation.is_finite()
                    );
                }
                assert!(!m.is_empty(), "coincident shapes must touch");
            }
        }
    }
    // Exactly touching: separation 0, no NaN.
    let b = cuboid(0.5, 0.5, 0.5);
    let m = collide(&b, &Pose::IDENTITY, &b, &at(1.0, 0.0, 0.0), 0.0).unwrap();
    assert_eq!(m.points.len(), 4);
    for p in &m.points {
        assert_eq!(p.separation, 0.0);
    }
    let s = Shape::sphere(0.5).unwrap();
    let m = collide(&s, &Pose::IDENTITY, &s, &at(1.0, 0.0, 0.0), 0.0).unwrap();
    assert_eq!(m.points[0].separation, 0.0);
    let c = Shape::capsule(0.5, 0.5).unwrap();
    let m = collide(&c, &Pose::IDENTITY, &c, &Pose::IDENTITY, 0.0).unwrap();
    assert_close(m.points[0].separation, -1.0, 1e-12, "coincident capsules");
}

#[test]
fn bad_input_gives_typed_errors() {
    let s = Shape::sphere(1.0).unwrap();
    let nan = at(f64::NAN, 0.0, 0.0);
    assert_eq!(
        collide(&s, &nan, &s, &Pose::IDENTITY, 0.0),
        Err(ContactError::BadPose { which: "a" })
    );
    let skew = Pose::new(DVec3::ZERO, DQuat::from_xyzw(0.0, 0.0, 0.0, 2.0));
    assert_eq!(
        collide(&s, &Pose::IDENTITY, &s, &skew, 0.0),
        Err(ContactError::BadPose { which: "b" })
    );
    assert!(matches!(
        collide(&s, &Pose::IDENTITY, &s, &Pose::IDENTITY, -1.0),
        Err(ContactError::BadSpeculative(_))
    ));
    let field = Shape::heightfield(vec![0.0; 4], 2, 2, DVec3::ONE).unwrap();
    assert!(matches!(
        collide(&field, &Pose::IDENTITY, &field, &Pose::IDENTITY, 0.0),
        Err(ContactError::Unsupported { .. })
    ));
    let comp = Shape::compound(vec![(Pose::IDENTITY, s.clone())]).unwrap();
    assert_eq!(
        collide(&comp, &Pose::IDENTITY, &s, &Pose::IDENTITY, 0.0),
        Err(ContactError::Compound)
    );
}

#[test]
fn stress_random_pairs_never_panic_or_nan() {
    let mut rng = Rng(99);
    let cloud: Vec<DVec3> = (0..40).map(|_| rng.in_cube(1.0)).collect();
    let verts: Vec<DVec3> = (0..16)
        .map(|i| {
            DVec3::new(
                (i % 4) as f64 - 1.5,
                rng.range(-0.2, 0.2),
                (i / 4) as f64 - 1.5,
            )
        })
        .collect();
    let mut tris = Vec::new();
    for r in 0..3u32 {
        for c in 0..3u32 {
            let i = r * 4 + c;
            tris.push([i, i + 4, i + 1]);
            tris.push([i + 1, i + 4, i + 5]);
        }
    }
    let heights: Vec<f64> = (0..36).map(|_| rng.range(-0.3, 0.3)).collect();
    let all = [
        Shape::sphere(0.3).unwrap(),
        cuboid(0.5, 0.1, 0.3),
        Shape::capsule(0.6, 0.1).unwrap(),
        Shape::cylinder(0.2, 0.5).unwrap(),
        Shape::convex_hull(&cloud).unwrap(),
        Shape::trimesh(verts, tris).unwrap(),
        Shape::heightfield(heights, 6, 6, DVec3::new(3.0, 1.0, 3.0)).unwrap(),
    ];
    for scale in [1e-3, 1.0, 1e3] {
        for _ in 0..300 {
            let ia = (rng.next_u64() % all.len() as u64) as usize;
            let ib = (rng.next_u64() % all.len() as u64) as usize;
            let pa = Pose::new(rng.in_cube(scale), rng.rotation());
            let offset = match rng.next_u64() % 4 {
                0 => DVec3::ZERO,
                1 => rng.in_cube(1e-9),
                _ => rng.in_cube(1.2),
            };
            let pb = Pose::new(pa.translation + offset, rng.rotation());
            match collide(&all[ia], &pa, &all[ib], &pb, 0.1) {
                Ok(m) => {
                    assert!(m.points.len() <= 4);
                    assert!(m.normal.is_finite());
                    if !m.is_empty() {
                        assert_close(m.normal.length(), 1.0, 1e-9, "unit normal");
                    }
                    let tol = if ia == 3 || ib == 3 { 2e-3 } else { 1e-6 };
                    for p in &m.points {
                        assert!(p.local_a.is_finite() && p.local_b.is_finite());
                        assert!(p.separation.is_finite() && p.separation <= 0.1 + 1e-9);
                        let wa = pa.transform_point(p.local_a);
                        let wb = pb.transform_point(p.local_b);
                        assert_vec_close(
                            wa + m.normal * p.separation,
                            wb,
                            tol,
                            &format!("{ia}-{ib} gap along normal {pa:?} {pb:?} {m:?}"),
                        );
                    }
                }
                Err(e) => assert!(ia >= 5 && ib >= 5, "{ia}-{ib}: {e}"),
            }
        }
    }
}

#[test]
fn speculative_rounded_and_curved_pairs() {
    let ground = cuboid(2.0, 0.5, 2.0);
    let cap = Shape::capsule(0.75, 0.25).unwrap();
    let cyl = Shape::cylinder(0.5, 0.3).unwrap();
    let lying = |y: f64| Pose::new(DVec3::new(0.0, y, 0.0), DQuat::from_rotation_z(FRAC_PI_2));
    // Capsule 3 cm above the box: two speculative points at +0.03.
    let m = collide(&ground, &Pose::IDENTITY, &cap, &lying(0.78), 0.05).unwrap();
    assert_eq!(m.points.len(), 2, "{m:?}");
    for p in &m.points {
        assert_close(p.separation, 0.03, 1e-9, "capsule gap");
    }
    assert!(collide(&ground, &Pose::IDENTITY, &cap, &lying(0.78), 0.02)
        .unwrap()
        .is_empty());
    // Capsule above capsule, crossed: one point.
    let crossed = Pose::new(
        DVec3::new(0.54, 0.0, 0.0),
        DQuat::from_rotation_x(FRAC_PI_2),
    );
    let m = collide(&cap, &Pose::IDENTITY, &cap, &crossed, 0.05).unwrap();
    assert_eq!(m.points.len(), 1);
    assert_close(m.points[0].separation, 0.04, 1e-9, "capsule-capsule gap");
    // Cylinder standing 2 cm above the box.
    let m = collide(&ground, &Pose::IDENTITY, &cyl, &at(0.0, 1.02, 0.0), 0.05).unwrap();
    assert!(m.points.len() >= 3, "{m:?}");
    for p in &m.points {
        assert_close(p.separation, 0.02, 1e-6, "cylinder gap");
    }
    assert!(
        collide(&ground, &Pose::IDENTITY, &cyl, &at(0.0, 1.02, 0.0), 0.01)
            .unwrap()
            .is_empty()
    );
}
