//! A real client over a link with a 100 ms round trip stamps its inputs
//! far enough ahead that they reach the server before their tick: the
//! server applies them on it, reports how they arrive, and the SDK's
//! statistics show it. Twice: with a steady link and with ±20 ms of
//! jitter, where the margin grows to cover it.
//!
//! `cargo test -p inertia-tests --test integration issue_17_inputs_on_their_tick:: -- --nocapture`
//! prints the figures.

use std::time::Duration;

use inertia_client::Client;
use inertia_tests::conditioner::{Conditioner, Impairment};
use inertia_tests::server::{start_server, test_config, token};

/// Runs a client for `seconds` through a link of `rtt` and `jitter`
/// (each way), walking in circles; returns the late and on-time inputs
/// counted over the last `seconds − 3` s, and the margin at the end.
async fn walk(what: &str, rtt_ms: u64, jitter_ms: u64, loss: f64, seconds: u64) -> (u64, u64, f64) {
    let server = start_server(test_config(Some("moving.ron"), what)).await;
    let link = Impairment::half_rtt(
        Duration::from_millis(rtt_ms),
        Duration::from_millis(jitter_ms),
        loss,
    );
    let conditioner = Conditioner::start(server.addr(), link, link, 17)
        .await
        .expect("conditioner");
    let (_, token) = token(&server, 9);
    let client = Client::connect(conditioner.addr(), &token)
        .await
        .expect("joins through the conditioner");
    let frames = seconds * 60;
    let mut before = None;
    for k in 0..frames {
        let angle = k as f32 * 0.02;
        client
            .set_input([angle.cos(), angle.sin()], angle, 0)
            .expect("the sandbox takes the sandbox's input");
        if k == 3 * 60 {
            before = Some(client.stats());
        }
        tokio::time::sleep(Duration::from_millis(16)).await;
    }
    // The last report comes about a second after the inputs it counts.
    tokio::time::sleep(Duration::from_millis(1200)).await;
    let after = client.stats();
    let before = before.expect("a warm-up");
    let late = after.inputs_late - before.inputs_late;
    let on_time = after.inputs_on_time - before.inputs_on_time;
    println!(
        "{what}: rtt {rtt_ms} ms ±{jitter_ms} ms, loss {loss}: {on_time} inputs on time, {late} late \
         over the last {} s; margin {:.1} ticks; measured rtt {:.0} ms, jitter {:.1} ms; \
         input {:.1} kbit/s; refused {}",
        seconds - 3,
        after.input_margin_ticks,
        after.rtt_ms,
        after.jitter_ms,
        after.kbps_out,
        after.inputs_refused,
    );
    assert_eq!(after.inputs_refused, 0);
    assert!(after.kbps_out > 0.0);
    client.close().await;
    server.shutdown().await;
    (late, on_time, after.input_margin_ticks)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_17_inputs_reach_the_server_before_their_tick_at_100ms_with_and_without_jitter() {
    let (late, on_time, _) = walk("steady", 100, 0, 0.0, 8).await;
    // One input per tick at 60 Hz over 5 s, less what the test's own
    // sleeps lose on a loaded machine.
    assert!(on_time > 200, "{on_time} on time");
    assert!(
        (late as f64) < 0.01 * (late + on_time) as f64,
        "{late} late of {}",
        late + on_time
    );
    let (late, on_time, margin) = walk("jittery", 100, 20, 0.02, 8).await;
    assert!(on_time > 200, "{on_time} on time");
    assert!(
        (late as f64) < 0.02 * (late + on_time) as f64,
        "{late} late of {} (margin {margin})",
        late + on_time
    );
}
