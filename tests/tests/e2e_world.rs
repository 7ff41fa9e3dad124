//! Real clients and a real server over loopback QUIC: every client sees the
//! server's world, and interpolation through a bad link stays close to the
//! truth.

use std::collections::BTreeMap;
use std::time::Duration;

use glam::{DQuat, DVec3};
use inertia_client::Client;
use inertia_protocol::EntityId;
use inertia_server::server::RunningServer;
use inertia_tests::admin::ids_named;
use inertia_tests::server::{start_server, test_config, token};
use inertia_tests::{Conditioner, Impairment};

/// The angle between two orientations, degrees.
fn angle_deg(a: DQuat, b: DQuat) -> f64 {
    2.0 * a.dot(b).abs().min(1.0).acos().to_degrees()
}

/// The server's state of `id` at fractional `tick`, linear between the
/// ticks either side; `None` when either frame is no longer held.
fn truth_at(server: &RunningServer, tick: f64, id: EntityId) -> Option<(DVec3, DQuat)> {
    let lo = tick.floor() as u64;
    let f = tick - lo as f64;
    let state = |t: u64| {
        let frame = server.frame_at(t)?;
        let i = frame.entities.binary_search_by_key(&id, |e| e.id).ok()?;
        Some((frame.entities[i].position, frame.entities[i].rotation))
    };
    let (p0, q0) = state(lo)?;
    if f == 0.0 {
        return Some((p0, q0));
    }
    let (p1, q1) = state(lo + 1)?;
    Some((p0.lerp(p1, f), q0.slerp(q1, f)))
}

fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn several_clients_see_the_servers_world_within_quantization() {
    let server = start_server(test_config(Some("moving.ron"), "same-world")).await;
    let mut clients = Vec::new();
    for id in 1..=3 {
        let (addr, token) = token(&server, id);
        clients.push(Client::connect(addr, &token).await.expect("joins"));
    }
    tokio::time::sleep(Duration::from_millis(1500)).await;
    // Half the grid cell's diagonal, and the rotation code's worst case
    // (11-bit smallest-three: about 0.1°), with a margin for f64 rounding.
    let grid = clients[0].server_info().snapshot.grid.resolution;
    let max_pos = grid * 3f64.sqrt() / 2.0 + 1e-9;
    let max_deg = 0.15;
    let (mut checked, mut worst_pos, mut worst_deg) = (0, 0.0f64, 0.0f64);
    for _round in 0..10 {
        for client in &clients {
            let (tick, view) = client.latest_view().expect("snapshots arrive");
            let truth = server.frame_at(tick).expect("the frame is still held");
            let view: BTreeMap<EntityId, _> = view.into_iter().map(|e| (e.id, e)).collect();
            for e in &truth.entities {
                let seen = view
                    .get(&e.id)
                    .unwrap_or_else(|| panic!("entity {} missing at tick {tick}", e.id));
                let dp = (seen.position - e.position).length();
                let dq = angle_deg(seen.rotation, e.rotation);
                worst_pos = worst_pos.max(dp);
                worst_deg = worst_deg.max(dq);
                assert!(
                    dp <= max_pos,
                    "entity {} off by {dp} m at tick {tick}",
                    e.id
                );
                assert!(dq <= max_deg, "entity {} off by {dq}° at tick {tick}", e.id);
                checked += 1;
            }
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    println!(
        "{checked} entity states compared: worst position error {:.3} mm, rotation {:.3}°",
        worst_pos * 1e3,
        worst_deg
    );
    assert!(checked > 100);
    // Every client was described the same world.
    let names = |c: &Client| {
        let mut v: Vec<(EntityId, String)> =
            c.entities().into_iter().map(|e| (e.id, e.name)).collect();
        v.sort();
        v
    };
    assert_eq!(names(&clients[0]), names(&clients[1]));
    assert_eq!(names(&clients[0]), names(&clients[2]));
    for c in clients {
        c.close().await;
    }
    server.shutdown().await;
}

/// At 100 ms round trip, ±10 ms jitter and 5 % loss each way, the
/// interpolated picture of moving bodies stays within 2 cm of the server's
/// truth at the rendered tick (p99; about 2.5 mm measured), and never
/// stalls.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn interpolation_stays_close_at_100ms_rtt_jitter_and_loss() {
    const P99_BOUND_M: f64 = 0.02;
    let server = start_server(test_config(Some("moving.ron"), "interp")).await;
    let link = Impairment::half_rtt(Duration::from_millis(100), Duration::from_millis(10), 0.05);
    let conditioner = Conditioner::start(server.addr(), link, link, 42)
        .await
        .expect("conditioner");
    let (_, token) = token(&server, 7);
    let client = Client::connect(conditioner.addr(), &token)
        .await
        .expect("joins through the conditioner");
    tokio::time::sleep(Duration::from_secs(2)).await;
    let moving = ids_named(&client, &["bob_a", "bob_b", "bob_c", "wheel"]);
    let stalls_before = client.stats().stalls;
    let (mut pos_err, mut rot_err) = (Vec::new(), Vec::new());
    let mut last_tick = f64::NEG_INFINITY;
    for _ in 0..(6 * 60) {
        tokio::time::sleep(Duration::from_millis(16)).await;
        let frame = client.sample();
        assert!(
            frame.render_tick >= last_tick,
            "the rendered tick went backwards"
        );
        last_tick = frame.render_tick;
        for &id in &moving {
            let (Some(drawn), Some((p, q))) =
                (frame.get(id), truth_at(&server, frame.render_tick, id))
            else {
                continue;
            };
            pos_err.push((drawn.position - p).length());
            rot_err.push(angle_deg(drawn.rotation, q));
        }
    }
    let stats = client.stats();
    let p99 = percentile(pos_err.clone(), 0.99);
    let rot_p99 = percentile(rot_err, 0.99);
    println!(
        "{} samples: position error p50 {:.2} mm, p99 {:.2} mm, max {:.2} mm; rotation p99 {:.3}°; \
         loss {:.1} %, buffer {:.0} ms, stalls {}",
        pos_err.len(),
        percentile(pos_err.clone(), 0.5) * 1e3,
        p99 * 1e3,
        percentile(pos_err.clone(), 1.0) * 1e3,
        rot_p99,
        stats.loss * 100.0,
        stats.buffer_ms,
        stats.stalls - stalls_before,
    );
    assert!(pos_err.len() > 1000, "only {} samples", pos_err.len());
    assert!(p99 < P99_BOUND_M, "p99 position error {p99} m");
    // The wheel turns at 120°/s and rotations carry no angular velocity:
    // a few degrees at worst between snapshots.
    assert!(rot_p99 < 5.0, "p99 rotation error {rot_p99}°");
    assert_eq!(stats.stalls, stalls_before, "interpolation stalled");
    client.close().await;
    server.shutdown().await;
}

/// Production servers keep no frame history (it held about 72 MB at 1000
/// bodies): only a server configured with one answers `frame_at`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_12_frame_history_is_off_unless_configured() {
    let config = inertia_server::config::ServerConfig {
        frame_history: 0,
        ..test_config(Some("moving.ron"), "no-history")
    };
    let server = start_server(config).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let tick = server.frame().tick;
    assert!(tick > 0, "the server ticks");
    assert!(
        (tick.saturating_sub(10)..=tick).all(|t| server.frame_at(t).is_none()),
        "no frame kept"
    );
    server.shutdown().await;

    let server = start_server(test_config(Some("moving.ron"), "history")).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let tick = server.frame().tick;
    let held = (tick.saturating_sub(10)..tick).filter(|&t| server.frame_at(t).is_some());
    assert!(held.count() >= 5, "the test server keeps its frames");
    server.shutdown().await;
}
