//! The classic lecture projectile: v0 = (2, 3), a = (0, -1), dt = 1 s.

use crate::common;

use inertia_physics::glam::DVec3;
use inertia_physics::{Integrator, ParticleDesc, SystemDesc, UniformGravity};

fn trajectory(integrator: Integrator, dt: f64, steps: usize) -> Vec<DVec3> {
    let mut world = common::world();
    let sys = world.add_system(SystemDesc::with_integrator(integrator));
    world
        .add_force(
            sys,
            UniformGravity {
                g: 1.0,
                direction: DVec3::NEG_Y,
            },
        )
        .unwrap();
    let p = world
        .add_particle(
            sys,
            ParticleDesc::at(DVec3::ZERO, 1.0).with_velocity(DVec3::new(2.0, 3.0, 0.0)),
        )
        .unwrap();
    let mut out = vec![world.particle(p).unwrap().position];
    for _ in 0..steps {
        world.step(dt).unwrap();
        out.push(world.particle(p).unwrap().position);
    }
    out
}

fn analytic(t: f64) -> DVec3 {
    DVec3::new(2.0 * t, 3.0 * t - 0.5 * t * t, 0.0)
}

#[test]
fn forward_euler_reproduces_the_lecture_table_exactly() {
    let expected = [
        (0, 0),
        (2, 3),
        (4, 5),
        (6, 6),
        (8, 6),
        (10, 5),
        (12, 3),
        (14, 0),
    ];
    let got = trajectory(Integrator::ForwardEuler, 1.0, 7);
    for (p, (x, y)) in got.iter().zip(expected) {
        assert_eq!(*p, DVec3::new(x as f64, y as f64, 0.0));
    }
}

/// Under constant acceleration the errors are known in closed form:
/// forward Euler lags the parabola by ½ a t dt, symplectic Euler leads it by
/// the same amount (both first order in dt); the second- and fourth-order
/// methods integrate a quadratic trajectory exactly.
#[test]
fn each_integrators_error_matches_its_order() {
    for dt in [1.0, 0.5, 0.25] {
        let steps = (7.0 / dt) as usize;
        for integrator in Integrator::ALL {
            let got = trajectory(integrator, dt, steps);
            for (n, p) in got.iter().enumerate() {
                let t = n as f64 * dt;
                let err = p.y - analytic(t).y;
                let expected = match integrator {
                    Integrator::ForwardEuler => 0.5 * t * dt,
                    Integrator::SymplecticEuler => -0.5 * t * dt,
                    _ => 0.0,
                };
                assert!(
                    (err - expected).abs() < 1e-12,
                    "{integrator:?} dt={dt} t={t}: error {err}, expected {expected}"
                );
                assert!((p.x - 2.0 * t).abs() < 1e-12);
            }
        }
    }
}
