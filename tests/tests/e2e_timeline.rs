//! Time control against a real server over QUIC: a pause freezes what a
//! connected client draws and resuming continues from the same state; a
//! seek shows a recorded tick with its recorded hash to clients (who see a
//! discontinuity) and seeking to the live tick returns to live; fast
//! forward beyond what the CPU can do keeps the server answering; a
//! checkpoint saved and loaded through the admin channel brings back the
//! state it saved.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use glam::DVec3;
use inertia_admin_client::AdminClient;
use inertia_client::{Client, ClientEvent};
use inertia_protocol::admin::{
    AdminErrorKind, AdminRequest, AdminResponse, CheckpointName, TimeMode,
};
use inertia_protocol::EntityId;
use inertia_tests::admin::{admin, call, error_kind, ids_named, ok, status, wait_for};
use inertia_tests::server::{start_server, test_config, token};

/// `(tick, state_hash, recorded_hash)` of a hash, seek or load reply.
async fn hash_reply(admin: &mut AdminClient, request: AdminRequest) -> (u64, u64, Option<u64>) {
    let what = format!("{request:?}");
    match call(admin, request).await {
        AdminResponse::Hash {
            tick,
            state_hash,
            recorded_hash,
        } => (tick, state_hash, recorded_hash),
        other => panic!("{what}: expected a hash, got {other:?}"),
    }
}

/// One drawn frame: local time, render tick, the positions of `ids`.
#[derive(Debug, Clone)]
struct Drawn {
    at: f64,
    render_tick: f64,
    positions: Vec<DVec3>,
}

fn draw(client: &Client, ids: &[EntityId]) -> Option<Drawn> {
    let at = client.local_time();
    let frame = client.sample_at(at);
    let positions = ids
        .iter()
        .map(|id| frame.get(*id).map(|e| e.position))
        .collect::<Option<Vec<_>>>()?;
    Some(Drawn {
        at,
        render_tick: frame.render_tick,
        positions,
    })
}

/// Draws every 16 ms for `wall`.
async fn draw_for(client: &Client, ids: &[EntityId], wall: Duration) -> Vec<Drawn> {
    let end = Instant::now() + wall;
    let mut out = Vec::new();
    while Instant::now() < end {
        if let Some(d) = draw(client, ids) {
            out.push(d);
        }
        tokio::time::sleep(Duration::from_millis(16)).await;
    }
    out
}

/// The largest speed (m/s) any entity appears to move at between two
/// consecutive frames.
fn fastest(frames: &[Drawn]) -> f64 {
    frames
        .windows(2)
        .map(|w| {
            let dt = (w[1].at - w[0].at).max(1e-3);
            w[0].positions
                .iter()
                .zip(&w[1].positions)
                .map(|(a, b)| (*b - *a).length() / dt)
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

fn discontinuities(client: &Client) -> Vec<inertia_client::clock::Discontinuity> {
    let mut out = Vec::new();
    while let Some(e) = client.poll_event() {
        if let ClientEvent::Discontinuity(d) = e {
            out.push(d);
        }
    }
    out
}

fn percentile(v: &[f64], p: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pause_freezes_the_clients_picture_and_resume_continues_from_the_same_state() {
    let server = start_server(test_config(Some("moving.ron"), "timeline-pause")).await;
    let mut admin = admin(&server).await;
    let (addr, token) = token(&server, 21);
    let client = Client::connect(addr, &token).await.expect("joins");
    assert!(
        wait_for(Duration::from_secs(3), || async {
            client.entities().len() >= 9
        })
        .await,
        "the scene is described"
    );
    let bobs = ids_named(&client, &["bob_a", "bob_b", "bob_c"]);
    let before = draw_for(&client, &bobs, Duration::from_millis(1000)).await;
    assert!(before.len() > 20, "the picture is drawn");
    let moving = fastest(&before);
    assert!(moving > 0.5, "the pendulums swing ({moving:.2} m/s)");
    discontinuities(&client);

    ok(&mut admin, AdminRequest::Pause).await;
    let paused = status(&mut admin).await;
    assert!(paused.paused);
    let t = paused.tick;
    let received = client.stats().snapshots_received;
    let during = draw_for(&client, &bobs, Duration::from_millis(2000)).await;
    let received = client.stats().snapshots_received - received;
    assert!(
        received >= 30,
        "snapshots keep coming while paused ({received} in 2 s)"
    );
    assert_eq!(
        client.latest_view().map(|v| v.0),
        Some(t),
        "the snapshots show the paused tick"
    );
    let later = status(&mut admin).await;
    assert_eq!(
        (later.tick, later.state_hash),
        (t, paused.state_hash),
        "nothing ran while paused"
    );

    // No jump: from before the pause into it, nothing moves faster than
    // the pendulums do.
    let mut around: Vec<Drawn> = before.clone();
    around.extend(during.iter().cloned());
    let fastest_around = fastest(&around);
    assert!(
        fastest_around < moving * 1.5 + 0.5,
        "a jump at the pause: {fastest_around:.2} m/s against {moving:.2} m/s before"
    );
    // Frozen: the render tick settles on the paused tick and the picture
    // stands still from then on.
    let settled = during
        .iter()
        .position(|d| d.render_tick >= t as f64)
        .expect("the render tick reaches the paused tick");
    let settle_s = during[settled].at - during[0].at;
    assert!(settle_s < 1.0, "settled after {settle_s:.2} s");
    let frozen = &during[settled..];
    assert!(frozen.len() > 40, "{} frozen frames", frozen.len());
    let ticks: Vec<f64> = during.iter().map(|d| d.render_tick).collect();
    for d in frozen {
        assert_eq!(
            d.render_tick, t as f64,
            "paused at tick {t}; render ticks while paused: {ticks:?}"
        );
    }
    // The picture stands still: at most the tail of a correction blend
    // (time constant 0.1 s) settles in the first moments, then nothing
    // moves over the last 0.8 s.
    let end = frozen.last().expect("frames");
    let off = |d: &Drawn| {
        d.positions
            .iter()
            .zip(&end.positions)
            .map(|(p, q)| (*p - *q).length())
            .fold(0.0, f64::max)
    };
    let settle_drift = frozen.iter().map(off).fold(0.0, f64::max);
    let late_drift = frozen
        .iter()
        .filter(|d| end.at - d.at <= 0.8)
        .map(off)
        .fold(0.0, f64::max);
    assert!(
        settle_drift < 0.02,
        "the paused picture moved {settle_drift} m"
    );
    assert!(
        late_drift < 1e-4,
        "the paused picture still moves: {late_drift} m over the last 0.8 s"
    );
    assert!(
        discontinuities(&client).is_empty(),
        "a pause is no timeline break"
    );
    println!(
        "paused at tick {t}: {received} snapshots in 2 s, render tick settled after {:.0} ms, {} frozen frames (settling {settle_drift:.1e} m, then {late_drift:.1e} m); fastest motion {fastest_around:.2} m/s (before {moving:.2})",
        settle_s * 1000.0,
        frozen.len()
    );

    // Resume: the world goes on from the paused state.
    ok(&mut admin, AdminRequest::Resume).await;
    let after = draw_for(&client, &bobs, Duration::from_millis(700)).await;
    assert!(fastest(&after) > 0.5, "the picture moves again");
    let resumed = status(&mut admin).await;
    assert!(!resumed.paused && resumed.tick > t + 10, "{resumed:?}");
    let (tick, at_pause, recorded) =
        hash_reply(&mut admin, AdminRequest::Hash { tick: Some(t) }).await;
    assert_eq!(tick, t);
    assert_eq!(
        at_pause, paused.state_hash,
        "the paused state, re-simulated"
    );
    assert_eq!(recorded, Some(paused.state_hash), "and as recorded");
    for next in [t + 1, t + 5] {
        let (_, state, recorded) =
            hash_reply(&mut admin, AdminRequest::Hash { tick: Some(next) }).await;
        assert_eq!(
            Some(state),
            recorded,
            "tick {next}: the resumed world continued from the paused state"
        );
    }
    client.close().await;
    admin.close().await;
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn seek_over_the_network_shows_the_recorded_tick_to_clients_and_returns_to_live() {
    let server = start_server(test_config(Some("moving.ron"), "timeline-seek")).await;
    let mut admin = admin(&server).await;
    let (addr, token) = token(&server, 22);
    let client = Client::connect(addr, &token).await.expect("joins");
    // Long enough for a recording to seek back into, and the scene
    // described (a fixed sleep alone lost the race on a loaded machine).
    tokio::time::sleep(Duration::from_millis(2500)).await;
    assert!(
        wait_for(Duration::from_secs(10), || async {
            client.entities().len() >= 9
        })
        .await,
        "the scene is described"
    );
    let bobs = ids_named(&client, &["bob_a", "bob_b", "bob_c"]);
    draw_for(&client, &bobs, Duration::from_millis(300)).await;
    discontinuities(&client);

    let s0 = status(&mut admin).await;
    assert_eq!(s0.mode, TimeMode::Live);
    assert!(s0.tick > 100, "{s0:?}");
    let target = s0.tick - 90;
    let started = Instant::now();
    let (tick, state_hash, recorded) =
        hash_reply(&mut admin, AdminRequest::Seek { tick: target }).await;
    let seek_ms = started.elapsed().as_secs_f64() * 1000.0;
    assert_eq!(tick, target);
    assert_eq!(
        Some(state_hash),
        recorded,
        "the recorded state, re-simulated"
    );
    let s1 = status(&mut admin).await;
    assert_eq!(s1.mode, TimeMode::History);
    assert_eq!((s1.tick, s1.state_hash), (target, state_hash));
    assert!(s1.paused);
    let live = s1.live_tick;
    assert!(live >= s0.tick && live < s0.tick + 60, "{s1:?}");
    tokio::time::sleep(Duration::from_millis(300)).await;
    let s2 = status(&mut admin).await;
    assert_eq!(
        (s2.mode, s2.tick, s2.live_tick),
        (TimeMode::History, target, live),
        "the live tick stands still while history is shown"
    );

    // The client sees the old tick and is told the timeline jumped.
    assert!(
        wait_for(Duration::from_secs(2), || async {
            client.latest_view().map(|v| v.0) == Some(target)
        })
        .await,
        "snapshots of tick {target} arrive"
    );
    let mut jumps = Vec::new();
    assert!(
        wait_for(Duration::from_secs(2), || {
            jumps.extend(discontinuities(&client));
            let found = jumps.iter().any(|d| d.to_tick == target);
            async move { found }
        })
        .await,
        "a discontinuity to tick {target}: {jumps:?}"
    );
    let jump = jumps
        .iter()
        .find(|d| d.to_tick == target)
        .copied()
        .expect("found");
    assert!(jump.is_backwards(), "{jump:?}");
    assert!(jump.from_tick > target, "{jump:?}");
    let shown = draw_for(&client, &bobs, Duration::from_millis(800)).await;
    let last = shown.last().expect("drawn");
    assert_eq!(
        last.render_tick, target as f64,
        "the client draws the old tick"
    );

    // Back to the live tick: live again, as recorded.
    let (tick, state_hash, recorded) =
        hash_reply(&mut admin, AdminRequest::Seek { tick: live }).await;
    assert_eq!(tick, live);
    assert_eq!(Some(state_hash), recorded, "the live state it was left in");
    let s3 = status(&mut admin).await;
    assert_eq!(s3.mode, TimeMode::Live);
    assert_eq!(
        (s3.tick, s3.live_tick, s3.state_hash),
        (live, live, state_hash)
    );
    ok(&mut admin, AdminRequest::Resume).await;
    assert!(
        wait_for(Duration::from_secs(3), || async {
            client.latest_view().is_some_and(|v| v.0 > live)
        })
        .await,
        "live snapshots again"
    );
    let s4 = status(&mut admin).await;
    assert_eq!(s4.mode, TimeMode::Live);
    assert!(s4.tick > live);
    println!(
        "seek {} ticks back answered in {seek_ms:.1} ms; client saw {:?}",
        s0.tick - target,
        jump
    );
    client.close().await;
    admin.close().await;
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fast_forward_beyond_the_cpu_keeps_the_server_responsive() {
    let mut config = test_config(None, "timeline-ff");
    config.scene = Some(
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("server")
            .join("scenes")
            .join("capacity.ron"),
    );
    let server = start_server(config).await;
    let mut admin = admin(&server).await;
    let (addr, token) = token(&server, 23);
    let client = Client::connect(addr, &token).await.expect("joins");
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert!(status(&mut admin).await.bodies >= 1000);

    ok(&mut admin, AdminRequest::Speed { scale: 64.0 }).await;
    let started = Instant::now();
    let first = status(&mut admin).await;
    let mut latencies = Vec::new();
    let mut per_second = Vec::new();
    let mut window = (Instant::now(), client.stats().snapshots_received);
    let mut last = first;
    while started.elapsed() < Duration::from_secs(4) {
        let t = Instant::now();
        last = status(&mut admin).await;
        latencies.push(t.elapsed().as_secs_f64() * 1000.0);
        if window.0.elapsed() >= Duration::from_secs(1) {
            let n = client.stats().snapshots_received;
            per_second.push(n - window.1);
            window = (Instant::now(), n);
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let wall = started.elapsed().as_secs_f64();
    let ticks_per_s = (last.tick - first.tick) as f64 / wall;
    let p50 = percentile(&latencies, 0.5);
    let max = latencies.iter().copied().fold(0.0, f64::max);
    println!(
        "speed 64 on 1000 balls: achieved {:.0} ticks/s (status), {ticks_per_s:.0} ticks/s measured, tick p99 {:.2} ms; {} status calls, latency p50 {p50:.1} ms, max {max:.1} ms; snapshots per second {per_second:?}",
        last.achieved_rate,
        last.tick_ms_p99,
        latencies.len()
    );
    assert_eq!(last.time_scale, 64.0);
    assert!(!last.paused);
    assert!(max < 500.0, "a status took {max:.0} ms");
    assert!(per_second.len() >= 3, "{per_second:?}");
    assert!(
        per_second.iter().all(|&n| n > 0),
        "snapshots every second: {per_second:?}"
    );
    assert!(
        last.achieved_rate < 64.0 * 60.0,
        "the CPU cannot run 3840 ticks/s here: {}",
        last.achieved_rate
    );
    assert!(last.achieved_rate > 60.0, "faster than real time: {last:?}");
    assert!(ticks_per_s > 60.0, "{ticks_per_s:.0} ticks/s");

    assert_eq!(client.disconnected(), None, "the client stayed connected");
    // Back to real time, still answering.
    ok(&mut admin, AdminRequest::Speed { scale: 1.0 }).await;
    assert_eq!(status(&mut admin).await.time_scale, 1.0);
    client.close().await;
    admin.close().await;
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn save_and_load_over_the_network_bring_back_the_saved_state() {
    let config = test_config(Some("moving.ron"), "timeline-save");
    let data_dir = config.data_dir.clone();
    let server = start_server(config).await;
    let mut admin = admin(&server).await;
    tokio::time::sleep(Duration::from_millis(500)).await;

    ok(&mut admin, AdminRequest::Pause).await;
    let (t, h, _) = hash_reply(&mut admin, AdminRequest::Hash { tick: None }).await;
    let name = CheckpointName::new("checkpoint.isim").expect("a name");
    let file = server.checkpoints().path().join("checkpoint.isim");
    assert_eq!(
        server.checkpoints().path(),
        data_dir.join("checkpoints"),
        "under the data directory by default"
    );
    ok(
        &mut admin,
        AdminRequest::Save {
            name: name.clone(),
            overwrite: false,
        },
    )
    .await;
    assert!(file.is_file(), "the checkpoint is written");
    let s = status(&mut admin).await;
    assert_eq!((s.tick, s.state_hash), (t, h), "saving changes nothing");
    // The tick after the save, to compare with after the load.
    ok(&mut admin, AdminRequest::Step { ticks: 1 }).await;
    assert!(wait_for(Duration::from_secs(3), || async { server.frame().tick > t }).await);
    let (t1, h1, _) = hash_reply(&mut admin, AdminRequest::Hash { tick: None }).await;
    assert_eq!(t1, t + 1);

    // Run on for a second, then load.
    ok(&mut admin, AdminRequest::Resume).await;
    tokio::time::sleep(Duration::from_millis(1000)).await;
    ok(&mut admin, AdminRequest::Pause).await;
    let on = status(&mut admin).await;
    assert!(on.tick > t + 30, "{on:?}");
    let (tick, state_hash, _) =
        hash_reply(&mut admin, AdminRequest::Load { name: name.clone() }).await;
    assert_eq!(
        (tick, state_hash),
        (t, h),
        "the load brings back the saved state"
    );
    let s = status(&mut admin).await;
    assert_eq!((s.tick, s.state_hash, s.mode), (t, h, TimeMode::Live));
    ok(&mut admin, AdminRequest::Step { ticks: 1 }).await;
    // Exactly the tick after: the frame published before the load is
    // past `t` too, and a hash asked on it could come before the step.
    assert!(
        wait_for(Duration::from_secs(3), || async {
            server.frame().tick == t + 1
        })
        .await
    );
    assert_eq!(
        hash_reply(&mut admin, AdminRequest::Hash { tick: None }).await,
        (t1, h1, Some(h1)),
        "and it continues as it did after the save"
    );

    // A file that is no checkpoint, and one that is not there: refused,
    // nothing changes.
    let garbage = server.checkpoints().path().join("garbage.isim");
    std::fs::write(&garbage, b"this is no checkpoint at all").expect("written");
    let load = |n: &str| AdminRequest::Load {
        name: CheckpointName::new(n).expect("a name"),
    };
    assert_eq!(
        error_kind(&mut admin, load("garbage.isim")).await,
        AdminErrorKind::Invalid
    );
    assert_eq!(
        error_kind(&mut admin, load("missing.isim")).await,
        AdminErrorKind::NotFound
    );
    let s = status(&mut admin).await;
    assert_eq!((s.tick, s.state_hash), (t1, h1));
    println!(
        "saved at tick {t} ({h:#018x}), ran to {}, loaded back",
        on.tick
    );
    admin.close().await;
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&data_dir);
}
