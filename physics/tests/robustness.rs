//! Bad input never corrupts the world: typed errors, nothing changed.

use crate::common;

use inertia_physics::glam::DVec3;
use inertia_physics::{
    Drag, Explosion, GravityMethod, Integrator, MutualGravity, ParticleDesc, PhysicsError,
    SavedStateError, SpringParams, SystemDesc, UniformGravity, Wind, World,
};

fn small_world() -> (
    World,
    inertia_physics::SystemHandle,
    Vec<inertia_physics::ParticleHandle>,
) {
    let mut w = common::world();
    let s = w.add_system(SystemDesc::default());
    w.add_force(s, UniformGravity::earth()).unwrap();
    let hs = (0..4)
        .map(|i| {
            w.add_particle(s, ParticleDesc::at(DVec3::new(i as f64, 0.0, 0.0), 1.0))
                .unwrap()
        })
        .collect();
    (w, s, hs)
}

#[test]
fn bad_values_are_refused_and_change_nothing() {
    let (mut w, s, hs) = small_world();
    let h0 = w.state_hash();
    let nan = f64::NAN;
    let bad_particles = [
        ParticleDesc::at(DVec3::new(nan, 0.0, 0.0), 1.0),
        ParticleDesc::at(DVec3::ZERO, 1.0).with_velocity(DVec3::new(0.0, f64::INFINITY, 0.0)),
        ParticleDesc::at(DVec3::ZERO, 0.0),
        ParticleDesc::at(DVec3::ZERO, -2.0),
        ParticleDesc::at(DVec3::ZERO, nan),
        ParticleDesc::at(DVec3::ZERO, 1e-320), // 1/m overflows
        ParticleDesc {
            drag_linear: -1.0,
            ..ParticleDesc::default()
        },
        ParticleDesc {
            area: nan,
            ..ParticleDesc::default()
        },
        ParticleDesc {
            group: inertia_physics::MAX_GROUPS,
            ..ParticleDesc::default()
        },
    ];
    for d in bad_particles {
        assert!(w.add_particle(s, d).is_err(), "{d:?} accepted");
    }
    // All-or-nothing batch.
    let batch = [ParticleDesc::default(), ParticleDesc::at(DVec3::ZERO, -1.0)];
    assert!(matches!(
        w.add_particles(s, &batch),
        Err(PhysicsError::NonPositiveMass(_))
    ));

    assert!(matches!(
        w.add_spring(
            hs[0],
            hs[1],
            SpringParams {
                rest_length: 0.0,
                stiffness: 1.0,
                damping: 0.0
            }
        ),
        Err(PhysicsError::DegenerateSpring(_))
    ));
    assert!(matches!(
        w.add_spring(
            hs[0],
            hs[0],
            SpringParams {
                rest_length: 1.0,
                stiffness: 1.0,
                damping: 0.0
            }
        ),
        Err(PhysicsError::DegenerateSpring(_))
    ));
    assert!(w
        .add_spring(
            hs[0],
            hs[1],
            SpringParams {
                rest_length: 1.0,
                stiffness: -1.0,
                damping: 0.0
            }
        )
        .is_err());
    assert!(w
        .add_force(
            s,
            UniformGravity {
                g: 9.8,
                direction: DVec3::ZERO
            }
        )
        .is_err());
    assert!(w
        .add_force(
            s,
            Wind {
                air_density: nan,
                ..Wind::default()
            }
        )
        .is_err());
    assert!(w
        .add_force(
            s,
            Drag {
                linear_scale: -1.0,
                quadratic_scale: 0.0
            }
        )
        .is_err());
    assert!(w
        .add_force(
            s,
            Explosion {
                front_speed: 0.0,
                ..Explosion::default()
            }
        )
        .is_err());
    assert!(matches!(
        w.add_force(
            s,
            MutualGravity {
                method: GravityMethod::BarnesHut { theta: 0.0 },
                ..MutualGravity::default()
            }
        ),
        Err(PhysicsError::BadTheta(_))
    ));
    assert!(w.set_position(hs[0], DVec3::splat(f64::INFINITY)).is_err());
    assert!(w.set_velocity(hs[0], DVec3::splat(nan)).is_err());
    assert!(w.set_control_force(hs[0], DVec3::splat(nan)).is_err());
    assert!(matches!(
        w.set_group_control(s, 1 << 20, DVec3::X),
        Err(PhysicsError::GroupOutOfRange(_))
    ));
    assert!(matches!(w.step(0.0), Err(PhysicsError::NotPositive { .. })));
    assert!(w.step(nan).is_err());
    assert!(w.step(-1.0).is_err());
    assert_eq!(w.state_hash(), h0, "a refused call changed the world");
}

#[test]
fn stale_handles_return_none_or_typed_errors() {
    let (mut w, s, hs) = small_world();
    let spring = w
        .add_spring(
            hs[1],
            hs[2],
            SpringParams {
                rest_length: 1.0,
                stiffness: 1.0,
                damping: 0.0,
            },
        )
        .unwrap();
    w.remove_particle(hs[1]).unwrap();
    assert_eq!(w.particle(hs[1]), None);
    assert_eq!(
        w.spring(spring),
        None,
        "springs of a removed particle go with it"
    );
    assert!(matches!(
        w.remove_particle(hs[1]),
        Err(PhysicsError::UnknownParticle(_))
    ));
    assert!(matches!(
        w.set_velocity(hs[1], DVec3::X),
        Err(PhysicsError::UnknownParticle(_))
    ));
    // Slot reuse does not revive the stale handle.
    let fresh = w.add_particle(s, ParticleDesc::default()).unwrap();
    assert_eq!(w.particle(hs[1]), None);
    assert!(w.particle(fresh).is_some());
    // Others are still addressed correctly after the swap-remove.
    assert_eq!(
        w.particle(hs[3]).unwrap().position,
        DVec3::new(3.0, 0.0, 0.0)
    );
    w.remove_system(s).unwrap();
    assert!(w.system(s).is_none());
    assert_eq!(w.particle(hs[0]), None);
    assert!(matches!(
        w.add_particle(s, ParticleDesc::default()),
        Err(PhysicsError::UnknownSystem(_))
    ));
}

#[test]
fn a_particle_that_blows_up_is_quarantined_and_touches_nothing_else() {
    for integrator in Integrator::ALL {
        let mut w = common::world();
        let s = w.add_system(SystemDesc {
            integrator,
            // One step, like the twin below, so the bystander is comparable bit for bit.
            max_substeps: 1,
            ..SystemDesc::default()
        });
        w.add_force(s, UniformGravity::earth()).unwrap();
        let bomb = w
            .add_particle(s, ParticleDesc::at(DVec3::ZERO, 1e-3))
            .unwrap();
        let friend = w
            .add_particle(s, ParticleDesc::at(DVec3::new(1.0, 0.0, 0.0), 1.0))
            .unwrap();
        let loner = w
            .add_particle(s, ParticleDesc::at(DVec3::new(5.0, 0.0, 0.0), 1.0))
            .unwrap();
        w.add_spring(
            bomb,
            friend,
            SpringParams {
                rest_length: 1.0,
                stiffness: 10.0,
                damping: 0.1,
            },
        )
        .unwrap();
        // A finite control force so large the integration overflows.
        w.set_control_force(bomb, DVec3::new(f64::MAX, 0.0, 0.0))
            .unwrap();

        let mut twin = common::world();
        let s2 = twin.add_system(SystemDesc::with_integrator(integrator));
        twin.add_force(s2, UniformGravity::earth()).unwrap();
        let loner2 = twin
            .add_particle(s2, ParticleDesc::at(DVec3::new(5.0, 0.0, 0.0), 1.0))
            .unwrap();

        let report = w.step(0.01).unwrap();
        twin.step(0.01).unwrap();
        assert_eq!(report.quarantined, vec![bomb], "{integrator:?}");
        let b = w.particle(bomb).unwrap();
        assert!(b.quarantined && b.position == DVec3::ZERO && b.velocity == DVec3::ZERO);
        let f = w.particle(friend).unwrap();
        assert!(
            f.position.is_finite() && f.velocity.is_finite(),
            "{integrator:?}: {f:?}"
        );
        assert_eq!(
            w.particle(loner).unwrap(),
            twin.particle(loner2).unwrap(),
            "{integrator:?}"
        );
        // Later steps: quarantined stays put, is not reported again, others continue.
        for _ in 0..10 {
            assert!(w.step(0.01).unwrap().quarantined.is_empty());
        }
        assert!(w.particle(friend).unwrap().position.is_finite());
        assert!(w.energy().total().is_finite());
        // Release it at a sane state.
        w.set_control_force(bomb, DVec3::ZERO).unwrap();
        w.release_quarantine(bomb, DVec3::new(0.0, 1.0, 0.0), DVec3::ZERO)
            .unwrap();
        w.step(0.01).unwrap();
        assert!(!w.particle(bomb).unwrap().quarantined);
    }
}

#[test]
fn corrupt_saved_states_are_refused_without_panics() {
    let (mut w, _, hs) = small_world();
    w.add_spring(
        hs[0],
        hs[1],
        SpringParams {
            rest_length: 1.0,
            stiffness: 1.0,
            damping: 0.0,
        },
    )
    .unwrap();
    w.step(0.01).unwrap();
    let good = w.save();
    let h0 = w.state_hash();
    assert!(matches!(
        w.restore(b"nonsense"),
        Err(SavedStateError::BadMagic)
    ));
    assert!(matches!(w.restore(&[]), Err(SavedStateError::BadMagic)));
    for cut in 0..good.len() {
        assert!(
            w.restore(&good[..cut]).is_err(),
            "truncated at {cut} accepted"
        );
    }
    let mut flipped = good.clone();
    for i in 8..good.len() {
        flipped[i] ^= 0x40;
        assert!(w.restore(&flipped).is_err(), "flipped byte {i} accepted");
        flipped[i] = good[i];
    }
    let mut rng = common::Rng(5);
    for _ in 0..2000 {
        let n = (rng.next_u64() % 300) as usize;
        let mut junk: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
        if junk.len() >= 8 {
            junk[..8].copy_from_slice(b"INRTWRLD");
        }
        let _ = w.restore(&junk);
    }
    assert_eq!(w.state_hash(), h0, "a refused restore changed the world");
    w.restore(&good).unwrap();
    assert_eq!(w.state_hash(), h0);
}
