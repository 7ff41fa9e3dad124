//! Energy behaviour of the integrators on an undamped oscillator at ω·dt = 0.05.

use crate::common;

use inertia_physics::Integrator;

const OMEGA_DT: f64 = 0.05;

/// Relative energy error after each of `steps` steps.
fn energy_errors(integrator: Integrator, steps: usize) -> Vec<f64> {
    let mut o = common::oscillator(integrator, 1.0, 1.0, 0.0, 0.1);
    let dt = OMEGA_DT / o.omega;
    let e0 = 0.5 * o.amplitude * o.amplitude; // ½ k A²
    (0..steps)
        .map(|_| {
            let r = o.world.step(dt).unwrap();
            (r.energy.total() - e0) / e0
        })
        .collect()
}

/// The second-order symplectic methods keep the energy within 1e-3 over a
/// million steps (their error is bounded, about (ω dt)² / 8).
#[test]
fn symplectic_energy_stays_within_1e_3_over_a_million_steps() {
    for integrator in [Integrator::Leapfrog, Integrator::Verlet] {
        let errs = energy_errors(integrator, 1_000_000);
        let worst = errs.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        assert!(
            worst < 1e-3,
            "{integrator:?}: worst relative energy error {worst}"
        );
    }
}

/// Symplectic Euler's energy oscillates (amplitude about ω dt / 2) but does
/// not drift: the last tenth of a million steps stays in the same band as
/// the first tenth.
#[test]
fn symplectic_euler_energy_is_bounded_without_drift() {
    let errs = energy_errors(Integrator::SymplecticEuler, 1_000_000);
    let band = |s: &[f64]| {
        s.iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &e| (lo.min(e), hi.max(e)))
    };
    let (lo0, hi0) = band(&errs[..100_000]);
    let (lo1, hi1) = band(&errs[900_000..]);
    assert!(hi0.max(-lo0) <= OMEGA_DT * 0.55, "band {lo0}..{hi0}");
    assert!(
        (lo1 - lo0).abs() < 1e-3 && (hi1 - hi0).abs() < 1e-3,
        "drift: {lo0}..{hi0} then {lo1}..{hi1}"
    );
}

/// Forward Euler gains energy every step: for the oscillator exactly by the
/// factor (1 + (ω dt)²) per step — the pendulum that swings ever wider.
#[test]
fn forward_euler_energy_grows_as_predicted() {
    let steps = 1000;
    let errs = energy_errors(Integrator::ForwardEuler, steps);
    for (n, w) in errs.windows(2).enumerate() {
        assert!(
            w[1] > w[0],
            "energy must grow every step: step {n}: {:?}",
            w
        );
    }
    let predicted = (1.0 + OMEGA_DT * OMEGA_DT).powi(steps as i32) - 1.0;
    let got = errs[steps - 1];
    assert!(
        (got - predicted).abs() / predicted < 1e-6,
        "grew by {got}, predicted {predicted}"
    );
    assert!(got > 10.0);
}

/// RK4 is not symplectic: tiny but one-signed drift (it loses energy).
#[test]
fn rk4_energy_drifts_slowly_downwards() {
    let errs = energy_errors(Integrator::Rk4, 100_000);
    let last = errs[errs.len() - 1];
    assert!(last < 0.0 && last > -1e-3, "rk4 drift {last}");
    assert!(
        errs[errs.len() / 2] > last,
        "drift must be monotone on average"
    );
}
