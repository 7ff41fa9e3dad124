//! Measured order of convergence: halving dt divides the error after a fixed
//! simulated time by about 2^order.

use crate::common;

use inertia_physics::Integrator;

fn oscillator_error(integrator: Integrator, dt: f64, t_end: f64) -> f64 {
    let mut o = common::oscillator(integrator, 1.0, 1.0, 0.0, 0.1);
    let n = (t_end / dt).round() as usize;
    common::run(&mut o.world, dt, n);
    let exact = o.amplitude * (o.omega * n as f64 * dt).cos();
    (o.x() - exact).abs()
}

fn kepler_error(integrator: Integrator, dt: f64, t_end: f64) -> f64 {
    let mut k = common::kepler(integrator, 1.0, 0.5);
    let n = (t_end / dt).round() as usize;
    common::run(&mut k.world, dt, n);
    let exact = common::kepler_position(k.a, k.e, n as f64 * dt);
    (k.world.particle(k.body).unwrap().position - exact).length()
}

fn order(errors: (f64, f64)) -> f64 {
    (errors.0 / errors.1).log2()
}

fn assert_order(name: &str, integrator: Integrator, measured: f64) {
    let expected = integrator.order() as f64;
    assert!(
        (measured - expected).abs() < 0.25 * expected.max(1.0),
        "{name} {integrator:?}: measured order {measured:.3}, expected {expected}"
    );
}

#[test]
fn oscillator_orders() {
    for integrator in Integrator::ALL {
        let dt = match integrator.order() {
            1 => 0.002,
            2 => 0.01,
            _ => 0.05,
        };
        let e = (
            oscillator_error(integrator, dt, 2.0),
            oscillator_error(integrator, dt / 2.0, 2.0),
        );
        assert_order("oscillator", integrator, order(e));
    }
}

#[test]
fn kepler_orders() {
    // One third of an orbit (period 2π) of an e = 0.5 ellipse, through periapsis speed-up.
    for integrator in Integrator::ALL {
        let dt = match integrator.order() {
            1 => 0.0005,
            2 => 0.002,
            _ => 0.01,
        };
        let e = (
            kepler_error(integrator, dt, 2.0),
            kepler_error(integrator, dt / 2.0, 2.0),
        );
        assert_order("kepler", integrator, order(e));
    }
}
