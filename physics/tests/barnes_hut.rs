//! Barnes–Hut force error stays below the bound stated for its θ.

use crate::common;

use inertia_physics::forces::barnes_hut::rms_error_bound;
use inertia_physics::forces::mutual_gravity::accelerations;
use inertia_physics::glam::DVec3;
use inertia_physics::{GravityMethod, MutualGravity};

fn errors(positions: &[DVec3], masses: &[f64], theta: f64) -> (f64, f64) {
    let g = |method| MutualGravity {
        g_constant: 1.0,
        softening: 0.01,
        method,
    };
    let exact = accelerations(positions, masses, &g(GravityMethod::Exact));
    let bh = accelerations(positions, masses, &g(GravityMethod::BarnesHut { theta }));
    let mut sum2 = 0.0;
    let mut worst = 0.0f64;
    for (e, b) in exact.iter().zip(&bh) {
        let rel = (*e - *b).length() / e.length();
        sum2 += rel * rel;
        worst = worst.max(rel);
    }
    ((sum2 / exact.len() as f64).sqrt(), worst)
}

fn distributions() -> Vec<(&'static str, Vec<DVec3>, Vec<f64>)> {
    let mut rng = common::Rng(11);
    let n = 3000;
    let ball: Vec<DVec3> = (0..n).map(|_| rng.in_ball(1.0)).collect();
    // Plummer-like: radius r = a / sqrt(u^(-2/3) - 1), capped.
    let plummer: Vec<DVec3> = (0..n)
        .map(|_| {
            let u = rng.f64().max(1e-6);
            let r = (0.2 / (u.powf(-2.0 / 3.0) - 1.0).sqrt()).min(5.0);
            let d = rng.in_ball(1.0).normalize_or(DVec3::X);
            d * r
        })
        .collect();
    let disc: Vec<DVec3> = (0..n)
        .map(|_| {
            let p = rng.in_ball(1.0);
            DVec3::new(p.x, 0.02 * p.y, p.z)
        })
        .collect();
    let masses: Vec<f64> = (0..n).map(|_| 0.5 + rng.f64()).collect();
    vec![
        ("ball", ball, masses.clone()),
        ("plummer", plummer, masses.clone()),
        ("disc", disc, masses),
    ]
}

#[test]
fn force_error_is_below_the_stated_bound() {
    for (name, x, m) in distributions() {
        let mut last = 0.0;
        for theta in [0.3, 0.5, 0.7, 1.0] {
            let (rms, worst) = errors(&x, &m, theta);
            let bound = rms_error_bound(theta);
            eprintln!("{name} θ={theta}: rms {rms:.5} max {worst:.4} bound {bound}");
            assert!(
                rms < bound,
                "{name} θ={theta}: rms error {rms} above bound {bound} (max {worst})"
            );
            assert!(rms >= last * 0.5, "{name}: error should grow with θ");
            last = rms;
        }
    }
}

#[test]
fn tiny_theta_approaches_exact() {
    let (_, x, m) = distributions().remove(0);
    let (rms, _) = errors(&x, &m, 0.05);
    assert!(rms < 1e-4, "θ=0.05 rms {rms}");
}
