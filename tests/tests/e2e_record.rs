//! Recording against a real server: `record off` and `record on` through
//! the admin channel, the hash of a past tick answered from the recording
//! and equal to the live hash that tick had, ticks recorded while off are
//! not found, and shutdown ends the recording with a keyframe.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use inertia_admin_client::AdminClient;
use inertia_protocol::admin::{AdminErrorKind, AdminRequest, AdminResponse};
use inertia_server::config::ServerConfig;
use inertia_server::record::{Record, RecordReader};
use inertia_server::server::RunningServer;
use inertia_tests::admin::{admin, call, status};
use inertia_tests::server::{start_server, test_config};

/// `(tick, state_hash, recorded_hash)`.
async fn hash(admin: &mut AdminClient, tick: Option<u64>) -> (u64, u64, Option<u64>) {
    match call(admin, AdminRequest::Hash { tick }).await {
        AdminResponse::Hash {
            tick,
            state_hash,
            recorded_hash,
        } => (tick, state_hash, recorded_hash),
        other => panic!("expected a hash, got {other:?}"),
    }
}

/// Steps one tick while paused and waits until it ran.
async fn step(server: &RunningServer, admin: &mut AdminClient) -> u64 {
    let target = server.frame().tick + 1;
    assert_eq!(
        call(admin, AdminRequest::Step { ticks: 1 }).await,
        AdminResponse::Ok
    );
    let deadline = Instant::now() + Duration::from_secs(3);
    while server.frame().tick < target {
        assert!(Instant::now() < deadline, "a step to {target}");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    target
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn record_off_on_and_the_hash_of_a_past_tick() {
    let config = ServerConfig {
        keyframe_ticks: 20,
        ..test_config(Some("moving.ron"), "record")
    };
    let dir = config.recording_dir();
    let server = start_server(config).await;
    let mut admin = admin(&server).await;
    assert_eq!(
        call(&mut admin, AdminRequest::Pause).await,
        AdminResponse::Ok
    );
    assert!(status(&mut admin).await.recording);

    // Off: the ticks stepped now are not recorded.
    assert_eq!(
        call(&mut admin, AdminRequest::Record { on: false }).await,
        AdminResponse::Ok
    );
    assert!(!status(&mut admin).await.recording);
    let unrecorded = step(&server, &mut admin).await;
    assert_eq!(
        hash(&mut admin, Some(unrecorded)).await,
        (unrecorded, server_hash(&server).await, None),
        "the current tick answers live, with nothing recorded"
    );
    step(&server, &mut admin).await;
    match call(
        &mut admin,
        AdminRequest::Hash {
            tick: Some(unrecorded),
        },
    )
    .await
    {
        AdminResponse::Error(e) => assert_eq!(e.kind, AdminErrorKind::NotRecorded),
        other => panic!("a tick recorded while off: {other:?}"),
    }

    // On again: a new session; every tick's live hash is what the
    // recording answers for it later.
    assert_eq!(
        call(&mut admin, AdminRequest::Record { on: true }).await,
        AdminResponse::Ok
    );
    assert!(status(&mut admin).await.recording);
    let mut live = BTreeMap::new();
    for _ in 0..25 {
        let t = step(&server, &mut admin).await;
        let (tick, state_hash, recorded) = hash(&mut admin, None).await;
        assert_eq!(tick, t);
        assert_eq!(recorded, Some(state_hash), "the current tick, recorded");
        live.insert(tick, state_hash);
    }
    for (&tick, &state_hash) in &live {
        assert_eq!(
            hash(&mut admin, Some(tick)).await,
            (tick, state_hash, Some(state_hash)),
            "tick {tick}"
        );
    }
    let last = *live.keys().last().expect("ticks");
    admin.close().await;
    server.shutdown().await;

    // Shutdown ended the recording with a keyframe of the last tick.
    let reader = RecordReader::open(&dir).expect("the recording");
    assert_eq!(
        reader.keyframe_at_or_before(last).unwrap().map(|(t, _)| t),
        Some(last)
    );
    let records: Vec<Record> = reader.iter().collect::<Result<_, _>>().unwrap();
    let edits: Vec<&[u8]> = records
        .iter()
        .filter_map(|r| match r {
            Record::AdminEdit { who, what, .. } if who == "e2e" => Some(what.as_slice()),
            _ => None,
        })
        .collect();
    assert_eq!(edits, vec![&b"record off"[..], &b"record on"[..]]);
    let _ = std::fs::remove_dir_all(dir.parent().expect("the data directory"));
}

async fn server_hash(server: &RunningServer) -> u64 {
    server
        .sim()
        .call(|s| s.state_hash())
        .expect("the simulation")
        .await
        .expect("an answer")
}
