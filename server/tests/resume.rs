//! `kill -9` while recording, then `--resume`: the world carries on from
//! at most a second before the crash, re-simulated from the recording
//! (every hash on the way checked), and the recording stays readable and
//! replays exactly, across the crash.

#![cfg(unix)]

use crate::common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use common::{admin, wait_for, DevServer};
use inertia_server::replay::{History, DEFAULT_KEYFRAME_BUDGET};
use inertia_server::rules::SandboxRules;
use inertia_server::sim::verify::verify;

/// `args` with `--json`, retried while the server is still starting.
fn json(credentials: &Path, args: &[&str]) -> serde_json::Value {
    let start = Instant::now();
    loop {
        let out = admin(credentials, args);
        if out.status.success() {
            return serde_json::from_slice(&out.stdout).expect("JSON");
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn kill_9_then_resume_loses_at_most_a_second() {
    let server = DevServer::start("resume");
    let dir = server.dir.clone();
    let credentials = server.credentials.clone();
    // Some history, with an edit in it (the pyramid's first box gets a shove).
    assert_eq!(json(&credentials, &["status", "--json"])["mode"], "live");
    let _ = admin(&credentials, &["impulse", "1", "0", "400", "0"]);
    wait_for("three seconds of ticks", Duration::from_secs(30), || {
        json(&credentials, &["status", "--json"])["tick"]
            .as_u64()
            .is_some_and(|t| t >= 180)
    });
    let before = json(&credentials, &["status", "--json"])["tick"]
        .as_u64()
        .expect("tick");
    // kill -9: no shutdown, no final keyframe.
    let mut server = server;
    server.child.kill().expect("SIGKILL");
    let _ = server.child.wait();
    let recording = dir.join("recording");
    let history = History::load(&recording, DEFAULT_KEYFRAME_BUDGET).expect("readable");
    let durable = history.last_hashed().expect("ticks on disk");
    println!("status tick before the kill {before}, last durable tick {durable}");
    assert!(
        durable + 66 >= before,
        "at most about a second (60 ticks) lost: {before} → {durable}"
    );
    // Keep the directory: the DevServer's drop would remove it.
    std::mem::forget(server);

    let resumed = DevServer::start_in(dir.clone(), &["--resume"]);
    let s = json(&resumed.credentials, &["status", "--json"]);
    let tick = s["tick"].as_u64().expect("tick");
    println!("resumed at tick {tick}");
    assert!(tick >= durable, "it carries on from the last durable tick");
    assert!(tick < durable + 600, "and not from the start");
    // The crash's last durable tick, re-simulated from the recording.
    let h = json(
        &resumed.credentials,
        &["hash", &durable.to_string(), "--json"],
    );
    assert_eq!(h["state_hash"], h["recorded_hash"], "{h}");
    // A clean stop, then the whole recording (both runs) replays exactly.
    let status = Command::new("kill")
        .args(["-TERM", &resumed.child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    let mut resumed = resumed;
    let _ = resumed.child.wait();
    let report = verify(&recording, || Box::new(SandboxRules::default()), |_, _| {})
        .expect("the recording verifies");
    println!(
        "verify: {} ticks, {} hashes, {} sessions, {:.0} ticks/s",
        report.ticks,
        report.hashes_checked,
        report.sessions,
        report.ticks_per_second()
    );
    assert!(report.ok(), "mismatches {:?}", report.mismatches);
    assert!(
        report.last_tick > durable,
        "the resumed run was recorded too"
    );
    assert!(report.sessions >= 2);
    drop(resumed);
}
