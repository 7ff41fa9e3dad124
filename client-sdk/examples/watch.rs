//! Connects to a server and prints, once a second, what arrives.
//!
//! ```text
//! cargo run -p inertia-client --example watch -- [--server ADDR] [--credentials FILE] [--seconds N] [--json]
//! ```
//!
//! The credentials default to `./inertia-data/dev-credentials.json`, which a
//! dev-mode server writes. With `--json`, one object per second with
//! `tick`, `entities`, `snapshots_received`, `kbps`, `rtt_ms`, `buffer_ms`
//! and more, and the game's replicated state: `match_state` (the match's
//! properties by name, as of the tick drawn) and `entities_with_properties`
//! (how many entities in view hold properties).

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use inertia_client::{dev, BlockingClient, ClientEvent};
use inertia_protocol::property::PropertyValue;

#[derive(Debug, Parser)]
#[command(about = "Watch what an Inertia server streams")]
struct Args {
    #[command(flatten)]
    dev: dev::DevArgs,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long)]
    seconds: Option<f64>,
    /// One JSON object per second instead of a table.
    #[arg(long)]
    json: bool,
}

/// The match's properties by name, as JSON values (a flag as a bool, a
/// number as a number).
fn match_state(client: &BlockingClient) -> serde_json::Value {
    let schema = client.property_schema();
    let values = client.match_state();
    let by_name: serde_json::Map<String, serde_json::Value> = schema
        .match_state
        .iter()
        .zip(values)
        .map(|(decl, value)| {
            let v = match value {
                PropertyValue::Bool(b) => serde_json::json!(b),
                PropertyValue::UInt(n) => serde_json::json!(n),
                PropertyValue::Int(n) => serde_json::json!(n),
                PropertyValue::F32(x) => serde_json::json!(x),
            };
            (decl.name.clone(), v)
        })
        .collect();
    serde_json::Value::Object(by_name)
}

fn main() -> ExitCode {
    let args = Args::parse();
    let (addr, token, _) = match dev::dev_token(&args.dev.credentials, None) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("watch: {e}");
            return ExitCode::FAILURE;
        }
    };
    let addr = args.dev.server.unwrap_or(addr);
    let client = match BlockingClient::connect(addr, &token) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("watch: cannot join {addr}: {e}");
            return ExitCode::FAILURE;
        }
    };
    let info = client.server_info().clone();
    if !args.json {
        println!(
            "joined {addr} as client {} (server {}, {} Hz ticks, {} Hz snapshots)",
            info.client_id, info.server_version, info.tick_hz, info.snapshot_hz
        );
        println!(
            "{:>8} {:>10} {:>9} {:>10} {:>8} {:>8} {:>9} {:>6} {:>7}",
            "time s",
            "tick",
            "entities",
            "snapshots",
            "kbps",
            "rtt ms",
            "buffer ms",
            "loss%",
            "stalls"
        );
    }
    let start = Instant::now();
    let mut next = start + Duration::from_secs(1);
    let mut code = ExitCode::SUCCESS;
    loop {
        // Render at 60 Hz, as a game would, so the buffer is exercised.
        std::thread::sleep(Duration::from_millis(16));
        let frame = client.sample();
        while let Some(event) = client.poll_event() {
            if let ClientEvent::Disconnected(reason) = &event {
                eprintln!("watch: disconnected: {reason:?}");
                code = ExitCode::FAILURE;
            } else if !args.json {
                if let ClientEvent::Discontinuity(d) = &event {
                    println!("timeline jump: {d:?}");
                }
            }
        }
        if client.disconnected().is_some() {
            break;
        }
        if Instant::now() < next {
            continue;
        }
        next += Duration::from_secs(1);
        let t = start.elapsed().as_secs_f64();
        let s = client.stats();
        let tick = frame.render_tick;
        if args.json {
            let line = serde_json::json!({
                "time_s": (t * 1000.0).round() / 1000.0,
                "tick": tick.max(0.0).round() as u64,
                "entities": frame.entities.len(),
                "described": client.entities().len(),
                "snapshots_received": s.snapshots_received,
                "kbps": s.kbps,
                "rtt_ms": s.rtt_ms,
                "buffer_ms": s.buffer_ms,
                "loss": s.loss,
                "stalls": s.stalls,
                "match_state": match_state(&client),
                "entities_with_properties": client.entities_with_properties().len(),
            });
            println!("{line}");
        } else {
            println!(
                "{:>8.1} {:>10.0} {:>9} {:>10} {:>8.1} {:>8.1} {:>9.1} {:>6.2} {:>7}",
                t,
                tick,
                frame.entities.len(),
                s.snapshots_received,
                s.kbps,
                s.rtt_ms,
                s.buffer_ms,
                s.loss * 100.0,
                s.stalls
            );
        }
        if args.seconds.is_some_and(|limit| t >= limit) {
            break;
        }
    }
    client.close();
    code
}
