//! `inertia-admin` against the server process: `status --json` and
//! `hash --json` print the fields scripts read, a paused world hashes the
//! same twice, a seek says whether the hash it reached matches the
//! recording, and a wrong credential or a bad argument exits non-zero
//! with a message.

#![cfg(unix)]

use crate::common;

use std::process::Output;

use common::{admin, DevServer};
use std::time::{Duration, Instant};

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "exit {:?}: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout.clone()).expect("UTF-8");
    assert_eq!(text.lines().count(), 1, "one object: {text}");
    serde_json::from_str(&text).expect("JSON")
}

#[test]
fn status_pause_hash_and_refusals_from_the_command_line() {
    let server = DevServer::start("admin-cli");
    let (dir, credentials) = (server.dir.clone(), server.credentials.clone());
    let start = Instant::now();
    // The file is written before the endpoint serves; retry briefly.
    let mut status = admin(&credentials, &["status", "--json"]);
    while !status.status.success() && start.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(100));
        status = admin(&credentials, &["status", "--json"]);
    }
    let s = json(&status);
    for field in [
        "tick",
        "sim_time",
        "time_scale",
        "paused",
        "clients",
        "bodies",
        "state_hash",
        "achieved_rate",
        "tick_ms_p99",
        "live_tick",
        "mode",
    ] {
        assert!(s.get(field).is_some(), "status lacks {field}: {s}");
    }
    assert_eq!(s["time_scale"], 1.0);
    assert_eq!(s["paused"], false);
    assert_eq!(s["mode"], "live");
    assert!(s["bodies"].as_u64().expect("a count") > 0);

    assert_eq!(json(&admin(&credentials, &["pause", "--json"]))["ok"], true);
    let h1 = json(&admin(&credentials, &["hash", "--json"]));
    std::thread::sleep(Duration::from_millis(200));
    let h2 = json(&admin(&credentials, &["hash", "--json"]));
    assert_eq!(h1, h2, "paused, the hash stands still");
    assert!(h1["state_hash"].as_u64().is_some());
    assert!(h1.get("recorded_hash").is_some());
    let s = json(&admin(&credentials, &["status", "--json"]));
    assert_eq!(s["paused"], true);
    assert_eq!(s["tick"], h1["tick"]);
    assert_eq!(s["state_hash"], h1["state_hash"]);

    // Human output by default.
    let out = admin(&credentials, &["status"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(text.contains("state hash"), "{text}");
    assert!(text.contains("mode live, live tick"), "{text}");

    // A seek answers the hash reached and whether it matches the recording.
    let live = h1["tick"].as_u64().expect("a tick");
    let back = (live - 1).to_string();
    let seek = json(&admin(&credentials, &["seek", &back, "--json"]));
    assert_eq!(seek["tick"], live - 1);
    assert_eq!(seek["matches"], true, "{seek}");
    assert!(seek["recorded_hash"].as_u64().is_some());
    let s = json(&admin(&credentials, &["status", "--json"]));
    assert_eq!(s["mode"], "history");
    assert_eq!(s["live_tick"], live);
    let out = admin(&credentials, &["seek", &back]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        text.contains(&format!("tick {back}")) && text.contains("matches"),
        "{text}"
    );

    // A bad argument, a server error and a wrong credential: non-zero,
    // with a message.
    let out = admin(&credentials, &["speed", "100"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("time scale"));
    let out = admin(&credentials, &["seek", "99999999", "--json"]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(json_error(&out), "out_of_range");
    let mut creds: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&credentials).expect("read")).expect("JSON");
    creds["admin_token"] = "wrong".into();
    let bad = dir.join("bad-credentials.json");
    std::fs::write(&bad, creds.to_string()).expect("write");
    let out = admin(&bad, &["pause", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(json_error(&out), "refused");
    assert!(String::from_utf8_lossy(&out.stderr).contains("credential"));
}

fn json_error(out: &Output) -> String {
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    v["error"]["kind"]
        .as_str()
        .expect("an error kind")
        .to_string()
}
