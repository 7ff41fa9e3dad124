//! Fluids (position-based fluids on small steps) in a world: what issue
//! 16 asks of them.

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{
    Backend, FluidDesc, FluidEmitter, FluidHandle, PhysicsError, SoftMaterial, SoftRope, World,
};

use crate::common;

use common::{at, earth_world, tank};

const DT: f64 = 1.0 / 60.0;

#[test]
fn issue_16_a_resting_tank_reaches_rest_density_and_its_level() {
    let mut w = earth_world(2);
    let s = 0.1;
    let size = DVec3::new(1.2, 1.2, 1.2);
    tank(&mut w, DVec3::ZERO, DVec3::new(1.2, 2.4, 1.2));
    let h = w
        .add_fluid(FluidDesc::block(DVec3::ZERO, size, s).unwrap())
        .unwrap();
    for _ in 0..240 {
        w.step(DT).unwrap();
    }
    let f = w.fluid(h).unwrap();
    let n = f.len() as f64;
    let mean: f64 = f.densities().iter().map(|d| f64::from(*d)).sum::<f64>() / n;
    let density_error = mean / f64::from(f.rest_density()) - 1.0;
    // The level: the mean height of a column of even fluid is half its
    // height.
    let level = 2.0 * f.positions().iter().map(|p| f64::from(p.y)).sum::<f64>() / n;
    let expected = n * s * s * s / (size.x * size.z);
    let fastest = f
        .velocities()
        .iter()
        .map(|v| v.length())
        .fold(0.0f32, f32::max);
    println!(
        "tank: {} particles, mean density {:+.2} % of rest, level {level:.3} m of {expected:.3} m ({:+.2} %), fastest {fastest:.3} m/s",
        f.len(),
        density_error * 100.0,
        (level / expected - 1.0) * 100.0
    );
    assert!(density_error.abs() < 0.01, "{density_error}");
    assert!((level / expected - 1.0).abs() < 0.02, "{level}");
    assert!(fastest < 0.3, "the tank is at rest ({fastest} m/s)");
    assert!(f
        .positions()
        .iter()
        .all(|p| p.y > -0.01 && p.x > -0.01 && p.x < 1.21));
}

/// A pool of fluid `s` m apart with a crate of `density` dropped on it,
/// with `friction` between them (the crate's and the fluid's), the fluid
/// stepped on `backend`; the crate's mean submerged fraction over the last
/// two of `seconds`, and its tilt.
pub(crate) fn float(
    density: f64,
    seconds: f64,
    s: f64,
    friction: f64,
    backend: Backend,
) -> (f64, f64) {
    let mut w = earth_world(2);
    let size = DVec3::new(1.6, 0.8, 1.6);
    tank(&mut w, DVec3::ZERO, DVec3::new(1.6, 2.0, 1.6));
    let mut fluid = FluidDesc::block(DVec3::ZERO, size, s).unwrap();
    fluid.friction = friction;
    let h = w.add_fluid(fluid).unwrap();
    let half = DVec3::new(0.3, 0.15, 0.3);
    let mut desc = RigidBodyDesc::dynamic(
        Shape::cuboid(half).unwrap(),
        density,
        at(DVec3::new(0.8, size.y + half.y, 0.8)),
    )
    .unwrap();
    desc.friction_static = friction;
    desc.friction_dynamic = friction;
    let crate_ = w.add_body(&desc).unwrap();
    w.set_fluid_backend(h, backend).unwrap();
    let steps = (seconds / DT) as usize;
    let from = steps - (2.0 / DT) as usize;
    let (mut sum, mut count) = (0.0, 0);
    let mut tilt: f64 = 0.0;
    for k in 0..steps {
        w.step(DT).unwrap();
        if k >= from {
            let b = w.body(crate_).unwrap();
            let bottom = b.center_of_mass().y - half.y;
            let f = w.fluid(h).unwrap();
            let clear = half.x + f64::from(f.kernel_radius());
            let (mut sum_y, mut n) = (0.0, 0usize);
            for p in f.positions() {
                if (f64::from(p.x) - 0.8).abs() > clear || (f64::from(p.z) - 0.8).abs() > clear {
                    sum_y += f64::from(p.y);
                    n += 1;
                }
            }
            let surface = 2.0 * sum_y / n as f64;
            sum += (surface - bottom) / (2.0 * half.y);
            count += 1;
            let up = b.pose().rotation * DVec3::Y;
            tilt = tilt.max(up.angle_between(DVec3::Y));
        }
    }
    (sum / count as f64, tilt)
}

/// Archimedes: a crate of half the fluid's density floats half submerged
/// (the issue asks 0.5 ± 0.05). The fluid is fine enough that the crate is
/// many kernels wide: the walls' density term takes a body's surface as
/// flat, and overcounts at its edges.
#[test]
fn issue_16_a_crate_of_half_the_fluids_density_floats_about_half_submerged() {
    let (fraction, tilt) = float(500.0, 6.0, 0.05, 0.5, Backend::Cpu);
    println!(
        "crate of 500 kg/m³: {fraction:.3} submerged, tilted at most {:.1}°",
        tilt.to_degrees()
    );
    assert!(
        (fraction - 0.5).abs() < 0.05,
        "submerged fraction {fraction}"
    );
    assert!(tilt < 0.2, "it floats level ({tilt} rad)");
}

/// A floating crate at rest ends each rigid stage sinking at its last
/// substep's speed, and the fluid lifts it again after. Friction held the
/// particles beside it to that speed, so they dragged it up: with friction
/// 1 it floated 0.446 submerged at 10 cm, 0.019 higher than without.
/// Friction now holds them to the crate's motion over the whole step, and
/// a crate at rest floats no higher for it (0.459 submerged with friction,
/// 0.456 without).
#[test]
fn issue_16_friction_does_not_lift_a_floating_crate() {
    let (rough, _) = float(500.0, 6.0, 0.1, 1.0, Backend::Cpu);
    let (smooth, _) = float(500.0, 6.0, 0.1, 0.0, Backend::Cpu);
    println!(
        "crate of 500 kg/m³ at 10 cm: {rough:.3} submerged with friction 1, {smooth:.3} without"
    );
    assert!(
        rough > smooth - 0.005,
        "friction lifts a crate at rest: {rough} submerged with it, {smooth} without"
    );
    assert!((rough - 0.5).abs() < 0.05, "submerged fraction {rough}");
}

#[test]
fn issue_16_a_dam_break_pushes_a_crate() {
    let mut w = earth_world(2);
    let s = 0.1;
    tank(&mut w, DVec3::ZERO, DVec3::new(4.0, 2.0, 1.0));
    let h = w
        .add_fluid(FluidDesc::block(DVec3::ZERO, DVec3::new(1.0, 1.2, 1.0), s).unwrap())
        .unwrap();
    let half = DVec3::splat(0.15);
    let crate_ = w
        .add_body(
            &RigidBodyDesc::dynamic(
                Shape::cuboid(half).unwrap(),
                300.0,
                at(DVec3::new(2.5, 0.16, 0.5)),
            )
            .unwrap(),
        )
        .unwrap();
    let start = w.body(crate_).unwrap().center_of_mass();
    for _ in 0..150 {
        w.step(DT).unwrap();
    }
    let end = w.body(crate_).unwrap().center_of_mass();
    let f = w.fluid(h).unwrap();
    println!(
        "dam break: the crate moved {:.3} m along x",
        end.x - start.x
    );
    assert!(
        end.x - start.x > 0.2,
        "the wave pushed the crate ({start} → {end})"
    );
    assert!(f.positions().iter().all(|p| p.is_finite() && p.y > -0.05));
}

#[test]
fn issue_16_fluids_step_alike_on_one_and_two_threads_and_after_a_restore() {
    let build = |threads| {
        let mut w = earth_world(threads);
        tank(&mut w, DVec3::ZERO, DVec3::new(1.0, 2.0, 1.0));
        let h = w
            .add_fluid(FluidDesc::block(DVec3::ZERO, DVec3::new(1.0, 0.8, 0.6), 0.05).unwrap())
            .unwrap();
        w.add_body(
            &RigidBodyDesc::dynamic(
                Shape::sphere(0.12).unwrap(),
                400.0,
                at(DVec3::new(0.5, 1.2, 0.5)),
            )
            .unwrap(),
        )
        .unwrap();
        let rope = SoftRope {
            start: DVec3::new(0.2, 1.5, 0.5),
            end: DVec3::new(0.8, 1.5, 0.5),
            segments: 10,
            material: SoftMaterial {
                collision_radius: 0.02,
                ..SoftMaterial::default()
            },
            ..SoftRope::default()
        };
        w.add_soft_body(&rope.build().unwrap()).unwrap();
        (w, h)
    };
    let (mut one, h) = build(1);
    let (mut two, _) = build(2);
    for _ in 0..40 {
        one.step(DT).unwrap();
        two.step(DT).unwrap();
    }
    assert_eq!(one.state_hash(), two.state_hash());
    let saved = one.save();
    let (mut restored, _) = build(2);
    restored.restore(&saved).unwrap();
    assert_eq!(restored.state_hash(), one.state_hash());
    for _ in 0..20 {
        one.step(DT).unwrap();
        restored.step(DT).unwrap();
    }
    assert_eq!(restored.state_hash(), one.state_hash());
    assert_eq!(
        restored.fluid(h).unwrap().positions(),
        one.fluid(h).unwrap().positions()
    );
}

#[test]
fn issue_16_bad_fluids_are_refused_and_emitters_keep_to_their_cap() {
    let mut w = earth_world(1);
    let mut bad = FluidDesc::new(0.1);
    bad.spacing = -1.0;
    assert!(matches!(
        w.add_fluid(bad),
        Err(PhysicsError::NotPositive { .. })
    ));
    let mut bad = FluidDesc::new(0.1);
    bad.positions = vec![DVec3::new(f64::NAN, 0.0, 0.0)];
    assert!(w.add_fluid(bad).is_err());
    let mut bad = FluidDesc::new(0.1);
    bad.viscosity = -0.5;
    assert!(w.add_fluid(bad).is_err());
    assert_eq!(w.fluids().count(), 0);
    let mut desc = FluidDesc::new(0.1);
    desc.max_particles = 10;
    let h = w.add_fluid(desc).unwrap();
    let spout: Vec<DVec3> = (0..8)
        .map(|k| DVec3::new(0.0, 1.0, k as f64 * 0.1))
        .collect();
    w.add_fluid_particles(h, &spout, &[]).unwrap();
    assert!(
        w.add_fluid_particles(h, &spout, &[]).is_err(),
        "past the cap"
    );
    assert_eq!(w.fluid(h).unwrap().len(), 8, "all or nothing");
    let stale = FluidHandle::from_raw([7, 0]);
    assert!(matches!(
        w.add_fluid_particles(stale, &spout, &[]),
        Err(PhysicsError::UnknownFluid(_))
    ));
}

/// A tank 2 m square and an empty fluid 0.1 m apart with one emitter: a
/// nozzle of radius 0.1 m (five particles a shot: the centre and its four
/// neighbours on the lattice) pointing down, a shot every 0.25 s from
/// 0.5 s to 2 s.
fn spout(limit: Option<u64>, cap: usize) -> (World, FluidHandle) {
    let mut w = earth_world(1);
    tank(&mut w, DVec3::ZERO, DVec3::new(2.0, 2.0, 2.0));
    let mut desc = FluidDesc::new(0.1);
    desc.max_particles = cap;
    let h = w.add_fluid(desc).unwrap();
    let emitter = FluidEmitter {
        radius: 0.1,
        interval: Some(0.25),
        start: 0.5,
        stop: Some(2.0),
        limit,
        ..FluidEmitter::new(DVec3::new(1.0, 1.5, 1.0), DVec3::new(0.0, -1.0, 0.0))
    };
    assert_eq!(w.add_fluid_emitter(h, emitter).unwrap(), 0);
    (w, h)
}

/// Shots due by `t` s for the emitter of [`spout`].
fn shots_due(t: f64) -> usize {
    if t < 0.5 - 1e-9 {
        0
    } else {
        ((t.min(2.0) - 0.5 + 1e-9) / 0.25).floor() as usize + 1
    }
}

#[test]
fn issue_16_an_emitter_adds_its_shots_on_time_and_stops() {
    let (mut w, h) = spout(None, 10_000);
    let f = w.fluid(h).unwrap();
    assert_eq!(f.emitters()[0].shot_size(), 5);
    assert!(f.is_empty());
    for step in 1..=180 {
        w.step(DT).unwrap();
        let t = step as f64 * DT;
        let f = w.fluid(h).unwrap();
        assert_eq!(f.len(), 5 * shots_due(t), "at {t} s");
        assert_eq!(f.emitters()[0].emitted(), f.len() as u64);
    }
    // Seven shots, from 0.5 s to 2 s; none after the stop.
    let f = w.fluid(h).unwrap();
    assert_eq!(f.len(), 35);
    assert!(f.emitters()[0].is_done(w.time()));
    assert!(f
        .positions()
        .iter()
        .all(|p| p.is_finite() && p.y > -0.05 && p.y < 1.6));
}

#[test]
fn issue_16_an_emitter_stops_at_its_limit_and_at_the_fluids_cap() {
    // A limit of 12: two full shots and two particles of the third.
    let (mut w, h) = spout(Some(12), 10_000);
    for _ in 0..180 {
        w.step(DT).unwrap();
    }
    let f = w.fluid(h).unwrap();
    assert_eq!(f.len(), 12);
    assert_eq!(f.emitters()[0].emitted(), 12);
    assert!(f.emitters()[0].is_done(w.time()));
    // A cap of 8: one shot and three of the second; the rest are skipped.
    let (mut w, h) = spout(None, 8);
    for _ in 0..180 {
        w.step(DT).unwrap();
    }
    let f = w.fluid(h).unwrap();
    assert_eq!(f.len(), 8);
    assert_eq!(f.emitters()[0].emitted(), 8);
    assert_eq!(f.emitters()[0].shots(), 7);
}

#[test]
fn issue_16_an_emitter_added_later_does_not_fire_its_past() {
    let mut w = earth_world(1);
    tank(&mut w, DVec3::ZERO, DVec3::new(2.0, 2.0, 2.0));
    let h = w.add_fluid(FluidDesc::new(0.1)).unwrap();
    for _ in 0..60 {
        w.step(DT).unwrap();
    }
    // A jet since time 0 (a shot every 0.1 s at 1 m/s), added at 1 s.
    w.add_fluid_emitter(
        h,
        FluidEmitter::new(DVec3::new(1.0, 1.5, 1.0), DVec3::new(0.0, -1.0, 0.0)),
    )
    .unwrap();
    for _ in 0..30 {
        w.step(DT).unwrap();
    }
    // Shots at 1.0, 1.1, ..., 1.5 s: six, not sixteen.
    assert_eq!(w.fluid(h).unwrap().len(), 6);
}

#[test]
fn issue_16_an_emitting_fluid_restores_bit_identically() {
    let (mut one, h) = spout(Some(30), 10_000);
    for _ in 0..50 {
        one.step(DT).unwrap();
    }
    let saved = one.save();
    let (mut restored, _) = spout(Some(30), 10_000);
    restored.restore(&saved).unwrap();
    assert_eq!(restored.state_hash(), one.state_hash());
    assert_eq!(
        restored.fluid(h).unwrap().emitters(),
        one.fluid(h).unwrap().emitters()
    );
    // Through the rest of the emission and past its limit.
    for _ in 0..100 {
        one.step(DT).unwrap();
        restored.step(DT).unwrap();
        assert_eq!(restored.state_hash(), one.state_hash());
    }
    let (a, b) = (one.fluid(h).unwrap(), restored.fluid(h).unwrap());
    assert_eq!(a.len(), 30);
    assert_eq!(a.positions(), b.positions());
    assert_eq!(a.velocities(), b.velocities());
}

#[test]
fn issue_16_bad_emitters_are_refused_with_typed_errors() {
    let mut w = earth_world(1);
    let h = w.add_fluid(FluidDesc::new(0.1)).unwrap();
    let good = FluidEmitter::new(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, -2.0, 0.0));
    let refused = |w: &mut World, change: &dyn Fn(&mut FluidEmitter)| {
        let mut e = good.clone();
        change(&mut e);
        w.add_fluid_emitter(h, e).unwrap_err()
    };
    assert!(matches!(
        refused(&mut w, &|e| e.velocity = DVec3::ZERO),
        PhysicsError::ZeroDirection(_)
    ));
    assert!(matches!(
        refused(&mut w, &|e| e.position.x = f64::NAN),
        PhysicsError::NonFinite { .. }
    ));
    assert!(matches!(
        refused(&mut w, &|e| e.radius = -0.1),
        PhysicsError::Negative { .. }
    ));
    assert!(matches!(
        refused(&mut w, &|e| e.radius = 100.0),
        PhysicsError::OutOfRange { .. }
    ));
    // Shots 0.02 s apart at 2 m/s are 4 cm apart: they would overlap.
    assert!(matches!(
        refused(&mut w, &|e| e.interval = Some(0.02)),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&mut w, &|e| e.interval = Some(0.0)),
        PhysicsError::NotPositive { .. }
    ));
    assert!(matches!(
        refused(&mut w, &|e| e.start = -1.0),
        PhysicsError::Negative { .. }
    ));
    assert!(matches!(
        refused(&mut w, &|e| {
            e.start = 2.0;
            e.stop = Some(1.0);
        }),
        PhysicsError::Invalid { .. }
    ));
    assert!(matches!(
        refused(&mut w, &|e| e.limit = Some(0)),
        PhysicsError::NotPositive { .. }
    ));
    assert!(w.fluid(h).unwrap().emitters().is_empty());
    let stale = FluidHandle::from_raw([7, 0]);
    assert!(matches!(
        w.add_fluid_emitter(stale, good.clone()),
        Err(PhysicsError::UnknownFluid(_))
    ));
    w.add_fluid_emitter(h, good).unwrap();
    assert_eq!(w.fluid(h).unwrap().emitters().len(), 1);
}

/// A crate of 500 kg/m³ dropped 0.55 m into a pool flew 3.5 m out of it
/// (to 4.36 m): the rigid stage moved it a whole step into the fluid, the
/// soft stage held it there and pushed each particle it met the whole
/// step's sink out in one substep, so the particles left at four times
/// the crate's speed, and the crate took as much back. Now the particles
/// meet the crate along its path over the step and share each push with
/// it (`xpbd/coupling.rs`): it splashes in, bobs and floats.
#[test]
fn issue_16_a_crate_dropped_into_a_pool_does_not_fly_out_of_it() {
    let mut w = earth_world(2);
    tank(&mut w, DVec3::ZERO, DVec3::new(1.6, 2.0, 1.6));
    let block = FluidDesc::block(DVec3::ZERO, DVec3::new(1.6, 0.8, 1.6), 0.1).unwrap();
    w.add_fluid(block).unwrap();
    let drop = 1.5;
    let crate_ = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::new(0.3, 0.15, 0.3)).unwrap(),
        500.0,
        at(DVec3::new(0.8, drop, 0.8)),
    )
    .unwrap();
    let b = w.add_body(&crate_).unwrap();
    let ys: Vec<f64> = (0..300)
        .map(|_| {
            w.step(DT).unwrap();
            w.body(b).unwrap().center_of_mass().y
        })
        .collect();
    // It meets the water after about 20 steps; its bounces after that.
    let highest = ys[30..].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let end = ys[ys.len() - 1];
    println!(
        "a crate dropped from {drop} m bounced back to at most {highest:.3} m \
         and floats at {end:.3} m"
    );
    assert!(
        highest < drop - 0.2,
        "it flew out of the pool to {highest} m"
    );
    // Floating: its centre a little above the surface (0.8 m) less half
    // its height, and at rest.
    assert!((0.7..0.9).contains(&end), "it floats at {end} m");
    assert!(w.body(b).unwrap().linear_velocity().length() < 0.05);
}
