//! Issue 11, defect 1(b): whatever stops the tick thread, the server stops
//! claiming to work. Before, a panic on the tick thread left `/healthz` and
//! `/readyz` at 200, clients watching a frozen world, new clients refused
//! as `ServerFull` and the process running; now health and readiness fail
//! at once with the reason, clients are told the simulation stopped, joins
//! are refused as such, a final keyframe is written when the state is
//! sound, and the process exits non-zero for a restart.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use inertia_client::{dev, BlockingClient, Client, ClientError};
use inertia_protocol::control::{DisconnectReason, Refusal};
use inertia_server::record::{Record, RecordReader};
use inertia_server::sim::SimExit;
use inertia_tests::server::{
    http_get, scene_path, start_server, temp_data_dir, test_config, token,
};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_failed_simulation_fails_health_tells_clients_and_refuses_joins() {
    let config = test_config(Some("moving.ron"), "supervision");
    let recording = config.recording_dir();
    let server = start_server(config).await;
    let metrics = server.metrics_addr();
    let (addr, t) = token(&server, 1);
    let client = Client::connect(addr, &t).await.expect("joins");
    let deadline = Instant::now() + Duration::from_secs(20);
    while client.stats().snapshots_received < 3 {
        assert!(Instant::now() < deadline, "no snapshots");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert_eq!(http_get(metrics, "/healthz").await.0, 200);
    assert_eq!(http_get(metrics, "/readyz").await.0, 200);

    // A failure between ticks (an admin call, a command): the state is
    // whole, so the recording gets a final keyframe of it.
    let tick = server.frame().tick;
    // The answer never comes: the receiver is dropped unread.
    drop(
        server
            .sim()
            .call(|_| panic!("a call that fails on the tick thread"))
            .expect("sent"),
    );
    let why = tokio::time::timeout(Duration::from_secs(5), server.failed())
        .await
        .expect("the failure is noticed within 5 s");
    assert!(why.contains("a call that fails"), "{why}");
    assert_eq!(server.failure().as_deref(), Some(why.as_str()));

    let (status, body) = http_get(metrics, "/healthz").await;
    assert_eq!(status, 503, "{body}");
    assert!(body.contains("a call that fails"), "{body}");
    assert_eq!(http_get(metrics, "/readyz").await.0, 503);

    let deadline = Instant::now() + Duration::from_secs(10);
    let told = loop {
        if let Some(reason) = client.disconnected() {
            break reason;
        }
        assert!(Instant::now() < deadline, "the client was not told");
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    match told {
        DisconnectReason::SimulationStopped { reason } => {
            assert!(reason.contains("a call that fails"), "{reason}")
        }
        other => panic!("expected SimulationStopped, got {other:?}"),
    }

    let (addr, t) = token(&server, 2);
    match Client::connect(addr, &t).await {
        Err(ClientError::Refused(Refusal::SimulationStopped)) => {}
        Err(other) => panic!("refused for the wrong reason: {other:?}"),
        Ok(_) => panic!("a stopped simulation admitted a client"),
    }
    match server.sim().exit() {
        Some(SimExit::Failed {
            keyframe, tick: at, ..
        }) => {
            assert!(keyframe, "a sound state gets a final keyframe");
            assert!(at >= tick);
        }
        other => panic!("expected a failure, got {other:?}"),
    }
    server.shutdown().await;
    let records: Vec<Record> = RecordReader::open(&recording)
        .expect("the recording")
        .iter()
        .collect::<Result<_, _>>()
        .expect("intact");
    let last_hash = records
        .iter()
        .filter_map(|r| match r {
            Record::TickHash { tick, .. } => Some(*tick),
            _ => None,
        })
        .max()
        .expect("hashes");
    assert!(
        matches!(records.last(), Some(Record::Keyframe { tick, .. }) if *tick == last_hash),
        "the recording ends with a keyframe of tick {last_hash}"
    );
}

#[test]
fn issue_11_failed_simulation_exits_non_zero() {
    let dir = temp_data_dir("fault-process");
    let mut child = Command::new(env!("CARGO_BIN_EXE_inertia-fault-server"))
        .args([
            "--listen",
            "127.0.0.1:0",
            "--metrics",
            "127.0.0.1:0",
            "--data-dir",
        ])
        .arg(&dir)
        .arg("--scene")
        .arg(scene_path("moving.ron"))
        .env("INERTIA_FAULT_AFTER_TICKS", "30")
        .env("INERTIA_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the fault server starts");
    let credentials = dir.join("dev-credentials.json");
    let start = Instant::now();
    while !credentials.exists() {
        assert!(start.elapsed() < Duration::from_secs(30), "no credentials");
        std::thread::sleep(Duration::from_millis(20));
    }
    let (addr, token, _) = dev::dev_token(&credentials, Some(7)).expect("token");
    let client = BlockingClient::connect(addr, &token).expect("joins");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("the server did not exit after its simulation failed");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(
        status.code(),
        Some(i32::from(inertia_server::process::EXIT_SIMULATION_FAILED)),
        "{status:?}"
    );
    match client.disconnected() {
        Some(DisconnectReason::SimulationStopped { reason }) => {
            assert!(reason.contains("injected fault"), "{reason}")
        }
        other => panic!("expected SimulationStopped, got {other:?}"),
    }
    // The failure came inside a tick: no keyframe of half a tick, but the
    // recording up to the last whole tick is intact for `--resume`.
    let records: Vec<Record> = RecordReader::open(dir.join("recording"))
        .expect("the recording")
        .iter()
        .collect::<Result<_, _>>()
        .expect("intact");
    assert!(records.iter().any(|r| matches!(r, Record::TickHash { .. })));
    let _ = std::fs::remove_dir_all(&dir);
}
