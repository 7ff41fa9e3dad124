//! Closed-form physics the engine must reproduce.

use crate::common;

use std::f64::consts::PI;

use inertia_physics::forces::buoyancy::submerged_fraction;
use inertia_physics::glam::DVec3;
use inertia_physics::{
    Buoyancy, Drag, GravityMethod, Integrator, MutualGravity, ParticleDesc, SpringParams,
    SystemDesc, UniformGravity,
};

/// Times at which `f` crosses zero going upwards, linearly interpolated.
fn upward_crossings(samples: &[(f64, f64)]) -> Vec<f64> {
    samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1) / (w[1].1 - w[0].1))
        .collect()
}

#[test]
fn two_body_orbit_period_matches_keplers_third_law() {
    let mut world = common::world();
    let sys = world.add_system(SystemDesc::with_integrator(Integrator::Leapfrog));
    let g = 1.0;
    world
        .add_force(
            sys,
            MutualGravity {
                g_constant: g,
                softening: 0.0,
                method: GravityMethod::Exact,
            },
        )
        .unwrap();
    let (m1, m2) = (1.0, 0.5);
    // Relative orbit with semi-major axis a and eccentricity e, started at
    // periapsis, in the centre-of-mass frame.
    let (a, e) = (1.0, 0.3);
    let mu = g * (m1 + m2);
    let rp = a * (1.0 - e);
    let vp = (mu * (1.0 + e) / rp).sqrt();
    let b1 = world
        .add_particle(
            sys,
            ParticleDesc::at(DVec3::new(-rp * m2 / (m1 + m2), 0.0, 0.0), m1)
                .with_velocity(DVec3::new(0.0, -vp * m2 / (m1 + m2), 0.0)),
        )
        .unwrap();
    let b2 = world
        .add_particle(
            sys,
            ParticleDesc::at(DVec3::new(rp * m1 / (m1 + m2), 0.0, 0.0), m2)
                .with_velocity(DVec3::new(0.0, vp * m1 / (m1 + m2), 0.0)),
        )
        .unwrap();
    let period = 2.0 * PI * (a * a * a / mu).sqrt();
    let dt = period / 20_000.0;
    let mut samples = Vec::new();
    for n in 0..(3.2 * period / dt) as usize {
        world.step(dt).unwrap();
        let r = world.particle(b2).unwrap().position - world.particle(b1).unwrap().position;
        samples.push(((n + 1) as f64 * dt, r.y));
    }
    // r.y crosses zero upwards at each periapsis passage after the first.
    let c = upward_crossings(&samples);
    assert!(c.len() >= 2, "{c:?}");
    let measured = (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
    let rel = (measured - period).abs() / period;
    assert!(rel < 1e-3, "period {measured}, Kepler {period}, rel {rel}");
}

#[test]
fn spring_period_is_two_pi_root_m_over_k() {
    let (m, k) = (2.0, 50.0);
    let mut o = common::oscillator(Integrator::SymplecticEuler, m, k, 0.0, 0.05);
    let period = 2.0 * PI * (m / k).sqrt();
    let dt = period / 200.0;
    let samples: Vec<(f64, f64)> = (1..=(10.5 * period / dt) as usize)
        .map(|n| {
            o.world.step(dt).unwrap();
            (n as f64 * dt, o.x())
        })
        .collect();
    let c = upward_crossings(&samples);
    let measured = (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
    let rel = (measured - period).abs() / period;
    assert!(
        rel < 5e-3,
        "period {measured}, expected {period}, rel {rel}"
    );
}

#[test]
fn damped_amplitude_decays_as_exp_minus_ct_over_2m() {
    let (m, k, c) = (1.0, 100.0, 0.4);
    let mut o = common::oscillator(Integrator::Rk4, m, k, c, 0.1);
    let dt = 1e-3;
    let gamma = c / (2.0 * m);
    let mut samples = vec![(0.0, o.x())];
    for n in 1..=5000 {
        o.world.step(dt).unwrap();
        samples.push((n as f64 * dt, o.x()));
    }
    // Local maxima of x(t) = A e^{-γt} cos(ω_d t) sit where the envelope is
    // A e^{-γt} cos(φ) with the same small phase factor each time: compare
    // ratios of successive peaks with e^{-γ T_d}.
    let peaks: Vec<(f64, f64)> = samples
        .windows(3)
        .filter(|w| w[1].1 > w[0].1 && w[1].1 >= w[2].1)
        .map(|w| w[1])
        .collect();
    assert!(peaks.len() >= 5);
    for p in &peaks {
        let envelope = o.amplitude * (-gamma * p.0).exp();
        let rel = (p.1 - envelope).abs() / envelope;
        assert!(
            rel < 0.01,
            "peak at t={} is {}, envelope {envelope}, rel {rel}",
            p.0,
            p.1
        );
    }
}

fn terminal_speed(linear: f64, quadratic: f64) -> f64 {
    let mut world = common::world();
    let sys = world.add_system(SystemDesc::with_integrator(Integrator::Rk4));
    world
        .add_force(
            sys,
            UniformGravity {
                g: 9.81,
                direction: DVec3::NEG_Y,
            },
        )
        .unwrap();
    world.add_force(sys, Drag::default()).unwrap();
    let p = world
        .add_particle(
            sys,
            ParticleDesc {
                drag_linear: linear,
                drag_quadratic: quadratic,
                ..ParticleDesc::at(DVec3::ZERO, 2.0)
            },
        )
        .unwrap();
    common::run(&mut world, 0.01, 3000);
    -world.particle(p).unwrap().velocity.y
}

#[test]
fn terminal_velocity_under_linear_and_quadratic_drag() {
    let (m, g) = (2.0, 9.81);
    let b = 1.5;
    let v = terminal_speed(b, 0.0);
    let expected = m * g / b;
    assert!(
        (v - expected).abs() / expected < 0.01,
        "linear: {v} vs {expected}"
    );
    let c = 0.3;
    let v = terminal_speed(0.0, c);
    let expected = (m * g / c).sqrt();
    assert!(
        (v - expected).abs() / expected < 0.01,
        "quadratic: {v} vs {expected}"
    );
}

#[test]
fn cloud_of_half_fluid_density_floats_half_submerged() {
    let mut world = common::world();
    let sys = world.add_system(SystemDesc::default());
    let rho = 1000.0;
    world
        .add_force(
            sys,
            UniformGravity {
                g: 9.81,
                direction: DVec3::NEG_Y,
            },
        )
        .unwrap();
    world
        .add_force(
            sys,
            Buoyancy {
                surface_height: 0.0,
                up: DVec3::Y,
                fluid_density: rho,
                gravity: 9.81,
                fluid_drag: 40.0,
            },
        )
        .unwrap();
    let mut rng = common::Rng(7);
    let mut handles = Vec::new();
    for _ in 0..64 {
        let volume = 0.01 + 0.02 * rng.f64();
        let p = rng.in_ball(3.0) + DVec3::new(0.0, 4.0, 0.0);
        handles.push(
            world
                .add_particle(
                    sys,
                    ParticleDesc {
                        volume,
                        ..ParticleDesc::at(p, 0.5 * rho * volume)
                    },
                )
                .unwrap(),
        );
    }
    common::run(&mut world, 1.0 / 120.0, 120 * 30);
    for (i, h) in handles.iter().enumerate() {
        let st = world.particle(*h).unwrap();
        let volume = st.mass / (0.5 * rho);
        let f = submerged_fraction(st.position.y, volume);
        assert!(
            (f - 0.5).abs() < 0.01,
            "particle {i}: submerged fraction {f}"
        );
        assert!(
            st.velocity.length() < 1e-3,
            "particle {i} still moving: {}",
            st.velocity
        );
    }
}

fn total_momentum(world: &inertia_physics::World) -> (DVec3, f64) {
    let mut p = DVec3::ZERO;
    let mut scale = 0.0;
    for s in world.systems() {
        for (v, im) in s.velocities().iter().zip(s.inverse_masses()) {
            p += *v / *im;
            scale += v.length() / im;
        }
    }
    (p, scale)
}

#[test]
fn internal_forces_conserve_momentum() {
    let mut rng = common::Rng(3);
    for gravity in [false, true] {
        let mut world = common::world();
        let sys = world.add_system(SystemDesc::default());
        if gravity {
            world
                .add_force(
                    sys,
                    MutualGravity {
                        g_constant: 1.0,
                        softening: 0.05,
                        method: GravityMethod::Exact,
                    },
                )
                .unwrap();
        }
        let hs: Vec<_> = (0..40)
            .map(|_| {
                let d = ParticleDesc::at(rng.in_ball(2.0), 0.5 + rng.f64())
                    .with_velocity(rng.in_ball(1.0));
                world.add_particle(sys, d).unwrap()
            })
            .collect();
        if !gravity {
            for i in 0..hs.len() {
                for j in [i + 1, i + 7] {
                    if j < hs.len() {
                        let params = SpringParams {
                            rest_length: 0.5 + rng.f64(),
                            stiffness: 40.0,
                            damping: 0.3,
                        };
                        world.add_spring(hs[i], hs[j], params).unwrap();
                    }
                }
            }
        }
        let (p0, scale) = total_momentum(&world);
        common::run(&mut world, 1e-3, 2000);
        let (p1, _) = total_momentum(&world);
        let rel = (p1 - p0).length() / scale;
        assert!(rel < 1e-9, "gravity={gravity}: momentum drift {rel}");
    }
}
