//! The server process stops cleanly on SIGTERM: it tells connected clients
//! it is shutting down, closes their connections, ends the recording with
//! a keyframe and exits 0.

#![cfg(unix)]

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use inertia_client::{dev, BlockingClient};
use inertia_protocol::control::DisconnectReason;
use inertia_server::record::{Record, RecordReader};

fn wait_for(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn sigterm_says_goodbye_to_clients_and_exits_zero() {
    let dir = std::env::temp_dir().join(format!("inertia-sigterm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/pyramid.json");
    let mut server = Command::new(env!("CARGO_BIN_EXE_inertia-server"))
        .args([
            "--listen",
            "127.0.0.1:0",
            "--metrics",
            "127.0.0.1:0",
            "--data-dir",
        ])
        .arg(&dir)
        .arg("--scene")
        .arg(&scene)
        .env("INERTIA_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the server binary starts");
    let credentials = dir.join("dev-credentials.json");
    wait_for("the credentials file", Duration::from_secs(30), || {
        credentials.exists()
    });
    let (addr, token, _) = dev::dev_token(&credentials, Some(3)).expect("dev token");
    let client = BlockingClient::connect(addr, &token).expect("joins");
    wait_for("snapshots", Duration::from_secs(10), || {
        client.stats().snapshots_received > 3
    });

    let status = Command::new("kill")
        .args(["-TERM", &server.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    wait_for("the goodbye", Duration::from_secs(10), || {
        client.disconnected().is_some()
    });
    assert_eq!(
        client.disconnected(),
        Some(DisconnectReason::ServerShutdown)
    );
    let start = Instant::now();
    let exit = loop {
        if let Some(exit) = server.try_wait().expect("wait") {
            break exit;
        }
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "the server did not exit"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(exit.success(), "exit status {exit:?}");
    // The recording ends with a keyframe of the last tick, after that
    // tick's hash.
    let records: Vec<Record> = RecordReader::open(dir.join("recording"))
        .expect("the recording")
        .iter()
        .collect::<Result<_, _>>()
        .expect("an intact recording");
    assert!(matches!(records[0], Record::SessionStart { tick: 0, .. }));
    let last_hashed = records
        .iter()
        .rev()
        .find_map(|r| match r {
            Record::TickHash { tick, .. } => Some(*tick),
            _ => None,
        })
        .expect("ticks were hashed");
    assert!(last_hashed > 0);
    assert!(
        matches!(records.last(), Some(Record::Keyframe { tick, .. }) if *tick == last_hashed),
        "the recording ends with {:?}",
        records.last()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
