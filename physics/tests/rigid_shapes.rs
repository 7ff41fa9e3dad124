//! Rigid shapes: poses, bounding boxes, convex hulls, mass properties and
//! support points, against closed forms and brute force.

use crate::common;

use common::Rng;
use std::f64::consts::PI;

use inertia_physics::glam::{DMat3, DQuat, DVec3};
use inertia_physics::rigid::aabb::Aabb;
use inertia_physics::rigid::mass::{parallel_axis, MassProperties};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::hull::ConvexHull;
use inertia_physics::rigid::shape::{Shape, ShapeError};

// ---------------------------------------------------------------- helpers

fn rel_err(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// Largest entry difference relative to the largest entry of `b`.
fn mat_rel_err(a: DMat3, b: DMat3) -> f64 {
    let scale = b
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()))
        .max(1e-300);
    let diff = (a - b)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    diff / scale
}

fn assert_mass_close(got: &MassProperties, want: &MassProperties, rel: f64, what: &str) {
    assert!(
        rel_err(got.mass, want.mass) <= rel,
        "{what}: mass {} vs {}",
        got.mass,
        want.mass
    );
    let len_scale = want.inertia.to_cols_array()[0].abs().max(1.0);
    let _ = len_scale;
    let com_err = (got.center_of_mass - want.center_of_mass).length();
    let size = (want.inertia.x_axis.x + want.inertia.y_axis.y + want.inertia.z_axis.z)
        .abs()
        .max(1e-300)
        / want.mass.max(1e-300);
    // com error relative to the body's radius of gyration (or to its
    // distance from the origin, whichever is larger).
    let com_scale = size.sqrt().max(want.center_of_mass.length());
    assert!(
        com_err <= rel * com_scale,
        "{what}: com {:?} vs {:?}",
        got.center_of_mass,
        want.center_of_mass
    );
    let e = mat_rel_err(got.inertia, want.inertia);
    assert!(
        e <= rel,
        "{what}: inertia rel err {e:e}\n got {:?}\nwant {:?}",
        got.inertia,
        want.inertia
    );
}

fn diag(x: f64, y: f64, z: f64) -> DMat3 {
    DMat3::from_diagonal(DVec3::new(x, y, z))
}

/// Mass properties of a solid of revolution about Y with radius profile
/// `radius(y)` on `[y0, y1]`, by composite Simpson over `n` slices: an
/// independent check of the closed forms.
fn revolution(
    density: f64,
    y0: f64,
    y1: f64,
    n: usize,
    radius: impl Fn(f64) -> f64,
) -> (f64, f64, f64) {
    let h = (y1 - y0) / n as f64;
    let (mut m, mut iy, mut ix) = (0.0, 0.0, 0.0);
    for k in 0..=n {
        let y = y0 + k as f64 * h;
        let w = if k == 0 || k == n {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let r = radius(y);
        let dm = density * PI * r * r; // per unit height
        m += w * dm;
        iy += w * 0.5 * dm * r * r;
        ix += w * (0.25 * dm * r * r + dm * y * y);
    }
    let s = h / 3.0;
    (m * s, ix * s, iy * s)
}

/// Checks everything a convex hull promises for the cloud it came from.
fn check_hull(hull: &ConvexHull, points: &[DVec3], what: &str) {
    let v = hull.vertices().len();
    let e = hull.edges().len();
    let f = hull.faces().len();
    assert_eq!(v as i64 - e as i64 + f as i64, 2, "{what}: Euler V-E+F");
    let scale = Aabb::from_points(points)
        .unwrap()
        .half_extents()
        .max_element()
        * 2.0;
    let magnitude = points
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    let tol = hull.tolerance();
    // Relative to the size, or to rounding of the coordinates far from the origin.
    assert!(
        tol > 0.0 && tol <= (2e-5 * scale).max(1e-12 * magnitude),
        "{what}: tolerance {tol}"
    );

    // Every hull vertex is an input point.
    for p in hull.vertices() {
        assert!(points.contains(p), "{what}: vertex {p} not an input point");
    }
    // Every directed edge once, its reverse once; the unique edges match.
    let mut directed = Vec::new();
    for face in hull.faces() {
        let n = face.vertices.len();
        assert!(n >= 3, "{what}: face with {n} vertices");
        assert!(
            (face.normal.length() - 1.0).abs() < 1e-12,
            "{what}: normal not unit"
        );
        for k in 0..n {
            directed.push((face.vertices[k], face.vertices[(k + 1) % n]));
        }
        // Planar, and no vertex above its own plane.
        for &i in &face.vertices {
            let d = face.distance(hull.vertices()[i as usize]);
            assert!(
                d <= 1e-12 * scale && d >= -2.0 * tol,
                "{what}: face not planar ({d:e})"
            );
        }
    }
    directed.sort_unstable();
    for w in directed.windows(2) {
        assert_ne!(w[0], w[1], "{what}: directed edge used twice");
    }
    for &(a, b) in &directed {
        assert!(
            directed.binary_search(&(b, a)).is_ok(),
            "{what}: open edge {a}-{b}"
        );
    }
    let mut unique: Vec<[u32; 2]> = directed
        .iter()
        .filter(|(a, b)| a < b)
        .map(|&(a, b)| [a, b])
        .collect();
    unique.sort_unstable();
    assert_eq!(unique, hull.edges(), "{what}: edges() disagrees with faces");
    // Convex and closed around the cloud: no point above any face.
    for face in hull.faces() {
        for p in points {
            let d = face.distance(*p);
            assert!(d <= tol, "{what}: point {p} above a face by {d:e}");
        }
    }
    // Outward: the centroid is below every face.
    let c = hull.vertices().iter().fold(DVec3::ZERO, |a, &v| a + v) / v as f64;
    for face in hull.faces() {
        assert!(face.distance(c) < 0.0, "{what}: face points inward");
    }
    // Support agrees with the point cloud's extreme in every direction.
    let mut rng = Rng(7);
    for _ in 0..200 {
        let d = rng.unit();
        let best = points
            .iter()
            .map(|p| p.dot(d))
            .fold(f64::NEG_INFINITY, f64::max);
        let s = hull.support(d);
        assert!(
            s.dot(d) >= best - tol,
            "{what}: support misses an extreme point"
        );
    }
    assert!(hull.volume() > 0.0, "{what}: volume");
}

/// A point on the faces of the cube [-1, 1]³, on a 1/3 grid if `grid`.
fn on_box_face(rng: &mut Rng, grid: bool) -> DVec3 {
    let mut p = rng.in_cube(1.0);
    if grid {
        p = (p * 3.0).round() / 3.0;
    }
    let axis = (rng.next_u64() % 3) as usize;
    p[axis] = if rng.f64() < 0.5 { -1.0 } else { 1.0 };
    p
}

fn box_corners(h: DVec3) -> Vec<DVec3> {
    let mut out = Vec::new();
    for i in 0..8 {
        out.push(DVec3::new(
            if i & 1 == 0 { -h.x } else { h.x },
            if i & 2 == 0 { -h.y } else { h.y },
            if i & 4 == 0 { -h.z } else { h.z },
        ));
    }
    out
}

/// Points on a unit sphere, evenly spread (Fibonacci lattice).
fn fibonacci_sphere(n: usize, r: f64) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let rho = (1.0 - y * y).sqrt();
            let t = golden * i as f64;
            DVec3::new(rho * t.cos(), y, rho * t.sin()) * r
        })
        .collect()
}

// ---------------------------------------------------------------- pose & aabb

#[test]
fn pose_composition_and_inverse() {
    let mut rng = Rng(1);
    for _ in 0..100 {
        let a = rng.pose();
        let b = rng.pose();
        let p = rng.in_cube(3.0);
        let ab = a.mul(&b);
        assert!((ab.transform_point(p) - a.transform_point(b.transform_point(p))).length() < 1e-12);
        assert!(
            (ab.transform_vector(p) - a.transform_vector(b.transform_vector(p))).length() < 1e-12
        );
        let back = a.inverse_transform_point(a.transform_point(p));
        assert!((back - p).length() < 1e-12);
        assert!((a.inverse().transform_point(a.transform_point(p)) - p).length() < 1e-12);
        let id = a.inverse().mul(&a);
        assert!(id.translation.length() < 1e-12);
        assert!(id.rotation.angle_between(DQuat::IDENTITY) < 1e-7);
        assert!(a.is_valid());
    }
    assert_eq!(Pose::IDENTITY.transform_point(DVec3::ONE), DVec3::ONE);
    assert_eq!(Pose::default(), Pose::IDENTITY);
    assert!(!Pose::new(DVec3::NAN, DQuat::IDENTITY).is_valid());
    assert!(!Pose::new(DVec3::ZERO, DQuat::from_xyzw(0.0, 0.0, 0.0, 2.0)).is_valid());
}

#[test]
fn aabb_operations() {
    let a = Aabb::new(DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0));
    let b = Aabb::new(DVec3::splat(0.5), DVec3::splat(4.0));
    let c = Aabb::new(DVec3::splat(5.0), DVec3::splat(6.0));
    assert_eq!(a.union(&b), Aabb::new(DVec3::ZERO, DVec3::splat(4.0)));
    assert!(a.intersects(&b) && b.intersects(&a));
    assert!(!a.intersects(&c));
    // Touching counts as intersecting.
    assert!(Aabb::new(DVec3::ONE, DVec3::splat(2.0))
        .intersects(&Aabb::new(DVec3::splat(2.0), DVec3::splat(3.0))));
    assert!(a.union(&b).contains(&a) && !a.contains(&b));
    assert!(a.contains(&a));
    assert!(a.contains_point(DVec3::new(1.0, 0.0, 3.0)) && !a.contains_point(DVec3::splat(-0.1)));
    assert_eq!(a.surface_area(), 2.0 * (2.0 + 6.0 + 3.0));
    assert_eq!(a.volume(), 6.0);
    assert_eq!(a.center(), DVec3::new(0.5, 1.0, 1.5));
    assert_eq!(a.half_extents(), DVec3::new(0.5, 1.0, 1.5));
    let e = a.expanded(0.25);
    assert_eq!(e.min, DVec3::splat(-0.25));
    assert_eq!(e.max, DVec3::new(1.25, 2.25, 3.25));
    assert_eq!(Aabb::from_points(&[]), None);
    assert_eq!(
        Aabb::from_points(&[DVec3::new(1.0, -1.0, 0.0), DVec3::new(-2.0, 3.0, 0.5)]),
        Some(Aabb::new(
            DVec3::new(-2.0, -1.0, 0.0),
            DVec3::new(1.0, 3.0, 0.5)
        ))
    );
    assert_eq!(
        Aabb::from_center_half_extents(DVec3::ONE, DVec3::splat(0.5)),
        Aabb::new(DVec3::splat(0.5), DVec3::splat(1.5))
    );
}

// ---------------------------------------------------------------- closed forms

#[test]
fn sphere_mass_properties() {
    let (r, rho) = (0.7, 1300.0);
    let s = Shape::sphere(r).unwrap();
    let mp = s.mass_properties(rho).unwrap();
    let m = rho * 4.0 / 3.0 * PI * r.powi(3);
    assert!(rel_err(mp.mass, m) < 1e-14);
    assert_eq!(mp.center_of_mass, DVec3::ZERO);
    let i = 2.0 / 5.0 * m * r * r;
    assert!(mat_rel_err(mp.inertia, diag(i, i, i)) < 1e-14);
    assert!(rel_err(s.volume().unwrap(), m / rho) < 1e-14);
    // Independent: slices of a solid of revolution.
    let (mn, ixn, iyn) = revolution(rho, -r, r, 2000, |y| (r * r - y * y).max(0.0).sqrt());
    assert!(rel_err(mp.mass, mn) < 1e-6 && rel_err(i, ixn) < 1e-6 && rel_err(i, iyn) < 1e-6);
}

#[test]
fn cuboid_mass_properties() {
    let h = DVec3::new(0.5, 1.0, 1.5);
    let rho = 700.0;
    let s = Shape::cuboid(h).unwrap();
    let mp = s.mass_properties(rho).unwrap();
    let (a, b, c) = (1.0, 2.0, 3.0);
    let m = rho * a * b * c;
    assert!(rel_err(mp.mass, m) < 1e-14);
    let want = diag(
        m / 12.0 * (b * b + c * c),
        m / 12.0 * (a * a + c * c),
        m / 12.0 * (a * a + b * b),
    );
    assert!(mat_rel_err(mp.inertia, want) < 1e-14);
    assert_eq!(s.volume(), Some(6.0));
}

#[test]
fn cylinder_mass_properties() {
    let (hh, r, rho) = (0.8, 0.3, 2700.0);
    let s = Shape::cylinder(hh, r).unwrap();
    let mp = s.mass_properties(rho).unwrap();
    let h = 2.0 * hh;
    let m = rho * PI * r * r * h;
    assert!(rel_err(mp.mass, m) < 1e-14);
    let radial = m / 12.0 * (3.0 * r * r + h * h);
    let axial = m * r * r / 2.0;
    assert!(mat_rel_err(mp.inertia, diag(radial, axial, radial)) < 1e-14);
    let (mn, ixn, iyn) = revolution(rho, -hh, hh, 2000, |_| r);
    assert!(rel_err(m, mn) < 1e-12 && rel_err(radial, ixn) < 1e-9 && rel_err(axial, iyn) < 1e-12);
}

#[test]
fn capsule_mass_properties() {
    let (hh, r, rho) = (0.6, 0.25, 950.0);
    let s = Shape::capsule(hh, r).unwrap();
    let mp = s.mass_properties(rho).unwrap();
    // Independent check: integrate slices of the capsule's profile.
    let profile = |y: f64| {
        let d = (y.abs() - hh).max(0.0);
        (r * r - d * d).max(0.0).sqrt()
    };
    let (mn, ixn, iyn) = revolution(rho, -hh - r, hh + r, 20000, profile);
    assert!(rel_err(mp.mass, mn) < 1e-6, "mass {} vs {}", mp.mass, mn);
    assert!(rel_err(mp.inertia.x_axis.x, ixn) < 1e-6);
    assert!(rel_err(mp.inertia.z_axis.z, ixn) < 1e-6);
    assert!(rel_err(mp.inertia.y_axis.y, iyn) < 1e-6);
    assert!(rel_err(s.volume().unwrap() * rho, mp.mass) < 1e-14);
    // Textbook form: cylinder plus two hemispheres offset by hh + 3r/8.
    let mc = rho * PI * r * r * 2.0 * hh;
    let ms = rho * 4.0 / 3.0 * PI * r.powi(3);
    let ix = mc * (r * r / 4.0 + (2.0 * hh).powi(2) / 12.0)
        + ms * (2.0 * r * r / 5.0 + hh * hh + 3.0 * hh * r / 4.0);
    let iy = mc * r * r / 2.0 + ms * 2.0 * r * r / 5.0;
    assert!(mat_rel_err(mp.inertia, diag(ix, iy, ix)) < 1e-14);
    // A very short capsule is nearly a ball.
    let tiny = Shape::capsule(1e-9, r)
        .unwrap()
        .mass_properties(rho)
        .unwrap();
    let ball = Shape::sphere(r).unwrap().mass_properties(rho).unwrap();
    assert_mass_close(&tiny, &ball, 1e-7, "short capsule");
}

// ---------------------------------------------------------------- hulls

#[test]
fn box_hull_is_exactly_the_box() {
    let mut rng = Rng(42);
    let h = DVec3::new(0.5, 1.25, 2.0);
    let mut pts = box_corners(h);
    for _ in 0..200 {
        // Interior points.
        pts.push(rng.in_cube(1.0) * h * 0.999);
    }
    for _ in 0..200 {
        // Points on the faces (one coordinate pinned to ±h).
        let mut p = rng.in_cube(1.0) * h;
        let axis = (rng.next_u64() % 3) as usize;
        p[axis] = if rng.f64() < 0.5 { -h[axis] } else { h[axis] };
        pts.push(p);
    }
    for _ in 0..60 {
        // Points on the edges (two coordinates pinned).
        let mut p = rng.in_cube(1.0) * h;
        let free = (rng.next_u64() % 3) as usize;
        for axis in 0..3 {
            if axis != free {
                p[axis] = if rng.f64() < 0.5 { -h[axis] } else { h[axis] };
            }
        }
        pts.push(p);
    }
    // Duplicated corners.
    pts.extend(box_corners(h));
    rng.shuffle(&mut pts);

    let hull = ConvexHull::from_points(&pts).unwrap();
    check_hull(&hull, &pts, "box with face points");
    assert_eq!(hull.vertices().len(), 8);
    assert_eq!(hull.edges().len(), 12);
    assert_eq!(hull.faces().len(), 6);
    for face in hull.faces() {
        assert_eq!(face.vertices.len(), 4, "box faces are quads");
        // Normals are the axes.
        assert!(face.normal.abs().max_element() > 1.0 - 1e-15);
    }
    let shape = Shape::ConvexHull(hull.into());
    let got = shape.mass_properties(500.0).unwrap();
    let want = Shape::cuboid(h).unwrap().mass_properties(500.0).unwrap();
    assert_mass_close(&got, &want, 1e-9, "box hull");
    assert!(got.center_of_mass.length() < 1e-12);
    assert_eq!(shape.local_aabb(), Aabb::new(-h, h));

    // The same box moved and turned: the transformed mass properties.
    for seed in 0..10 {
        let mut rng = Rng(100 + seed);
        let pose = rng.pose();
        let moved: Vec<DVec3> = pts.iter().map(|&p| pose.transform_point(p)).collect();
        let hull = ConvexHull::from_points(&moved).unwrap();
        check_hull(&hull, &moved, "moved box");
        assert_eq!(
            (
                hull.vertices().len(),
                hull.edges().len(),
                hull.faces().len()
            ),
            (8, 12, 6)
        );
        let got = Shape::ConvexHull(hull.into())
            .mass_properties(500.0)
            .unwrap();
        assert_mass_close(&got, &want.transformed(&pose), 1e-9, "moved box hull");
    }
}

#[test]
fn lattice_and_far_away_boxes_merge_to_six_faces() {
    // A 6×6×6 lattice: most points are coplanar or collinear with others.
    let mut pts = Vec::new();
    for i in 0..6 {
        for j in 0..6 {
            for k in 0..6 {
                pts.push(DVec3::new(i as f64, j as f64, k as f64) * 0.2);
            }
        }
    }
    let hull = ConvexHull::from_points(&pts).unwrap();
    check_hull(&hull, &pts, "lattice");
    assert_eq!(
        (
            hull.vertices().len(),
            hull.edges().len(),
            hull.faces().len()
        ),
        (8, 12, 6)
    );
    assert!(rel_err(hull.volume(), 1.0) < 1e-12);

    // A unit box a million metres from the origin.
    let offset = DVec3::new(1e6, -2e6, 3e6);
    let far: Vec<DVec3> = pts.iter().map(|&p| p + offset).collect();
    let hull = ConvexHull::from_points(&far).unwrap();
    check_hull(&hull, &far, "far lattice");
    assert_eq!(
        (
            hull.vertices().len(),
            hull.edges().len(),
            hull.faces().len()
        ),
        (8, 12, 6)
    );
    let mp = Shape::ConvexHull(hull.into()).mass_properties(1.0).unwrap();
    assert!(rel_err(mp.mass, 1.0) < 1e-9, "far box volume {}", mp.mass);
    assert!((mp.center_of_mass - (offset + DVec3::splat(0.5))).length() < 1e-9);
    assert!(mat_rel_err(mp.inertia, diag(1.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0)) < 1e-6);

    // Tiny and huge scales behave the same.
    for s in [1e-6, 1e6] {
        let scaled: Vec<DVec3> = pts.iter().map(|&p| p * s).collect();
        let hull = ConvexHull::from_points(&scaled).unwrap();
        check_hull(&hull, &scaled, "scaled lattice");
        assert_eq!(hull.faces().len(), 6);
    }
}

#[test]
fn prism_and_pyramid_faces() {
    // A hexagonal prism: 2 hexagons + 6 quads, with points on every face.
    let mut pts = Vec::new();
    for k in 0..6 {
        let a = k as f64 * PI / 3.0;
        for y in [-1.0, 1.0] {
            pts.push(DVec3::new(a.cos(), y, a.sin()));
        }
        pts.push(DVec3::new(a.cos(), 0.3, a.sin())); // on a vertical edge
    }
    pts.push(DVec3::new(0.0, 1.0, 0.0)); // on the top hexagon
    pts.push(DVec3::new(0.1, -1.0, 0.2)); // on the bottom hexagon
    let hull = ConvexHull::from_points(&pts).unwrap();
    check_hull(&hull, &pts, "hex prism");
    assert_eq!((hull.vertices().len(), hull.faces().len()), (12, 8));
    let mut sizes: Vec<usize> = hull.faces().iter().map(|f| f.vertices.len()).collect();
    sizes.sort_unstable();
    assert_eq!(sizes, vec![4, 4, 4, 4, 4, 4, 6, 6]);
    let want = 3.0 * 3f64.sqrt() / 2.0 * 2.0; // hexagon area × height
    assert!(rel_err(hull.volume(), want) < 1e-12);

    // A square pyramid: 1 quad + 4 triangles.
    let pts = vec![
        DVec3::new(-1.0, 0.0, -1.0),
        DVec3::new(1.0, 0.0, -1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(-1.0, 0.0, 1.0),
        DVec3::new(0.0, 1.5, 0.0),
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(0.0, 0.5, 0.0),
    ];
    let hull = ConvexHull::from_points(&pts).unwrap();
    check_hull(&hull, &pts, "pyramid");
    assert_eq!(
        (
            hull.vertices().len(),
            hull.edges().len(),
            hull.faces().len()
        ),
        (5, 8, 5)
    );
    assert!(rel_err(hull.volume(), 4.0 * 1.5 / 3.0) < 1e-12);
}

#[test]
fn tetrahedron_hull_matches_formula() {
    // Right-corner tetrahedron with legs a, b, c: V = abc/6, centroid at
    // (a, b, c)/4; about the centroid I_xx = 3m/80 (b² + c²) and the
    // product terms I_xy = +m ab/80 (tensor entry −∫xy dm + m x̄ ȳ).
    let (a, b, c, rho) = (1.0, 2.0, 3.0, 1200.0);
    let pts = [
        DVec3::ZERO,
        DVec3::new(a, 0.0, 0.0),
        DVec3::new(0.0, b, 0.0),
        DVec3::new(0.0, 0.0, c),
    ];
    let hull = ConvexHull::from_points(&pts).unwrap();
    check_hull(&hull, &pts, "tetrahedron");
    assert_eq!(
        (
            hull.vertices().len(),
            hull.edges().len(),
            hull.faces().len()
        ),
        (4, 6, 4)
    );
    let m = rho * a * b * c / 6.0;
    let want = MassProperties::new(
        m,
        DVec3::new(a, b, c) / 4.0,
        DMat3::from_cols(
            DVec3::new(
                3.0 * m / 80.0 * (b * b + c * c),
                m * a * b / 80.0,
                m * a * c / 80.0,
            ),
            DVec3::new(
                m * a * b / 80.0,
                3.0 * m / 80.0 * (a * a + c * c),
                m * b * c / 80.0,
            ),
            DVec3::new(
                m * a * c / 80.0,
                m * b * c / 80.0,
                3.0 * m / 80.0 * (a * a + b * b),
            ),
        ),
    );
    let shape = Shape::ConvexHull(hull.into());
    let got = shape.mass_properties(rho).unwrap();
    assert_mass_close(&got, &want, 1e-13, "tetrahedron");
    // Same tetrahedron placed anywhere.
    let mut rng = Rng(3);
    for _ in 0..10 {
        let pose = rng.pose();
        let moved: Vec<DVec3> = pts.iter().map(|&p| pose.transform_point(p)).collect();
        let got = Shape::convex_hull(&moved)
            .unwrap()
            .mass_properties(rho)
            .unwrap();
        assert_mass_close(&got, &want.transformed(&pose), 1e-11, "moved tetrahedron");
    }
}

#[test]
fn sphere_hull_converges_to_sphere() {
    let r = 1.0;
    let ball = Shape::sphere(r).unwrap().mass_properties(1.0).unwrap();
    let mut last = f64::INFINITY;
    for n in [50usize, 200, 1000, 5000] {
        let pts = fibonacci_sphere(n, r);
        let hull = ConvexHull::from_points(&pts).unwrap();
        check_hull(&hull, &pts, "sphere points");
        assert_eq!(
            hull.vertices().len(),
            n,
            "every point on a sphere is a vertex"
        );
        let mp = Shape::ConvexHull(hull.into()).mass_properties(1.0).unwrap();
        let vol_err = rel_err(mp.mass, ball.mass);
        let inertia_err = mat_rel_err(mp.inertia, ball.inertia);
        println!(
            "sphere hull n={n:5}: volume rel err {vol_err:.3e}, inertia rel err {inertia_err:.3e}, |com| {:.1e}",
            mp.center_of_mass.length()
        );
        assert!(mp.mass < ball.mass, "an inscribed hull is smaller");
        // Error shrinks like 1/n (area per facet).
        assert!(vol_err < 8.0 / n as f64, "n={n}: {vol_err}");
        assert!(inertia_err < 12.0 / n as f64, "n={n}: {inertia_err}");
        assert!(vol_err < last);
        last = vol_err;
    }
}

#[test]
fn random_hulls_are_valid_and_deterministic() {
    for seed in 0..300u64 {
        let mut rng = Rng(seed);
        let n = 4 + (seed as usize % 60);
        let turn = rng.rotation();
        let pts: Vec<DVec3> = match seed % 6 {
            0 => (0..n).map(|_| rng.in_cube(1.0)).collect(),
            1 => (0..n).map(|_| rng.unit() * 2.0).collect(),
            // Flattened clouds: thin in one axis.
            2 => (0..n)
                .map(|_| rng.in_cube(1.0) * DVec3::new(1.0, 0.05, 1.0))
                .collect(),
            // Rounded to a coarse grid: many duplicates and coplanar sets.
            3 => (0..n).map(|_| (rng.in_cube(1.0) * 3.0).round()).collect(),
            // A turned box's faces on a grid, rounded to f32 (asset data).
            4 => (0..n)
                .map(|_| {
                    let q = turn * on_box_face(&mut rng, true);
                    DVec3::new(q.x as f32 as f64, q.y as f32 as f64, q.z as f32 as f64)
                })
                .collect(),
            // The same with noise right at the coplanarity tolerance.
            _ => (0..n)
                .map(|_| turn * on_box_face(&mut rng, true) + rng.in_cube(2e-6))
                .collect(),
        };
        let hull = match ConvexHull::from_points(&pts) {
            Ok(h) => h,
            // Grid clouds can be flat by chance; that must be the reason.
            Err(e) => {
                assert!(
                    matches!(
                        e,
                        ShapeError::CoplanarPoints
                            | ShapeError::CollinearPoints
                            | ShapeError::CoincidentPoints
                    ),
                    "seed {seed}: {e}"
                );
                continue;
            }
        };
        check_hull(&hull, &pts, &format!("random seed {seed}"));
        assert_eq!(
            ConvexHull::from_points(&pts).unwrap(),
            hull,
            "deterministic"
        );
        // Shuffled input gives the same vertex set and volume (noisy sets:
        // the same volume to the tolerance, since which near-coplanar
        // triangles merge depends on the order).
        let mut shuffled = pts.clone();
        rng.shuffle(&mut shuffled);
        let again = ConvexHull::from_points(&shuffled).unwrap();
        check_hull(&again, &shuffled, &format!("shuffled seed {seed}"));
        // (The hull's surface is at most its bounding box's.)
        let area = Aabb::from_points(&pts).unwrap().surface_area();
        let dv = (again.volume() - hull.volume()).abs();
        assert!(
            dv <= area * hull.tolerance(),
            "seed {seed}: volume moved {dv:e}"
        );
        if seed % 6 >= 4 {
            continue;
        }
        // (+ 0.0 folds −0.0 into 0.0: the grid clouds hold both.)
        let key = |v: &DVec3| v.to_array().map(|c| (c + 0.0).to_bits());
        let mut a: Vec<[u64; 3]> = hull.vertices().iter().map(key).collect();
        let mut b: Vec<[u64; 3]> = again.vertices().iter().map(key).collect();
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b, "seed {seed}: same vertices whatever the order");
    }
}

#[test]
fn noisy_boxes_stay_boxes() {
    // Box corners plus face points that are coplanar only to rounding,
    // f32 precision or noise up to and past the tolerance (2e-6 m here):
    // the hull stays valid, its volume is the box's, and within the
    // tolerance its faces are the box's six quads.
    for (noise, f32_round) in [(0.0, true), (1e-12, false), (1e-6, false), (1e-5, false)] {
        for seed in 0..20 {
            let mut rng = Rng(7000 + seed);
            let turn = rng.rotation();
            let mut pts: Vec<DVec3> = box_corners(DVec3::ONE)
                .into_iter()
                .map(|c| turn * c)
                .collect();
            for _ in 0..150 {
                pts.push(turn * on_box_face(&mut rng, seed % 2 == 0) + rng.in_cube(noise));
            }
            if f32_round {
                for p in &mut pts {
                    *p = DVec3::new(p.x as f32 as f64, p.y as f32 as f64, p.z as f32 as f64);
                }
            }
            let what = format!("noisy box {noise:e} seed {seed}");
            let hull = ConvexHull::from_points(&pts).unwrap();
            check_hull(&hull, &pts, &what);
            // Faces move by the noise (outward at most √3 of it) and by the
            // merge (at most the tolerance); 24 m² of surface.
            let rounding = if f32_round { 2e-7 } else { 0.0 };
            let slack = 24.0 * (3f64.sqrt() * noise + rounding + hull.tolerance());
            assert!(
                (hull.volume() - 8.0).abs() <= slack,
                "{what}: volume {}",
                hull.volume()
            );
            if noise <= 1e-6 {
                // Coplanar to within the tolerance: exactly six quads.
                assert_eq!(hull.faces().len(), 6, "{what}");
                assert_eq!(hull.vertices().len(), 8, "{what}");
                for face in hull.faces() {
                    assert_eq!(face.vertices.len(), 4, "{what}");
                }
            }
            // Noise well above the tolerance is real (if tiny) geometry:
            // its facets stay, and the hull is still valid (checked above).
        }
    }
}

#[test]
fn thirty_two_vertex_hulls() {
    // The bench's mixed pile uses 32-vertex hulls.
    for seed in 0..50 {
        let mut rng = Rng(1000 + seed);
        let pts: Vec<DVec3> = (0..32)
            .map(|_| rng.unit() * DVec3::new(0.5, 0.3, 0.4))
            .collect();
        let hull = ConvexHull::from_points(&pts).unwrap();
        check_hull(&hull, &pts, "32-vertex");
        assert_eq!(hull.vertices().len(), 32);
        assert_eq!(hull.faces().len(), 60, "simplicial: F = 2V - 4");
        assert_eq!(hull.edges().len(), 90);
    }
}

// ---------------------------------------------------------------- compound & algebra

#[test]
fn compound_of_two_boxes_is_the_box_they_make() {
    let half = Shape::cuboid(DVec3::new(0.5, 0.5, 0.75)).unwrap();
    let whole = Shape::cuboid(DVec3::new(1.0, 0.5, 0.75)).unwrap();
    let compound = Shape::compound(vec![
        (
            Pose::from_translation(DVec3::new(-0.5, 0.0, 0.0)),
            half.clone(),
        ),
        (
            // Turned half a turn about X: still the same box.
            Pose::new(DVec3::new(0.5, 0.0, 0.0), DQuat::from_rotation_x(PI)),
            half,
        ),
    ])
    .unwrap();
    let got = compound.mass_properties(300.0).unwrap();
    let want = whole.mass_properties(300.0).unwrap();
    assert_mass_close(&got, &want, 1e-14, "two boxes");
    assert!(got.center_of_mass.length() < 1e-15);
    assert_eq!(compound.volume(), whole.volume());
    let a = compound.local_aabb();
    assert!((a.min - whole.local_aabb().min).length() < 1e-15);
    assert!((a.max - whole.local_aabb().max).length() < 1e-15);
    // Moved as a whole: the compound of moved parts.
    let mut rng = Rng(9);
    let pose = rng.pose();
    let nested = Shape::compound(vec![(pose, compound)]).unwrap();
    assert_mass_close(
        &nested.mass_properties(300.0).unwrap(),
        &want.transformed(&pose),
        1e-13,
        "nested",
    );
}

#[test]
fn transformed_combine_and_parallel_axis_agree() {
    let mut rng = Rng(11);
    // Eight sub-boxes of a 2×2×2 box, each placed by a pose, combine into
    // the big box; the whole thing rotated equals the big box rotated.
    let small = Shape::cuboid(DVec3::new(0.25, 0.5, 0.75)).unwrap();
    let small_mp = small.mass_properties(2.0).unwrap();
    let big = Shape::cuboid(DVec3::new(0.5, 1.0, 1.5))
        .unwrap()
        .mass_properties(2.0)
        .unwrap();
    let outer = rng.pose();
    let parts: Vec<MassProperties> = box_corners(DVec3::new(0.25, 0.5, 0.75))
        .into_iter()
        .map(|c| small_mp.transformed(&outer.mul(&Pose::from_translation(c))))
        .collect();
    let combined = MassProperties::combine(&parts);
    assert_mass_close(&combined, &big.transformed(&outer), 1e-13, "eight boxes");

    // Parallel axis by hand against combine of a single displaced part.
    let d = DVec3::new(0.3, -1.2, 2.0);
    let moved = small_mp.transformed(&Pose::from_translation(d));
    let about_origin = parallel_axis(moved.inertia, moved.mass, moved.center_of_mass);
    let m = small_mp.mass;
    let expect = small_mp.inertia
        + (DMat3::from_diagonal(DVec3::splat(d.length_squared()))
            - DMat3::from_cols(d * d.x, d * d.y, d * d.z))
            * m;
    assert!(mat_rel_err(about_origin, expect) < 1e-14);
    // A part and its mirror image about the origin combine to a centred body
    // whose inertia is the parallel-axis sum.
    let mirror = small_mp.transformed(&Pose::from_translation(-d));
    let both = MassProperties::combine(&[moved, mirror]);
    assert!(both.center_of_mass.length() < 1e-15);
    assert!(mat_rel_err(both.inertia, expect * 2.0) < 1e-14);
    // A hull's inertia, moved by parallel axis to the origin, matches a
    // direct integration about the origin (hull of the displaced points).
    let tet = [DVec3::ZERO, DVec3::X, DVec3::Y * 2.0, DVec3::Z * 0.5];
    let mp = Shape::convex_hull(&tet)
        .unwrap()
        .mass_properties(1.0)
        .unwrap();
    let i_origin = parallel_axis(mp.inertia, mp.mass, mp.center_of_mass);
    // ∫(y²+z²) over the corner tetrahedron = V (b² + c²)/10.
    let v = 1.0 * 2.0 * 0.5 / 6.0;
    assert!(rel_err(i_origin.x_axis.x, v * (4.0 + 0.25) / 10.0) < 1e-13);
    assert!(rel_err(i_origin.y_axis.x, -v * 2.0 / 20.0) < 1e-13);
    // Combining nothing is no mass.
    assert_eq!(MassProperties::combine(&[]).mass, 0.0);
}

fn check_principal(mp: &MassProperties, want_moments: [f64; 3], what: &str) {
    let (moments, rot) = mp.principal_axes();
    let mut want = want_moments;
    want.sort_by(f64::total_cmp);
    let scale = want[2].abs();
    for k in 0..3 {
        assert!(
            (moments[k] - want[k]).abs() <= 1e-12 * scale,
            "{what}: moments {moments} vs {want:?}"
        );
    }
    assert!(
        moments.x <= moments.y && moments.y <= moments.z,
        "{what}: ascending"
    );
    let r = DMat3::from_quat(rot);
    assert!(
        (r.determinant() - 1.0).abs() < 1e-12,
        "{what}: proper rotation"
    );
    let rebuilt = r * DMat3::from_diagonal(moments) * r.transpose();
    let e = mat_rel_err(rebuilt, mp.inertia);
    assert!(e < 1e-12, "{what}: R diag Rᵀ off by {e:e}");
}

#[test]
fn principal_axes_recover_moments() {
    let mut rng = Rng(21);
    let shapes: Vec<(Shape, &str)> = vec![
        (Shape::cuboid(DVec3::new(0.3, 0.7, 1.1)).unwrap(), "box"),
        (
            Shape::cuboid(DVec3::splat(0.4)).unwrap(),
            "cube (triple moment)",
        ),
        (
            Shape::cylinder(0.9, 0.2).unwrap(),
            "cylinder (double moment)",
        ),
        (Shape::capsule(0.5, 0.3).unwrap(), "capsule (double moment)"),
        (Shape::sphere(1.5).unwrap(), "sphere (triple moment)"),
        (
            Shape::cuboid(DVec3::new(0.5, 0.5, 1.0)).unwrap(),
            "square box (double moment)",
        ),
    ];
    for (shape, what) in &shapes {
        let mp = shape.mass_properties(800.0).unwrap();
        let d = [
            mp.inertia.x_axis.x,
            mp.inertia.y_axis.y,
            mp.inertia.z_axis.z,
        ];
        check_principal(&mp, d, what);
        for _ in 0..50 {
            let pose = rng.pose();
            check_principal(&mp.transformed(&pose), d, what);
        }
    }
    // Off-diagonal tensors from hulls: rebuild must still hold, and the
    // moments must be the eigenvalues (trace and determinant preserved).
    for seed in 0..50 {
        let mut rng = Rng(500 + seed);
        let pts: Vec<DVec3> = (0..20)
            .map(|_| rng.in_cube(1.0) * DVec3::new(1.0, 0.3, 0.6))
            .collect();
        let mp = Shape::convex_hull(&pts)
            .unwrap()
            .mass_properties(1.0)
            .unwrap();
        let (moments, rot) = mp.principal_axes();
        let r = DMat3::from_quat(rot);
        let e = mat_rel_err(
            r * DMat3::from_diagonal(moments) * r.transpose(),
            mp.inertia,
        );
        assert!(e < 1e-12, "hull {seed}: {e:e}");
        let trace = mp.inertia.x_axis.x + mp.inertia.y_axis.y + mp.inertia.z_axis.z;
        assert!(rel_err(moments.x + moments.y + moments.z, trace) < 1e-13);
        assert!(rel_err(moments.x * moments.y * moments.z, mp.inertia.determinant()) < 1e-10);
    }
    // Degenerate tensors do not panic.
    let _ = MassProperties::ZERO.principal_axes();
    let _ = MassProperties::new(1.0, DVec3::ZERO, DMat3::from_cols_array(&[f64::NAN; 9]))
        .principal_axes();
}

// ---------------------------------------------------------------- aabb & support

fn convex_shapes() -> Vec<(Shape, &'static str)> {
    let mut rng = Rng(77);
    let cloud: Vec<DVec3> = (0..32)
        .map(|_| rng.unit() * DVec3::new(0.6, 0.3, 0.4))
        .collect();
    vec![
        (Shape::sphere(0.4).unwrap(), "sphere"),
        (Shape::cuboid(DVec3::new(0.2, 0.5, 0.9)).unwrap(), "cuboid"),
        (Shape::capsule(0.7, 0.25).unwrap(), "capsule"),
        (Shape::cylinder(0.6, 0.35).unwrap(), "cylinder"),
        (Shape::convex_hull(&cloud).unwrap(), "hull"),
    ]
}

#[test]
fn aabbs_are_tight_and_contain_support_points() {
    let mut rng = Rng(31);
    for (shape, what) in convex_shapes() {
        for _ in 0..100 {
            let pose = rng.pose();
            let aabb = shape.aabb(&pose);
            let world_support = |d: DVec3| {
                pose.transform_point(shape.support(pose.inverse_transform_vector(d)).unwrap())
            };
            let eps = 1e-12 * (1.0 + pose.translation.length());
            let grown = aabb.expanded(eps);
            for _ in 0..100 {
                let d = rng.unit();
                assert!(
                    grown.contains_point(world_support(d)),
                    "{what}: support outside aabb"
                );
            }
            // Tight: the support along each axis touches the box.
            for axis in 0..3 {
                let mut d = DVec3::ZERO;
                d[axis] = 1.0;
                assert!(
                    (world_support(d)[axis] - aabb.max[axis]).abs() <= eps,
                    "{what}: max not tight"
                );
                assert!(
                    (world_support(-d)[axis] - aabb.min[axis]).abs() <= eps,
                    "{what}: min not tight"
                );
            }
        }
    }
}

#[test]
fn mesh_heightfield_and_compound_aabbs() {
    let mut rng = Rng(41);
    let verts: Vec<DVec3> = (0..30).map(|_| rng.in_cube(2.0)).collect();
    let tris: Vec<[u32; 3]> = (0..28).map(|i| [i, i + 1, i + 2]).collect();
    let mesh = Shape::trimesh(verts.clone(), tris).unwrap();
    let heights: Vec<f64> = (0..4 * 5).map(|i| (i as f64 * 0.7).sin()).collect();
    let field = Shape::heightfield(heights.clone(), 4, 5, DVec3::new(10.0, 2.0, 6.0)).unwrap();
    let Shape::HeightField(hf) = &field else {
        unreachable!()
    };
    let grid: Vec<DVec3> = (0..4)
        .flat_map(|r| (0..5).map(move |c| (r, c)))
        .map(|(r, c)| hf.vertex(r, c).unwrap())
        .collect();
    assert_eq!(hf.vertex(0, 0), Some(DVec3::new(-5.0, 0.0, -3.0)));
    assert_eq!(hf.vertex(3, 4).unwrap().x, 5.0);
    assert_eq!(hf.vertex(3, 4).unwrap().z, 3.0);
    assert_eq!(hf.vertex(4, 0), None);
    for _ in 0..50 {
        let pose = rng.pose();
        let a = mesh.aabb(&pose);
        let moved: Vec<DVec3> = verts.iter().map(|&v| pose.transform_point(v)).collect();
        assert_eq!(
            a,
            Aabb::from_points(&moved).unwrap(),
            "mesh aabb is the vertices' box"
        );
        let a = field.aabb(&pose).expanded(1e-9);
        for &v in &grid {
            assert!(
                a.contains_point(pose.transform_point(v)),
                "heightfield aabb holds its samples"
            );
        }
    }
    // Unrotated heightfield: exact.
    let pose = Pose::from_translation(DVec3::new(1.0, 2.0, 3.0));
    let moved: Vec<DVec3> = grid.iter().map(|&v| pose.transform_point(v)).collect();
    let exact = Aabb::from_points(&moved).unwrap();
    let got = field.aabb(&pose);
    assert!((got.min - exact.min).length() < 1e-12 && (got.max - exact.max).length() < 1e-12);

    // Compound: the union of its parts' boxes.
    let parts: Vec<(Pose, Shape)> = convex_shapes()
        .into_iter()
        .map(|(s, _)| (rng.pose(), s))
        .collect();
    let compound = Shape::compound(parts.clone()).unwrap();
    for _ in 0..20 {
        let pose = rng.pose();
        let want = parts
            .iter()
            .map(|(p, s)| s.aabb(&pose.mul(p)))
            .reduce(|a, b| a.union(&b))
            .unwrap();
        let got = compound.aabb(&pose);
        assert!((got.min - want.min).length() < 1e-12 && (got.max - want.max).length() < 1e-12);
    }
    assert_eq!(compound.support(DVec3::X), None);
    assert_eq!(mesh.support(DVec3::X), None);
    assert_eq!(field.support(DVec3::X), None);
    assert!(!compound.is_convex() && !mesh.is_convex() && !field.is_convex());
    assert_eq!(mesh.volume(), None);
    assert_eq!(field.volume(), None);
}

#[test]
fn support_points_lie_on_the_surface_and_are_extreme() {
    let mut rng = Rng(51);
    for (shape, what) in convex_shapes() {
        // Dense samples of the shape (its supports in many directions) give
        // the extreme value along d; the support must reach it.
        let samples: Vec<DVec3> = (0..4000)
            .map(|_| shape.support(rng.unit()).unwrap())
            .collect();
        for _ in 0..300 {
            let d = rng.unit() * rng.range(0.1, 10.0);
            let s = shape.support(d).unwrap();
            let best = samples
                .iter()
                .map(|p| p.dot(d))
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(
                s.dot(d) >= best - 1e-12 * d.length(),
                "{what}: support not extreme"
            );
            // On the surface.
            let on_surface = match &shape {
                Shape::Sphere { radius } => (s.length() - radius).abs() < 1e-12,
                Shape::Cuboid { half_extents } => {
                    ((s.abs() / *half_extents).max_element() - 1.0).abs() < 1e-12
                        && (s.abs() - *half_extents).max_element() <= 1e-15
                }
                Shape::Capsule {
                    half_height,
                    radius,
                } => {
                    let y = s.y.clamp(-half_height, *half_height);
                    ((s - DVec3::new(0.0, y, 0.0)).length() - radius).abs() < 1e-12
                }
                Shape::Cylinder {
                    half_height,
                    radius,
                } => {
                    let radial = DVec3::new(s.x, 0.0, s.z).length();
                    (s.y.abs() - half_height).abs() < 1e-12 && radial <= radius + 1e-12
                }
                Shape::ConvexHull(h) => h.vertices().contains(&s),
                _ => unreachable!(),
            };
            assert!(on_surface, "{what}: support {s} not on the surface");
        }
        // Zero direction: still a finite point of the shape, no panic.
        assert!(shape.support(DVec3::ZERO).unwrap().is_finite());
    }
}

// ---------------------------------------------------------------- bad input

#[test]
fn bad_inputs_give_typed_errors() {
    use ShapeError::*;
    let nan = f64::NAN;
    let inf = f64::INFINITY;
    for r in [0.0, -1.0] {
        assert!(matches!(Shape::sphere(r), Err(NotPositive { .. })));
        assert!(matches!(Shape::capsule(r, 1.0), Err(NotPositive { .. })));
        assert!(matches!(Shape::capsule(1.0, r), Err(NotPositive { .. })));
        assert!(matches!(Shape::cylinder(r, 1.0), Err(NotPositive { .. })));
        assert!(matches!(Shape::cylinder(1.0, r), Err(NotPositive { .. })));
        assert!(matches!(
            Shape::cuboid(DVec3::new(1.0, r, 1.0)),
            Err(NotPositive { .. })
        ));
    }
    for r in [nan, inf, -inf] {
        assert!(matches!(Shape::sphere(r), Err(NonFinite { .. })));
        assert!(matches!(Shape::capsule(r, 1.0), Err(NonFinite { .. })));
        assert!(matches!(Shape::cylinder(1.0, r), Err(NonFinite { .. })));
        assert!(matches!(
            Shape::cuboid(DVec3::new(1.0, 1.0, r)),
            Err(NonFinite { .. })
        ));
    }
    // Density.
    let ball = Shape::sphere(1.0).unwrap();
    assert!(matches!(
        ball.mass_properties(0.0),
        Err(NotPositive {
            what: "density",
            ..
        })
    ));
    assert!(matches!(
        ball.mass_properties(-5.0),
        Err(NotPositive { .. })
    ));
    assert!(matches!(ball.mass_properties(nan), Err(NonFinite { .. })));

    // Hulls.
    let tet = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    for n in 0..4 {
        assert_eq!(
            ConvexHull::from_points(&tet[..n]),
            Err(TooFewPoints {
                what: "convex hull points",
                got: n,
                need: 4
            })
        );
    }
    assert!(matches!(
        ConvexHull::from_points(&[DVec3::ONE; 10]),
        Err(CoincidentPoints)
    ));
    let line: Vec<DVec3> = (0..10)
        .map(|i| DVec3::new(1.0, 2.0, 3.0) * i as f64)
        .collect();
    assert_eq!(ConvexHull::from_points(&line), Err(CollinearPoints));
    let mut rng = Rng(61);
    let plane: Vec<DVec3> = (0..50)
        .map(|_| {
            let p = rng.in_cube(1.0);
            DVec3::new(p.x, 0.5 * p.x - 0.25 * p.z, p.z)
        })
        .collect();
    assert_eq!(ConvexHull::from_points(&plane), Err(CoplanarPoints));
    // Nearly coplanar (1e-12 of the size) is coplanar too.
    let mut flat = plane.clone();
    flat.push(DVec3::new(0.0, 1e-12, 0.0));
    assert_eq!(ConvexHull::from_points(&flat), Err(CoplanarPoints));
    for bad in [nan, inf] {
        let mut pts = tet.to_vec();
        pts.push(DVec3::new(0.2, bad, 0.1));
        assert!(matches!(
            ConvexHull::from_points(&pts),
            Err(NonFinite { .. })
        ));
    }
    assert!(matches!(
        ConvexHull::from_points(&[
            DVec3::ZERO,
            DVec3::X * 1e308,
            DVec3::X * -1e308,
            DVec3::Y,
            DVec3::Z
        ]),
        Err(NonFinite { .. })
    ));
    assert!(matches!(Shape::convex_hull(&line), Err(CollinearPoints)));

    // Triangle meshes.
    let v = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    assert!(matches!(
        Shape::trimesh(v[..2].to_vec(), vec![[0, 1, 0]]),
        Err(TooFewPoints { .. })
    ));
    assert_eq!(
        Shape::trimesh(v.clone(), vec![]),
        Err(Empty("triangle mesh triangles"))
    );
    assert_eq!(
        Shape::trimesh(v.clone(), vec![[0, 1, 2], [1, 2, 4]]),
        Err(IndexOutOfRange {
            triangle: 1,
            index: 4,
            vertex_count: 4
        })
    );
    assert_eq!(
        Shape::trimesh(v.clone(), vec![[0, 1, 1]]),
        Err(DegenerateTriangle { triangle: 0 })
    );
    let collinear = vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
    assert_eq!(
        Shape::trimesh(collinear, vec![[0, 1, 2]]),
        Err(DegenerateTriangle { triangle: 0 })
    );
    let mut nan_v = v.clone();
    nan_v[3] = DVec3::new(nan, 0.0, 0.0);
    assert!(matches!(
        Shape::trimesh(nan_v, vec![[0, 1, 2]]),
        Err(NonFinite { .. })
    ));
    let mesh = Shape::trimesh(v, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap();
    assert_eq!(mesh.mass_properties(1000.0), Err(NotSolid));

    // Heightfields.
    let s = DVec3::ONE;
    assert_eq!(
        Shape::heightfield(vec![0.0; 3], 1, 3, s),
        Err(HeightFieldSize {
            rows: 1,
            cols: 3,
            len: 3
        })
    );
    assert_eq!(
        Shape::heightfield(vec![0.0; 5], 2, 3, s),
        Err(HeightFieldSize {
            rows: 2,
            cols: 3,
            len: 5
        })
    );
    assert!(matches!(
        Shape::heightfield(vec![0.0; 4], usize::MAX, 2, s),
        Err(HeightFieldSize { .. })
    ));
    assert!(matches!(
        Shape::heightfield(vec![0.0, nan, 0.0, 0.0], 2, 2, s),
        Err(NonFinite { .. })
    ));
    assert!(matches!(
        Shape::heightfield(vec![0.0; 4], 2, 2, DVec3::new(1.0, 0.0, 1.0)),
        Err(NotPositive { .. })
    ));
    assert!(matches!(
        Shape::heightfield(vec![0.0; 4], 2, 2, DVec3::new(inf, 1.0, 1.0)),
        Err(NonFinite { .. })
    ));
    let field = Shape::heightfield(vec![0.0; 4], 2, 2, s).unwrap();
    assert_eq!(field.mass_properties(1000.0), Err(NotSolid));

    // Compounds.
    assert_eq!(Shape::compound(vec![]), Err(Empty("compound parts")));
    let bad_rot = Pose::new(DVec3::ZERO, DQuat::from_xyzw(0.0, 0.0, 0.0, 1.1));
    assert!(matches!(
        Shape::compound(vec![
            (Pose::IDENTITY, ball.clone()),
            (bad_rot, ball.clone())
        ]),
        Err(NotUnitRotation { part: 1, .. })
    ));
    let nan_rot = Pose::new(DVec3::ZERO, DQuat::from_xyzw(nan, 0.0, 0.0, 1.0));
    assert!(matches!(
        Shape::compound(vec![(nan_rot, ball.clone())]),
        Err(NotUnitRotation { part: 0, .. })
    ));
    let nan_pos = Pose::from_translation(DVec3::new(0.0, nan, 0.0));
    assert!(matches!(
        Shape::compound(vec![(nan_pos, ball.clone())]),
        Err(NonFinite { .. })
    ));
    // Slightly off-unit rotations are accepted and renormalised.
    let near = Pose::new(DVec3::ZERO, DQuat::from_xyzw(0.0, 0.0, 0.0, 1.0 + 1e-9));
    let Shape::Compound(parts) = Shape::compound(vec![(near, ball.clone())]).unwrap() else {
        unreachable!()
    };
    assert!((parts[0].0.rotation.length() - 1.0).abs() < 1e-15);
    // A compound holding a surface has no mass.
    let mixed = Shape::compound(vec![(Pose::IDENTITY, ball), (Pose::IDENTITY, field)]).unwrap();
    assert_eq!(mixed.mass_properties(1.0), Err(NotSolid));
    assert_eq!(mixed.volume(), None);
    // Errors print something useful.
    assert_eq!(
        NotSolid.to_string(),
        "triangle meshes and heightfields are not solid and have no mass properties"
    );
    assert!(CoplanarPoints.to_string().contains("coplanar"));
}
