//! Client-side prediction (issue 17) through a real link: a real server on
//! a flat scene with obstacles, a client with prediction on behind 100 ms
//! of round trip and 5 % loss each way, walking a scripted path (turns,
//! stops, jumps, into a wall). The own avatar answers the next frame, the
//! prediction agrees with the server's states to within 5 cm (p99), and
//! the drawn avatar never moves by more than 10 cm in a frame beyond its
//! predicted motion.
//!
//! Prints the figures: `cargo test -p inertia-tests --test
//! issue_17_prediction -- --nocapture`.

use std::time::Duration;

use inertia_client::predict::PredictionConfig;
use inertia_client::{Client, ConnectOptions};
use inertia_tests::server::{start_server, test_config, token};
use inertia_tests::{Conditioner, Impairment};

/// One frame of the game, s.
const FRAME: Duration = Duration::from_millis(16);

/// The path: for how long, which way (x, z), which buttons (1 = jump).
const SCRIPT: &[(f64, [f32; 2], u8)] = &[
    (1.2, [0.0, 1.0], 0),  // towards the wall, and into it
    (0.4, [0.0, 1.0], 1),  // jump at the wall
    (0.3, [1.0, 0.0], 0),  // along it
    (0.6, [0.7, -0.7], 0), // away, diagonally
    (0.5, [0.0, 0.0], 0),  // stop
    (0.2, [0.0, 0.0], 1),  // jump on the spot
    (0.6, [0.0, 0.0], 0),
    (0.8, [-1.0, 0.0], 0), // run the other way
    (0.2, [-1.0, 0.0], 1), // jump while running
    (0.6, [-1.0, 0.0], 0),
    (0.6, [0.0, -1.0], 0), // turn
    (0.8, [0.0, 0.0], 0),  // stop
];

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_17_the_predicted_avatar_answers_at_once_and_corrects_smoothly() {
    const ERROR_P99_BOUND_M: f64 = 0.05;
    const SNAP_BOUND_M: f64 = 0.10;
    let server = start_server(test_config(Some("walk.ron"), "predict")).await;
    let link = Impairment::half_rtt(Duration::from_millis(100), Duration::ZERO, 0.05);
    let conditioner = Conditioner::start(server.addr(), link, link, 17)
        .await
        .expect("conditioner");
    let (_, token) = token(&server, 3);
    let client = Client::connect_with(
        conditioner.addr(),
        &token,
        ConnectOptions {
            predict: Some(PredictionConfig::default()),
            ..ConnectOptions::default()
        },
    )
    .await
    .expect("joins through the conditioner");

    // Standing still while the clock and the input lead settle.
    client
        .set_input([0.0, 0.0], 0.0, 0)
        .expect("the sandbox takes the sandbox's input");
    tokio::time::sleep(Duration::from_secs(3)).await;
    let start = client.predicted_avatar().expect("the avatar is predicted");
    assert!(
        client
            .sample()
            .get(start.id)
            .is_some_and(|e| (e.position - start.position).length() < 0.05),
        "the sampled frame draws the avatar where prediction puts it"
    );

    // The first frame after the stick moves, the avatar does.
    client
        .set_input([1.0, 0.0], 0.0, 0)
        .expect("the sandbox takes the sandbox's input");
    let mut frames = 0;
    let moved = loop {
        tokio::time::sleep(FRAME).await;
        frames += 1;
        let a = client.predicted_avatar().expect("predicted");
        if (a.predicted - start.predicted).length() > 1e-3 || frames >= 30 {
            break a;
        }
    };
    eprintln!(
        "response: moved {:.1} mm in {frames} frame(s), predicted tick {} -> {}",
        (moved.predicted - start.predicted).length() * 1000.0,
        start.tick,
        moved.tick
    );
    assert!(frames <= 2, "the avatar answered after {frames} frames");
    client
        .set_input([0.0, 0.0], 0.0, 0)
        .expect("the sandbox takes the sandbox's input");
    tokio::time::sleep(Duration::from_secs(1)).await;

    // The path, drawn frame by frame.
    let mut last = client.predicted_avatar().expect("predicted");
    let mut snap_max: f64 = 0.0;
    let mut samples = 0;
    for &(seconds, movement, buttons) in SCRIPT {
        let frames = (seconds / FRAME.as_secs_f64()).round() as usize;
        for f in 0..frames {
            // Jumps are presses: held for two frames, then let go.
            client
                .set_input(movement, 0.0, if f < 2 { buttons } else { 0 })
                .expect("the sandbox takes the sandbox's input");
            tokio::time::sleep(FRAME).await;
            let a = client.predicted_avatar().expect("predicted");
            let motion = (a.predicted - last.predicted) - (a.corrected - last.corrected);
            snap_max = snap_max.max(((a.position - last.position) - motion).length());
            samples += 1;
            last = a;
        }
    }
    client
        .set_input([0.0, 0.0], 0.0, 0)
        .expect("the sandbox takes the sandbox's input");
    tokio::time::sleep(Duration::from_millis(500)).await;

    let stats = client.stats();
    let end = client.predicted_avatar().expect("predicted");
    eprintln!(
        "walked to {:.2?} in {samples} frames; inputs on time {}, late {}, margin {:.1} ticks, rtt {:.0} ms",
        end.predicted.to_array(),
        stats.inputs_on_time,
        stats.inputs_late,
        stats.input_margin_ticks,
        stats.rtt_ms
    );
    eprintln!(
        "correction error: p50 {:.2} mm, p99 {:.2} mm, max {:.2} mm over the states received; {} corrections, {} teleports",
        stats.prediction_error_p50_m * 1000.0,
        stats.prediction_error_p99_m * 1000.0,
        stats.prediction_error_max_m * 1000.0,
        stats.prediction_corrections,
        stats.prediction_teleports
    );
    eprintln!(
        "visible snap: largest per-frame move off the predicted motion {:.2} mm (predictor's own per-tick figure {:.2} mm)",
        snap_max * 1000.0,
        stats.prediction_snap_max_m * 1000.0
    );
    assert!(
        end.predicted.x < -2.0,
        "the avatar walked the path: {end:?}"
    );
    assert!(
        stats.prediction_error_p99_m <= ERROR_P99_BOUND_M,
        "correction error p99 {} m",
        stats.prediction_error_p99_m
    );
    assert!(snap_max <= SNAP_BOUND_M, "a visible snap of {snap_max} m");
    assert_eq!(stats.prediction_teleports, 0, "no teleport on a walk");
    client.close().await;
    server.shutdown().await;
}
