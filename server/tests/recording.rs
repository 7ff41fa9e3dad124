//! Recording the live session: a simulation driven by hand (and the tick
//! thread for real) leaves a recording that starts with a session start and
//! a keyframe, holds a keyframe every K ticks, every tick's state hash as
//! the world gave it, and the inputs applied at each tick; shutdown ends it
//! with a keyframe; a recorder that cannot keep up drops, counts and stops
//! instead of blocking the tick.

use crate::common;
use inertia_protocol::input::GameInput;

use common::FLAT;

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use inertia_protocol::PlayerInput;
use inertia_server::record::{Record, RecordReader, Recorder, RecorderConfig};
use inertia_server::replay::journal::{self, JournalEntry};
use inertia_server::replay::SimState;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::verify::verify;
use inertia_server::sim::{SimConfig, SimHandle, Simulation};

fn temp_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inertia-recording-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn config(dir: &PathBuf, keyframe_ticks: u64) -> SimConfig {
    SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks,
            ..RecorderConfig::new(dir)
        }),
        record_at_start: true,
        ..SimConfig::default()
    }
}

fn sim(config: SimConfig) -> Simulation {
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    Simulation::new(built, Box::new(SandboxRules::default()), config)
}

fn input(sequence: u32, tick: u64, x: f32) -> PlayerInput {
    PlayerInput {
        sequence,
        tick,
        payload: inertia_sandbox::SandboxInput {
            movement: [x, 0.5],
            yaw: 0.25,
            buttons: 0,
        }
        .to_payload(),
        view_behind: 0.0,
    }
}

#[test]
fn every_tick_is_recorded_with_its_hash_inputs_and_keyframes() {
    let dir = temp_dir("by-hand");
    let k = 25;
    let mut s = sim(config(&dir, k));
    assert!(s.recording());
    s.join(7).unwrap();
    let mut hashes = Vec::new();
    let mut sent = Vec::new();
    let mut sequence = 0;
    for i in 0..100u64 {
        // A fake client sends an input before every third tick.
        if i % 3 == 0 {
            sequence += 1;
            let inp = input(sequence, s.world().tick(), (i as f32 / 100.0).min(1.0));
            s.input(7, &inp).unwrap();
            sent.push((s.world().tick(), inp));
        }
        s.run_ticks(1);
        hashes.push((s.world().tick(), s.state_hash()));
    }
    let last_state = s.world().save();
    let last_tick = s.world().tick();
    let last_hash = s.state_hash();
    s.finish_recording();
    assert!(!s.recording());

    let records: Vec<Record> = RecordReader::open(&dir)
        .unwrap()
        .iter()
        .collect::<Result<_, _>>()
        .unwrap();
    match &records[0] {
        Record::SessionStart {
            tick,
            tick_hz,
            scene,
        } => {
            assert_eq!((*tick, *tick_hz, scene.as_str()), (0, 60, "flat"));
        }
        r => panic!("first record {r:?}"),
    }
    assert!(matches!(&records[1], Record::Keyframe { tick: 0, .. }));

    let recorded: Vec<(u64, u64)> = records
        .iter()
        .filter_map(|r| match r {
            Record::TickHash { tick, hash } => Some((*tick, *hash)),
            _ => None,
        })
        .collect();
    assert_eq!(recorded, hashes, "every tick's hash, as the world gave it");

    let keyframes: Vec<u64> = records
        .iter()
        .filter_map(|r| match r {
            Record::Keyframe { tick, .. } => Some(*tick),
            _ => None,
        })
        .collect();
    assert_eq!(
        keyframes,
        vec![0, 25, 50, 75, 100, 100],
        "one at the start, every K ticks, one at the end"
    );
    match records.last().unwrap() {
        Record::Keyframe { tick, state } => {
            assert_eq!(*tick, last_tick);
            let state = SimState::decode(state).unwrap();
            assert_eq!(
                state.world, last_state,
                "the final keyframe holds the saved world"
            );
            assert_eq!(state.clients, vec![7]);
            assert!(!state.rules.is_empty(), "and the rules' players");
        }
        r => panic!("last record {r:?}"),
    }

    // The join, then each input in the journal of the tick it was applied
    // at (before that tick's step).
    let mut journal: Vec<(u64, JournalEntry)> = Vec::new();
    for r in &records {
        if let Record::Journal { tick, entries } = r {
            for e in journal::decode(*tick, entries).unwrap() {
                journal.push((*tick, e));
            }
        }
    }
    assert_eq!(journal[0], (0, JournalEntry::Join(7)));
    let inputs: Vec<(u64, PlayerInput)> = journal[1..]
        .iter()
        .map(|(tick, e)| match e {
            JournalEntry::Input(7, input) => (*tick, *input),
            e => panic!("{e:?}"),
        })
        .collect();
    assert_eq!(inputs, sent, "each input at the tick that applied it");

    // A keyframe restores to the state whose hash was recorded.
    let reader = RecordReader::open(&dir).unwrap();
    let (t, state) = reader.keyframe_at_or_before(60).unwrap().unwrap();
    assert_eq!(t, 50);
    let state = SimState::decode(&state).unwrap();
    let restored = Simulation::from_state(
        &state,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    )
    .unwrap();
    assert_eq!(Some(restored.state_hash()), reader.hash_at(50).unwrap());

    // Re-simulating the whole recording reaches every recorded hash.
    let report = verify(&dir, || Box::new(SandboxRules::default()), |_, _| {}).unwrap();
    assert!(report.ok(), "{:?}", report.mismatches);
    assert_eq!(report.hashes_checked, 100);
    assert_eq!(report.last_tick, last_tick);
    let _ = last_hash;
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn stopping_and_starting_makes_a_new_session() {
    let dir = temp_dir("on-off");
    let mut s = sim(config(&dir, 1000));
    s.run_ticks(10);
    s.record_admin_edit("ops", "record off");
    s.stop_recording();
    s.run_ticks(10);
    s.start_recording().unwrap();
    s.run_ticks(5);
    s.finish_recording();
    let records: Vec<Record> = RecordReader::open(&dir)
        .unwrap()
        .iter()
        .collect::<Result<_, _>>()
        .unwrap();
    let hashed: Vec<u64> = records
        .iter()
        .filter_map(|r| match r {
            Record::TickHash { tick, .. } => Some(*tick),
            _ => None,
        })
        .collect();
    let expected: Vec<u64> = (1..=10).chain(21..=25).collect();
    assert_eq!(hashed, expected, "nothing recorded while off");
    let starts: Vec<u64> = records
        .iter()
        .filter_map(|r| match r {
            Record::SessionStart { tick, .. } => Some(*tick),
            _ => None,
        })
        .collect();
    assert_eq!(starts, vec![0, 20]);
    assert!(records.iter().any(|r| matches!(
        r,
        Record::AdminEdit { tick: 10, who, what } if who == "ops" && what == b"record off"
    )));
    assert!(records
        .iter()
        .any(|r| matches!(r, Record::Keyframe { tick: 20, .. })));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_full_channel_drops_and_counts_and_never_blocks() {
    let dir = temp_dir("full");
    // The recorder itself: a channel of one, filled faster than a disk.
    let recorder = Recorder::start(
        RecorderConfig {
            capacity: 1,
            ..RecorderConfig::new(&dir)
        },
        0,
        None,
    )
    .unwrap();
    let t0 = Instant::now();
    let mut dropped = 0;
    for tick in 0..20_000u64 {
        if recorder
            .send(Record::Keyframe {
                tick,
                state: vec![0; 4096],
            })
            .is_err()
        {
            dropped += 1;
        }
    }
    assert!(t0.elapsed() < Duration::from_secs(2), "sending never waits");
    assert!(dropped > 0, "a channel of one overflows");
    assert_eq!(recorder.stats().dropped.load(Ordering::Relaxed), dropped);
    recorder.stop();
    std::fs::remove_dir_all(&dir).ok();

    // The simulation: a drop stops the recording (a gap breaks replay).
    let dir = temp_dir("full-sim");
    let mut c = config(&dir, 1);
    c.recording.as_mut().unwrap().capacity = 3;
    let mut s = sim(c);
    let t0 = Instant::now();
    s.run_ticks(200);
    assert!(t0.elapsed() < Duration::from_secs(10));
    assert!(!s.recording(), "a gap stops the recording");
    assert_eq!(s.stats().record_gaps.load(Ordering::Relaxed), 1);
    s.finish_recording();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_tick_thread_records_and_its_shutdown_ends_with_a_keyframe() {
    let dir = temp_dir("thread");
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    let h = SimHandle::spawn(built, Box::new(SandboxRules::default()), config(&dir, 30)).unwrap();
    h.pause().unwrap();
    h.join_blocking(3).unwrap();
    h.input(3, input(1, 0, 1.0)).unwrap();
    h.step(45).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    while h.frame().tick < 45 {
        assert!(Instant::now() < deadline, "45 steps");
        std::thread::sleep(Duration::from_millis(5));
    }
    let live = h.call(|s| (s.world().tick(), s.state_hash())).unwrap();
    let (tick, hash) = live.blocking_recv().unwrap();
    assert_eq!(tick, 45);
    h.shutdown();
    let reader = RecordReader::open(&dir).unwrap();
    assert_eq!(reader.hash_at(45).unwrap(), Some(hash));
    assert_eq!(reader.keyframe_at_or_before(45).unwrap().unwrap().0, 45);
    let journals: Vec<Vec<JournalEntry>> = reader
        .iter()
        .filter_map(|r| match r.unwrap() {
            Record::Journal { tick, entries } => Some(journal::decode(tick, &entries).unwrap()),
            _ => None,
        })
        .collect();
    let entries: Vec<JournalEntry> = journals.into_iter().flatten().collect();
    assert_eq!(entries.len(), 2, "{entries:?}");
    assert_eq!(entries[0], JournalEntry::Join(3));
    assert!(matches!(entries[1], JournalEntry::Input(3, _)));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn records_reach_the_disk_within_a_second_unasked() {
    let dir = temp_dir("synced");
    let recorder = Recorder::start(RecorderConfig::new(&dir), 0, None).unwrap();
    for tick in 0..10 {
        recorder
            .send(Record::TickHash { tick, hash: tick })
            .unwrap();
    }
    let deadline = Instant::now() + Duration::from_secs(3);
    loop {
        let n = RecordReader::open(&dir).unwrap().iter().count();
        if n == 10 && recorder.stats().flushes.load(Ordering::Relaxed) >= 1 {
            break;
        }
        assert!(Instant::now() < deadline, "{n} of 10 records on disk");
        std::thread::sleep(Duration::from_millis(50));
    }
    recorder.stop();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_older_run_past_the_new_start_is_moved_aside() {
    let dir = temp_dir("aside");
    let mut s = sim(config(&dir, 1000));
    s.run_ticks(30);
    s.finish_recording();
    // A new run of the server starts again at tick 0.
    let mut s = sim(config(&dir, 1000));
    s.run_ticks(5);
    s.finish_recording();
    let reader = RecordReader::open(&dir).unwrap();
    assert_eq!(reader.hash_at(5).unwrap(), Some(s.state_hash()));
    assert_eq!(
        reader.hash_at(30).unwrap(),
        None,
        "the old run is elsewhere"
    );
    let parent = dir.parent().unwrap();
    let name = dir.file_name().unwrap().to_str().unwrap().to_string();
    let aside: Vec<PathBuf> = std::fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(&format!("{name}.")))
        })
        .collect();
    assert_eq!(aside.len(), 1, "{aside:?}");
    assert!(RecordReader::open(&aside[0])
        .unwrap()
        .hash_at(30)
        .unwrap()
        .is_some());
    std::fs::remove_dir_all(&aside[0]).ok();
    std::fs::remove_dir_all(&dir).ok();
}
