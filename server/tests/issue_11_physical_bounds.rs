//! Issue 11, defect 1(a): one validation of physical quantities, shared by
//! scene files, operator edits and the game rules. Before, `spawn` of a
//! dynamic body of 10³⁰⁸ kg passed the edit's "finite and above zero"
//! check and panicked the contact solver on NaN bounds a tick later (a
//! scene file refused 10³⁰⁸ but took 2 × 10³⁰⁷), and `speed 1e-300`
//! passed the admin check and panicked the tick thread.

use inertia_physics::limits;
use inertia_protocol::admin::{AdminRequest, MassSpec, SpawnDesc, MIN_TIME_SCALE};
use inertia_protocol::{EntityKind, ShapeDesc};
use inertia_server::replay::WorldEdit;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::edit::{EditError, EditOutcome};
use inertia_server::sim::{SimConfig, Simulation};

const FLOOR: &str = r#"(
    name: "floor",
    spawn_points: [(0.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (20.0, 0.5, 20.0)), position: (0.0, -0.5, 0.0)),
        (name: "pebble", shape: Sphere(radius: 0.05), mass: 0.01, position: (0.0, 0.05, 0.0)),
    ],
)"#;

fn sim() -> Simulation {
    let built = Scene::parse(FLOOR, SceneFormat::Ron)
        .expect("parses")
        .build()
        .expect("builds");
    Simulation::new(
        built,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    )
}

fn crate_of(mass: f64, at: [f64; 3]) -> SpawnDesc {
    SpawnDesc {
        kind: EntityKind::Dynamic,
        shape: ShapeDesc::Cuboid {
            half_extents: [0.5; 3],
        },
        mass: MassSpec::Mass(mass),
        position: at,
        rotation: [0.0, 0.0, 0.0, 1.0],
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        color: [200, 100, 50, 255],
        name: "crate".into(),
    }
}

#[test]
fn issue_11_spawn_of_an_absurd_mass_is_refused() {
    let mut sim = sim();
    let bodies = sim.world().bodies().count();
    let hash = sim.state_hash();
    for mass in [1e308, 2e307, 1e10, limits::MIN_MASS / 2.0] {
        let desc = crate_of(mass, [0.0, 0.6, 0.0]);
        // The admin channel's own check only asks for finite and positive.
        assert!(AdminRequest::Spawn { desc: desc.clone() }.check().is_ok());
        match sim.edit(WorldEdit::Spawn { desc }) {
            Err(EditError::Invalid(why)) => assert!(why.contains("mass"), "{mass}: {why}"),
            other => panic!("a {mass:e} kg crate: {other:?}"),
        }
    }
    assert_eq!(sim.world().bodies().count(), bodies, "nothing was added");
    assert_eq!(sim.state_hash(), hash, "nothing changed");
    for (what, desc) in [
        (
            "too fast",
            SpawnDesc {
                velocity: [2e5, 0.0, 0.0],
                ..crate_of(10.0, [0.0, 3.0, 0.0])
            },
        ),
        (
            "too far",
            SpawnDesc {
                position: [0.0, 3.0, 1e8],
                ..crate_of(10.0, [0.0, 3.0, 0.0])
            },
        ),
        (
            "too big",
            SpawnDesc {
                shape: ShapeDesc::Sphere { radius: 1e6 },
                ..crate_of(10.0, [0.0, 3.0, 0.0])
            },
        ),
    ] {
        assert!(
            matches!(
                sim.edit(WorldEdit::Spawn { desc }),
                Err(EditError::Invalid(_))
            ),
            "{what}"
        );
    }

    // The heaviest legal body, dropped on the lightest pebble, runs on.
    let heavy = crate_of(limits::MAX_MASS, [0.0, 1.2, 0.0]);
    assert!(matches!(
        sim.edit(WorldEdit::Spawn { desc: heavy }),
        Ok(EditOutcome::Spawned(_))
    ));
    sim.run_ticks(120);
    assert!(sim.state_is_sound());
}

/// Pins issue 11's abuse suite finding: an operator's impulse is capped in
/// size, but one of 1 N·s applied 10²⁰⁰ m away spun the body past any
/// bound, and the body was quarantined and removed a tick later. An
/// impulse outside the world's coordinates, or one that would leave the
/// body beyond its speed limits, is refused and changes nothing.
#[test]
fn issue_11_an_impulse_far_off_is_refused_and_changes_nothing() {
    let mut sim = sim();
    let pebble = sim
        .entities()
        .catalog()
        .into_iter()
        .find(|(_, d)| d.name == "pebble")
        .map(|(id, _)| id)
        .expect("the pebble");
    let hash = sim.state_hash();
    for point in [[0.0, 1e200, 0.0], [0.0, 1e8, 0.0], [0.0, 1e7, 0.0]] {
        let edit = WorldEdit::Impulse {
            id: pebble,
            impulse: [1.0, 0.0, 0.0],
            point: Some(point),
        };
        assert!(
            matches!(sim.edit(edit), Err(EditError::Context(_))),
            "an impulse at {point:?}"
        );
    }
    assert_eq!(sim.state_hash(), hash, "nothing changed");
    // An ordinary one, at the body's surface, still acts.
    let edit = WorldEdit::Impulse {
        id: pebble,
        impulse: [0.0, 0.01, 0.0],
        point: Some([0.05, 0.05, 0.0]),
    };
    assert!(matches!(sim.edit(edit), Ok(EditOutcome::Impulse(_))));
    sim.run_ticks(60);
    assert!(sim.state_is_sound());
    assert!(sim.entities().get(pebble).is_some(), "the pebble is there");
}

#[test]
fn issue_11_scene_masses_use_the_same_bounds() {
    for mass in ["1e308", "2e307", "1e10"] {
        let text = FLOOR.replace("mass: 0.01", &format!("mass: {mass}"));
        let err = Scene::parse(&text, SceneFormat::Ron)
            .and_then(|s| s.build())
            .expect_err(mass);
        let msg = err.to_string();
        assert!(msg.contains("bodies[1]") && msg.contains("mass"), "{msg}");
    }
}

#[test]
fn issue_11_tiny_speeds_are_refused_on_the_wire() {
    for scale in [1e-300, 5e-324, MIN_TIME_SCALE / 2.0] {
        assert!(AdminRequest::Speed { scale }.check().is_err(), "{scale}");
        assert!(AdminRequest::Reverse { speed: scale }.check().is_err());
        assert!(AdminRequest::Replay {
            from: 0,
            to: 10,
            speed: scale
        }
        .check()
        .is_err());
    }
    assert!(AdminRequest::Speed {
        scale: MIN_TIME_SCALE
    }
    .check()
    .is_ok());
    // And the tick thread refuses them too (a studio's own code calling
    // the clock directly).
    let mut sim = sim();
    assert!(sim.clock_mut().set_time_scale(1e-300).is_err());
    sim.advance(std::time::Duration::from_millis(50));
}
