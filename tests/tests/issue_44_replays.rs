//! Players' replays (issue 44) over a real server: a player is run into by
//! another, asks for its kill-cam of the last 5 s centred on the one who
//! hit it, sees the hit from the hitter's side while the match goes on,
//! and is back on the live match; the other player never stops receiving
//! it. Requests the server cannot play are refused with typed answers and
//! counted.
//!
//! Prints the figures: `cargo test -p inertia-tests --test
//! issue_44_replays -- --nocapture`.

use std::time::{Duration, Instant};

use inertia_client::{Client, ClientEvent, ReplayEvent, ReplayStatus};
use inertia_protocol::replay::{ReplayEnd, ReplayRefusal, ReplayRequest};
use inertia_protocol::EntityId;
use inertia_tests::server::{http_get, start_server, test_config, token};

/// One frame of the game, s.
const FRAME: Duration = Duration::from_millis(16);

async fn join(server: &inertia_server::server::RunningServer, id: u64) -> Client {
    let (addr, token) = token(server, id);
    Client::connect(addr, &token).await.expect("joins")
}

/// The avatar `client` owns, once described.
async fn avatar_of(client: &Client) -> EntityId {
    let id = client.client_id();
    for _ in 0..300 {
        if let Some(e) = client.entities().iter().find(|e| e.owner == Some(id)) {
            return e.id;
        }
        tokio::time::sleep(FRAME).await;
    }
    panic!("client {id} was never told its avatar");
}

/// The newest live tick `client` received.
fn live_tick(client: &Client) -> u64 {
    client.timeline().map_or(0, |t| t.tick)
}

/// The replay events `client` has had since the last look.
fn replay_events(client: &Client) -> Vec<ReplayEvent> {
    let mut out = Vec::new();
    while let Some(e) = client.poll_event() {
        if let ClientEvent::Replay(r) = e {
            out.push(r);
        }
    }
    out
}

/// Waits for `client`'s next replay event.
async fn next_replay_event(client: &Client) -> ReplayEvent {
    for _ in 0..300 {
        if let Some(e) = replay_events(client).into_iter().next() {
            return e;
        }
        tokio::time::sleep(FRAME).await;
    }
    panic!("no answer about the replay");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_44_a_kill_cam_shows_the_hit_from_the_hitters_side_while_the_match_goes_on() {
    let server = start_server(test_config(Some("moving.ron"), "killcam")).await;
    let victim = join(&server, 1).await;
    let hitter = join(&server, 2).await;
    let (victim_avatar, hitter_avatar) = (avatar_of(&victim).await, avatar_of(&hitter).await);
    victim.set_input([0.0, 0.0], 0.0, 0).unwrap();
    hitter.set_input([0.0, 0.0], 0.0, 0).unwrap();
    // Long enough for the server to hold the 5 s the kill-cam asks for.
    tokio::time::sleep(Duration::from_secs(5)).await;

    // The hitter runs into the victim, and on for a moment.
    let distance = |s: &inertia_client::interp::Sample| {
        let (a, b) = (s.get(victim_avatar)?, s.get(hitter_avatar)?);
        Some((a.position - b.position).length())
    };
    let started = Instant::now();
    let mut hit_at = None;
    while started.elapsed() < Duration::from_secs(6) {
        let s = hitter.sample();
        let (Some(a), Some(b)) = (s.get(victim_avatar), s.get(hitter_avatar)) else {
            tokio::time::sleep(FRAME).await;
            continue;
        };
        let to = a.position - b.position;
        let flat = glam::DVec2::new(to.x, to.z).normalize_or_zero();
        hitter
            .set_input([flat.x as f32, flat.y as f32], 0.0, 0)
            .unwrap();
        if distance(&s).is_some_and(|d| d < 1.2) && hit_at.is_none() {
            hit_at = Some(Instant::now());
        }
        if hit_at.is_some_and(|t| t.elapsed() > Duration::from_millis(500)) {
            break;
        }
        tokio::time::sleep(FRAME).await;
    }
    assert!(hit_at.is_some(), "the hitter reached the victim");
    hitter.set_input([0.0, 0.0], 0.0, 0).unwrap();
    let _ = replay_events(&victim);

    // The victim's kill-cam: the last 5 s, as it happened, on the hitter.
    let asked = Instant::now();
    victim
        .kill_cam(5.0, 1.0, Some(hitter_avatar))
        .expect("asked");
    let (from_tick, to_tick) = match next_replay_event(&victim).await {
        ReplayEvent::Started {
            from_tick,
            to_tick,
            speed,
        } => {
            assert_eq!(speed, 1.0);
            (from_tick, to_tick)
        }
        other => panic!("the kill-cam was not started: {other:?}"),
    };
    let tick_hz = u64::from(victim.server_info().tick_hz);
    assert!(
        to_tick - from_tick >= 5 * tick_hz - tick_hz / 5,
        "{from_tick}..{to_tick}"
    );
    let mut first_snapshot = None;
    let mut closest = f64::INFINITY;
    let mut replay_ticks = Vec::new();
    let mut live_ticks = Vec::new();
    let ended = loop {
        assert!(asked.elapsed() < Duration::from_secs(12), "the replay ends");
        if first_snapshot.is_none() && victim.replay_tick().is_some() {
            first_snapshot = Some(asked.elapsed());
        }
        if let Some(s) = victim.replay_sample() {
            assert!(
                s.get(hitter_avatar).is_some(),
                "the replay always shows the hitter, whom it follows"
            );
            if let Some(d) = distance(&s) {
                closest = closest.min(d);
            }
            replay_ticks.push(s.render_tick);
        }
        // The live match goes on for both, meanwhile.
        live_ticks.push((live_tick(&victim), live_tick(&hitter)));
        if let Some(ReplayEvent::Ended(why)) = replay_events(&victim).into_iter().next() {
            break why;
        }
        tokio::time::sleep(FRAME).await;
    };
    assert_eq!(ended, ReplayEnd::Finished);
    assert_eq!(
        victim.replay_status(),
        ReplayStatus::Ended(ReplayEnd::Finished)
    );
    let played = asked.elapsed();
    let first = first_snapshot.expect("replay snapshots came");
    println!(
        "kill-cam: first replay snapshot after {:.1} ms; {from_tick}..{to_tick} played in {:.2} s; \
         closest the replay drew them: {closest:.2} m",
        first.as_secs_f64() * 1e3,
        played.as_secs_f64()
    );
    assert!(first < Duration::from_millis(500), "{first:?}");
    assert!(closest < 1.3, "the replay shows the hit: {closest} m");
    let (lo, hi) = (from_tick as f64 - 1.0, to_tick as f64 + 1.0);
    assert!(
        replay_ticks.iter().all(|t| (lo..=hi).contains(t)),
        "the replay draws only its stretch"
    );
    assert!(
        replay_ticks.windows(2).all(|w| w[1] >= w[0]),
        "the replay runs forwards"
    );
    // Played at real time: about 5 s of wall time for 5 s of match.
    assert!(
        played > Duration::from_secs(4) && played < Duration::from_secs(8),
        "{played:?}"
    );
    // Neither player's live stream stalled: the newest live tick moved
    // on at least every 250 ms of the replay, for both.
    let stalls = |f: fn(&(u64, u64)) -> u64| {
        let ticks: Vec<u64> = live_ticks.iter().map(f).collect();
        ticks.windows(16).filter(|w| w.first() == w.last()).count()
    };
    assert_eq!(stalls(|t| t.0), 0, "the victim's live stream went on");
    assert_eq!(stalls(|t| t.1), 0, "the hitter's live stream went on");
    // Back live: the victim's live view is the present.
    let (v, h) = (live_tick(&victim), live_tick(&hitter));
    assert!(v.abs_diff(h) <= tick_hz / 2, "victim at {v}, hitter at {h}");
    assert!(
        v > to_tick + 4 * tick_hz,
        "the live match went on meanwhile"
    );
    assert!(victim.sample().get(victim_avatar).is_some());
    assert!(
        replay_events(&hitter).is_empty(),
        "the hitter saw nothing of it"
    );
    let (_, metrics) = http_get(server.metrics_addr(), "/metrics").await;
    assert!(
        metrics.contains("inertia_replays_total{outcome=\"started\"} 1"),
        "{metrics}"
    );
    assert!(metrics.contains("inertia_replays_total{outcome=\"finished\"} 1"));
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_44_replays_the_server_cannot_play_are_refused_with_typed_answers() {
    let server = start_server(test_config(Some("moving.ron"), "replay-refusals")).await;
    let client = join(&server, 1).await;
    client.set_input([0.0, 0.0], 0.0, 0).unwrap();
    tokio::time::sleep(Duration::from_secs(2)).await;
    let now = live_tick(&client);
    let tick_hz = u64::from(client.server_info().tick_hz);
    let ask = |from_tick: u64, to_tick: u64| ReplayRequest {
        from_tick,
        to_tick,
        speed: 1.0,
        focus: None,
    };

    // Refused here, before anything is sent.
    for (bad, why) in [
        (ask(now, now), ReplayRefusal::Empty),
        (
            ReplayRequest {
                speed: f32::NAN,
                ..ask(now - 10, now)
            },
            ReplayRefusal::Speed,
        ),
        (
            ReplayRequest {
                speed: 100.0,
                ..ask(now - 10, now)
            },
            ReplayRefusal::Speed,
        ),
    ] {
        match client.replay(bad) {
            Err(inertia_client::ClientError::Replay(r)) => assert_eq!(r, why),
            other => panic!("{bad:?}: {other:?}"),
        }
    }

    // Refused by the server, saying why.
    client
        .replay(ask(now + 10 * tick_hz, now + 11 * tick_hz))
        .unwrap();
    assert!(matches!(
        next_replay_event(&client).await,
        ReplayEvent::Refused(ReplayRefusal::Future { newest }) if newest >= now
    ));
    // Longer than the window (30 s), wherever it lies.
    client.replay(ask(now, now + 31 * tick_hz)).unwrap();
    assert!(matches!(
        next_replay_event(&client).await,
        ReplayEvent::Refused(ReplayRefusal::TooLong { max_ticks }) if max_ticks == 30 * tick_hz
    ));
    client.replay(ask(0, 1)).unwrap();
    // The server's first frames may still be held one second in: the
    // oldest is then past tick 1 only if the world started before it.
    match next_replay_event(&client).await {
        ReplayEvent::Refused(ReplayRefusal::TooOld { oldest }) => assert!(oldest > 0),
        ReplayEvent::Started { .. } => {}
        other => panic!("{other:?}"),
    }
    // Faster than one a second: refused once the burst is spent.
    let mut rate_limited = false;
    for _ in 0..6 {
        client.replay(ask(now - tick_hz / 2, now)).unwrap();
        if let ReplayEvent::Refused(ReplayRefusal::RateLimited) = next_replay_event(&client).await {
            rate_limited = true;
            break;
        }
    }
    assert!(rate_limited, "a flood of requests is refused");

    // Nothing of it touched the live match.
    let before = live_tick(&client);
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(live_tick(&client) > before, "the live stream goes on");
    let (_, metrics) = http_get(server.metrics_addr(), "/metrics").await;
    for outcome in ["future", "too_long", "rate"] {
        assert!(
            metrics.contains(&format!("inertia_replays_total{{outcome=\"{outcome}\"}}")),
            "{outcome}: {metrics}"
        );
    }
    server.shutdown().await;
}
