//! The tick thread for real: frames flow, pause/step/run_to work through the
//! handle, and a flood of inputs neither stalls the tick nor blocks the
//! sender.

use std::time::{Duration, Instant};

use inertia_protocol::PlayerInput;
use inertia_server::rules::{JoinRefusal, SandboxRules};
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{CommandError, SimConfig, SimHandle};

const FLAT: &str = r#"(
    spawn_points: [(0.0, 1.0, 0.0), (3.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (50.0, 0.5, 50.0)), position: (0.0, -0.5, 0.0)),
        (name: "ball", shape: Sphere(radius: 0.3), position: (2.0, 3.0, 2.0)),
    ],
)"#;

fn start(config: SimConfig) -> SimHandle {
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    SimHandle::spawn(built, Box::new(SandboxRules::default()), config).unwrap()
}

fn wait_for(h: &SimHandle, what: &str, mut ok: impl FnMut(&inertia_server::sim::Frame) -> bool) {
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        if ok(&h.frame()) {
            return;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!(
        "timed out waiting for {what}; last frame tick {}",
        h.frame().tick
    );
}

#[test]
fn frames_flow_and_the_clock_obeys() {
    let h = start(SimConfig::default());
    let avatar = h.join_blocking(9).unwrap();
    wait_for(&h, "ticks", |f| f.tick >= 10);
    let f = h.frame();
    assert!(f.catalog.contains_key(&avatar));
    assert!(f.entities.iter().any(|s| s.id == avatar));
    assert!(f.entities.windows(2).all(|w| w[0].id < w[1].id));
    assert!(!f.paused && f.time_scale == 1.0);
    assert_eq!(f.clients, 1);
    assert!((f.sim_time - f.tick as f64 / 60.0).abs() < 1e-9);

    h.pause().unwrap();
    wait_for(&h, "pause", |f| f.paused);
    let t0 = h.frame().tick;
    std::thread::sleep(Duration::from_millis(150));
    assert_eq!(h.frame().tick, t0, "paused: no ticks");

    h.step(7).unwrap();
    wait_for(&h, "7 steps", |f| f.tick == t0 + 7);
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(h.frame().tick, t0 + 7, "exactly 7");

    h.run_to(t0 + 40).unwrap();
    wait_for(&h, "run_to", |f| f.tick == t0 + 40);
    std::thread::sleep(Duration::from_millis(100));
    let f = h.frame();
    assert_eq!(f.tick, t0 + 40);
    assert!(f.paused);

    // Four times real time: about 240 ticks a second.
    h.set_time_scale(4.0).unwrap();
    let (t1, w1) = (h.frame().tick, Instant::now());
    std::thread::sleep(Duration::from_millis(500));
    let rate = (h.frame().tick - t1) as f64 / w1.elapsed().as_secs_f64();
    assert!(rate > 120.0, "fast-forward rate {rate} ticks/s");
    assert_eq!(h.frame().time_scale, 4.0);

    h.resume().unwrap();
    h.leave(9).unwrap();
    wait_for(&h, "leave", |f| {
        f.clients == 0 && !f.catalog.contains_key(&avatar)
    });
    assert!(h.stats().ticks.load(std::sync::atomic::Ordering::Relaxed) > 0);
    h.shutdown();
}

#[test]
fn a_flood_of_inputs_does_not_stall_the_tick() {
    let h = start(SimConfig {
        input_capacity: 512,
        max_inputs_per_loop: 64,
        ..SimConfig::default()
    });
    h.join_blocking(1).unwrap();
    wait_for(&h, "start", |f| f.tick > 5);
    let (t0, w0) = (h.frame().tick, Instant::now());
    let mut busy = 0u64;
    let mut sent = 0u64;
    let mut seq = 0u32;
    let mut slowest = Duration::ZERO;
    while w0.elapsed() < Duration::from_millis(500) {
        seq = seq.wrapping_add(1);
        let input = PlayerInput {
            sequence: seq,
            tick: h.frame().tick,
            ..PlayerInput::default()
        };
        let s = Instant::now();
        match h.input(1, input) {
            Ok(()) => sent += 1,
            Err(CommandError::Busy) => busy += 1,
            Err(e) => panic!("{e}"),
        }
        slowest = slowest.max(s.elapsed());
    }
    let ticks = h.frame().tick - t0;
    let secs = w0.elapsed().as_secs_f64();
    assert!(
        ticks as f64 > 0.4 * 60.0 * secs,
        "{ticks} ticks in {secs:.2} s under a flood of {sent} inputs"
    );
    assert!(busy > 0, "the bounded channel pushes back");
    assert!(slowest < Duration::from_millis(200), "sending never blocks");
    assert!(
        h.stats()
            .inputs_rejected
            .load(std::sync::atomic::Ordering::Relaxed)
            > 0
    );
    h.shutdown();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn async_join_and_frame_subscription() {
    let h = start(SimConfig {
        max_clients: 1,
        ..SimConfig::default()
    });
    let a = h.join(5).await.unwrap();
    assert_eq!(h.join(6).await, Err(JoinRefusal::Full { max: 1 }));
    let mut rx = h.subscribe();
    let before = rx.borrow_and_update().tick;
    // A frame is also published when only the catalog changed (the join's
    // avatar), so wait for one that carries a new tick.
    let f = tokio::time::timeout(Duration::from_secs(2), async {
        loop {
            rx.changed().await.unwrap();
            let f = rx.borrow_and_update().clone();
            if f.tick > before {
                break f;
            }
        }
    })
    .await
    .expect("a new tick within 2 s");
    assert!(f.tick > before);
    assert!(f.messages.iter().all(|m| m.tick <= f.tick));
    assert!(f.catalog.contains_key(&a));
    drop(h);
}
