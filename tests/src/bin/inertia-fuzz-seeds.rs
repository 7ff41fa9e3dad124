//! Writes the seed inputs of the fuzz targets in `fuzz/` from the real
//! encoders: a short recording of a small scene with a client and its
//! inputs (segments, keyframes, journals), the states a checkpoint and a
//! keyframe hold, and the scene files shipped in `server/scenes/`.
//! Formats guarded by checksums and compression are out of a fuzzer's
//! reach without such seeds.
//!
//! ```sh
//! cargo run -p inertia-tests --bin inertia-fuzz-seeds -- fuzz/corpus
//! ```

use inertia_protocol::input::GameInput;
use std::fs;
use std::path::{Path, PathBuf};

use inertia_protocol::message::{Delivery, GameMessage, MessageDatagram};
use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema, PropertyValue};
use inertia_protocol::PlayerInput;
use inertia_sandbox::{SandboxEvent, SandboxRequest};
use inertia_server::properties::PropertyStore;
use inertia_server::record::compress::pack;
use inertia_server::record::RecorderConfig;
use inertia_server::replay::journal::{self, JournalEntry};
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

/// A small scene with something of each kind the recording holds: a
/// static ground, dynamic bodies that touch, a joint and a rope.
const SCENE: &str = r#"(
    name: "seeds",
    spawn_points: [(0.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (20.0, 0.5, 20.0)), position: (0.0, -0.5, 0.0)),
        (name: "ball", shape: Sphere(radius: 0.3), position: (2.0, 0.4, 2.0)),
        (name: "box", shape: Cuboid(half_extents: (0.3, 0.3, 0.3)), position: (-2.0, 0.4, 1.0)),
    ],
)"#;

fn main() {
    let out = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("fuzz/corpus"));
    let scratch = std::env::temp_dir().join(format!("inertia-fuzz-seeds-{}", std::process::id()));
    let _ = fs::remove_dir_all(&scratch);

    let built = Scene::parse(SCENE, SceneFormat::Ron)
        .and_then(|s| s.build())
        .expect("the seed scene builds");
    let config = SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks: 20,
            segment_bytes: 16 * 1024,
            ..RecorderConfig::new(&scratch)
        }),
        record_at_start: true,
        ..SimConfig::default()
    };
    let mut sim = Simulation::new(built, Box::new(SandboxRules::default()), config);
    sim.join(7).expect("client 7 joins");
    let mut inputs = Vec::new();
    for i in 0..60u64 {
        let input = PlayerInput {
            sequence: i as u32 + 1,
            tick: sim.world().tick(),
            payload: inertia_sandbox::SandboxInput {
                movement: [(i % 10) as f32 / 10.0, 0.5],
                yaw: 0.25,
                buttons: (i % 4) as u8,
            }
            .to_payload(),
            view_behind: 0.0,
        };
        let _ = sim.input(7, &input);
        inputs.push(input);
        sim.run_ticks(1);
    }
    let state = sim.capture(0);
    sim.finish_recording();

    let world = state.world.clone();
    let encoded = state.encode();
    write(&out, "fuzz_world_state", "seeds", &world);
    write(&out, "fuzz_sim_state", "raw", &encoded);
    write(&out, "fuzz_sim_state", "packed", &pack(&encoded));
    write(&out, "fuzz_checkpoint", "packed", &pack(&encoded));

    let tick = state.tick;
    let entries = vec![
        JournalEntry::Join(8),
        JournalEntry::Input(7, inputs[3]),
        JournalEntry::Message(8, Delivery::Reliable, SandboxRequest::Respawn.to_bytes()),
        JournalEntry::Leave(8),
    ];
    let mut journal_seed = tick.to_le_bytes().to_vec();
    journal_seed.extend(journal::encode(tick, &entries));
    write(&out, "fuzz_journal", "join-input-leave", &journal_seed);

    let mut segments: Vec<_> = fs::read_dir(&scratch)
        .expect("the recording directory")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "irec"))
        .collect();
    segments.sort();
    for (i, segment) in segments.iter().enumerate() {
        // The target's first byte: 1 = make the checksums right first.
        let mut bytes = vec![1u8];
        bytes.extend(fs::read(segment).expect("a segment"));
        write(&out, "fuzz_segment", &format!("segment-{i}"), &bytes);
    }

    // Game messages: the target's first byte picks the decoder (0 a
    // message datagram, 1 a sandbox request, 2 a sandbox event).
    let chat = SandboxRequest::Chat { text: "gg".into() };
    let seeds: [(&str, u8, Vec<u8>); 5] = [
        (
            "datagram",
            0,
            MessageDatagram::encode(&chat.to_bytes()).expect("short"),
        ),
        ("request-chat", 1, chat.to_bytes()),
        ("request-respawn", 1, SandboxRequest::Respawn.to_bytes()),
        (
            "event-pushed",
            2,
            SandboxEvent::Pushed {
                avatar: 3,
                target: 300,
                impulse: [1.0, 2.0, -3.0],
            }
            .to_bytes(),
        ),
        (
            "event-chat",
            2,
            SandboxEvent::Chat {
                client: 7,
                text: "hello".into(),
            }
            .to_bytes(),
        ),
    ];
    // Football's: an ask, a tell, a play.
    let football: [(&str, u8, Vec<u8>); 3] = [
        (
            "football-ask",
            3,
            inertia_football::Ask::Say("gl".into()).to_bytes(),
        ),
        (
            "football-tell-goal",
            4,
            inertia_football::Tell::Goal {
                tick: 400,
                team: inertia_football::properties::Team::Red,
                scorer: Some(1),
                score: [1, 0],
            }
            .to_bytes(),
        ),
        (
            "football-play",
            5,
            inertia_football::Play::new([1.0, 0.0], 1.0, 10.0, 2)
                .to_payload()
                .as_bytes()
                .to_vec(),
        ),
    ];
    for (name, which, bytes) in seeds.into_iter().chain(football) {
        let mut seed = vec![which];
        seed.extend(bytes);
        write(&out, "fuzz_game_messages", name, &seed);
    }

    // The game's properties as a keyframe saves them (the target's schema:
    // health, heading, speed per entity; over, bonus per match).
    let schema = std::sync::Arc::new(PropertySchema {
        entity: vec![
            PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
            PropertyDecl::new("heading", PropertyKind::Int { bits: 10 }),
            PropertyDecl::new("speed", PropertyKind::F32),
        ],
        match_state: vec![
            PropertyDecl::new("over", PropertyKind::Bool),
            PropertyDecl::new("bonus", PropertyKind::Int { bits: 64 }),
        ],
    });
    let mut store = PropertyStore::new(schema);
    store.set(3, 0, PropertyValue::UInt(100)).expect("in range");
    store.set(9, 1, PropertyValue::Int(-300)).expect("in range");
    store.set(9, 2, PropertyValue::F32(2.5)).expect("in range");
    store
        .set_match(1, PropertyValue::Int(i64::MIN))
        .expect("in range");
    write(&out, "fuzz_property_store", "two-rows", &store.to_bytes());

    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../server/scenes");
    for entry in fs::read_dir(&scenes).expect("server/scenes") {
        let path = entry.expect("a scene file").path();
        let target = match path.extension().and_then(|x| x.to_str()) {
            Some("ron") => "fuzz_scene_ron",
            Some("json") => "fuzz_scene_json",
            _ => continue,
        };
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
        write(&out, target, name, &fs::read(&path).expect("a scene file"));
    }
    write(&out, "fuzz_scene_ron", "seeds", SCENE.as_bytes());
    let _ = fs::remove_dir_all(&scratch);
}

/// Writes one seed as `<out>/<target>/seed-<name>`.
fn write(out: &Path, target: &str, name: &str, bytes: &[u8]) {
    let dir = out.join(target);
    fs::create_dir_all(&dir).expect("a corpus directory");
    let path = dir.join(format!("seed-{name}"));
    fs::write(&path, bytes).expect("writing a seed");
    println!("{} ({} bytes)", path.display(), bytes.len());
}
