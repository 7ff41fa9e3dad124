//! Issue 11: a 100 000-body scene started and ran at 1.7 ticks a second
//! with nothing said. `--max-bodies` bounds the rigid bodies in the world
//! wherever they come from (the scene at start, an operator's spawn, a
//! client's avatar, a loaded state), and the first ticks' cost is measured
//! against the tick budget and said.

use inertia_protocol::admin::{MassSpec, SpawnDesc};
use inertia_protocol::{EntityKind, ShapeDesc};
use inertia_server::config::ServerConfig;
use inertia_server::replay::WorldEdit;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::server::StartError;
use inertia_server::sim::edit::EditError;
use inertia_server::sim::startup::STARTUP_TICKS;
use inertia_server::sim::{SimConfig, Simulation};

/// A ground and a 4 × 4 × 4 grid of crates: 65 rigid bodies.
const GRID: &str = r#"(
    name: "grid",
    spawn_points: [(0.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (20.0, 0.5, 20.0)), position: (0.0, -0.5, 0.0)),
    ],
    generators: [
        Grid(
            name: "crate",
            body: (name: "crate", shape: Cuboid(half_extents: (0.25, 0.25, 0.25))),
            counts: (4, 4, 4),
            spacing: (1.0, 1.0, 1.0),
            origin: (-1.5, 0.3, -1.5),
        ),
    ],
)"#;

fn sim(max_bodies: usize) -> Simulation {
    let mut built = Scene::parse(GRID, SceneFormat::Ron)
        .expect("parses")
        .build()
        .expect("builds");
    built
        .world
        .set_max_bodies(max_bodies)
        .expect("within the limit");
    Simulation::new(
        built,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    )
}

fn crate_at(x: f64) -> SpawnDesc {
    SpawnDesc {
        kind: EntityKind::Dynamic,
        shape: ShapeDesc::Cuboid {
            half_extents: [0.25; 3],
        },
        mass: MassSpec::Mass(10.0),
        position: [x, 5.0, 8.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        color: [200, 100, 50, 255],
        name: "crate".into(),
    }
}

#[test]
fn issue_11_scene_over_max_bodies_is_refused_at_start() {
    let dir =
        std::env::temp_dir().join(format!("inertia-issue11-maxbodies-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    let scene = dir.join("grid.ron");
    std::fs::write(&scene, GRID).expect("scene file");
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir.join("data"),
        scene: Some(scene),
        max_bodies: 64,
        ..Default::default()
    };
    let rt = tokio::runtime::Runtime::new().expect("runtime");
    match rt.block_on(inertia_server::server::start(config)) {
        Err(
            e @ StartError::TooManyBodies {
                bodies: 65,
                max: 64,
            },
        ) => {
            let said = e.to_string();
            assert!(
                said.contains("65") && said.contains("--max-bodies 64"),
                "{said}"
            );
        }
        Err(e) => panic!("refused for another reason: {e}"),
        Ok(_) => panic!("a 65-body scene started under --max-bodies 64"),
    }
    assert!(
        !dir.join("data").exists(),
        "nothing is written for a refused scene"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn issue_11_spawn_beyond_max_bodies_is_refused_and_changes_nothing() {
    let mut s = sim(66);
    s.edit(WorldEdit::Spawn {
        desc: crate_at(0.0),
    })
    .expect("the 66th body fits");
    let hash = s.state_hash();
    match s.edit(WorldEdit::Spawn {
        desc: crate_at(1.0),
    }) {
        Err(EditError::Invalid(why)) => assert!(why.contains("66"), "{why}"),
        other => panic!("the 67th body: {other:?}"),
    }
    assert_eq!(s.world().bodies().count(), 66);
    assert_eq!(s.state_hash(), hash, "nothing changed");
    s.run_ticks(3);
}

#[test]
fn issue_11_avatar_beyond_max_bodies_is_refused() {
    let mut s = sim(65);
    assert!(s.join(7).is_err(), "no room for an avatar");
    assert_eq!(s.world().bodies().count(), 65);
    let mut roomy = sim(66);
    roomy.join(7).expect("room for one avatar");
}

#[test]
fn issue_11_loaded_state_beyond_max_bodies_is_refused() {
    let mut big = sim(1000);
    for i in 0..10 {
        big.edit(WorldEdit::Spawn {
            desc: crate_at(f64::from(i)),
        })
        .expect("room");
    }
    let state = big.capture(0);
    let mut small = sim(70);
    let hash = small.state_hash();
    let err = small
        .restore(&state)
        .expect_err("a 75-body state under a limit of 70");
    assert!(err.to_string().contains("70"), "{err}");
    assert_eq!(small.state_hash(), hash, "nothing changed");
    assert_eq!(small.world().bodies().count(), 65);
}

#[test]
fn issue_11_first_ticks_are_measured_against_the_tick_budget() {
    let mut s = sim(1000);
    assert_eq!(s.startup_cost(), None);
    s.run_ticks(STARTUP_TICKS as u64 - 1);
    assert_eq!(s.startup_cost(), None, "not before the startup ticks");
    s.run_ticks(1);
    let cost = s.startup_cost().expect("said after the startup ticks");
    assert_eq!(cost.ticks, STARTUP_TICKS);
    assert_eq!(cost.budget, std::time::Duration::from_secs_f64(1.0 / 60.0));
    assert!(cost.median > std::time::Duration::ZERO && cost.median <= cost.max);
    assert_eq!(cost.over_budget(), cost.median > cost.budget);
}

/// The grid scene with a joint that names no body after it: building
/// checks joints after bodies, so a build under the limit stops at the
/// 65th body and never reaches the joint.
fn grid_with_a_bad_joint_and(extra_generators: usize) -> String {
    let big = r#"Grid(
            name: "filler",
            body: (name: "filler", shape: Sphere(radius: 0.1)),
            counts: (100, 100, 10),
            spacing: (0.5, 0.5, 0.5),
            origin: (0.0, 50.0, 0.0),
        ),"#;
    let extra = big.repeat(extra_generators);
    GRID.replace(
        "    ],\n)",
        &format!(
            "    {extra}\n    ],\n    joints: [(a: \"ground\", b: \"nowhere\", kind: Ball)],\n)"
        ),
    )
}

fn start_refusal(scene_text: &str, max_bodies: usize) -> StartError {
    let dir = std::env::temp_dir().join(format!(
        "inertia-issue11-onebuild-{}-{}",
        std::process::id(),
        scene_text.len()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    let scene = dir.join("scene.ron");
    std::fs::write(&scene, scene_text).expect("scene file");
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir.join("data"),
        scene: Some(scene),
        max_bodies,
        ..Default::default()
    };
    let rt = tokio::runtime::Runtime::new().expect("runtime");
    let refusal = match rt.block_on(inertia_server::server::start(config)) {
        Err(e) => e,
        Ok(_) => panic!("the scene started"),
    };
    assert!(!dir.join("data").exists(), "nothing is written");
    let _ = std::fs::remove_dir_all(&dir);
    refusal
}

/// A scene file is built once at start, under `--max-bodies`: one that
/// would make a million bodies is refused at the body past the limit, not
/// built whole (twice, as it was: once to check it, once to run it).
#[test]
fn issue_11_scene_is_built_once_under_max_bodies() {
    // Past the limit before the bad joint: the limit is what is said.
    match start_refusal(&grid_with_a_bad_joint_and(0), 64) {
        StartError::TooManyBodies {
            bodies: 65,
            max: 64,
        } => {}
        e => panic!("refused for another reason: {e}"),
    }
    // Under a limit it fits, the joint is what is said.
    match start_refusal(&grid_with_a_bad_joint_and(0), 1000) {
        StartError::Scene(e) => assert_eq!(e.at(), Some("joints[0].b"), "{e}"),
        e => panic!("refused for another reason: {e}"),
    }
    // Ten generators of 100 000 bodies each: refused at body 65.
    match start_refusal(&grid_with_a_bad_joint_and(10), 64) {
        StartError::TooManyBodies { max: 64, .. } => {}
        e => panic!("refused for another reason: {e}"),
    }
}
