//! Time control, recording and replay with the simulation driven by hand:
//! seeking to any recorded tick re-simulates exactly the recorded state;
//! stepping forward from the past hands over to the live world; reverse
//! play and replays show recorded ticks and give the live world back as it
//! was left; a checkpoint saved to a file and loaded again continues with
//! identical hashes, and bad checkpoint files are refused without changing
//! anything; a paused clock runs no ticks.

use inertia_protocol::input::GameInput;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use inertia_protocol::admin::{MassSpec, SpawnDesc, TimeMode};
use inertia_protocol::connection::ReceivedMessage;
use inertia_protocol::input::quantize_input;
use inertia_protocol::message::{Delivery, GameMessage};
use inertia_protocol::rng::SplitMix;
use inertia_protocol::{EntityId, EntityKind, PlayerInput, ShapeDesc};
use inertia_sandbox::{buttons, SandboxRequest};
use inertia_server::record::RecorderConfig;
use inertia_server::replay::checkpoint::{CheckpointDir, CheckpointError, CheckpointName};
use inertia_server::replay::{JournalEntry, SimState, StateError, WorldEdit};
use inertia_server::rules::{ClientId, SandboxRules};
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::edit::EditOutcome;
use inertia_server::sim::{SimConfig, Simulation};

/// A walled pen with a few dozen bodies (spheres, boxes, capsules) dropped
/// into it and room for eight avatars: busy enough that every tick moves
/// something, small enough that ten thousand ticks take seconds.
const PEN: &str = r#"(
    name: "pen",
    spawn_points: [
        (-4.0, 1.2, -4.0), (-1.5, 1.2, -4.0), (1.5, 1.2, -4.0), (4.0, 1.2, -4.0),
        (-4.0, 1.2, 4.0), (-1.5, 1.2, 4.0), (1.5, 1.2, 4.0), (4.0, 1.2, 4.0),
    ],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (30.0, 0.5, 30.0)), position: (0.0, -0.5, 0.0)),
        (name: "wall_n", kind: Static, shape: Cuboid(half_extents: (7.0, 1.0, 0.25)), position: (0.0, 1.0, -7.0)),
        (name: "wall_s", kind: Static, shape: Cuboid(half_extents: (7.0, 1.0, 0.25)), position: (0.0, 1.0, 7.0)),
        (name: "wall_w", kind: Static, shape: Cuboid(half_extents: (0.25, 1.0, 7.0)), position: (-7.0, 1.0, 0.0)),
        (name: "wall_e", kind: Static, shape: Cuboid(half_extents: (0.25, 1.0, 7.0)), position: (7.0, 1.0, 0.0)),
        (name: "roller", shape: Capsule(half_height: 0.4, radius: 0.25), position: (0.0, 4.0, 0.0), velocity: (2.0, 0.0, 1.0)),
    ],
    generators: [
        Grid(name: "ball", counts: (4, 2, 3), spacing: (1.3, 1.1, 1.3), origin: (-2.0, 1.5, -1.3),
             body: (shape: Sphere(radius: 0.3), density: 300.0, restitution: 0.5), ),
        Grid(name: "crate", counts: (3, 1, 3), spacing: (1.5, 0.0, 1.5), origin: (-1.5, 4.0, -1.5),
             body: (shape: Cuboid(half_extents: (0.3, 0.3, 0.3)), density: 400.0, friction: 0.6), ),
    ],
)"#;

/// Clients 1..=8.
const BOTS: u64 = 8;

fn temp_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inertia-timeline-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    dir
}

/// Recording into `<dir>/recording`, a keyframe every `keyframe_ticks`.
fn config(dir: &Path, keyframe_ticks: u64) -> SimConfig {
    SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks,
            // Ticks here run as fast as the machine goes, far faster than
            // real time: a recorder thread starved by other tests must not
            // fill the channel (a dropped record ends the recording, and
            // the history with it).
            capacity: 1 << 16,
            ..RecorderConfig::new(dir.join("recording"))
        }),
        record_at_start: true,
        ..SimConfig::default()
    }
}

fn sim(config: SimConfig) -> Simulation {
    let built = Scene::parse(PEN, SceneFormat::Ron)
        .expect("the scene parses")
        .build()
        .expect("the scene builds");
    Simulation::new(built, Box::new(SandboxRules::default()), config)
}

/// One wall tick at 60 Hz, a hair long so each advance owes exactly one.
const FRAME: Duration = Duration::from_nanos(16_666_667);

/// Fake clients that send a random, wire-quantized input every tick.
struct Bots {
    rng: SplitMix,
    sequence: BTreeMap<ClientId, u32>,
    present: BTreeSet<ClientId>,
}

impl Bots {
    fn new(seed: u64) -> Self {
        Bots {
            rng: SplitMix(seed),
            sequence: (1..=BOTS).map(|c| (c, 0)).collect(),
            present: BTreeSet::new(),
        }
    }

    fn join(&mut self, sim: &mut Simulation, client: ClientId) {
        sim.join(client)
            .unwrap_or_else(|e| panic!("client {client} joins: {e}"));
        self.present.insert(client);
    }

    fn leave(&mut self, sim: &mut Simulation, client: ClientId) {
        sim.leave(client);
        self.present.remove(&client);
    }

    fn input(&mut self, client: ClientId, tick: u64) -> PlayerInput {
        let seq = self.sequence.entry(client).or_insert(0);
        *seq += 1;
        let sequence = *seq;
        let r = &mut self.rng;
        let mut b = 0;
        if r.uniform() < 0.15 {
            b |= buttons::JUMP;
        }
        if r.uniform() < 0.2 {
            b |= buttons::PUSH;
        }
        quantize_input(&PlayerInput {
            sequence,
            tick,
            payload: inertia_sandbox::SandboxInput {
                movement: [r.range(-1.0, 1.0) as f32, r.range(-1.0, 1.0) as f32],
                yaw: r.range(-std::f64::consts::PI, std::f64::consts::PI) as f32,
                buttons: b,
            }
            .to_payload(),
            view_behind: 0.0,
        })
    }

    /// Sends every present client's input for the current tick; returns
    /// what was sent (all accepted).
    fn send(&mut self, sim: &mut Simulation) -> Vec<(ClientId, PlayerInput)> {
        let tick = sim.world().tick();
        self.send_for(sim, tick)
    }

    /// Sends every present client's input stamped for `tick` (one that
    /// has passed is applied at once); returns what was sent.
    fn send_for(&mut self, sim: &mut Simulation, tick: u64) -> Vec<(ClientId, PlayerInput)> {
        let clients: Vec<ClientId> = self.present.iter().copied().collect();
        let mut sent = Vec::new();
        for c in clients {
            let input = self.input(c, tick);
            sim.input(c, &input)
                .unwrap_or_else(|e| panic!("client {c} at tick {tick}: {e}"));
            sent.push((c, input));
        }
        sent
    }
}

/// Entity ids of the scene's dynamic bodies named `prefix…`, by name.
fn named(sim: &mut Simulation, prefix: &str) -> Vec<EntityId> {
    let mut v: Vec<(String, EntityId)> = sim
        .frame()
        .catalog
        .iter()
        .filter(|(_, d)| d.name.starts_with(prefix))
        .map(|(id, d)| (d.name.clone(), *id))
        .collect();
    v.sort();
    v.into_iter().map(|(_, id)| id).collect()
}

fn spawn_desc(name: &str, x: f64) -> SpawnDesc {
    SpawnDesc {
        kind: EntityKind::Dynamic,
        shape: ShapeDesc::Sphere { radius: 0.4 },
        mass: MassSpec::Mass(8.0),
        position: [x, 3.0, 0.5],
        rotation: [0.0, 0.0, 0.0, 1.0],
        velocity: [0.5, 0.0, -1.0],
        angular_velocity: [0.0, 1.0, 0.0],
        color: [255, 0, 0, 255],
        name: name.into(),
    }
}

/// `hashes[t]`: the live state hash after tick `t` (`hashes[0]` the state
/// the recording started from).
struct Run {
    sim: Simulation,
    hashes: Vec<u64>,
    dir: PathBuf,
    bots: Bots,
}

/// Records `ticks` ticks of eight bots sending random inputs every tick;
/// bots 3 and 6 leave at tick 3000 and rejoin at 3600, bot 8 leaves at
/// 0.7 × ticks for good; an operator pushes, spawns and despawns bodies.
fn record(what: &str, ticks: u64, keyframe_ticks: u64) -> Run {
    let dir = temp_dir(what);
    let mut sim = sim(config(&dir, keyframe_ticks));
    assert!(sim.recording());
    let mut hashes = vec![sim.state_hash()];
    let mut bots = Bots::new(0x5eed_0000 + ticks);
    for c in 1..=BOTS {
        bots.join(&mut sim, c);
    }
    let balls = named(&mut sim, "ball[");
    let crates = named(&mut sim, "crate[");
    assert_eq!((balls.len(), crates.len()), (24, 9));
    let mut spawned: Option<EntityId> = None;
    let scaled = |f: f64| (ticks as f64 * f) as u64;
    for t in 0..ticks {
        assert_eq!(sim.world().tick(), t);
        if t == scaled(0.3) && ticks >= 3600 {
            bots.leave(&mut sim, 3);
            bots.leave(&mut sim, 6);
        }
        if t == scaled(0.36) && ticks >= 3600 {
            bots.join(&mut sim, 3);
            bots.join(&mut sim, 6);
        }
        if t == scaled(0.7) {
            bots.leave(&mut sim, 8);
        }
        if t == scaled(0.15) {
            let outcome = sim
                .edit(WorldEdit::Impulse {
                    id: balls[5],
                    impulse: [4.0, 6.0, -2.0],
                    point: None,
                })
                .expect("a ball takes an impulse");
            assert!(matches!(outcome, EditOutcome::Impulse(_)));
        }
        if t == scaled(0.25) {
            match sim.edit(WorldEdit::Spawn {
                desc: spawn_desc("visitor", 1.0),
            }) {
                Ok(EditOutcome::Spawned(id)) => spawned = Some(id),
                other => panic!("spawn: {other:?}"),
            }
        }
        if t == scaled(0.4) {
            sim.edit(WorldEdit::Impulse {
                id: spawned.expect("spawned"),
                impulse: [-10.0, 20.0, 5.0],
                point: Some([1.0, 3.0, 0.5]),
            })
            .expect("the visitor takes an impulse");
        }
        if t == scaled(0.6) {
            sim.edit(WorldEdit::Despawn { id: crates[4] })
                .expect("a crate goes");
        }
        if t == scaled(0.8) {
            sim.edit(WorldEdit::Despawn {
                id: spawned.expect("spawned"),
            })
            .expect("the visitor goes");
        }
        // Players' messages: a chat line, and a respawn (which moves an
        // avatar, so a seek past it reproduces the hash only if the
        // journal hands it to the rules again at its tick).
        if t == scaled(0.5) {
            message(&mut sim, 1, &SandboxRequest::Chat { text: "gg".into() });
            message(&mut sim, 2, &SandboxRequest::Respawn);
        }
        bots.send(&mut sim);
        sim.run_ticks(1);
        hashes.push(sim.state_hash());
    }
    Run {
        sim,
        hashes,
        dir,
        bots,
    }
}

/// `client` sends `request` reliably, as its connection would hand it on.
fn message(sim: &mut Simulation, client: u64, request: &SandboxRequest) {
    let message = ReceivedMessage {
        delivery: Delivery::Reliable,
        bytes: request.to_bytes(),
    };
    sim.message(client, message)
        .expect("a message of a client in the game");
}

/// The kinds of entry the journal holds over `ticks`.
fn journal_kinds(sim: &Simulation, ticks: std::ops::Range<u64>) -> [bool; 5] {
    let history = sim.history().expect("a history");
    let mut kinds = [false; 5];
    for t in ticks {
        for e in history.journal_at(t) {
            let k = match e {
                JournalEntry::Join(_) => 0,
                JournalEntry::Leave(_) => 1,
                JournalEntry::Input(..) => 2,
                JournalEntry::Edit(_) => 3,
                JournalEntry::Message(..) => 4,
            };
            kinds[k] = true;
        }
    }
    kinds
}

#[test]
fn ten_thousand_ticks_of_eight_bots_seek_to_any_tick_with_the_recorded_hash() {
    const TICKS: u64 = 10_000;
    let t0 = Instant::now();
    let Run {
        mut sim,
        hashes,
        dir,
        mut bots,
    } = record("seek", TICKS, 600);
    let recorded_in = t0.elapsed();
    let live = sim.world().tick();
    let live_hash = sim.state_hash();
    assert_eq!(live, TICKS);
    assert_eq!(sim.client_count(), 7);
    assert_eq!(
        journal_kinds(&sim, 0..TICKS),
        [true; 5],
        "joins, leaves, inputs, edits and messages are all in the journal"
    );
    {
        let history = sim.history().expect("a history");
        assert_eq!(history.range().map(|r| r.1), Some(TICKS));
        for (t, h) in hashes.iter().enumerate().skip(1) {
            assert_eq!(history.hash_at(t as u64), Some(*h), "tick {t} recorded");
        }
    }

    // A hundred seeks in random order.
    let mut rng = SplitMix(0x7133_5eec);
    let t1 = Instant::now();
    let mut resimulated = 0;
    for i in 0..100 {
        let tick = 1 + rng.next_u64() % (TICKS - 1);
        let report = sim
            .seek(tick)
            .unwrap_or_else(|e| panic!("seek {tick}: {e}"));
        assert_eq!(report.tick, tick);
        assert_eq!(sim.world().tick(), tick);
        assert_eq!(
            report.state_hash,
            report.recorded_hash.expect("the tick is recorded"),
            "seek #{i} to tick {tick} (from tick {}, {} ticks re-simulated)",
            report.base_tick,
            report.resimulated
        );
        assert_eq!(report.state_hash, hashes[tick as usize], "tick {tick}");
        assert_eq!(sim.state_hash(), report.state_hash);
        assert_eq!(sim.mode(), TimeMode::History);
        assert_eq!(sim.live_tick(), live, "the live world stands still");
        assert!(report.base_tick <= tick);
        resimulated += report.resimulated;
    }
    let seeks_in = t1.elapsed();

    // `hash_at` re-simulates without changing what is shown.
    let shown = sim.world().tick();
    let other = if shown > 5000 { 1234 } else { 8765 };
    let r = sim.hash_at(other).expect("a recorded tick");
    assert_eq!(r.state_hash, hashes[other as usize]);
    assert_eq!(sim.world().tick(), shown);
    assert_eq!(sim.state_hash(), hashes[shown as usize]);

    // Back to the live tick: the live world, as it was.
    let back = sim.seek(live).expect("the live tick");
    assert_eq!(sim.mode(), TimeMode::Live);
    assert_eq!((back.tick, back.state_hash), (live, live_hash));
    assert_eq!(back.recorded_hash, Some(live_hash));
    assert_eq!((sim.world().tick(), sim.state_hash()), (live, live_hash));
    assert_eq!(sim.client_count(), 7);

    // Stepping forward from the past follows the recording and hands over
    // to the live world at the live tick.
    let from = live - 650;
    sim.seek(from).expect("a recorded tick");
    for t in from + 1..=live {
        sim.run_ticks(1);
        assert_eq!(sim.world().tick(), t);
        assert_eq!(sim.state_hash(), hashes[t as usize], "stepping to tick {t}");
        if t < live {
            assert_ne!(sim.mode(), TimeMode::Live, "tick {t} is history");
        }
    }
    assert_eq!(sim.mode(), TimeMode::Live, "the live world took over");
    assert_eq!(sim.live_tick(), live);
    assert_eq!(sim.state_hash(), live_hash);
    assert!(sim.clock().paused(), "handed over paused, as the view was");

    // The same with the clock playing the view forward at real time: it
    // runs on live at the same speed without a pause.
    sim.seek(live - 30).expect("a recorded tick");
    sim.clock_mut().resume();
    assert_eq!(sim.mode(), TimeMode::Forward);
    for k in 1..=30u64 {
        assert_eq!(sim.advance(FRAME), 1);
        assert_eq!(sim.state_hash(), hashes[(live - 30 + k) as usize]);
    }
    assert_eq!(sim.mode(), TimeMode::Live);
    assert_eq!((sim.world().tick(), sim.state_hash()), (live, live_hash));
    assert!(!sim.clock().paused());
    // Live again: bots play on and every new tick is recorded.
    for _ in 0..3 {
        bots.send(&mut sim);
        assert_eq!(sim.advance(FRAME), 1);
    }
    assert_eq!(sim.world().tick(), live + 3);
    assert_ne!(sim.state_hash(), live_hash);
    assert_eq!(
        sim.history().and_then(|h| h.hash_at(live + 3)),
        Some(sim.state_hash()),
        "the live world records on"
    );
    println!(
        "recorded {TICKS} ticks with {BOTS} bots in {:.2} s; 100 seeks in {:.2} s ({} ticks re-simulated, {:.0} per seek)",
        recorded_in.as_secs_f64(),
        seeks_in.as_secs_f64(),
        resimulated,
        resimulated as f64 / 100.0
    );
    sim.finish_recording();
    std::fs::remove_dir_all(&dir).ok();
}

/// Sends the inputs stored for `tick`.
fn resend(sim: &mut Simulation, inputs: &BTreeMap<u64, Vec<(ClientId, PlayerInput)>>, tick: u64) {
    for (c, input) in inputs.get(&tick).map(Vec::as_slice).unwrap_or_default() {
        sim.input(*c, input)
            .unwrap_or_else(|e| panic!("client {c} at tick {tick}: {e}"));
    }
}

#[test]
fn save_load_and_continue_give_identical_hashes() {
    const N: u64 = 300;
    const M: u64 = 300;
    let Run {
        mut sim,
        hashes: _,
        dir,
        mut bots,
    } = record("save-load", N, 120);
    assert_eq!(sim.world().tick(), N);
    // Inputs for a tick that has passed are applied at once, before the
    // save: the checkpoint holds them (they are not sent again after the
    // load). Inputs held for a tick to come are not part of a state.
    let mut inputs = BTreeMap::new();
    inputs.insert(N, bots.send_for(&mut sim, N - 1));
    let state = sim.checkpoint();
    assert_eq!(state.tick, N);
    assert_eq!(state.applied, BOTS as u32 - 1, "seven bots' inputs applied");
    let saved_hash = sim.state_hash();
    let checkpoints = CheckpointDir::new(dir.join("checkpoints"));
    let saved = name("save.isim");
    checkpoints
        .write(&saved, &state.encode(), false)
        .expect("written");
    let file = checkpoints.path().join("save.isim");

    let mut after = Vec::new();
    for t in N..N + M {
        if t > N {
            inputs.insert(t, bots.send(&mut sim));
        }
        sim.run_ticks(1);
        after.push(sim.state_hash());
    }
    assert_ne!(sim.state_hash(), saved_hash);

    // Bad files are refused with a typed error; loading nothing changes
    // nothing.
    let good = std::fs::read(&file).expect("the checkpoint");
    refuses_bad_checkpoints(&dir, &checkpoints, &good, &state.encode(), &sim);
    let (tick, hash) = (sim.world().tick(), sim.state_hash());
    for bad in broken_states(&state) {
        let e = sim.load(&bad, "ops").expect_err("a broken state");
        assert!(
            matches!(e, StateError::World(_) | StateError::Rules(_)),
            "{e:?}"
        );
        assert_eq!((sim.world().tick(), sim.state_hash()), (tick, hash));
        assert!(sim.recording());
        assert_eq!(sim.client_count(), 7);
    }

    // Load the file and play the same inputs again: the same hashes.
    let loaded = checkpoints.read(&saved).expect("the checkpoint reads back");
    assert_eq!(
        loaded.encode(),
        state.encode(),
        "read gives back what was written"
    );
    let h = sim.load(&loaded, "ops").expect("loads");
    assert_eq!(h, saved_hash);
    assert_eq!(
        (sim.world().tick(), sim.state_hash()),
        (N, saved_hash),
        "the saved tick and state"
    );
    assert_eq!(sim.client_count(), 7);
    assert!(sim.recording(), "recording goes on as a new session");
    for (k, t) in (N..N + M).enumerate() {
        if t > N {
            resend(&mut sim, &inputs, t);
        }
        sim.run_ticks(1);
        assert_eq!(sim.state_hash(), after[k], "tick {} after the load", t + 1);
    }
    assert_eq!(
        sim.history().and_then(|h| h.hash_at(N + M)),
        Some(after[M as usize - 1]),
        "the new session recorded the ticks after the load"
    );

    // A fresh simulation made from the file continues the same way.
    let mut fresh = Simulation::from_state(
        &loaded,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    )
    .expect("restores");
    assert_eq!(fresh.state_hash(), saved_hash);
    for (k, t) in (N..N + M).enumerate() {
        if t > N {
            resend(&mut fresh, &inputs, t);
        }
        fresh.run_ticks(1);
        assert_eq!(fresh.state_hash(), after[k], "fresh: tick {}", t + 1);
    }
    sim.finish_recording();
    std::fs::remove_dir_all(&dir).ok();
}

/// States that decode but do not restore: a cut world, rules' garbage.
fn broken_states(state: &SimState) -> Vec<SimState> {
    let mut cut = state.clone();
    cut.world.truncate(cut.world.len() / 2);
    let mut rules = state.clone();
    rules.rules = b"not the rules' state".to_vec();
    vec![cut, rules]
}

fn name(s: &str) -> CheckpointName {
    CheckpointName::new(s).expect("a checkpoint name")
}

/// `good`: a checkpoint file as written; `raw`: the state it holds,
/// encoded.
fn refuses_bad_checkpoints(
    dir: &Path,
    checkpoints: &CheckpointDir,
    good: &[u8],
    raw: &[u8],
    sim: &Simulation,
) {
    let write = |n: &str, bytes: &[u8]| {
        std::fs::write(checkpoints.path().join(n), bytes).expect("written");
        (checkpoints.clone(), name(n))
    };
    let state_error = |(d, n): (CheckpointDir, CheckpointName)| match d.read(&n) {
        Err(CheckpointError::State { source, .. }) => source,
        other => panic!("{n}: expected a state error, got {other:?}"),
    };
    let mut rng = SplitMix(17);
    let garbage: Vec<u8> = (0..4096).map(|_| rng.next_u64() as u8).collect();
    let p = write("garbage.isim", &garbage);
    assert_eq!(state_error(p), StateError::BadMagic);
    assert_eq!(
        SimState::decode(&garbage).unwrap_err(),
        StateError::BadMagic
    );

    // Cut short, packed as written or not; one byte too many.
    for (what, bytes, cuts) in [
        ("packed", good, vec![good.len() / 2, good.len() - 1, 17]),
        ("raw", raw, vec![raw.len() / 2, raw.len() - 1, 17, 5]),
    ] {
        for cut in cuts {
            let p = write("truncated.isim", &bytes[..cut]);
            let e = state_error(p);
            assert!(
                matches!(e, StateError::Malformed(_)),
                "{what}, {cut} bytes: {e:?}"
            );
            assert_eq!(SimState::decode(&bytes[..cut]).unwrap_err(), e);
        }
    }
    let mut longer = raw.to_vec();
    longer.push(0);
    assert!(matches!(
        state_error(write("longer.isim", &longer)),
        StateError::Malformed(_)
    ));

    // Other formats: the engine's own save, a recording segment, JSON,
    // nothing at all, a newer version of this one.
    let world = sim.world().save();
    assert_eq!(
        state_error(write("world.bin", &world)),
        StateError::BadMagic
    );
    let segment = std::fs::read_dir(dir.join("recording"))
        .expect("the recording")
        .map(|e| e.expect("an entry").path())
        .find(|p| p.is_file())
        .expect("a segment file");
    let segment_name = name(segment.file_name().and_then(|n| n.to_str()).expect("UTF-8"));
    assert_eq!(
        state_error((CheckpointDir::new(dir.join("recording")), segment_name)),
        StateError::BadMagic
    );
    assert_eq!(
        state_error(write("x.json", br#"{"tick": 3}"#)),
        StateError::BadMagic
    );
    assert_eq!(state_error(write("empty", b"")), StateError::BadMagic);
    let newer_version = inertia_server::replay::state::STATE_VERSION + 1;
    let mut newer = raw.to_vec();
    newer[4..6].copy_from_slice(&newer_version.to_le_bytes());
    assert_eq!(
        state_error(write("newer.isim", &newer)),
        StateError::Version(newer_version)
    );
    let packed = name("newer-packed.isim");
    checkpoints.write(&packed, &newer, false).expect("written");
    assert_eq!(
        state_error((checkpoints.clone(), packed)),
        StateError::Version(newer_version)
    );
    assert!(matches!(
        checkpoints.read(&name("no-such-file")),
        Err(CheckpointError::NotFound { .. })
    ));
}

#[test]
fn reverse_play_shows_each_recorded_tick_back_to_the_start_and_replay_returns_to_live() {
    const TICKS: u64 = 400;
    let Run {
        mut sim,
        hashes,
        dir,
        bots: _,
    } = record("reverse", TICKS, 120);
    let live_hash = sim.state_hash();
    let recorded = |sim: &Simulation, t: u64| sim.history().and_then(|h| h.hash_at(t));

    // Backwards at real time: one tick less per 1/60 s.
    sim.reverse(1.0).expect("there is a recording");
    assert_eq!(sim.mode(), TimeMode::Reverse);
    assert_eq!(sim.live_tick(), TICKS);
    let t0 = Instant::now();
    for t in (0..TICKS).rev() {
        assert_eq!(sim.advance(FRAME), 1);
        assert_eq!(sim.world().tick(), t, "one tick back per 1/60 s");
        if t > 0 {
            assert_eq!(recorded(&sim, t), Some(hashes[t as usize]));
        }
        assert_eq!(sim.state_hash(), hashes[t as usize], "reverse at tick {t}");
        assert_eq!(sim.live_tick(), TICKS, "the live world stands still");
    }
    let reversed_in = t0.elapsed();
    // It stops, paused, at the recording's first tick.
    assert!(sim.clock().paused());
    assert_eq!(sim.mode(), TimeMode::History);
    for _ in 0..10 {
        sim.advance(FRAME);
    }
    assert_eq!((sim.world().tick(), sim.state_hash()), (0, hashes[0]));

    let back = sim.seek(TICKS).expect("the live tick");
    assert_eq!(sim.mode(), TimeMode::Live);
    assert_eq!(back.state_hash, live_hash);
    assert_eq!((sim.world().tick(), sim.state_hash()), (TICKS, live_hash));
    assert!(sim.clock().paused(), "seeking pauses");

    println!(
        "reverse play over {TICKS} ticks in {:.2} s",
        reversed_in.as_secs_f64()
    );

    // A replay of 100..=300 at 4×: four recorded ticks per 1/60 s, then
    // the live world where it was left.
    replay_and_return(&mut sim, &hashes, 100, 300, live_hash);
    // Again over a stretch that does not end on a whole 1/60 s: the live
    // world still comes back exactly as it was left.
    replay_and_return(&mut sim, &hashes, 103, 300, live_hash);
    sim.finish_recording();
    std::fs::remove_dir_all(&dir).ok();
}

fn replay_and_return(sim: &mut Simulation, hashes: &[u64], from: u64, to: u64, live_hash: u64) {
    let live = sim.live_tick();
    let report = sim.replay(from, to, 4.0).expect("a recorded stretch");
    assert_eq!(report.tick, from);
    assert_eq!(Some(report.state_hash), report.recorded_hash);
    assert_eq!(report.state_hash, hashes[from as usize]);
    assert_eq!(sim.mode(), TimeMode::Replay);
    let mut shown = from;
    let mut advances = 0;
    while sim.mode() == TimeMode::Replay {
        let n = sim.advance(FRAME);
        advances += 1;
        assert!(advances <= (to - from) / 4 + 2, "the replay ends");
        assert_eq!(n, 4, "4× is four ticks per 1/60 s");
        if sim.mode() == TimeMode::Replay {
            shown += 4;
            assert_eq!(sim.world().tick(), shown);
            assert_eq!(sim.state_hash(), hashes[shown as usize], "replay {shown}");
        }
    }
    assert_eq!(sim.mode(), TimeMode::Live);
    assert_eq!(
        (sim.world().tick(), sim.state_hash()),
        (live, live_hash),
        "replay {from}..={to}: the live world comes back where it was left"
    );
    assert!(sim.clock().paused(), "and as it was left: paused");
    sim.advance(FRAME);
    assert_eq!(sim.world().tick(), live);
}

#[test]
fn a_paused_clock_runs_no_ticks_and_resume_continues_from_the_same_hash() {
    let dir = temp_dir("pause");
    let mut paused = sim(config(&dir, 600));
    let mut straight = sim(SimConfig::default());
    let mut bots_a = Bots::new(5);
    let mut bots_b = Bots::new(5);
    for c in 1..=BOTS {
        bots_a.join(&mut paused, c);
        bots_b.join(&mut straight, c);
    }
    let play = |s: &mut Simulation, bots: &mut Bots, frames: u32| {
        for _ in 0..frames {
            bots.send(s);
            assert_eq!(s.advance(FRAME), 1);
        }
    };
    play(&mut paused, &mut bots_a, 120);
    play(&mut straight, &mut bots_b, 120);
    assert_eq!(paused.state_hash(), straight.state_hash());

    paused.clock_mut().pause();
    assert!(paused.clock().paused());
    assert_eq!(paused.frame().time_scale, 0.0);
    let (tick, hash) = (paused.world().tick(), paused.state_hash());
    for wall in [
        FRAME,
        FRAME * 3,
        Duration::from_secs(2),
        Duration::from_millis(1),
    ] {
        assert_eq!(paused.advance(wall), 0, "no ticks while paused");
        assert_eq!((paused.world().tick(), paused.state_hash()), (tick, hash));
    }
    let frame = paused.frame();
    assert!(frame.paused);
    assert_eq!(frame.tick, tick);
    assert_eq!(paused.mode(), TimeMode::Live);

    // A step while paused runs exactly that many ticks.
    paused.clock_mut().step(2).expect("two ticks fit");
    straight.clock_mut().step(0).expect("no ticks fit");
    assert_eq!(paused.advance(Duration::from_secs(1)), 2);
    straight.run_ticks(2);
    assert_eq!(paused.state_hash(), straight.state_hash());
    assert!(paused.clock().paused());
    assert_eq!(paused.advance(Duration::from_secs(1)), 0);

    paused.clock_mut().resume();
    assert!(!paused.clock().paused());
    play(&mut paused, &mut bots_a, 60);
    play(&mut straight, &mut bots_b, 60);
    assert_eq!(paused.world().tick(), 120 + 2 + 60);
    assert_eq!(
        paused.state_hash(),
        straight.state_hash(),
        "resuming continued from the paused state"
    );
    let history = paused.history().expect("recorded");
    assert_eq!(history.range(), Some((0, 182)));
    assert_eq!(history.hashed_ticks(), 182, "no gap across the pause");
    paused.finish_recording();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn issue_43_the_state_hash_holds_the_rules_state_and_the_properties() {
    // Two states alike in their world but not in what the rules remember
    // (one knows a player the other does not) hash apart: a seek that
    // reproduces the recorded hash reproduced the rules' state too.
    let mut with = sim(SimConfig::default());
    with.join(7).expect("7 joins");
    let mut without = sim(SimConfig::default());
    let mut state = with.capture(0);
    let rules_with = state.rules.clone();
    state.rules = without.capture(0).rules;
    without.restore(&state).expect("restores");
    assert_eq!(without.world().state_hash(), with.world().state_hash());
    assert_ne!(without.state_hash(), with.state_hash(), "the rules differ");
    // The same state again: the same hash.
    state.rules = rules_with;
    without.restore(&state).expect("restores");
    assert_eq!(without.state_hash(), with.state_hash());
    // The properties count too: the match's players went from 1 to 0.
    let mut fewer = with.capture(0);
    fewer.properties = sim(SimConfig::default()).capture(0).properties;
    without.restore(&fewer).expect("restores");
    assert_ne!(
        without.state_hash(),
        with.state_hash(),
        "the properties differ"
    );
}
