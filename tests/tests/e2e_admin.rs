//! The admin channel against a real server: status, pause, step, resume,
//! speed, run-to, hash, kick, despawn, impulse and spawn do what they say;
//! loads of a missing or garbage checkpoint and seeks into the future are
//! refused and change nothing; hellos without the credential, with a wrong one or with garbage, and
//! malformed calls after a good hello, are refused, logged and counted,
//! and change nothing.

use std::time::{Duration, Instant};

use inertia_admin_client::{connect_quic, read_credentials, AdminClient, AdminClientError};
use inertia_client::Client;
use inertia_protocol::admin::{
    AdminErrorKind, AdminHandshake, AdminRefusal, AdminRequest, AdminResponse, CheckpointName,
    MassSpec, SpawnDesc, TimeMode,
};
use inertia_protocol::control::{encode_frame, DisconnectReason, FrameDecoder};
use inertia_protocol::{EntityId, EntityKind, ShapeDesc};
use inertia_server::server::RunningServer;
use inertia_tests::admin::{error_kind, ok, status, wait_for};
use inertia_tests::server::{start_server, test_config, token};

fn fingerprint(server: &RunningServer) -> [u8; 32] {
    let path = server.credentials_path().expect("dev mode");
    read_credentials(path)
        .expect("dev credentials")
        .fingerprint()
        .expect("fingerprint")
}

async fn admin_with(
    server: &RunningServer,
    credential: &str,
) -> Result<AdminClient, AdminClientError> {
    AdminClient::connect(server.addr(), fingerprint(server), credential, "e2e").await
}

async fn admin(server: &RunningServer) -> AdminClient {
    admin_with(server, server.admin_token())
        .await
        .expect("the admin credential is accepted")
}

async fn hash(admin: &mut AdminClient, tick: Option<u64>) -> (u64, u64) {
    match admin.call(AdminRequest::Hash { tick }).await.expect("hash") {
        AdminResponse::Hash {
            tick,
            state_hash,
            recorded_hash,
        } => {
            // The recording's hash of a tick is the one the world had.
            assert!(
                recorded_hash.is_none() || recorded_hash == Some(state_hash),
                "tick {tick}: live {state_hash:#x}, recorded {recorded_hash:?}"
            );
            (tick, state_hash)
        }
        other => panic!("expected a hash, got {other:?}"),
    }
}

fn entity_named(server: &RunningServer, name: &str) -> EntityId {
    *server
        .frame()
        .catalog
        .iter()
        .find(|(_, d)| d.name == name)
        .map(|(id, _)| id)
        .expect("the scene has it")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn status_pause_step_resume_run_to_and_hash() {
    let server = start_server(test_config(Some("moving.ron"), "admin-clock")).await;
    let mut admin = admin(&server).await;
    assert_eq!(admin.welcome().tick_hz, 60);
    tokio::time::sleep(Duration::from_millis(300)).await;

    let s = status(&mut admin).await;
    let frame = server.frame();
    assert!(s.tick > 0 && s.tick.abs_diff(frame.tick) <= 3, "{s:?}");
    assert!((s.sim_time - s.tick as f64 / 60.0).abs() < 1e-9, "{s:?}");
    assert_eq!(s.time_scale, 1.0);
    assert!(!s.paused);
    assert_eq!(s.clients, 0);
    assert_eq!(s.bodies, 9);
    assert!(s.recording, "recording is on by default");
    assert!(s.tick_ms_p99 >= 0.0 && s.tick_ms_p99 < 1000.0);
    assert!(s.achieved_rate > 20.0, "{s:?}");
    assert!(s.wall_time_unix > 1.6e9);

    // Pause: the tick stands still.
    ok(&mut admin, AdminRequest::Pause).await;
    let paused = status(&mut admin).await;
    assert!(paused.paused);
    assert_eq!(paused.time_scale, 0.0);
    tokio::time::sleep(Duration::from_millis(300)).await;
    let later = status(&mut admin).await;
    assert_eq!(later.tick, paused.tick, "no ticks while paused");
    assert_eq!(later.state_hash, paused.state_hash);
    assert_eq!(server.frame().tick, paused.tick);

    // The hash of the current tick, twice equal while paused; a past tick
    // comes from the recording; a future one is out of range.
    let (t1, h1) = hash(&mut admin, None).await;
    let (t2, h2) = hash(&mut admin, Some(paused.tick)).await;
    assert_eq!((t1, h1), (paused.tick, paused.state_hash));
    assert_eq!((t2, h2), (t1, h1));
    assert_eq!(hash(&mut admin, Some(1)).await.0, 1);
    assert_eq!(
        error_kind(
            &mut admin,
            AdminRequest::Hash {
                tick: Some(paused.tick + 1000)
            }
        )
        .await,
        AdminErrorKind::OutOfRange
    );

    // Step 5: exactly five ticks, then still paused.
    ok(&mut admin, AdminRequest::Step { ticks: 5 }).await;
    let target = paused.tick + 5;
    assert!(
        wait_for(Duration::from_secs(3), || async {
            server.frame().tick >= target
        })
        .await
    );
    tokio::time::sleep(Duration::from_millis(200)).await;
    let stepped = status(&mut admin).await;
    assert_eq!(stepped.tick, target);
    assert!(stepped.paused);
    assert_ne!(stepped.state_hash, paused.state_hash, "the pendulums moved");

    // Run to a tick ahead, then paused there; a tick behind is refused.
    let goal = stepped.tick + 30;
    ok(&mut admin, AdminRequest::RunTo { tick: goal }).await;
    assert!(
        wait_for(Duration::from_secs(3), || async {
            server.frame().tick >= goal
        })
        .await
    );
    tokio::time::sleep(Duration::from_millis(200)).await;
    let ran = status(&mut admin).await;
    assert_eq!(ran.tick, goal);
    assert!(ran.paused);
    assert_eq!(
        error_kind(&mut admin, AdminRequest::RunTo { tick: goal - 1 }).await,
        AdminErrorKind::OutOfRange
    );

    // Resume: real time again, at scale 1.
    ok(&mut admin, AdminRequest::Resume).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let resumed = status(&mut admin).await;
    assert!(!resumed.paused);
    assert_eq!(resumed.time_scale, 1.0);
    assert!(resumed.tick >= goal + 5, "{resumed:?}");

    // Every action was counted.
    let m = server.metrics();
    assert_eq!(m.admin_action_count("hello", "ok"), 1);
    assert_eq!(m.admin_action_count("pause", "ok"), 1);
    assert_eq!(m.admin_action_count("step", "ok"), 1);
    assert_eq!(m.admin_action_count("resume", "ok"), 1);
    assert_eq!(m.admin_action_count("run_to", "out_of_range"), 1);
    assert_eq!(m.admin_action_count("hash", "out_of_range"), 1);
    assert!(m.encode().contains("inertia_admin_actions_total"));
    admin.close().await;
    server.shutdown().await;
}

/// Ticks per wall second, as a multiple of real time, over `wall`.
async fn measured_scale(server: &RunningServer, wall: Duration) -> f64 {
    let (t0, w0) = (server.frame().tick, Instant::now());
    tokio::time::sleep(wall).await;
    let (t1, w1) = (server.frame().tick, Instant::now());
    (t1 - t0) as f64 / (w1 - w0).as_secs_f64() / 60.0
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn speed_changes_the_rate_of_ticks() {
    let server = start_server(test_config(Some("moving.ron"), "admin-speed")).await;
    let mut admin = admin(&server).await;

    ok(&mut admin, AdminRequest::Speed { scale: 4.0 }).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    let fast = measured_scale(&server, Duration::from_millis(1200)).await;
    // 4× within a quarter either way (a loaded machine may lag a little).
    assert!((3.0..=5.0).contains(&fast), "speed 4 ran at {fast:.2}×");
    let s = status(&mut admin).await;
    assert_eq!(s.time_scale, 4.0);
    assert!(
        (180.0..=300.0).contains(&s.achieved_rate),
        "achieved {} ticks/s at speed 4",
        s.achieved_rate
    );

    ok(&mut admin, AdminRequest::Speed { scale: 0.25 }).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    let slow = measured_scale(&server, Duration::from_millis(2000)).await;
    // 0.25× is 15 ticks a second: 30 in two seconds, ±8.
    assert!(
        (0.18..=0.32).contains(&slow),
        "speed 0.25 ran at {slow:.3}×"
    );
    assert_eq!(status(&mut admin).await.time_scale, 0.25);

    // Out of range: the tool will not send it, and the server refuses it
    // when sent anyway (call id 9, speed, the f64); the scale unchanged.
    for scale in [0.0, -1.0, 64.5, f64::NAN] {
        assert!(matches!(
            admin.call(AdminRequest::Speed { scale }).await,
            Err(AdminClientError::Protocol(_))
        ));
        let mut frame = 10u32.to_le_bytes().to_vec();
        frame.extend_from_slice(&[9, 4]);
        frame.extend_from_slice(&scale.to_le_bytes());
        let reply = admin.send_raw(&frame).await.expect("an answer");
        assert!(
            matches!(&reply.response, AdminResponse::Error(e) if e.kind == AdminErrorKind::Invalid),
            "speed {scale}: {reply:?}"
        );
    }
    assert_eq!(status(&mut admin).await.time_scale, 0.25);
    assert_eq!(
        server.metrics().admin_action_count("malformed", "invalid"),
        4
    );
    admin.close().await;
    server.shutdown().await;
}

/// The server keeps ticking at scale 1, unpaused.
async fn assert_unchanged(server: &RunningServer) {
    let before = server.frame().tick;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let frame = server.frame();
    assert!(frame.tick > before, "the tick keeps running");
    assert_eq!(frame.time_scale, 1.0);
    assert!(!frame.paused);
}

/// Sends `bytes` as the first thing on an admin connection and returns
/// what came back: a handshake, or `None` when the connection just closed.
async fn raw_first_message(server: &RunningServer, bytes: &[u8]) -> Option<AdminHandshake> {
    let (_endpoint, connection) = connect_quic(server.addr(), fingerprint(server))
        .await
        .expect("QUIC connects");
    let (mut send, mut recv) = connection.open_bi().await.expect("a stream");
    send.write_all(bytes).await.expect("written");
    let _ = send.finish();
    let mut frames = FrameDecoder::new();
    let mut buf = [0u8; 1024];
    let answer = tokio::time::timeout(Duration::from_secs(8), async {
        loop {
            if let Some(msg) = frames.next::<AdminHandshake>() {
                return msg.ok();
            }
            match recv.read(&mut buf).await {
                Ok(Some(n)) => frames.push(&buf[..n]).ok()?,
                _ => return None,
            }
        }
    })
    .await
    .expect("the server answers or closes in time");
    // Whatever it answered, the server closes the connection.
    let closed = tokio::time::timeout(Duration::from_secs(3), connection.closed()).await;
    assert!(closed.is_ok(), "the connection is closed after a refusal");
    answer
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hellos_without_the_credential_are_refused_and_change_nothing() {
    let server = start_server(test_config(Some("moving.ron"), "admin-refused")).await;

    for credential in ["not-the-credential", ""] {
        match admin_with(&server, credential).await {
            Err(AdminClientError::Refused(AdminRefusal::BadCredential)) => {}
            other => panic!("credential {credential:?}: expected a refusal, got {other:?}"),
        }
    }
    // The right credential with a different last character.
    let mut near = server.admin_token().to_string();
    let last = near.pop().expect("not empty");
    near.push(if last == '0' { '1' } else { '0' });
    assert!(matches!(
        admin_with(&server, &near).await,
        Err(AdminClientError::Refused(AdminRefusal::BadCredential))
    ));
    assert_unchanged(&server).await;

    // Garbage instead of a hello: refused as malformed, or closed.
    let garbage: Vec<u8> = (0..64u32).map(|i| (i * 97 + 13) as u8).collect();
    let answer = raw_first_message(&server, &garbage).await;
    assert!(
        matches!(
            answer,
            None | Some(AdminHandshake::Refused(AdminRefusal::Malformed))
        ),
        "{answer:?}"
    );
    // A well-formed call in place of the hello does nothing either.
    let call = encode_frame(&inertia_protocol::admin::AdminCall {
        id: 1,
        request: AdminRequest::Pause,
    })
    .expect("encodes");
    let answer = raw_first_message(&server, &call).await;
    assert!(
        !matches!(answer, Some(AdminHandshake::Welcome(_))),
        "{answer:?}"
    );
    // A frame header promising more than a frame may hold.
    let answer = raw_first_message(&server, &u32::MAX.to_le_bytes()).await;
    assert!(
        matches!(
            answer,
            None | Some(AdminHandshake::Refused(AdminRefusal::Malformed))
        ),
        "{answer:?}"
    );
    assert_unchanged(&server).await;

    let m = server.metrics();
    assert_eq!(m.admin_action_count("hello", "refused_credential"), 3);
    assert_eq!(m.admin_action_count("hello", "refused_malformed"), 3);
    assert_eq!(m.admin_action_count("hello", "ok"), 0);
    assert_eq!(m.admin_action_count("pause", "ok"), 0);
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_calls_after_a_good_hello_change_nothing() {
    let server = start_server(test_config(Some("moving.ron"), "admin-malformed")).await;
    let mut admin = admin(&server).await;

    // Bytes that are no call, in a well-formed frame: an error under id 0,
    // and the connection still serves.
    let mut frame = 3u32.to_le_bytes().to_vec();
    frame.extend_from_slice(&[0xff, 0xff, 0xff]);
    let reply = admin.send_raw(&frame).await.expect("an answer");
    assert_eq!(reply.id, 0);
    assert!(
        matches!(&reply.response, AdminResponse::Error(e) if e.kind == AdminErrorKind::Invalid),
        "{reply:?}"
    );
    // A call that decodes but fails its checks (id 7, step, 0 ticks).
    let mut frame = 3u32.to_le_bytes().to_vec();
    frame.extend_from_slice(&[7, 3, 0]);
    let reply = admin.send_raw(&frame).await.expect("an answer");
    assert!(
        matches!(&reply.response, AdminResponse::Error(e) if e.kind == AdminErrorKind::Invalid),
        "{reply:?}"
    );
    assert_unchanged(&server).await;
    let s = status(&mut admin).await;
    assert!(!s.paused);

    // A frame too large for the channel: an error, then the connection
    // closes; nothing changed.
    let reply = admin.send_raw(&u32::MAX.to_le_bytes()).await;
    if let Ok(reply) = &reply {
        assert!(
            matches!(&reply.response, AdminResponse::Error(_)),
            "{reply:?}"
        );
    }
    assert!(
        admin.call(AdminRequest::Pause).await.is_err(),
        "the connection is closed"
    );
    assert_unchanged(&server).await;
    let m = server.metrics();
    assert_eq!(m.admin_action_count("malformed", "invalid"), 3);
    assert_eq!(m.admin_action_count("pause", "ok"), 0);
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kick_despawn_impulse_spawn_and_refused_loads() {
    let server = start_server(test_config(Some("moving.ron"), "admin-kick")).await;
    let mut admin = admin(&server).await;

    let (addr, token) = token(&server, 42);
    let client = Client::connect(addr, &token).await.expect("joins");
    assert!(wait_for(Duration::from_secs(3), || async { server.clients() == 1 }).await);
    assert_eq!(status(&mut admin).await.clients, 1);
    ok(
        &mut admin,
        AdminRequest::Kick {
            client: 42,
            reason: "testing kicks".into(),
        },
    )
    .await;
    assert!(
        wait_for(Duration::from_secs(3), || async {
            client.disconnected().is_some()
        })
        .await
    );
    assert_eq!(
        client.disconnected(),
        Some(DisconnectReason::Kicked {
            reason: "testing kicks".into()
        })
    );
    assert!(wait_for(Duration::from_secs(3), || async { server.clients() == 0 }).await);
    assert_eq!(
        error_kind(
            &mut admin,
            AdminRequest::Kick {
                client: 42,
                reason: String::new()
            }
        )
        .await,
        AdminErrorKind::NotFound
    );

    // An impulse on a bob, then its removal.
    let bob = entity_named(&server, "bob_a");
    ok(
        &mut admin,
        AdminRequest::Impulse {
            id: bob,
            impulse: [0.0, 5.0, 0.0],
            point: None,
        },
    )
    .await;
    let bodies = status(&mut admin).await.bodies;
    ok(&mut admin, AdminRequest::Despawn { id: bob }).await;
    assert_eq!(status(&mut admin).await.bodies, bodies - 1);
    assert!(
        wait_for(Duration::from_secs(2), || async {
            !server.frame().catalog.contains_key(&bob)
        })
        .await
    );
    assert_eq!(
        error_kind(&mut admin, AdminRequest::Despawn { id: bob }).await,
        AdminErrorKind::NotFound
    );
    assert_eq!(
        error_kind(
            &mut admin,
            AdminRequest::Impulse {
                id: bob,
                impulse: [1.0, 0.0, 0.0],
                point: None
            }
        )
        .await,
        AdminErrorKind::NotFound
    );

    // A crate spawned by the operator: it is named in the reply, counted,
    // and reaches the clients' catalog with its description.
    let bodies = status(&mut admin).await.bodies;
    let desc = SpawnDesc {
        kind: EntityKind::Dynamic,
        shape: ShapeDesc::Cuboid {
            half_extents: [0.5; 3],
        },
        mass: MassSpec::Mass(10.0),
        position: [3.0, 4.0, 0.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        color: [200, 100, 50, 255],
        name: "crate".into(),
    };
    let id = match admin
        .call(AdminRequest::Spawn { desc: desc.clone() })
        .await
        .expect("an answer")
    {
        AdminResponse::Spawned { id } => id,
        other => panic!("expected Spawned, got {other:?}"),
    };
    assert_eq!(status(&mut admin).await.bodies, bodies + 1);
    assert!(
        wait_for(Duration::from_secs(2), || async {
            server
                .frame()
                .catalog
                .get(&id)
                .is_some_and(|d| d.name == "crate" && d.kind == EntityKind::Dynamic)
        })
        .await
    );
    // A shape the engine cannot make is refused and adds nothing.
    let ground = SpawnDesc {
        shape: ShapeDesc::Ground,
        ..desc
    };
    assert_eq!(
        error_kind(&mut admin, AdminRequest::Spawn { desc: ground }).await,
        AdminErrorKind::Invalid
    );
    assert_eq!(status(&mut admin).await.bodies, bodies + 1);

    // Loads of a missing checkpoint or of garbage, and seeks into the
    // future, are refused and change nothing.
    let checkpoints = server.checkpoints().clone();
    std::fs::create_dir_all(checkpoints.path()).expect("the checkpoint directory");
    let garbage = checkpoints.path().join("garbage.ckpt");
    std::fs::write(&garbage, b"not a checkpoint").expect("write");
    assert_eq!(
        error_kind(
            &mut admin,
            AdminRequest::Load {
                name: CheckpointName::new("missing.ckpt").expect("a name"),
            }
        )
        .await,
        AdminErrorKind::NotFound
    );
    assert_eq!(
        error_kind(
            &mut admin,
            AdminRequest::Load {
                name: CheckpointName::new("garbage.ckpt").expect("a name"),
            }
        )
        .await,
        AdminErrorKind::Invalid
    );
    std::fs::remove_file(&garbage).ok();
    assert_eq!(
        error_kind(&mut admin, AdminRequest::Seek { tick: u64::MAX / 2 }).await,
        AdminErrorKind::OutOfRange
    );
    assert_eq!(status(&mut admin).await.mode, TimeMode::Live);
    assert_unchanged(&server).await;
    client.close().await;
    admin.close().await;
    server.shutdown().await;
}
