//! `capacity`: how many clients one server process serves at 60 Hz.
//!
//! A whole dev-mode server runs in this process (tick thread, tokio, QUIC
//! on loopback, ephemeral ports, data under the temporary folder) on
//! `server/scenes/capacity.ron`: 1000 balls tumbling in a turning drum,
//! so every body keeps moving. It ticks at 60 Hz and sends 30 snapshots a
//! second to each client, under the default per-client budget.
//!
//! For each client count K (1, 10, 50, 100, 200, 300, 500, 700, 1000
//! by default; `--clients`), K bot clients start in bot processes of
//! their own ([`super::bots`]: up to 128 QUIC connections to a process,
//! on one runtime), so their CPU time is not the server's. Every bot
//! decodes every snapshot and sends inputs (30 a second, each with the
//! last 4), as a game does, and does not render. After a warm-up the
//! bench tells every bot to start counting, measures the server for
//! `--seconds`, tells them to stop, and each bot reports what it received
//! as one JSON line.
//!
//! Measured per K:
//!
//! * `tick_ms_p50`, `tick_ms_p99`, `tick_ms_max`: the wall time of each
//!   tick (rules and physics step), read from the frames the tick thread
//!   publishes (`server.sim().subscribe()`, each frame's
//!   `tick_duration`). A loop that runs more than one tick to catch up
//!   publishes one frame, so `tick_samples` may be a little below `ticks`;
//!   such loops are counted in `overruns` when they hit the cap.
//! * `encode_us_per_client`: mean wall time to encode one snapshot for one
//!   client (the server's `snapshot_encode_seconds` histogram).
//! * `server_cpu_percent`: this process's user + system CPU time over the
//!   step (`/proc/self/stat`) per wall second, × 100; the bots are other
//!   processes and not in it. The machine's ceiling is 100 × cores.
//! * `server_idle_cpu_percent`: the same for the server alone, measured
//!   once before the first step (the tick, with no client);
//!   `server_cpu_us_per_client_snapshot`: the server's CPU beyond that,
//!   per client snapshot sent, µs.
//! * `tick_cpu_percent`, `snapshots_cpu_percent`, `network_cpu_percent`,
//!   `other_cpu_percent`: the server's CPU split by thread: the tick
//!   thread (and the physics workers it starts), the snapshot stage, the
//!   network (the tokio workers: QUIC, connections, inputs) and the rest.
//! * `rss_mb`: this process's resident set at the end of the step;
//!   `rss_kb_per_client`: beyond the idle server's, per client, KiB.
//! * `bots_cpu_percent`: the bots' own CPU over the same window, summed;
//!   `machine_cpu_percent`: every process on the machine (`/proc/stat`);
//!   `steal_ms`: CPU time the host took from the machine's virtual cores
//!   in the window (a stall of everything, named in the verdict).
//! * `kbps_per_client`: mean over bots of the snapshot bytes each received
//!   in the window, kbit/s; `snapshots_per_client_hz` (mean) and
//!   `snapshots_min_client_hz` (worst bot): snapshots received per second.
//! * `settle_s`: how long after the warm-up the step waited for every
//!   client to be back at full rate (at most [`SETTLE_MAX_S`]), so the
//!   window does not measure the rate policy recovering from the joins.
//! * `rate_degrade_steps`: steps the server's rate policy took to lower
//!   clients' snapshot rates during the window; `clients_degraded`: the
//!   clients at a lower rate at its end (`/metrics`). A step with clients
//!   degraded is not served: their rate falls below 95 %.
//! * `physics_threads`: the threads stepping the physics (the server's
//!   default: half the cores, at least one)
//! * `tick_realtime`: whether the tick thread got real-time priority
//!   (the bench asks for it, as `--tick-realtime` does; it needs
//!   `CAP_SYS_NICE`).
//! * `snapshots_superseded`: snapshots replaced unsent by the client's
//!   next one, its connection task not having run for a whole period.
//!
//! The last line adds `projected_max_clients`: the machine's cores (as
//! CPU %) less the idle server's, over the server's CPU per client at the
//! largest step served.
//!
//! A K is served at 60 Hz when `tick_ms_p99 < 16.7` and every bot received
//! at least 95 % of the snapshot rate. Steps go on while K is served; the
//! last line gives the largest K served and what bounded it.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::{EntityId, EntityKind};
use inertia_server::config::ServerConfig;
use inertia_server::server::{start, RunningServer};

use super::bots::{process_cpu_s, stat_cpu, stat_fields, BotReport, Bots};
use crate::report::{logical_cores, note, progress, Measurement, Sink, Suspended};
use crate::{BenchError, Opts};

/// Client counts stepped through by default (`--clients`).
pub const DEFAULT_CLIENTS: [u32; 9] = [1, 10, 50, 100, 200, 300, 500, 700, 1000];
/// Seconds measured per step by default (`--seconds`).
pub const DEFAULT_SECONDS: u32 = 10;
/// Seconds each step runs before it is measured (joins, catalog, the
/// first full view), not counted.
pub const WARMUP_S: f64 = 3.0;
/// Ticks per second.
pub const TICK_HZ: u32 = 60;
/// Snapshots per second per client.
pub const SNAPSHOT_HZ: u32 = 30;
/// A tick must take less than this at the 99th percentile, ms.
pub const TICK_BUDGET_MS: f64 = 1000.0 / TICK_HZ as f64;
/// A client is served at its rate when it receives at least this
/// fraction of [`SNAPSHOT_HZ`].
pub const SERVED_FRACTION: f64 = 0.95;
/// After the warm-up, how long a step may wait at most for the server's
/// rate policy to bring every client back to full rate (it lowers rates
/// while a wave of handshakes costs CPU, and restores them a step a few
/// slots at a time), s. The wait is reported as `settle_s`.
pub const SETTLE_MAX_S: f64 = 15.0;
/// How long every bot of a step has to connect, s.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(60);

/// Stolen time in a step worth naming as a cause, ms: a stall of a few
/// tens of milliseconds costs a slot or two at 30 Hz.
const STEAL_NOTED_MS: f64 = 20.0;

/// The scene every step runs.
pub fn scene_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../server/scenes/capacity.ron")
}

/// The bench's server: a dev-mode server on loopback and ephemeral
/// ports, data in `data_dir`, the capacity scene at [`TICK_HZ`] ticks and
/// [`SNAPSHOT_HZ`] snapshots a second, room for `clients` (at least 64).
pub fn server_config(data_dir: PathBuf, clients: u32) -> ServerConfig {
    ServerConfig {
        listen: Some(std::net::SocketAddr::from(([127, 0, 0, 1], 0))),
        metrics: std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
        scene: Some(scene_path()),
        data_dir,
        tick_hz: TICK_HZ,
        snapshot_hz: SNAPSHOT_HZ,
        max_clients: clients.max(64),
        // A game server's tick on a machine whose cores are all busy; where
        // the privilege is missing it runs at a raised nice value, and
        // `tick_realtime` says which.
        tick_realtime: true,
        ..ServerConfig::default()
    }
}

/// The machine's busy, total and stolen CPU time so far, s
/// (`/proc/stat`; stolen: time the host ran something else while this
/// machine's virtual cores had work).
fn machine_cpu_s() -> (f64, f64, f64) {
    let Ok(stat) = std::fs::read_to_string("/proc/stat") else {
        return (f64::NAN, f64::NAN, f64::NAN);
    };
    let Some(line) = stat.lines().find(|l| l.starts_with("cpu ")) else {
        return (f64::NAN, f64::NAN, f64::NAN);
    };
    let v: Vec<f64> = line
        .split_whitespace()
        .skip(1)
        .filter_map(|x| x.parse().ok())
        .collect();
    // user nice system idle iowait irq softirq steal (guest is in user).
    let total: f64 = v.iter().take(8).sum();
    let idle = v.get(3).copied().unwrap_or(0.0) + v.get(4).copied().unwrap_or(0.0);
    let steal = v.get(7).copied().unwrap_or(0.0);
    ((total - idle) / 100.0, total / 100.0, steal / 100.0)
}

/// The server-side counters a step compares at its start and end.
#[derive(Debug, Clone, Copy)]
struct ServerMark {
    at: Instant,
    cpu_s: f64,
    threads_cpu_s: [f64; THREAD_GROUPS.len()],
    machine_busy_s: f64,
    machine_total_s: f64,
    machine_steal_s: f64,
    encode_s: f64,
    encodes: u64,
    degrade_steps: u64,
    superseded: u64,
    degraded: i64,
    bytes_sent: u64,
    ticks: u64,
    overruns: u64,
}

impl ServerMark {
    fn take(server: &RunningServer) -> Self {
        let m = server.metrics();
        let stats = server.sim().stats();
        let (busy, total, steal) = machine_cpu_s();
        // The histogram's sum and count, as Prometheus reads them.
        let text = m.encode();
        let (encode_s, encodes) = (
            exposed(&text, "inertia_snapshot_encode_seconds_sum").unwrap_or(f64::NAN),
            exposed(&text, "inertia_snapshot_encode_seconds_count").unwrap_or(0.0) as u64,
        );
        Self {
            at: Instant::now(),
            cpu_s: process_cpu_s(),
            threads_cpu_s: threads_cpu_s(),
            machine_busy_s: busy,
            machine_total_s: total,
            machine_steal_s: steal,
            encode_s,
            encodes,
            degrade_steps: m
                .snapshot_rate_steps
                .get_or_create(&[("direction", "degrade")])
                .get(),
            superseded: m.snapshots_superseded.get(),
            degraded: m.snapshot_clients_degraded.get(),
            bytes_sent: m.bytes_sent.get(),
            ticks: stats.ticks.load(std::sync::atomic::Ordering::Relaxed),
            overruns: stats.overruns.load(std::sync::atomic::Ordering::Relaxed),
        }
    }
}

/// The server's threads by what they do, each named by the prefix of its
/// thread name (Linux keeps 15 bytes): the tick (with the physics worker
/// threads it starts, which take its name), the snapshot stage, the
/// network (this suite's tokio workers), and the rest.
const THREAD_GROUPS: [(&str, &str); 4] = [
    ("tick", "inertia-tick"),
    ("snapshots", "inertia-snapsho"),
    ("network", "inertia-bench-s"),
    ("other", ""),
];

/// Whether the tick thread runs at real-time priority (`--tick-realtime`
/// granted): the policy field of its `/proc/self/task/*/stat`.
fn tick_realtime() -> bool {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return false;
    };
    tasks.flatten().any(|task| {
        let Ok(stat) = std::fs::read_to_string(task.path().join("stat")) else {
            return false;
        };
        // The policy is field 41 of the file: 38 after the name.
        stat_fields(&stat).is_some_and(|(name, f)| {
            name == "inertia-tick" && matches!(f.get(38), Some(&("1" | "2")))
        })
    })
}

/// User + system CPU time of this process's threads so far, s, summed by
/// [`THREAD_GROUPS`] (`/proc/self/task/*/stat`; threads that ended are
/// not counted).
fn threads_cpu_s() -> [f64; THREAD_GROUPS.len()] {
    let mut out = [0.0; THREAD_GROUPS.len()];
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return [f64::NAN; THREAD_GROUPS.len()];
    };
    for task in tasks.flatten() {
        let Ok(stat) = std::fs::read_to_string(task.path().join("stat")) else {
            continue;
        };
        let Some((name, seconds)) = stat_cpu(&stat) else {
            continue;
        };
        let group = THREAD_GROUPS
            .iter()
            .position(|(_, prefix)| name.starts_with(prefix))
            .unwrap_or(THREAD_GROUPS.len() - 1);
        out[group] += seconds;
    }
    out
}

/// The value of the sample `name` in an OpenMetrics exposition.
pub(crate) fn exposed(text: &str, name: &str) -> Option<f64> {
    text.lines().find_map(|l| {
        let (n, v) = l.split_once(' ')?;
        (n == name).then(|| v.trim().parse().ok()).flatten()
    })
}

/// The `p`-quantile of `xs` (sorted here), NaN for none.
/// The `p` quantile of `xs` (sorted in place), NaN when empty.
pub(crate) fn quantile(xs: &mut [f64], p: f64) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    xs.sort_by(f64::total_cmp);
    xs[((xs.len() - 1) as f64 * p).round() as usize]
}

/// Logs every tick `server` publishes, with its wall time (ms), into
/// `log`, until the returned task is aborted.
pub(crate) fn record_ticks(
    runtime: &tokio::runtime::Runtime,
    server: &RunningServer,
    log: TickLog,
) -> tokio::task::JoinHandle<()> {
    let mut frames = server.sim().subscribe();
    runtime.spawn(async move {
        let mut last = 0u64;
        while frames.changed().await.is_ok() {
            let f = frames.borrow_and_update().clone();
            if f.tick != last {
                last = f.tick;
                if let Ok(mut l) = log.lock() {
                    l.push((f.tick, f.tick_duration.as_secs_f64() * 1e3));
                }
            }
        }
    })
}

/// One measured step.
#[derive(Debug, Clone)]
struct Step {
    clients: u32,
    /// Server CPU per client beyond the idle server's, % of one core.
    cpu_percent_per_client: f64,
    tick_p99: f64,
    min_hz: f64,
    server_cpu: f64,
    bots_cpu: f64,
    machine_cpu: f64,
    /// CPU time the host took from the machine in the step, ms.
    steal_ms: f64,
    served: bool,
}

/// What the tick thread published: each frame's tick and tick time.
pub(crate) type TickLog = Arc<Mutex<Vec<(u64, f64)>>>;

/// Runs the steps and reports one record per K and the verdict.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    if !opts.wants("capacity") {
        return Ok(());
    }
    let mut ks: Vec<u32> = opts
        .clients
        .clone()
        .unwrap_or_else(|| DEFAULT_CLIENTS.to_vec());
    if opts.quick && opts.clients.is_none() {
        ks = vec![1, 2];
    }
    if ks.is_empty() || ks.contains(&0) {
        return Err("--clients takes client counts of at least 1".into());
    }
    let seconds = f64::from(
        opts.seconds
            .unwrap_or(if opts.quick { 2 } else { DEFAULT_SECONDS }),
    );
    let warmup = if opts.quick { 1.5 } else { WARMUP_S };
    let max_k = ks.iter().copied().max().unwrap_or(1);

    let data_dir =
        std::env::temp_dir().join(format!("inertia-bench-capacity-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&data_dir);
    let config = server_config(data_dir.clone(), max_k);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .thread_name("inertia-bench-server")
        .enable_all()
        .build()?;
    // The bench leaves the server's default: half the cores, at least one.
    let physics_threads = config.physics_threads_now();
    let server = runtime.block_on(start(config))?;
    let result = steps(
        &runtime,
        &server,
        physics_threads,
        &ks,
        seconds,
        warmup,
        sink,
    );
    runtime.block_on(server.shutdown());
    drop(runtime);
    let _ = std::fs::remove_dir_all(&data_dir);
    result
}

fn steps(
    runtime: &tokio::runtime::Runtime,
    server: &RunningServer,
    physics_threads: usize,
    ks: &[u32],
    seconds: f64,
    warmup: f64,
    sink: &mut dyn Sink,
) -> Result<(), BenchError> {
    let credentials = server
        .credentials_path()
        .ok_or("the bench server runs in dev mode")?
        .clone();
    let first = server.frame();
    let dynamic: BTreeSet<EntityId> = first
        .catalog
        .values()
        .filter(|d| d.kind == EntityKind::Dynamic)
        .map(|d| d.id)
        .collect();
    let bodies = dynamic.len();
    // Scene bodies awake and faster than 0.1 m/s in the latest frame.
    let moving = || {
        server
            .frame()
            .entities
            .iter()
            .filter(|e| dynamic.contains(&e.id) && !e.asleep && e.linear_velocity.length() > 0.1)
            .count()
    };

    // Every frame the tick thread publishes, with its last tick's time.
    let log: TickLog = Arc::new(Mutex::new(Vec::new()));
    let recorder = record_ticks(runtime, server, log.clone());

    // The server alone first: what it spends with no client, and its
    // resident set, for the figures per client.
    let idle_s = seconds.min(5.0);
    let idle_a = ServerMark::take(server);
    std::thread::sleep(Duration::from_secs_f64(idle_s));
    let idle_b = ServerMark::take(server);
    let idle_cpu = (idle_b.cpu_s - idle_a.cpu_s) / (idle_b.at - idle_a.at).as_secs_f64() * 100.0;
    let idle_rss_mb = crate::usage::rss_mb();

    let per_step = warmup + seconds;
    let pb = progress(ks.len() as u64, "capacity");
    let mut out = Suspended::new(&pb, sink);
    let mut served_max: Option<u32> = None;
    let mut last: Option<Step> = None;
    // The largest step served, for the projection.
    let mut best: Option<Step> = None;
    for (n, &k) in ks.iter().enumerate() {
        pb.set_message(format!("K={k}: starting bots"));
        let ids: Vec<u64> = (0..u64::from(k))
            .map(|i| 100_000 * (n as u64 + 1) + i)
            .collect();
        let mut bots = Bots::spawn(&credentials, &ids, per_step + SETTLE_MAX_S + 60.0)?;
        bots.wait_ready(CONNECT_TIMEOUT)?;
        let bot_processes = bots.processes();
        pb.set_message(format!("K={k}: warm-up"));
        std::thread::sleep(Duration::from_secs_f64(warmup));
        let settling = Instant::now();
        while server.metrics().snapshot_clients_degraded.get() > 0
            && settling.elapsed().as_secs_f64() < SETTLE_MAX_S
        {
            pb.set_message(format!("K={k}: waiting for full rates"));
            std::thread::sleep(Duration::from_millis(100));
        }
        let settle_s = settling.elapsed().as_secs_f64();
        let entities = server.frame().entities.len();

        bots.tell("start");
        if let Ok(mut l) = log.lock() {
            l.clear();
        }
        let a = ServerMark::take(server);
        pb.set_message(format!("K={k}: measuring {seconds:.0} s"));
        let mut moving_counts = Vec::new();
        let end = a.at + Duration::from_secs_f64(seconds);
        loop {
            moving_counts.push(moving() as f64);
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(Duration::from_millis(500)));
        }
        let b = ServerMark::take(server);
        let ticks_log = log.lock().map(|l| l.clone()).unwrap_or_default();
        let reports = bots.stop()?;
        drop(bots);
        let connected_after = server.clients();
        // Let the server see them go before the next step.
        let deadline = Instant::now() + Duration::from_secs(5);
        while server.clients() > 0 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }

        let wall = (b.at - a.at).as_secs_f64();
        let mut tick_ms: Vec<f64> = ticks_log.iter().map(|(_, ms)| *ms).collect();
        let ticks = b.ticks - a.ticks;
        let encodes = b.encodes - a.encodes;
        let encode_us = if encodes > 0 {
            (b.encode_s - a.encode_s) / encodes as f64 * 1e6
        } else {
            f64::NAN
        };
        let server_cpu = (b.cpu_s - a.cpu_s) / wall * 100.0;
        let thread_cpu: Vec<f64> = (0..THREAD_GROUPS.len())
            .map(|g| (b.threads_cpu_s[g] - a.threads_cpu_s[g]) / wall * 100.0)
            .collect();
        let rss_mb = crate::usage::rss_mb();
        // The server's CPU beyond what it spends with no client, per
        // snapshot sent.
        let cpu_us_per_snapshot = if encodes > 0 {
            ((server_cpu - idle_cpu) / 100.0 * wall).max(0.0) / encodes as f64 * 1e6
        } else {
            f64::NAN
        };
        let steal_ms = ((b.machine_steal_s - a.machine_steal_s) * 1e3).round();
        let machine_cpu = (b.machine_busy_s - a.machine_busy_s)
            / (b.machine_total_s - a.machine_total_s).max(1e-9)
            * 100.0
            * logical_cores() as f64;
        let kf = f64::from(k);
        let mean = |f: &dyn Fn(&BotReport) -> f64| {
            reports.iter().map(f).sum::<f64>() / reports.len().max(1) as f64
        };
        let bots_cpu: f64 = reports.iter().map(|r| r.cpu_percent).sum();
        let min_hz = reports
            .iter()
            .map(|r| r.snapshots_hz)
            .fold(f64::INFINITY, f64::min);
        let p50 = quantile(&mut tick_ms, 0.5);
        let p99 = quantile(&mut tick_ms, 0.99);
        let max_ms = tick_ms.last().copied().unwrap_or(f64::NAN);
        let target_hz = SERVED_FRACTION * f64::from(SNAPSHOT_HZ);
        let served = reports.len() == k as usize
            && p99 < TICK_BUDGET_MS
            && min_hz >= target_hz
            && reports.iter().all(|r| !r.disconnected);
        out.record(
            Measurement::new()
                .field("case", format!("capacity_{k}"))
                .field("scene", "capacity")
                .field("clients", k)
                .field("bodies", bodies)
                .field("entities", entities)
                .num(
                    "moving_mean",
                    moving_counts.iter().sum::<f64>() / moving_counts.len() as f64,
                )
                .num(
                    "moving_min",
                    moving_counts.iter().copied().fold(f64::INFINITY, f64::min),
                )
                .field("tick_hz", TICK_HZ)
                .field("snapshot_hz", SNAPSHOT_HZ)
                .num("seconds", wall)
                .num("tick_ms_p50", p50)
                .num("tick_ms_p99", p99)
                .num("tick_ms_max", max_ms)
                .field("tick_samples", ticks_log.len())
                .field("ticks", ticks)
                .num("ticks_per_s", ticks as f64 / wall)
                .field("overruns", b.overruns - a.overruns)
                .num("encode_us_per_client", encode_us)
                .num("snapshots_encoded_per_s", encodes as f64 / wall)
                .num("server_cpu_percent", server_cpu)
                .num("server_idle_cpu_percent", idle_cpu)
                .num("server_cpu_us_per_client_snapshot", cpu_us_per_snapshot)
                .num("tick_cpu_percent", thread_cpu[0])
                .num("snapshots_cpu_percent", thread_cpu[1])
                .num("network_cpu_percent", thread_cpu[2])
                .num("other_cpu_percent", thread_cpu[3])
                .num("rss_mb", rss_mb)
                .num("rss_kb_per_client", (rss_mb - idle_rss_mb) * 1024.0 / kf)
                .num("bots_cpu_percent", bots_cpu)
                .field("bot_processes", bot_processes)
                .num("machine_cpu_percent", machine_cpu)
                .num("steal_ms", steal_ms)
                .num("cpu_ceiling_percent", 100.0 * logical_cores() as f64)
                .num("kbps_per_client", mean(&|r| r.kbps))
                .num(
                    "server_kbps_per_client",
                    (b.bytes_sent - a.bytes_sent) as f64 * 8.0 / 1000.0 / wall / kf,
                )
                .num("snapshots_per_client_hz", mean(&|r| r.snapshots_hz))
                .num("snapshots_min_client_hz", min_hz)
                .num("settle_s", settle_s)
                .field("rate_degrade_steps", b.degrade_steps - a.degrade_steps)
                .field("snapshots_superseded", b.superseded - a.superseded)
                .field("clients_degraded", b.degraded)
                .num("loss_mean", mean(&|r| r.loss))
                .field("stalls", reports.iter().map(|r| r.stalls).sum::<u64>())
                .field(
                    "bots_disconnected",
                    reports.iter().filter(|r| r.disconnected).count(),
                )
                .field("clients_connected_at_end", connected_after)
                .field("served", served)
                .field(
                    "tick_source",
                    "per-frame tick_duration via server.sim().subscribe()",
                )
                .field("threads", logical_cores())
                .field("physics_threads", physics_threads)
                .field("tick_realtime", tick_realtime()),
        );
        pb.inc(1);
        let step = Step {
            clients: k,
            cpu_percent_per_client: (server_cpu - idle_cpu) / kf,
            tick_p99: p99,
            min_hz,
            server_cpu,
            bots_cpu,
            machine_cpu,
            steal_ms,
            served,
        };
        if served {
            best = Some(step.clone());
        }
        last = Some(step);
        if served {
            served_max = Some(k);
        } else {
            break;
        }
    }
    pb.finish_and_clear();
    recorder.abort();
    let Some(last) = last else {
        return Ok(());
    };
    let bounded_by = verdict(&last);
    note(&pb, &format!("capacity: {bounded_by}"));
    sink.record(
        Measurement::new()
            .field("case", "capacity_max")
            .field("scene", "capacity")
            .field("max_clients_at_60hz", served_max.unwrap_or(0))
            // The machine's cores, less what the server spends with no
            // client (the tick), over its CPU per client at the largest
            // step served.
            .num(
                "projected_max_clients",
                best.as_ref().map_or(f64::NAN, |b| {
                    (100.0 * logical_cores() as f64 - idle_cpu) / b.cpu_percent_per_client
                }),
            )
            .num("server_idle_cpu_percent", idle_cpu)
            .field("bounded_by", bounded_by)
            .num("tick_budget_ms", TICK_BUDGET_MS)
            .num("min_snapshot_hz", SERVED_FRACTION * f64::from(SNAPSHOT_HZ))
            .field("bots_on_same_machine", true)
            .field("threads", logical_cores()),
    );
    Ok(())
}

/// In words: what stopped the steps (or that none did).
fn verdict(last: &Step) -> String {
    let ceiling = 100.0 * logical_cores() as f64;
    let cpu = format!(
        "machine CPU {:.0} % of {ceiling:.0} % (server {:.0} %, bots {:.0} %)",
        last.machine_cpu, last.server_cpu, last.bots_cpu
    );
    let shared = "the bots run on the same cores as the server, so this is a lower bound \
                  for a server with the machine to itself";
    if last.served {
        return format!(
            "not reached: every step up to {} clients was served (at that step {cpu}); \
             {shared}",
            last.clients
        );
    }
    let mut what = Vec::new();
    if last.tick_p99.is_nan() || last.tick_p99 >= TICK_BUDGET_MS {
        what.push(format!(
            "tick time (p99 {:.1} ms >= {TICK_BUDGET_MS:.1} ms)",
            last.tick_p99
        ));
    }
    let target = SERVED_FRACTION * f64::from(SNAPSHOT_HZ);
    if last.min_hz.is_nan() || last.min_hz < target {
        what.push(format!(
            "snapshot rate (worst client {:.1} Hz < {target:.1} Hz)",
            last.min_hz
        ));
    }
    if what.is_empty() {
        what.push("a bot disconnected or failed to report".into());
    }
    let saturated = last.machine_cpu >= 0.9 * ceiling;
    let cause = if saturated && last.bots_cpu >= 0.25 * last.machine_cpu {
        format!("CPU: both cores saturated and shared with the bots; {cpu}; {shared}")
    } else if saturated {
        format!("CPU: both cores saturated, mostly by the server; {cpu}")
    } else if last.steal_ms >= STEAL_NOTED_MS {
        format!(
            "not CPU-saturated ({cpu}), but the host took {:.0} ms of the machine's cores \
             in the step (steal time)",
            last.steal_ms
        )
    } else {
        format!("not CPU-saturated ({cpu}): the server's own latency")
    };
    format!(
        "{} at {} clients; {cause}",
        what.join(" and "),
        last.clients
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_file_is_there() {
        assert!(scene_path().is_file(), "{}", scene_path().display());
    }

    #[test]
    fn cpu_counters_read() {
        let (busy, total, steal) = machine_cpu_s();
        assert!(total > 0.0 && busy <= total && steal <= total);
    }

    #[test]
    fn encode_timing_is_exposed() {
        let m = inertia_server::metrics::Metrics::new();
        m.snapshot_encode.observe(25e-6);
        m.snapshot_encode.observe(35e-6);
        let text = m.encode();
        let sum = exposed(&text, "inertia_snapshot_encode_seconds_sum").unwrap();
        assert!((sum - 60e-6).abs() < 1e-12, "{text}");
        assert_eq!(
            exposed(&text, "inertia_snapshot_encode_seconds_count"),
            Some(2.0)
        );
    }
}
