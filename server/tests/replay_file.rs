//! `inertia-admin replay-file` against a recording made by driving a
//! simulation by hand: `inspect --json` counts what was recorded, `export`
//! prints one JSON object per record in the tick range, `verify` re-
//! simulates every tick and exits 0; a recording with a wrong tick hash
//! fails `verify` with exit 1, a damaged one fails with a message, and a
//! path that holds no recording is misuse (exit 2).

use crate::common;
use inertia_protocol::input::GameInput;

use common::FLAT;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use inertia_protocol::PlayerInput;
use inertia_server::record::{Record, RecordOptions, RecordReader, RecordWriter, RecorderConfig};
use inertia_server::replay::WorldEdit;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

/// Ticks recorded.
const TICKS: u64 = 240;
/// Ticks between keyframes.
const KEYFRAME_TICKS: u64 = 60;
/// Inputs sent: one before every third tick.
const INPUTS: u64 = TICKS / 3;

/// A fresh scratch directory (removed on drop).
struct Scratch(PathBuf);

impl Scratch {
    fn new(what: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("inertia-replay-file-{what}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch directory");
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Records `TICKS` ticks of the flat scene into `dir`: a client joins, sends
/// an input before every third tick, and an operator pushes its avatar once.
fn record(dir: &Path) {
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    let config = SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks: KEYFRAME_TICKS,
            ..RecorderConfig::new(dir)
        }),
        record_at_start: true,
        ..SimConfig::default()
    };
    let mut s = Simulation::new(built, Box::new(SandboxRules::default()), config);
    let avatar = s.join(7).unwrap();
    for i in 0..TICKS {
        if i % 3 == 0 {
            let input = PlayerInput {
                sequence: (i / 3 + 1) as u32,
                tick: s.world().tick(),
                payload: inertia_sandbox::SandboxInput {
                    movement: [(i as f32 / TICKS as f32).min(1.0), 0.5],
                    yaw: 0.25,
                    buttons: 0,
                }
                .to_payload(),
                view_behind: 0.0,
            };
            s.input(7, &input).unwrap();
        }
        if i == 100 {
            s.edit(WorldEdit::Impulse {
                id: avatar,
                impulse: [0.0, 5.0, 0.0],
                point: None,
            })
            .unwrap();
            s.record_admin_edit("ops", "impulse on the avatar");
        }
        s.run_ticks(1);
    }
    s.finish_recording();
}

fn admin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_inertia-admin"))
        .args(args)
        .output()
        .expect("inertia-admin runs")
}

fn arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

fn stdout(out: &Output) -> String {
    String::from_utf8(out.stdout.clone()).expect("UTF-8")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The single JSON object a `--json` command printed.
fn object(out: &Output) -> serde_json::Value {
    let text = stdout(out);
    assert_eq!(text.lines().count(), 1, "one object: {text}");
    serde_json::from_str(&text).expect("JSON")
}

#[test]
fn inspect_export_and_verify_a_recording() {
    let scratch = Scratch::new("good");
    let dir = scratch.0.join("recording");
    record(&dir);
    let d = arg(&dir);

    // inspect
    let out = admin(&["replay-file", "inspect", d, "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let s = object(&out);
    assert_eq!(s["first_tick"], 0);
    assert_eq!(s["last_tick"], TICKS);
    assert_eq!(s["tick_hz"], 60);
    assert_eq!(s["duration_s"], TICKS as f64 / 60.0);
    assert_eq!(s["sessions"][0]["scene"], "flat");
    assert_eq!(s["sessions"][0]["start_tick"], 0);
    assert_eq!(s["records"]["tick_hashes"], TICKS);
    assert_eq!(s["records"]["session_starts"], 1);
    assert_eq!(s["records"]["admin_edits"], 1);
    // One at the start, every K ticks, one at the end.
    assert_eq!(s["records"]["keyframes"], 1 + TICKS / KEYFRAME_TICKS + 1);
    let entries = &s["journal_entries"];
    assert_eq!(entries["joins"], 1);
    assert_eq!(entries["leaves"], 0);
    assert_eq!(entries["inputs"], INPUTS);
    assert_eq!(entries["edits"], 1);
    let segment_bytes: u64 = s["segments"]
        .as_array()
        .unwrap()
        .iter()
        .map(|seg| seg["bytes"].as_u64().unwrap())
        .sum();
    assert_eq!(s["total_bytes"], segment_bytes);
    assert!(s["bytes_per_sim_hour"].as_f64().unwrap() > 0.0);
    assert_eq!(s["damaged"], false);
    assert_eq!(s["torn_tail"], false);

    let out = admin(&["replay-file", "inspect", d]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    for want in [
        "scene \"flat\"",
        "60 Hz",
        "damage: none",
        "per simulated hour",
    ] {
        assert!(text.contains(want), "inspect lacks {want:?}:\n{text}");
    }

    // export, to stdout
    let (from, to) = (50u64, 120u64);
    let out = admin(&[
        "replay-file",
        "export",
        d,
        "--from",
        &from.to_string(),
        "--to",
        &to.to_string(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let lines: Vec<serde_json::Value> = stdout(&out)
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect();
    assert!(!lines.is_empty());
    for line in &lines {
        let tick = line["tick"].as_u64().expect("a tick");
        assert!((from..=to).contains(&tick), "tick {tick} out of range");
        assert!(line["kind"].is_string());
        assert!(line.get("error").is_none(), "{line}");
    }
    let of_kind = |k: &'static str| lines.iter().filter(move |l| l["kind"] == k);
    assert_eq!(of_kind("tick_hash").count() as u64, to - from + 1);
    for h in of_kind("tick_hash") {
        let hash = h["hash"].as_str().unwrap();
        assert_eq!(hash.len(), 16);
        assert!(u64::from_str_radix(hash, 16).is_ok());
    }
    let keyframe = of_kind("keyframe").next().expect("the keyframe at 60");
    assert_eq!(keyframe["tick"], 60);
    assert_eq!(keyframe["bodies"], 3, "ground, ball and avatar");
    assert_eq!(keyframe["entities"], 3);
    assert_eq!(keyframe["clients"], 1);
    let journal_entries: Vec<&serde_json::Value> = of_kind("journal")
        .flat_map(|j| j["entries"].as_array().unwrap())
        .collect();
    assert!(journal_entries
        .iter()
        .any(|e| e["type"] == "input" && e["client"] == 7));
    assert!(journal_entries.iter().any(|e| e["type"] == "edit"));
    let edit = of_kind("admin_edit").next().expect("the admin edit");
    assert_eq!(edit["who"], "ops");
    assert_eq!(edit["what"], "impulse on the avatar");

    // export, to a file
    let file = scratch.0.join("export.jsonl");
    let out = admin(&[
        "replay-file",
        "export",
        d,
        "--from",
        "0",
        "--to",
        "0",
        "--out",
        arg(&file),
        "--json",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let summary = object(&out);
    let written = std::fs::read_to_string(&file).unwrap();
    assert_eq!(summary["records"], written.lines().count() as u64);
    let kinds: Vec<String> = written
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["kind"].to_string())
        .collect();
    assert_eq!(
        kinds[..3],
        ["\"session_start\"", "\"keyframe\"", "\"journal\""],
        "{written}"
    );

    // verify
    let out = admin(&["replay-file", "verify", d, "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v = object(&out);
    assert_eq!(v["ok"], true, "{v}");
    assert_eq!(v["ticks"], TICKS);
    assert_eq!(v["hashes_checked"], TICKS);
    assert!(v["keyframes_checked"].as_u64().unwrap() >= TICKS / KEYFRAME_TICKS);
    assert_eq!(v["mismatches"], serde_json::json!([]));
    assert!(v["ticks_per_s"].as_f64().unwrap() > 0.0);
    let out = admin(&["replay-file", "verify", d]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("every hash matches"),
        "{}",
        stdout(&out)
    );
}

#[test]
fn a_wrong_hash_or_damage_fails_verify() {
    let scratch = Scratch::new("bad");
    let good = scratch.0.join("good");
    record(&good);

    // The same records with one tick's hash changed.
    let wrong_tick = 77;
    let wrong = scratch.0.join("wrong-hash");
    let mut writer = RecordWriter::open(&wrong, RecordOptions::default()).unwrap();
    for record in RecordReader::open(&good).unwrap().iter() {
        let record = match record.unwrap() {
            Record::TickHash { tick, hash } if tick == wrong_tick => Record::TickHash {
                tick,
                hash: hash ^ 1,
            },
            r => r,
        };
        writer.append(&record).unwrap();
    }
    writer.flush().unwrap();
    drop(writer);
    let out = admin(&["replay-file", "verify", arg(&wrong), "--json"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let v = object(&out);
    assert_eq!(v["ok"], false);
    assert_eq!(v["mismatch_count"], 1);
    assert_eq!(v["mismatches"][0]["tick"], wrong_tick);
    assert!(
        stderr(&out).contains(&format!("tick {wrong_tick}")),
        "{}",
        stderr(&out)
    );
    let out = admin(&["replay-file", "verify", arg(&wrong)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stdout(&out).contains("DIFFER"), "{}", stdout(&out));

    // A flipped byte in the middle of a segment: a checksum fails.
    let damaged = scratch.0.join("damaged");
    std::fs::create_dir_all(&damaged).unwrap();
    for entry in std::fs::read_dir(&good).unwrap() {
        let path = entry.unwrap().path();
        let mut bytes = std::fs::read(&path).unwrap();
        let middle = bytes.len() / 2;
        bytes[middle] ^= 0x55;
        std::fs::write(damaged.join(path.file_name().unwrap()), bytes).unwrap();
    }
    let out = admin(&["replay-file", "verify", arg(&damaged)]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("damaged"), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("DAMAGED"),
        "{}{}",
        stdout(&out),
        stderr(&out)
    );
    issue_44_verify_reads_past_damage_and_checks_the_rest(&good, &damaged);
    let out = admin(&["replay-file", "inspect", arg(&damaged), "--json"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let s = object(&out);
    assert_eq!(s["damaged"], true);
    assert!(s["damage"][0]["offset"].as_u64().unwrap() > 0);
    let out = admin(&["replay-file", "export", arg(&damaged)]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("corrupt"), "{}", stderr(&out));

    // A torn tail (a crash mid-append) is noted, not an error.
    let torn = scratch.0.join("torn");
    std::fs::create_dir_all(&torn).unwrap();
    let mut newest = None;
    for entry in std::fs::read_dir(&good).unwrap() {
        let path = entry.unwrap().path();
        let to = torn.join(path.file_name().unwrap());
        std::fs::copy(&path, &to).unwrap();
        newest = newest.max(Some(to));
    }
    let newest = newest.unwrap();
    let mut bytes = std::fs::read(&newest).unwrap();
    bytes.extend_from_slice(&[4, 16, 0, 0, 0, 1, 2]);
    std::fs::write(&newest, bytes).unwrap();
    let out = admin(&["replay-file", "inspect", arg(&torn), "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let s = object(&out);
    assert_eq!(
        (s["torn_tail"].clone(), s["damaged"].clone()),
        (true.into(), false.into())
    );
    let out = admin(&["replay-file", "verify", arg(&torn), "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

/// One flipped byte made `verify` refuse the whole recording although
/// every later keyframe was intact. It reads past the damage now, starts
/// again at the next keyframe, checks every hash from there without a
/// false mismatch, and says where the damage was and where it went on.
fn issue_44_verify_reads_past_damage_and_checks_the_rest(good: &Path, damaged: &Path) {
    let all = object(&admin(&["replay-file", "verify", arg(good), "--json"]));
    let out = admin(&["replay-file", "verify", arg(damaged), "--json"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let v = object(&out);
    assert_eq!(v["ok"], false);
    assert_eq!(v["mismatch_count"], 0, "the gap is not re-simulated: {v}");
    let damage = v["damage"].as_array().expect("the damage listed");
    assert!(!damage.is_empty());
    assert!(damage[0]["offset"].as_u64().unwrap() > 0);
    assert!(
        damage.iter().any(|d| d["restarted_at"].as_u64().is_some()),
        "{v}"
    );
    let (checked, of) = (
        v["hashes_checked"].as_u64().unwrap(),
        all["hashes_checked"].as_u64().unwrap(),
    );
    assert!(
        checked > 0 && checked < of,
        "the rest is checked: {checked} of {of} hashes"
    );
}

#[test]
fn a_path_without_a_recording_is_misuse() {
    let scratch = Scratch::new("misuse");
    let missing = scratch.0.join("missing");
    for cmd in ["inspect", "export", "verify"] {
        let out = admin(&["replay-file", cmd, arg(&missing)]);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("no such file"),
            "{cmd}: {}",
            stderr(&out)
        );
        let out = admin(&["replay-file", cmd, arg(&scratch.0), "--json"]);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert_eq!(object(&out)["error"]["kind"], "not_a_recording");
        assert!(stderr(&out).contains("not a recording"), "{}", stderr(&out));
    }
    // A file named like a segment that is not one.
    let fake = scratch.0.join("fake");
    std::fs::create_dir_all(&fake).unwrap();
    std::fs::write(
        fake.join("segment-00000000000000000000.irec"),
        b"hello, not a segment",
    )
    .unwrap();
    for cmd in ["inspect", "verify"] {
        let out = admin(&["replay-file", cmd, arg(&fake)]);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert!(stderr(&out).contains("not a recording"), "{}", stderr(&out));
    }
    let out = admin(&[
        "replay-file",
        "export",
        arg(&scratch.0),
        "--from",
        "9",
        "--to",
        "3",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--from"), "{}", stderr(&out));
}
