//! The server process stops cleanly on SIGTERM: it tells connected clients
//! it is shutting down, closes their connections, ends the recording with
//! a keyframe and exits 0.

#![cfg(unix)]

use crate::common;

use std::process::Command;
use std::time::{Duration, Instant};

use inertia_protocol::control::DisconnectReason;
use inertia_server::record::{Record, RecordReader};

use common::player::Player;
use common::{wait_for, DevServer};

#[test]
fn sigterm_says_goodbye_to_clients_and_exits_zero() {
    let mut server = DevServer::start("sigterm");
    let credentials = server.credentials.clone();
    let client = Player::join_dev(&credentials, Some(3)).expect("joins");
    wait_for("snapshots", Duration::from_secs(10), || {
        client.snapshots() > 3
    });

    let status = Command::new("kill")
        .args(["-TERM", &server.child.id().to_string()])
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
        if let Some(exit) = server.child.try_wait().expect("wait") {
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
    let records: Vec<Record> = RecordReader::open(server.dir.join("recording"))
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
}
