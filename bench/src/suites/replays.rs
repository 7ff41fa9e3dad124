//! `replays`: players' replays (kill-cams) beside a loaded live match.
//!
//! The watching bots run in a bot process of their own (as players on
//! machines of their own), so that the time to a replay's first snapshot
//! is the server's and the link's, not that of a bot process busy with a
//! hundred other clients' snapshots.
//!
//! The server of [`super::capacity`] (in this process, 1000 balls tumbling
//! in a drum, 60 Hz ticks, 30 Hz snapshots) serves K bot players (200 by
//! default; `--clients`) in steps that alternate without and with
//! replays, [`ROUNDS`] of each, so that machine noise falls on both. In a
//! step with replays, [`WATCHERS`] of the bots watch kill-cams the whole
//! window: each asks for the last 10 s at real time, and again as soon as
//! one ends ([`super::bots::BOT_REPLAY_S`]), so 10 ten-second replays
//! play at once throughout. Every step warms up for [`WARMUP_S`] first,
//! so the server holds the 10 s a kill-cam asks for.
//!
//! Measured per step, as `capacity` measures them: `tick_ms_p99`,
//! `snapshots_min_client_hz` (the live snapshots of the worst bot, the
//! watchers' included), `server_cpu_percent`; with replays also the
//! replays asked, refused and played, and `first_replay_snapshot_ms_*`:
//! from a bot's request to its first replay snapshot (to within one bot
//! frame, 17 ms, so an upper bound).
//!
//! `replay_mismatches` is checked apart, on the same scene: the frames
//! the server publishes for `--seconds` are held in a replay window, one
//! every other tick as the snapshot stage serves them, and a replay of
//! the whole stretch is played from it under a live client's byte budget;
//! every entity state a replayed snapshot carries is compared with the
//! frame of its tick as a client holding everything decodes it. Any
//! difference counts.
//!
//! The last record gives the figures: `first_replay_snapshot_ms_p99`,
//! `live_tick_p99_ms_without` and `_with`, `live_snapshot_hz_min_without`
//! and `_with` (the worst over the rounds), and `replay_mismatches`.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::replay::{ReplayAsk, ReplayDatagram, ReplayRequest};
use inertia_protocol::snapshot::{QuantizedFrame, SharedDeltas, SnapshotConfig, SnapshotDecoder};
use inertia_protocol::{ServerSession, SessionConfig, ViewEntity};
use inertia_server::net::replays::{DeskOutput, ReplayDesk, ReplayLimits, ReplayWindow};
use inertia_server::server::{start, RunningServer};

use super::bots::{process_cpu_s, BotReport, Bots};
use super::capacity::{quantile, record_ticks, server_config, TickLog, SNAPSHOT_HZ, TICK_HZ};
use crate::report::{progress, Measurement, Sink, Suspended};
use crate::{BenchError, Opts};

/// Live players by default (`--clients`).
pub const DEFAULT_CLIENTS: u32 = 200;
/// Players watching kill-cams in a step with replays.
pub const WATCHERS: usize = 10;
/// Seconds measured per step by default (`--seconds`).
pub const DEFAULT_SECONDS: u32 = 10;
/// Seconds each step runs before it is measured: the joins, and the 10 s
/// of the past a kill-cam asks for.
pub const WARMUP_S: f64 = 12.0;
/// Steps without and with replays, each.
pub const ROUNDS: usize = 3;
/// How long every bot of a step has to connect.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(60);

/// What one step measured.
#[derive(Debug, Clone)]
struct Step {
    tick_ms_p99: f64,
    snapshots_min_client_hz: f64,
    server_cpu_percent: f64,
    asked: u64,
    refused: u64,
    first_ms: Vec<f64>,
}

/// Runs the suite.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    if !opts.wants("replays") {
        return Ok(());
    }
    let k = opts
        .clients
        .as_ref()
        .and_then(|c| c.first().copied())
        .unwrap_or(if opts.quick { 20 } else { DEFAULT_CLIENTS })
        .max(1);
    let watchers = if opts.quick { 2 } else { WATCHERS }.min(k as usize);
    let seconds = f64::from(
        opts.seconds
            .unwrap_or(if opts.quick { 3 } else { DEFAULT_SECONDS }),
    );
    let warmup = if opts.quick { 11.0 } else { WARMUP_S };
    let rounds = if opts.quick { 1 } else { ROUNDS };

    let data_dir =
        std::env::temp_dir().join(format!("inertia-bench-replays-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&data_dir);
    let config = server_config(data_dir.clone(), k);
    let snapshot = config.snapshot_config();
    let budget = (config.client_budget_bytes_per_sec() / u64::from(SNAPSHOT_HZ)) as usize;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .thread_name("inertia-bench-server")
        .enable_all()
        .build()?;
    let server = runtime.block_on(start(config))?;
    let result = (|| {
        let pb = progress(1 + 2 * rounds as u64, "replays");
        let mut out = Suspended::new(&pb, sink);
        pb.set_message("exactness");
        let (compared, mismatches) = exactness(&runtime, &server, snapshot, budget, seconds);
        pb.inc(1);
        let credentials = server
            .credentials_path()
            .ok_or("the bench server runs in dev mode")?
            .clone();
        let log: TickLog = Arc::new(Mutex::new(Vec::new()));
        let recorder = record_ticks(&runtime, &server, log.clone());
        let mut without = Vec::new();
        let mut with = Vec::new();
        for round in 0..rounds {
            for replays in [false, true] {
                let n = 2 * round + usize::from(replays);
                pb.set_message(format!(
                    "{} replays, round {}",
                    if replays { "with" } else { "without" },
                    round + 1
                ));
                let ids: Vec<u64> = (0..u64::from(k))
                    .map(|i| 100_000 * (n as u64 + 1) + i)
                    .collect();
                let step = step(
                    &server,
                    &credentials,
                    &ids,
                    if replays { watchers } else { 0 },
                    warmup,
                    seconds,
                    &log,
                )?;
                out.record(step_record(&step, k, replays, round, watchers));
                if replays {
                    with.push(step);
                } else {
                    without.push(step);
                }
                pb.inc(1);
            }
        }
        pb.finish_and_clear();
        recorder.abort();
        let mut first: Vec<f64> = with.iter().flat_map(|s| s.first_ms.clone()).collect();
        let worst =
            |steps: &[Step], f: fn(&Step) -> f64| steps.iter().map(f).fold(f64::NAN, f64::max);
        let least =
            |steps: &[Step], f: fn(&Step) -> f64| steps.iter().map(f).fold(f64::NAN, f64::min);
        out.record(
            Measurement::new()
                .field("case", "replays")
                .field("scene", "capacity")
                .field("clients", k)
                .field("watchers", watchers)
                .field("rounds", rounds)
                .field("seconds", seconds)
                .field("replays_played", first.len())
                .field(
                    "replays_refused",
                    with.iter().map(|s| s.refused).sum::<u64>(),
                )
                .field("first_replay_snapshot_ms_p50", quantile(&mut first, 0.5))
                .field("first_replay_snapshot_ms_p99", quantile(&mut first, 0.99))
                .field(
                    "first_replay_snapshot_ms_max",
                    first.last().copied().unwrap_or(f64::NAN),
                )
                .field(
                    "live_tick_p99_ms_without",
                    worst(&without, |s| s.tick_ms_p99),
                )
                .field("live_tick_p99_ms_with", worst(&with, |s| s.tick_ms_p99))
                .field(
                    "live_snapshot_hz_min_without",
                    least(&without, |s| s.snapshots_min_client_hz),
                )
                .field(
                    "live_snapshot_hz_min_with",
                    least(&with, |s| s.snapshots_min_client_hz),
                )
                .field(
                    "server_cpu_percent_without",
                    mean(without.iter().map(|s| s.server_cpu_percent)),
                )
                .field(
                    "server_cpu_percent_with",
                    mean(with.iter().map(|s| s.server_cpu_percent)),
                )
                .field("replay_states_compared", compared)
                .field("replay_mismatches", mismatches),
        );
        Ok(())
    })();
    runtime.block_on(server.shutdown());
    drop(runtime);
    let _ = std::fs::remove_dir_all(&data_dir);
    result
}

/// One step: `ids` join as bots, the first `watchers` of them watching
/// kill-cams while counting; measured for `seconds` after `warmup`.
fn step(
    server: &RunningServer,
    credentials: &std::path::Path,
    ids: &[u64],
    watchers: usize,
    warmup: f64,
    seconds: f64,
    log: &TickLog,
) -> Result<Step, BenchError> {
    let mut bots = Bots::spawn_watching(credentials, ids, watchers, warmup + seconds + 90.0)?;
    bots.wait_ready(CONNECT_TIMEOUT)?;
    std::thread::sleep(Duration::from_secs_f64(warmup));
    let settling = Instant::now();
    while server.metrics().snapshot_clients_degraded.get() > 0
        && settling.elapsed() < Duration::from_secs(15)
    {
        std::thread::sleep(Duration::from_millis(100));
    }
    bots.tell("start");
    if let Ok(mut l) = log.lock() {
        l.clear();
    }
    let (t0, cpu0) = (Instant::now(), process_cpu_s());
    std::thread::sleep(Duration::from_secs_f64(seconds));
    let cpu = (process_cpu_s() - cpu0) / t0.elapsed().as_secs_f64() * 100.0;
    let mut ticks: Vec<f64> = log
        .lock()
        .map(|l| l.iter().map(|(_, ms)| *ms).collect())
        .unwrap_or_default();
    let reports: Vec<BotReport> = bots.stop()?;
    drop(bots);
    let deadline = Instant::now() + Duration::from_secs(5);
    while server.clients() > 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
    }
    if reports.len() != ids.len() || reports.iter().any(|r| r.disconnected) {
        return Err(format!(
            "{} of {} bots reported, {} dropped",
            reports.len(),
            ids.len(),
            reports.iter().filter(|r| r.disconnected).count()
        )
        .into());
    }
    Ok(Step {
        tick_ms_p99: quantile(&mut ticks, 0.99),
        snapshots_min_client_hz: reports
            .iter()
            .map(|r| r.snapshots_hz)
            .fold(f64::INFINITY, f64::min),
        server_cpu_percent: cpu,
        asked: reports.iter().map(|r| r.replays_asked).sum(),
        refused: reports.iter().map(|r| r.replays_refused).sum(),
        first_ms: reports
            .iter()
            .flat_map(|r| r.replay_first_ms.iter().copied())
            .collect(),
    })
}

fn step_record(step: &Step, k: u32, replays: bool, round: usize, watchers: usize) -> Measurement {
    let mut first = step.first_ms.clone();
    Measurement::new()
        .field(
            "case",
            format!(
                "replays_{}_{}",
                if replays { "with" } else { "without" },
                round + 1
            ),
        )
        .field("clients", k)
        .field("watchers", if replays { watchers } else { 0 })
        .field("tick_ms_p99", step.tick_ms_p99)
        .field("snapshots_min_client_hz", step.snapshots_min_client_hz)
        .field("server_cpu_percent", step.server_cpu_percent)
        .field("replays_asked", step.asked)
        .field("replays_refused", step.refused)
        .field("replays_played", step.first_ms.len())
        .field("first_replay_snapshot_ms_p99", quantile(&mut first, 0.99))
}

/// Plays a replay of `seconds` of the server's own frames, as the
/// snapshot stage would, and compares every state it carries with its
/// frame: (states compared, states that differ).
fn exactness(
    runtime: &tokio::runtime::Runtime,
    server: &RunningServer,
    config: SnapshotConfig,
    budget: usize,
    seconds: f64,
) -> (u64, u64) {
    // The frames of `seconds`, every other tick, as the stage serves them.
    let frames: Vec<QuantizedFrame> = runtime.block_on(async {
        let mut sub = server.sim().subscribe();
        let mut out: Vec<QuantizedFrame> = Vec::new();
        let end = tokio::time::Instant::now() + Duration::from_secs_f64(seconds);
        while tokio::time::Instant::now() < end {
            if tokio::time::timeout_at(end, sub.changed()).await.is_err() {
                break;
            }
            let f = sub.borrow_and_update().clone();
            if out.last().is_none_or(|l| f.tick >= l.tick + 2) {
                out.push(f.quantized(&config).clone());
            }
        }
        out
    });
    let (Some(first), Some(last)) = (frames.first(), frames.last()) else {
        return (0, 0);
    };
    let (from_tick, to_tick) = (first.tick, last.tick);
    let mut window = ReplayWindow::new(u64::MAX / 4, usize::MAX);
    for f in &frames {
        window.push(f);
    }
    // Each frame as a client holding everything decodes it.
    let truth: BTreeMap<u64, BTreeMap<u32, ViewEntity>> = frames
        .iter()
        .map(|f| (f.tick, full_view(f, config)))
        .collect();
    let mut desk = ReplayDesk::new(
        ReplayLimits::new(1, TICK_HZ, SNAPSHOT_HZ),
        SessionConfig::new(config, budget),
    );
    let now = Instant::now();
    let mut out = Vec::new();
    desk.ask(
        1,
        ReplayAsk::Play(ReplayRequest {
            from_tick,
            to_tick,
            speed: 1.0,
            focus: None,
        }),
        None,
        &window,
        now,
        &mut out,
    );
    let mut decoder = SnapshotDecoder::new(config).expect("the server's settings");
    let (mut compared, mut mismatches) = (0u64, 0u64);
    for slot in 0..(frames.len() * 2 + 10) {
        out.clear();
        desk.serve(&window, now, |_| 1200, || true, &mut out);
        for o in &out {
            let DeskOutput::Datagram { bytes, .. } = o else {
                continue;
            };
            let Ok(ReplayDatagram::Snapshot { replay, snapshot }) =
                ReplayDatagram::decode_snapshot(bytes)
            else {
                mismatches += 1;
                continue;
            };
            let Ok(snap) = decoder.decode(snapshot) else {
                mismatches += 1;
                continue;
            };
            // Acknowledged but one in four, as a lossy link would.
            if slot % 4 != 3 {
                desk.on_ack(1, replay, snap.sequence);
            }
            let Some(want) = truth.get(&snap.tick) else {
                mismatches += 1;
                continue;
            };
            for e in &snap.updated {
                compared += 1;
                if want.get(&e.id) != Some(e) {
                    mismatches += 1;
                }
            }
        }
        if desk.playing() == 0 {
            break;
        }
    }
    (compared, mismatches)
}

/// `frame` as a client decodes it once it holds all of it: snapshots of
/// the frame, each acknowledged, until the client's view holds every
/// entity.
fn full_view(frame: &QuantizedFrame, config: SnapshotConfig) -> BTreeMap<u32, ViewEntity> {
    let mut session =
        ServerSession::new(SessionConfig::new(config, 60_000)).expect("the server's settings");
    let mut decoder = SnapshotDecoder::new(config).expect("the server's settings");
    let mut shared = SharedDeltas::new();
    for _ in 0..1000 {
        let bytes = session.snapshot_at(frame, frame.time_scale, &mut shared, 60_000);
        let Ok(snap) = decoder.decode(&bytes) else {
            break;
        };
        session.on_ack(snap.sequence);
        let view = decoder.entities(snap.sequence).unwrap_or_default();
        if view.len() >= frame.len() {
            return view.into_iter().map(|e| (e.id, e)).collect();
        }
    }
    BTreeMap::new()
}

fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = xs.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}
