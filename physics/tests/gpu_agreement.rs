//! The GPU path (f32) follows the CPU path (f64) within the stated
//! `GPU_TOLERANCE`, scene by scene, and repeats bit for bit on one device.
//!
//! Run: `cargo test -p inertia-physics --features gpu --test integration gpu_agreement::`.
//! Without a GPU these run on Mesa lavapipe / llvmpipe; with no adapter at
//! all they fail unless `INERTIA_SKIP_GPU_TESTS=1`.
#![cfg(feature = "gpu")]

use crate::gpu_support;

use gpu_support::{assert_agreement, gpu_world, Lcg, Scene};
use inertia_physics::glam::DVec3;
use inertia_physics::{
    build_cloth, Backend, Buoyancy, ClothDesc, Drag, Explosion, GravityMethod, Integrator,
    MutualGravity, ParticleDesc, SystemDesc, UniformGravity, Wind, World, WorldConfig,
};

/// 100 particles falling through air with linear and quadratic drag and a
/// gusting wind, half of them pinned or slow, for `integrator`.
fn free_fall(integrator: Integrator) -> impl Fn(&mut World) -> Scene {
    move |w: &mut World| {
        let sys = w.add_system(SystemDesc::with_integrator(integrator));
        let mut rng = Lcg(7);
        let descs: Vec<ParticleDesc> = (0..100)
            .map(|k| ParticleDesc {
                position: rng.vec(20.0) + DVec3::new(0.0, 50.0, 0.0),
                velocity: rng.vec(10.0),
                mass: rng.range(0.1, 5.0),
                drag_linear: rng.range(0.0, 0.5),
                drag_quadratic: rng.range(0.0, 0.05),
                area: rng.range(0.0, 0.2),
                pinned: k % 17 == 0,
                ..ParticleDesc::default()
            })
            .collect();
        w.add_particles(sys, &descs).unwrap();
        w.add_force(sys, UniformGravity::earth()).unwrap();
        w.add_force(
            sys,
            Drag {
                linear_scale: 1.0,
                quadratic_scale: 0.8,
            },
        )
        .unwrap();
        let wind = w
            .add_force(
                sys,
                Wind {
                    velocity: DVec3::new(8.0, 0.0, 3.0),
                    air_density: 1.225,
                    pressure_coefficient: 1.2,
                },
            )
            .unwrap();
        Scene {
            sys,
            forces: vec![wind],
        }
    }
}

/// Every 40 steps the wind turns: forces change between GPU steps.
fn gusts(w: &mut World, scene: &Scene, step: u32) {
    if step % 40 == 39 {
        let h = scene.forces[0];
        let turn = f64::from(step) * 0.05;
        w.set_force(
            h,
            Wind {
                velocity: DVec3::new(8.0 * turn.cos(), 1.0, 8.0 * turn.sin()),
                air_density: 1.225,
                pressure_coefficient: 1.2,
            },
        )
        .unwrap();
    }
}

#[test]
fn free_fall_with_drag_and_wind_forward_euler() {
    assert_agreement(
        "free fall + drag + wind, forward Euler",
        200,
        1.0 / 60.0,
        free_fall(Integrator::ForwardEuler),
        gusts,
    );
}

#[test]
fn free_fall_with_drag_and_wind_symplectic_euler() {
    assert_agreement(
        "free fall + drag + wind, symplectic Euler",
        200,
        1.0 / 60.0,
        free_fall(Integrator::SymplecticEuler),
        gusts,
    );
}

fn cloth(w: &mut World) -> Scene {
    let sys = w.add_system(SystemDesc::with_integrator(Integrator::SymplecticEuler));
    build_cloth(
        w,
        sys,
        &ClothDesc {
            origin: DVec3::new(0.0, 2.0, 0.0),
            nu: 12,
            nv: 10,
            drag_linear: 0.01,
            pinned: vec![(0, 0), (11, 0)],
            ..ClothDesc::default()
        },
    )
    .unwrap();
    w.add_force(sys, UniformGravity::earth()).unwrap();
    w.add_force(sys, Drag::default()).unwrap();
    w.add_force(
        sys,
        Wind {
            velocity: DVec3::new(0.0, 0.0, 4.0),
            ..Wind::default()
        },
    )
    .unwrap();
    Scene {
        sys,
        forces: Vec::new(),
    }
}

#[test]
fn spring_cloth() {
    assert_agreement(
        "cloth 12x10, springs + gravity + drag + wind",
        240,
        1.0 / 240.0,
        cloth,
        |_, _, _| {},
    );
}

/// A cloth far too stiff for its substep budget (2): the CPU plan softens
/// the springs for each step, and the GPU must apply the same factors.
#[test]
fn stiff_cloth_softened_by_the_substep_plan() {
    let build = |w: &mut World| {
        let sys = w.add_system(SystemDesc {
            max_substeps: 2,
            ..SystemDesc::with_integrator(Integrator::SymplecticEuler)
        });
        build_cloth(
            w,
            sys,
            &ClothDesc {
                nu: 8,
                nv: 8,
                pinned: vec![(0, 0), (7, 0)],
                ..ClothDesc::default()
            },
        )
        .unwrap();
        w.add_force(sys, UniformGravity::earth()).unwrap();
        let mut probe = w.system(sys).unwrap().clone();
        probe.substeps_for(1.0 / 30.0);
        assert!(
            probe.spring_stiffness_scale() < 1.0,
            "scene must be softened"
        );
        Scene {
            sys,
            forces: Vec::new(),
        }
    };
    assert_agreement(
        "stiff cloth 8x8, softened at 2 substeps",
        60,
        1.0 / 30.0,
        build,
        |_, _, _| {},
    );
}

/// 150 bodies (three partial N-body tiles of 64) in a softened cluster, one
/// pinned at the centre.
fn cluster(w: &mut World) -> Scene {
    let sys = w.add_system(SystemDesc::with_integrator(Integrator::SymplecticEuler));
    let mut rng = Lcg(42);
    let mut descs: Vec<ParticleDesc> = (0..150)
        .map(|_| ParticleDesc {
            position: rng.vec(1.0),
            velocity: rng.vec(0.1),
            mass: rng.range(0.5, 2.0) / 150.0,
            ..ParticleDesc::default()
        })
        .collect();
    descs[75] = ParticleDesc {
        position: DVec3::ZERO,
        mass: 0.5,
        pinned: true,
        ..ParticleDesc::default()
    };
    w.add_particles(sys, &descs).unwrap();
    w.add_force(
        sys,
        MutualGravity {
            g_constant: 1.0,
            softening: 0.1,
            method: GravityMethod::Exact,
        },
    )
    .unwrap();
    Scene {
        sys,
        forces: Vec::new(),
    }
}

#[test]
fn exact_n_body_cluster() {
    assert_agreement(
        "N-body 150, exact, softened",
        100,
        1.0 / 100.0,
        cluster,
        |_, _, _| {},
    );
}

/// Buoyancy, an explosion that passes during the run, per-particle and
/// group control forces.
fn field_forces(w: &mut World) -> Scene {
    let sys = w.add_system(SystemDesc::with_integrator(Integrator::ForwardEuler));
    let mut rng = Lcg(3);
    let descs: Vec<ParticleDesc> = (0..80)
        .map(|k| ParticleDesc {
            position: DVec3::new(
                rng.range(-10.0, 10.0),
                rng.range(-1.0, 1.0),
                rng.range(-10.0, 10.0),
            ),
            velocity: rng.vec(1.0),
            mass: rng.range(0.5, 2.0),
            area: rng.range(0.01, 0.1),
            volume: rng.range(0.0005, 0.003),
            group: k % 3,
            ..ParticleDesc::default()
        })
        .collect();
    let handles = w.add_particles(sys, &descs).unwrap();
    w.add_force(sys, UniformGravity::earth()).unwrap();
    w.add_force(
        sys,
        Buoyancy {
            fluid_drag: 0.5,
            ..Buoyancy::default()
        },
    )
    .unwrap();
    w.add_force(
        sys,
        Explosion {
            center: DVec3::new(0.0, -2.0, 0.0),
            start_time: 0.05,
            front_speed: 60.0,
            front_thickness: 0.5,
            peak_pressure: 2.0e3,
            reference_radius: 1.0,
            max_radius: 12.0,
        },
    )
    .unwrap();
    for h in handles.iter().step_by(7) {
        w.set_control_force(*h, DVec3::new(0.5, 2.0, -0.3)).unwrap();
    }
    w.set_group_control(sys, 1, DVec3::new(-1.0, 0.5, 0.0))
        .unwrap();
    Scene {
        sys,
        forces: Vec::new(),
    }
}

#[test]
fn buoyancy_explosion_and_control() {
    assert_agreement(
        "buoyancy + explosion + control",
        150,
        1.0 / 120.0,
        field_forces,
        |_, _, _| {},
    );
}

/// Two fresh worlds, each with its own context on the same adapter, step
/// the same spring + N-body scene: the states are bit-identical. So are a
/// run with readback every step and one that syncs only at the end.
#[test]
fn gpu_runs_repeat_bit_for_bit() {
    let run = |readback: bool| -> Option<(u64, Vec<DVec3>)> {
        let mut w = gpu_world(WorldConfig {
            threads: 1,
            gpu_readback_every_step: readback,
            ..WorldConfig::default()
        })?;
        let a = cloth(&mut w).sys;
        let b = cluster(&mut w).sys;
        w.set_backend(a, Backend::Gpu).unwrap();
        w.set_backend(b, Backend::Gpu).unwrap();
        for _ in 0..60 {
            w.step(1.0 / 240.0).unwrap();
        }
        w.sync_gpu().unwrap();
        let mut state: Vec<DVec3> = w.system(a).unwrap().positions().to_vec();
        state.extend_from_slice(w.system(b).unwrap().velocities());
        Some((w.state_hash(), state))
    };
    let Some(first) = run(true) else { return };
    let second = run(true).unwrap();
    let quiet = run(false).unwrap();
    let bits = |v: &[DVec3]| -> Vec<[u64; 3]> {
        v.iter()
            .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect()
    };
    assert_eq!(bits(&first.1), bits(&second.1));
    assert_eq!(first.0, second.0, "state hash differs between two GPU runs");
    assert_eq!(first.0, quiet.0, "readback changed the GPU result");
}
