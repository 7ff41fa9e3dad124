//! The scalar contact solver against hand-worked cases.

use super::block::{cholesky, cholesky_solve};
use super::*;

/// A unit-mass cube-like body resting on a fixed ground through one
/// point under gravity: the solver holds it and the normal impulse per
/// step equals m g dt.
#[test]
fn a_resting_point_carries_the_weight() {
    let cfg = SolverConfig::default();
    let dt = 1.0 / 60.0;
    let h = dt / f64::from(cfg.substeps);
    let mut bodies = vec![
        SolverBody::fixed(),
        SolverBody {
            inv_mass: 1.0,
            inv_inertia: DMat3::IDENTITY * 6.0,
            ..SolverBody::fixed()
        },
    ];
    let mut points = [PointConstraint::default(); MAX_POINTS];
    points[0] = PointConstraint {
        base_separation: 0.5,
        ..PointConstraint::new(DVec3::ZERO, DVec3::new(0.0, -0.5, 0.0), 0.0, [0.0; 2])
    };
    let mut c = ContactConstraint::new(&ContactSource {
        ends: (0, 1),
        normal: DVec3::Y,
        materials: (0.6, 0.5, 0.0),
        points,
        len: 1,
    });
    let (solve, relax) = (
        ContactPass::new(&cfg, h, true),
        ContactPass::new(&cfg, h, false),
    );
    // base: separation 0 with rb pointing down half a metre: s = n·(dp + rb) + base = -0.5 + 0.5 = 0.
    let mut y = 0.0;
    for _ in 0..120 {
        c.prepare(&bodies[0], &bodies[1], DVec3::ZERO, cfg.stick_speed, &solve);
        c.rows.impulse[0] = c.rows.impulse[0].max(0.0);
        for _ in 0..cfg.substeps {
            bodies[1].v.y -= 9.81 * h;
            let (a, b) = pair(&mut bodies, 0, 1);
            c.warm_start(a, b);
            c.solve(a, b, &solve);
            let v = bodies[1].v;
            bodies[1].dp += v * h;
            let (a, b) = pair(&mut bodies, 0, 1);
            c.solve(a, b, &relax);
        }
        y += bodies[1].dp.y;
        // Start the next step from the moved body.
        c.rows.base[0] += bodies[1].dp.y;
        bodies[1].dp = DVec3::ZERO;
    }
    assert!(y.abs() < 1e-3, "sank {y}");
    assert!(bodies[1].v.length() < 1e-6);
    let per_substep = c.rows.impulse[0];
    assert!((per_substep - 9.81 * h).abs() < 1e-9, "{per_substep}");
}

/// A box resting on four corner points: the block solve gives the four
/// points equal shares of the weight, as symmetry demands (points solved
/// one by one would not).
#[test]
fn four_points_share_a_load_evenly() {
    let cfg = SolverConfig::default();
    let h = 1.0 / 240.0;
    let mut bodies = vec![
        SolverBody::fixed(),
        SolverBody {
            inv_mass: 1.0 / 300.0,
            inv_inertia: DMat3::IDENTITY * (6.0 / 300.0),
            ..SolverBody::fixed()
        },
    ];
    let mut points = [PointConstraint::default(); MAX_POINTS];
    for (k, p) in points.iter_mut().enumerate() {
        let x = if k % 2 == 0 { -0.5 } else { 0.5 };
        let z = if k < 2 { -0.5 } else { 0.5 };
        *p = PointConstraint::new(DVec3::new(x, 0.0, z), DVec3::new(x, -0.5, z), 0.0, [0.0; 2]);
        p.base_separation = 0.5 - 1e-3; // a millimetre of overlap
    }
    let (solve, relax) = (
        ContactPass::new(&cfg, h, true),
        ContactPass::new(&cfg, h, false),
    );
    let mut c = ContactConstraint::new(&ContactSource {
        ends: (0, 1),
        normal: DVec3::Y,
        materials: (0.6, 0.6, 0.0),
        points,
        len: 4,
    });
    c.prepare(&bodies[0], &bodies[1], DVec3::ZERO, cfg.stick_speed, &solve);
    assert!(c.block.is_some());
    for _ in 0..8 {
        bodies[1].v.y -= 9.81 * h;
        let (a, b) = pair(&mut bodies, 0, 1);
        c.warm_start(a, b);
        c.solve(a, b, &solve);
        c.solve(a, b, &relax);
    }
    let impulses: Vec<f64> = c.rows.impulse.to_vec();
    let mean = impulses.iter().sum::<f64>() / 4.0;
    assert!(mean > 0.0);
    for i in &impulses {
        assert!((i - mean).abs() < 1e-9 * mean, "{impulses:?}");
    }
    assert!(
        bodies[1].w.length() < 1e-15,
        "the box turned: {}",
        bodies[1].w
    );
}

#[test]
fn cholesky_solves_a_small_spd_system() {
    let k = [
        [4.0, 1.0, 0.5, 0.0],
        [1.0, 3.0, 0.2, 0.1],
        [0.5, 0.2, 2.0, 0.3],
        [0.0, 0.1, 0.3, 1.0],
    ];
    let l = cholesky(&k).unwrap();
    let rhs = [1.0, -2.0, 0.5, 3.0];
    let x = cholesky_solve(&l, rhs);
    for i in 0..4 {
        let row: f64 = (0..4).map(|j| k[i][j] * x[j]).sum();
        assert!((row - rhs[i]).abs() < 1e-12);
    }
    // Not positive definite: refused.
    let mut bad = k;
    bad[3][3] = -1.0;
    assert!(cholesky(&bad).is_none());
}

#[test]
fn tangent_basis_is_orthonormal() {
    for n in [
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        DVec3::new(1.0, 2.0, -3.0).normalize(),
        DVec3::new(-0.9, 0.1, 0.1).normalize(),
    ] {
        let [t1, t2] = tangent_basis(n);
        assert!((t1.length() - 1.0).abs() < 1e-12 && (t2.length() - 1.0).abs() < 1e-12);
        assert!(t1.dot(n).abs() < 1e-12 && t2.dot(n).abs() < 1e-12 && t1.dot(t2).abs() < 1e-12);
    }
}
