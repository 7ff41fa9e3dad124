//! Behaviour of the individual force generators.

use crate::common;

use inertia_physics::glam::DVec3;
use inertia_physics::{
    build_cloth, build_rope, ClothDesc, Explosion, Integrator, ParticleDesc, RopeDesc, SystemDesc,
    UniformGravity, Wind,
};

#[test]
fn wind_pushes_a_light_particle_up_to_wind_speed_and_no_further() {
    let mut w = common::world();
    let s = w.add_system(SystemDesc::default());
    let wind = Wind {
        velocity: DVec3::new(6.0, 0.0, 0.0),
        air_density: 1.2,
        pressure_coefficient: 1.0,
    };
    w.add_force(s, wind).unwrap();
    let p = w
        .add_particle(
            s,
            ParticleDesc {
                area: 0.05,
                ..ParticleDesc::at(DVec3::ZERO, 0.01)
            },
        )
        .unwrap();
    // Initial push: F = ½ ρ C s² A = 0.5 * 1.2 * 36 * 0.05.
    w.step(1e-4).unwrap();
    let a = w.particle(p).unwrap().velocity.x / 1e-4;
    assert!(
        (a * 0.01 - 1.08).abs() < 1e-3,
        "initial wind force {}",
        a * 0.01
    );
    common::run(&mut w, 1e-3, 20_000);
    let v = w.particle(p).unwrap().velocity;
    assert!(v.x > 5.9 && v.x <= 6.0 + 1e-9, "{v}");
    assert!(v.y == 0.0 && v.z == 0.0);
}

#[test]
fn wind_does_not_push_particles_without_area() {
    let mut w = common::world();
    let s = w.add_system(SystemDesc::default());
    w.add_force(s, Wind::default()).unwrap();
    let p = w
        .add_particle(s, ParticleDesc::at(DVec3::ZERO, 1.0))
        .unwrap();
    common::run(&mut w, 0.01, 10);
    assert_eq!(w.particle(p).unwrap().velocity, DVec3::ZERO);
}

/// The blast front reaches particles in order of distance, at finite speed,
/// gives each the impulse P(r) A w / c whatever dt is, and removes itself
/// once spent.
#[test]
fn explosion_front_travels_at_finite_speed_and_delivers_the_stated_impulse() {
    let blast = Explosion {
        center: DVec3::ZERO,
        start_time: 0.0,
        front_speed: 100.0,
        front_thickness: 0.5,
        peak_pressure: 2000.0,
        reference_radius: 1.0,
        max_radius: 30.0,
    };
    for dt in [1e-3, 1.0 / 60.0, 0.1] {
        let mut w = common::world();
        let s = w.add_system(SystemDesc::default());
        let fh = w.add_force(s, blast).unwrap();
        let near = w
            .add_particle(
                s,
                ParticleDesc {
                    area: 0.1,
                    ..ParticleDesc::at(DVec3::new(5.0, 0.0, 0.0), 2.0)
                },
            )
            .unwrap();
        let far = w
            .add_particle(
                s,
                ParticleDesc {
                    area: 0.1,
                    ..ParticleDesc::at(DVec3::new(0.0, 20.0, 0.0), 2.0)
                },
            )
            .unwrap();
        let outside = w
            .add_particle(
                s,
                ParticleDesc {
                    area: 0.1,
                    ..ParticleDesc::at(DVec3::new(0.0, 0.0, -40.0), 2.0)
                },
            )
            .unwrap();
        let mut expired = false;
        let mut t = 0.0;
        let mut far_hit_before_near = false;
        while t < 0.5 {
            let r = w.step(dt).unwrap();
            t += dt;
            expired |= r.expired_forces.contains(&fh);
            let (vn, vf) = (
                w.particle(near).unwrap().velocity,
                w.particle(far).unwrap().velocity,
            );
            if vf.length() > 0.0 && vn.length() == 0.0 {
                far_hit_before_near = true;
            }
            if t < 5.0 / 100.0 - dt {
                assert_eq!(vn, DVec3::ZERO, "dt={dt}: pushed before the front arrived");
            }
        }
        assert!(!far_hit_before_near);
        assert!(
            expired && w.force(fh).is_none(),
            "dt={dt}: spent explosion was not removed"
        );
        for (h, r, dir) in [(near, 5.0, DVec3::X), (far, 20.0, DVec3::Y)] {
            let expected = blast.impulse_at(r, 0.1) / 2.0;
            let v = w.particle(h).unwrap().velocity;
            // The particle recedes with the front a little (v/c ~ 1e-4), so it stays in the shell slightly longer.
            assert!(
                (v - dir * expected).length() < 1e-3 * expected,
                "dt={dt} r={r}: {v} vs {expected}"
            );
        }
        assert_eq!(w.particle(outside).unwrap().velocity, DVec3::ZERO);
    }
}

#[test]
fn control_forces_per_particle_and_per_group() {
    let mut w = common::world();
    let s = w.add_system(SystemDesc::with_integrator(Integrator::ForwardEuler));
    let a = w
        .add_particle(
            s,
            ParticleDesc {
                group: 2,
                ..ParticleDesc::at(DVec3::ZERO, 2.0)
            },
        )
        .unwrap();
    let b = w
        .add_particle(
            s,
            ParticleDesc {
                group: 2,
                ..ParticleDesc::at(DVec3::ZERO, 1.0)
            },
        )
        .unwrap();
    let c = w
        .add_particle(
            s,
            ParticleDesc {
                group: 0,
                ..ParticleDesc::at(DVec3::ZERO, 1.0)
            },
        )
        .unwrap();
    w.set_group_control(s, 2, DVec3::new(0.0, 4.0, 0.0))
        .unwrap();
    w.set_control_force(a, DVec3::new(2.0, 0.0, 0.0)).unwrap();
    w.step(1.0).unwrap();
    assert_eq!(w.particle(a).unwrap().velocity, DVec3::new(1.0, 2.0, 0.0));
    assert_eq!(w.particle(b).unwrap().velocity, DVec3::new(0.0, 4.0, 0.0));
    assert_eq!(w.particle(c).unwrap().velocity, DVec3::ZERO);
    // Particles added later join the per-particle control array at zero.
    let d = w
        .add_particle(s, ParticleDesc::at(DVec3::ZERO, 1.0))
        .unwrap();
    w.step(1.0).unwrap();
    assert_eq!(w.particle(d).unwrap().velocity, DVec3::ZERO);
}

#[test]
fn pinned_particles_never_move() {
    let mut w = common::world();
    for integrator in Integrator::ALL {
        let s = w.add_system(SystemDesc::with_integrator(integrator));
        w.add_force(s, UniformGravity::earth()).unwrap();
        let rope = build_rope(
            &mut w,
            s,
            &RopeDesc {
                segments: 8,
                pin_start: true,
                pin_end: true,
                ..RopeDesc::default()
            },
        )
        .unwrap();
        let ends = [rope.particles[0], rope.particles[8]];
        let before: Vec<_> = ends
            .iter()
            .map(|h| w.particle(*h).unwrap().position)
            .collect();
        common::run(&mut w, 1.0 / 120.0, 240);
        for (h, p) in ends.iter().zip(before) {
            assert_eq!(w.particle(*h).unwrap().position, p, "{integrator:?}");
        }
        // The middle sags under gravity (forward Euler gains energy with
        // every step of an undamped spring and is not expected to settle).
        if integrator != Integrator::ForwardEuler {
            let mid = w.particle(rope.particles[4]).unwrap().position;
            assert!(mid.y < -0.01 && mid.y > -0.5, "{integrator:?}: {mid}");
        }
    }
}

#[test]
fn cloth_has_structural_shear_and_bend_springs_and_hangs_plausibly() {
    let mut w = common::world();
    let s = w.add_system(SystemDesc::with_integrator(Integrator::SymplecticEuler));
    w.add_force(s, UniformGravity::earth()).unwrap();
    let (nu, nv) = (12, 10);
    let desc = ClothDesc {
        nu,
        nv,
        v_axis: DVec3::NEG_Y,
        pinned: vec![(0, 0), (nu - 1, 0)],
        drag_linear: 0.01,
        ..ClothDesc::default()
    };
    let cloth = build_cloth(&mut w, s, &desc).unwrap();
    let structural = nu * (nv - 1) + nv * (nu - 1);
    let shear = 2 * (nu - 1) * (nv - 1);
    let bend = nu * (nv - 2) + nv * (nu - 2);
    assert_eq!(cloth.spring_counts, [structural, shear, bend]);
    assert_eq!(
        w.system(s).unwrap().spring_count(),
        structural + shear + bend
    );
    let mut max_energy = f64::MIN;
    for _ in 0..600 {
        let r = w.step(1.0 / 240.0).unwrap();
        max_energy = max_energy.max(r.energy.total());
    }
    // It never gains energy beyond what it started with (it starts at rest
    // with every spring at rest length and only falls) and stays finite.
    assert!(max_energy <= 1e-9, "cloth gained energy: {max_energy}");
    let sys = w.system(s).unwrap();
    assert!(sys.positions().iter().all(|p| p.is_finite()));
    // The bottom edge hangs below the top and the sheet did not tear apart.
    let bottom = w
        .particle(cloth.particles[(nv - 1) * nu + nu / 2])
        .unwrap()
        .position;
    assert!(bottom.y < -0.9 && bottom.y > -1.3, "{bottom}");
}

/// A stiff cloth at a 60 Hz world step is unstable for an explicit method
/// taken in one step; the system cuts the step into enough substeps, and
/// where even the most substeps allowed are not enough it softens the
/// springs for the step rather than explode.
#[test]
fn stiff_cloth_at_60_hz_stays_stable_through_substeps() {
    let run = |max_substeps: u32| {
        let mut w = common::world();
        let s = w.add_system(SystemDesc {
            integrator: Integrator::SymplecticEuler,
            max_substeps,
            ..SystemDesc::default()
        });
        w.add_force(s, UniformGravity::earth()).unwrap();
        let desc = ClothDesc {
            nu: 16,
            nv: 16,
            v_axis: DVec3::NEG_Y,
            pinned: vec![(0, 0), (15, 0)],
            ..ClothDesc::default()
        };
        build_cloth(&mut w, s, &desc).unwrap();
        let n = w.substeps_for(s, 1.0 / 60.0);
        let scale = w.system(s).unwrap().spring_stiffness_scale();
        let mut worst = f64::MIN;
        let mut quarantined = 0;
        for _ in 0..300 {
            let r = w.step(1.0 / 60.0).unwrap();
            worst = worst.max(r.energy.total());
            quarantined += r.quarantined.len();
        }
        (n, scale, worst, quarantined)
    };
    let (n, scale, worst, q) = run(32);
    assert!(n > 1, "expected substeps, got {n}");
    assert_eq!(scale, 1.0, "32 substeps are enough: no softening");
    assert!(
        worst <= 1e-9 && q == 0,
        "with {n} substeps: max energy {worst}, {q} quarantined"
    );
    let (n1, scale1, worst1, q1) = run(1);
    assert_eq!(n1, 1);
    assert!(
        scale1 < 0.5,
        "one step per tick needs softer springs (scale {scale1})"
    );
    assert!(
        worst1 <= 1e-9 && q1 == 0,
        "softened: max energy {worst1}, {q1} quarantined"
    );
}
