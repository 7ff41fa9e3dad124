//! The server under Agones, against a fake SDK server that speaks the
//! sidecar's REST API and records every call: the sequence Agones checks
//! its own SDKs with, the server's lifecycle (ready, health, players,
//! allocation, shutdown), and the faults (an SDK server that starts late,
//! one that goes away, a tick that stalls).

use crate::fake_agones;

use std::time::{Duration, Instant};

use fake_agones::{game_server, FakeAgones};
use inertia_server::config::ServerConfig;
use inertia_server::orchestrator::sdk::{Counter, CounterUpdate, List, Sdk};
use inertia_server::orchestrator::OrchestratorMode;
use inertia_server::server::{start, RunningServer};

/// Polls `done` every 20 ms until it holds; fails after `timeout`.
async fn wait_for(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < timeout, "timed out waiting for {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// A dev-mode server on loopback, under Agones with the SDK server on
/// `sdk_port`.
async fn server_under_agones(what: &str, sdk_port: u16) -> RunningServer {
    server_with_scenes(what, sdk_port, None).await
}

/// [`server_under_agones`], allocations' scenes taken from `scenes`.
async fn server_with_scenes(
    what: &str,
    sdk_port: u16,
    scenes: Option<std::path::PathBuf>,
) -> RunningServer {
    let config = ServerConfig {
        record: false,
        max_clients: 16,
        scenes_dir: scenes,
        ..agones_config(what, sdk_port)
    };
    start(config).await.expect("the server starts")
}

/// A dev-mode server's settings on loopback, under Agones with the SDK
/// server on `sdk_port`, its data directory (emptied) named after `what`.
fn agones_config(what: &str, sdk_port: u16) -> ServerConfig {
    let dir = std::env::temp_dir().join(format!("inertia-agones-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir,
        orchestrator: OrchestratorMode::Agones,
        agones_sdk_port: Some(sdk_port),
        ..ServerConfig::default()
    }
}

/// A loopback port nothing listens on (for now).
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    l.local_addr().expect("bound").port()
}

fn players_declared() -> (Vec<Counter>, Vec<List>) {
    (
        vec![Counter {
            name: "players".into(),
            count: 0,
            capacity: 0,
        }],
        vec![List {
            name: "players".into(),
            capacity: 0,
            values: vec![],
        }],
    )
}

/// The calls Agones's own REST SDK test (`test/sdk/restapi`) makes, in its
/// order, with the answers it checks: lifecycle, metadata, the watch, and
/// counters and lists.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_the_sdk_client_passes_agones_own_sdk_sequence() {
    let fake = FakeAgones::start(
        0,
        game_server(5),
        vec![Counter {
            name: "rooms".into(),
            count: 1,
            capacity: 10,
        }],
        vec![List {
            name: "players".into(),
            capacity: 100,
            values: vec!["test0".into(), "test1".into(), "test2".into()],
        }],
    )
    .await;
    let sdk = Sdk::on_port(fake.addr.port());
    sdk.ready().await.expect("ready");
    let mut watch = sdk.watch().await.expect("watch");
    let first = watch.next().await.expect("a game server").expect("open");
    assert_eq!(first.status.state, "Ready");
    sdk.health().await.expect("health");
    sdk.reserve(5).await.expect("reserve");
    assert_eq!(
        watch.next().await.unwrap().unwrap().status.state,
        "Reserved"
    );
    sdk.allocate().await.expect("allocate");
    assert_eq!(
        watch.next().await.unwrap().unwrap().status.state,
        "Allocated"
    );
    let gs = sdk.game_server().await.expect("game server");
    assert_eq!(gs.object_meta.uid, first.object_meta.uid);
    let created = gs.object_meta.creation_timestamp.to_string();
    sdk.set_label("creationTimestamp", &created)
        .await
        .expect("label");
    sdk.set_annotation("UID", &gs.object_meta.uid)
        .await
        .expect("annotation");
    let now = sdk.game_server().await.expect("game server");
    assert_eq!(
        now.object_meta
            .labels
            .get("agones.dev/sdk-creationTimestamp"),
        Some(&created)
    );
    assert_eq!(
        now.object_meta.annotations.get("agones.dev/sdk-UID"),
        Some(&gs.object_meta.uid)
    );

    // Counters.
    let rooms = |count, capacity| Counter {
        name: "rooms".into(),
        count,
        capacity,
    };
    assert_eq!(sdk.counter("rooms").await.expect("counter"), rooms(1, 10));
    let diff = CounterUpdate {
        count_diff: Some(-1),
        capacity: Some(42),
        count: None,
    };
    assert_eq!(
        sdk.update_counter("rooms", &diff).await.expect("update"),
        rooms(0, 42)
    );
    let set = CounterUpdate {
        count: Some(40),
        capacity: Some(42),
        count_diff: None,
    };
    assert_eq!(
        sdk.update_counter("rooms", &set).await.expect("update"),
        rooms(40, 42)
    );
    let over = CounterUpdate {
        count: Some(43),
        ..CounterUpdate::default()
    };
    let refused = sdk.update_counter("rooms", &over).await.unwrap_err();
    assert!(refused.to_string().contains("400"), "{refused}");
    assert!(sdk.counter("sessions").await.unwrap_err().is_not_found());

    // Lists.
    let players = |values: &[&str], capacity| List {
        name: "players".into(),
        capacity,
        values: values.iter().map(|v| v.to_string()).collect(),
    };
    assert_eq!(
        sdk.list("players").await.expect("list"),
        players(&["test0", "test1", "test2"], 100)
    );
    assert_eq!(
        sdk.update_list(&players(&["test123", "test456"], 10))
            .await
            .expect("update"),
        players(&["test123", "test456"], 10)
    );
    assert_eq!(
        sdk.add_list_value("players", "test789").await.expect("add"),
        players(&["test123", "test456", "test789"], 10)
    );
    assert_eq!(
        sdk.remove_list_value("players", "test456")
            .await
            .expect("remove"),
        players(&["test123", "test789"], 10)
    );

    sdk.shutdown().await.expect("shutdown");
    // The metadata changes came down the watch too; the last is Shutdown.
    loop {
        let gs = watch.next().await.expect("the watch").expect("open");
        if gs.status.state == "Shutdown" {
            break;
        }
        assert_eq!(gs.status.state, "Allocated");
    }
    let whats = fake.whats();
    let expected = [
        "POST /ready",
        "GET /watch/gameserver",
        "POST /health",
        "POST /reserve",
        "POST /allocate",
        "GET /gameserver",
        "PUT /metadata/label",
        "PUT /metadata/annotation",
        "GET /gameserver",
        "GET /v1beta1/counters/rooms",
        "PATCH /v1beta1/counters/rooms",
        "PATCH /v1beta1/counters/rooms",
        "PATCH /v1beta1/counters/rooms",
        "GET /v1beta1/counters/sessions",
        "GET /v1beta1/lists/players",
        "PATCH /v1beta1/lists/players",
        "POST /v1beta1/lists/players:addValue",
        "POST /v1beta1/lists/players:removeValue",
        "POST /shutdown",
    ];
    assert_eq!(whats, expected);
}

/// A server under Agones calls Ready once it serves, pings Health every
/// half period, keeps the players counter and list equal to the clients
/// connected, and calls Shutdown last, after which nothing more is sent.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_server_under_agones_is_ready_healthy_counts_players_and_shuts_down() {
    let (counters, lists) = players_declared();
    let fake = FakeAgones::start(0, game_server(1), counters, lists).await;
    let server = server_under_agones("lifecycle", fake.addr.port()).await;
    wait_for("Ready", Duration::from_secs(10), || {
        fake.count("POST /ready") == 1
    })
    .await;
    wait_for("health pings", Duration::from_secs(10), || {
        fake.count("POST /health") >= 3
    })
    .await;
    // Pings come every half period (0.5 s here).
    let pings: Vec<Instant> = fake
        .calls()
        .into_iter()
        .filter(|c| c.what == "POST /health")
        .map(|c| c.at)
        .collect();
    for pair in pings.windows(2) {
        let gap = pair[1] - pair[0];
        assert!(
            gap > Duration::from_millis(300) && gap < Duration::from_millis(900),
            "{gap:?}"
        );
    }
    assert_eq!(fake.counter("players").unwrap().capacity, 16);

    let credentials = server.credentials_path().expect("dev mode").clone();
    let client = tokio::task::spawn_blocking(move || {
        crate::common::player::Player::join_dev(&credentials, Some(41)).expect("joins")
    })
    .await
    .unwrap();
    wait_for("the player counted", Duration::from_secs(10), || {
        fake.counter("players").unwrap().count == 1
            && fake.list("players").unwrap().values == ["41"]
    })
    .await;
    // The client's runtime is dropped outside the async context.
    tokio::task::spawn_blocking(move || drop(client))
        .await
        .unwrap();
    wait_for("the player gone", Duration::from_secs(15), || {
        fake.counter("players").unwrap().count == 0
            && fake.list("players").unwrap().values.is_empty()
    })
    .await;

    server.shutdown().await;
    let calls = fake.whats();
    assert_eq!(calls.last().map(String::as_str), Some("POST /shutdown"));
    assert_eq!(fake.game_server().status.state, "Shutdown");
    tokio::time::sleep(Duration::from_millis(1200)).await;
    assert_eq!(fake.whats().len(), calls.len(), "nothing after Shutdown");
}

/// The sidecar may start after the server: Ready is retried until it is
/// accepted, and the server serves meanwhile.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_ready_is_retried_until_the_sdk_server_is_up() {
    let port = free_port();
    let server = server_under_agones("late", port).await;
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert!(server.failure().is_none());
    let (counters, lists) = players_declared();
    let fake = FakeAgones::start(port, game_server(1), counters, lists).await;
    wait_for("Ready", Duration::from_secs(10), || {
        fake.count("POST /ready") == 1
    })
    .await;
    wait_for("health pings", Duration::from_secs(5), || {
        fake.count("POST /health") >= 1
    })
    .await;
    server.shutdown().await;
}

/// An SDK server that goes away does not stop the game: the server keeps
/// ticking and serving, and its pings resume when the SDK server is back.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_the_server_serves_on_when_the_sdk_server_goes_away() {
    let (counters, lists) = players_declared();
    let fake = FakeAgones::start(0, game_server(1), counters.clone(), lists.clone()).await;
    let port = fake.addr.port();
    let server = server_under_agones("away", port).await;
    wait_for("health pings", Duration::from_secs(10), || {
        fake.count("POST /health") >= 2
    })
    .await;
    fake.stop().await;
    let ticks = server
        .sim()
        .stats()
        .ticks
        .load(std::sync::atomic::Ordering::Relaxed);
    tokio::time::sleep(Duration::from_secs(2)).await;
    let later = server
        .sim()
        .stats()
        .ticks
        .load(std::sync::atomic::Ordering::Relaxed);
    assert!(later > ticks + 60, "the tick went on: {ticks} -> {later}");
    assert!(server.failure().is_none(), "still healthy");

    let back = FakeAgones::start(port, game_server(1), counters, lists).await;
    wait_for("pings to resume", Duration::from_secs(5), || {
        back.count("POST /health") >= 2
    })
    .await;
    assert_eq!(back.count("POST /ready"), 0, "Ready is not sent again");
    server.shutdown().await;
    assert_eq!(
        back.whats().last().map(String::as_str),
        Some("POST /shutdown")
    );
}

/// A tick that stalls stops the health pings within two health periods
/// (Agones then marks the game server Unhealthy), while `/healthz`, which
/// only sees a stopped tick thread, says nothing; pings resume with the
/// tick.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_stalled_tick_stops_health_pings_within_two_periods() {
    let period = Duration::from_secs(1);
    let fake = FakeAgones::start(0, game_server(1), vec![], vec![]).await;
    let server = server_under_agones("stall", fake.addr.port()).await;
    wait_for("health pings", Duration::from_secs(10), || {
        fake.count("POST /health") >= 2
    })
    .await;
    let stall = Duration::from_secs(4);
    let stalled_at = Instant::now();
    let done = server
        .sim()
        .call(move |_| std::thread::sleep(stall))
        .expect("the call is queued");
    tokio::time::sleep(stall - Duration::from_millis(200)).await;
    let pings_during: Vec<Instant> = fake
        .calls()
        .into_iter()
        .filter(|c| c.what == "POST /health" && c.at > stalled_at)
        .map(|c| c.at)
        .collect();
    let last = pings_during.last().copied().unwrap_or(stalled_at);
    assert!(
        last - stalled_at <= 2 * period,
        "a ping {:?} into the stall",
        last - stalled_at
    );
    done.await.expect("the stall ends");
    let resumed = fake.count("POST /health");
    wait_for("pings to resume", Duration::from_secs(3), || {
        fake.count("POST /health") > resumed
    })
    .await;
    assert!(server.failure().is_none());
    server.shutdown().await;
}

/// An allocation's labels and annotations set the match; its length ends
/// it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_an_allocation_sets_the_match_and_its_length_ends_it() {
    let fake = FakeAgones::start(0, game_server(1), vec![], vec![]).await;
    let server = server_under_agones("allocated", fake.addr.port()).await;
    wait_for("Ready", Duration::from_secs(10), || {
        fake.count("POST /ready") == 1
    })
    .await;
    // Let the watch connect before the allocation (it would be seen
    // either way: the watch starts with the game server as it is).
    wait_for("the watch", Duration::from_secs(5), || {
        fake.count("GET /watch/gameserver") >= 1
    })
    .await;
    assert!(server.allocation().is_none());
    fake.allocate_with(
        &[("inertia.dev/rules", "ctf")],
        &[
            ("inertia.dev/match-seconds", "1"),
            ("inertia.dev/scene", "arena.ron"),
            ("inertia.dev/replay-seed", "not a seed"),
        ],
    );
    let allocated_at = Instant::now();
    wait_for("the allocation", Duration::from_secs(5), || {
        server.allocation().is_some()
    })
    .await;
    let settings = server.allocation().unwrap().settings;
    assert_eq!(settings.length, Some(Duration::from_secs(1)));
    assert_eq!(settings.scene.as_deref(), Some("arena.ron"));
    assert_eq!(settings.rules.as_deref(), Some("ctf"));
    assert_eq!(settings.replay_seed, None, "a bad value is left out");
    let why = tokio::time::timeout(Duration::from_secs(5), server.match_over())
        .await
        .expect("the match ends");
    assert_eq!(why, "the match's time is up");
    let over = allocated_at.elapsed();
    assert!(over >= Duration::from_millis(900), "{over:?}");
    server.end_match(why).await;
    assert_eq!(
        fake.whats().last().map(String::as_str),
        Some("POST /shutdown")
    );
}

/// The scene an allocation names is loaded from the scenes directory in
/// place of the one the server started with; one that is a path is
/// refused and changes nothing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_an_allocation_s_scene_replaces_the_starting_one() {
    use inertia_server::scene::Scene;
    use std::sync::atomic::Ordering;
    let scenes = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let pyramid = Scene::read_file(scenes.join("pyramid.json"))
        .expect("the pyramid scene")
        .build_with(inertia_physics::WorldConfig::default())
        .expect("builds")
        .world
        .bodies()
        .count() as u64;
    for (scene, applied) in [("../scenes/pyramid.json", false), ("pyramid.json", true)] {
        let fake = FakeAgones::start(0, game_server(1), vec![], vec![]).await;
        let server = server_with_scenes("scene", fake.addr.port(), Some(scenes.clone())).await;
        wait_for("the watch", Duration::from_secs(10), || {
            fake.count("GET /watch/gameserver") >= 1
        })
        .await;
        let bodies = || server.sim().stats().bodies.load(Ordering::Relaxed);
        wait_for("the demo scene", Duration::from_secs(5), || bodies() > 0).await;
        let demo = bodies();
        assert_ne!(demo, pyramid, "the demo and the pyramid differ");
        fake.allocate_with(&[], &[("inertia.dev/scene", scene)]);
        wait_for("the allocation", Duration::from_secs(5), || {
            server.allocation().is_some()
        })
        .await;
        if applied {
            wait_for("the pyramid", Duration::from_secs(10), || {
                bodies() == pyramid
            })
            .await;
        } else {
            assert_eq!(server.allocation().unwrap().settings.scene, None);
            tokio::time::sleep(Duration::from_millis(500)).await;
            assert_eq!(bodies(), demo, "a path is refused; the demo plays on");
        }
        server.shutdown().await;
    }
}

/// The sandbox, remembering the match settings it was given.
struct Configured {
    inner: inertia_server::rules::SandboxRules,
    seen: std::sync::Arc<std::sync::Mutex<Option<inertia_server::orchestrator::MatchSettings>>>,
}

impl inertia_server::rules::GameRules for Configured {
    fn input_bytes(&self) -> usize {
        self.inner.input_bytes()
    }
    fn on_connect(
        &mut self,
        c: inertia_server::rules::ClientId,
        ctx: &mut inertia_server::rules::SimContext<'_>,
    ) -> Result<inertia_protocol::EntityId, inertia_server::rules::JoinRefusal> {
        self.inner.on_connect(c, ctx)
    }
    fn on_disconnect(
        &mut self,
        c: inertia_server::rules::ClientId,
        ctx: &mut inertia_server::rules::SimContext<'_>,
    ) {
        self.inner.on_disconnect(c, ctx)
    }
    fn on_input(
        &mut self,
        c: inertia_server::rules::ClientId,
        input: &inertia_protocol::PlayerInput,
        ctx: &mut inertia_server::rules::SimContext<'_>,
    ) -> Result<(), inertia_server::rules::InputRefusal> {
        self.inner.on_input(c, input, ctx)
    }
    fn configure_match(
        &mut self,
        settings: &inertia_server::orchestrator::MatchSettings,
        _ctx: &mut inertia_server::rules::SimContext<'_>,
    ) -> Result<(), String> {
        *self.seen.lock().unwrap() = Some(settings.clone());
        Ok(())
    }
}

/// The allocation's rules variant and seed reach the game rules.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_an_allocation_s_rules_and_seed_reach_the_game_rules() {
    let fake = FakeAgones::start(0, game_server(1), vec![], vec![]).await;
    let config = agones_config("rules", fake.addr.port());
    let dir = config.data_dir.clone();
    let seen = std::sync::Arc::default();
    let rules = Configured {
        inner: inertia_server::rules::SandboxRules::default(),
        seen: std::sync::Arc::clone(&seen),
    };
    let server = inertia_server::server::start_with_rules(config, Box::new(rules))
        .await
        .expect("starts");
    wait_for("the watch", Duration::from_secs(10), || {
        fake.count("GET /watch/gameserver") >= 1
    })
    .await;
    fake.allocate_with(
        &[("inertia.dev/rules", "ctf")],
        &[("inertia.dev/replay-seed", "42")],
    );
    wait_for("the rules configured", Duration::from_secs(5), || {
        seen.lock().unwrap().is_some()
    })
    .await;
    let got = seen.lock().unwrap().clone().unwrap();
    assert_eq!(got.rules.as_deref(), Some("ctf"));
    assert_eq!(got.replay_seed, Some(42));
    assert!(server.failure().is_none());
    server.shutdown().await;
    // The recording started a new session, with the configured rules in
    // its first keyframe, and reads back whole.
    let records: Vec<_> = inertia_server::record::RecordReader::open(dir.join("recording"))
        .expect("the recording")
        .iter()
        .collect::<Result<_, _>>()
        .expect("intact");
    let sessions = records
        .iter()
        .filter(|r| matches!(r, inertia_server::record::Record::SessionStart { .. }))
        .count();
    assert_eq!(sessions, 2, "the start, then the configured match");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The match's recording is kept (moved to the matches directory, which a
/// fleet mounts from a shared volume) before Agones hears `Shutdown` and
/// deletes the pod with its data.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_match_s_recording_is_kept_before_agones_deletes_the_pod() {
    let fake = FakeAgones::start(0, game_server(1), vec![], vec![]).await;
    let config = agones_config("kept", fake.addr.port());
    let dir = config.data_dir.clone();
    let matches = config.matches_dir();
    fake.look_into_at_shutdown(matches);
    let server = start(config).await.expect("starts");
    wait_for("the watch", Duration::from_secs(10), || {
        fake.count("GET /watch/gameserver") >= 1
    })
    .await;
    fake.allocate_with(&[], &[("inertia.dev/match-seconds", "1")]);
    let why = tokio::time::timeout(Duration::from_secs(10), server.match_over())
        .await
        .expect("the match ends");
    let kept = server.end_match(why).await.expect("kept");
    assert_eq!(
        fake.seen_at_shutdown(),
        Some(vec![kept.as_str().to_string()]),
        "the recording was in place when Shutdown came"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
