//! Bot clients for the suites that need players (`capacity`, `soak`):
//! real SDK clients, many to a process.
//!
//! A bot process is this executable again, with the hidden `bot`
//! subcommand, so the bots' CPU time is not the server's. It hosts up to
//! [`BOTS_PER_PROCESS`] clients on one single-threaded tokio runtime, each
//! a [`Client`] with its own QUIC connection. Every client decodes every
//! snapshot into its interpolation buffer and entity table and sends
//! inputs ([`BOT_INPUT_HZ`], each datagram with the last
//! [`BOT_INPUT_REDUNDANCY`]; the SDK's driver does both), and walks its
//! avatar with a changing stick, jumping and pushing now and then, set at
//! [`BOT_FRAME_HZ`] like a game's frame loop. It does not render: the
//! picture is sampled once a second ([`BOT_SAMPLE_HZ`]), to check there is
//! one, not every frame.
//!
//! The suite talks to a process over its standard streams: the process
//! prints `{"ready":<id>}` once per client connected; `start` on its
//! stdin starts the count and `stop` ends it, after which it prints one
//! [`BotReport`] per client as a JSON line and leaves.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use clap::Parser;
use inertia_client::dev::dev_token;
use inertia_client::stats::ClientStats;
use inertia_client::{Client, ConnectOptions};
use inertia_sandbox::buttons;
use serde::{Deserialize, Serialize};

use crate::BenchError;

/// Most clients one bot process hosts.
pub const BOTS_PER_PROCESS: usize = 128;
/// How often a bot sets its input (stick, facing, buttons), Hz.
pub const BOT_FRAME_HZ: f64 = 60.0;
/// Input datagrams a bot sends per second, Hz: half the tick rate, as
/// many games send (each input holds for the ticks until the next).
pub const BOT_INPUT_HZ: u32 = 30;
/// Inputs each input datagram carries: the last 4, so an input is lost
/// only when 4 datagrams in a row are (133 ms at 30 Hz).
pub const BOT_INPUT_REDUNDANCY: usize = 4;
/// How often a bot samples its interpolated picture, Hz.
pub const BOT_SAMPLE_HZ: f64 = 1.0;
/// How much less urgent a bot process is than the server (added to its
/// nice value): the bots stand in for the players' own machines, so on a
/// machine short of cores they wait for the server, not it for them.
pub const BOT_NICE: i32 = 10;
/// Clients of one bot process that connect at once (players join over
/// seconds, not all in one millisecond; the server refuses handshakes
/// beyond its own limit in flight).
const CONNECTS_AT_ONCE: usize = 16;
/// Tries a bot makes to connect before it gives up.
const CONNECT_ATTEMPTS: u32 = 5;
/// The wait between two tries.
const CONNECT_RETRY: Duration = Duration::from_millis(250);
/// How long a bot process's clients have to report after `stop`.
const REPORT_TIMEOUT: Duration = Duration::from_secs(20);

/// What a bot prints when told to stop: what it received between `start`
/// and `stop`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BotReport {
    /// The bot's client id.
    pub client_id: u64,
    /// Wall seconds between `start` and `stop`.
    pub seconds: f64,
    /// Snapshots received in the window.
    pub snapshots_received: u64,
    /// Snapshots received per second.
    pub snapshots_hz: f64,
    /// Snapshot bytes received in the window, kbit/s.
    pub kbps: f64,
    /// Fraction of snapshot sequence numbers missed (last 256), 0 to 1.
    pub loss: f64,
    /// Times the picture held because snapshots ran out, in the window.
    pub stalls: u64,
    /// Extrapolations past the newest snapshot, in the window.
    pub extrapolations: u64,
    /// This bot's share of its process's CPU time per wall second in the
    /// window, × 100 (the process's, over the clients it hosts).
    pub cpu_percent: f64,
    /// Input frames the bot ran in the window.
    pub frames: u64,
    /// Whether the server said goodbye or dropped the bot.
    pub disconnected: bool,
    /// Kill-cams a watching bot asked for in the window.
    #[serde(default)]
    pub replays_asked: u64,
    /// Of those, the ones the server refused.
    #[serde(default)]
    pub replays_refused: u64,
    /// For each kill-cam that played, the wall time from asking to its
    /// first replay snapshot, ms (to within one bot frame).
    #[serde(default)]
    pub replay_first_ms: Vec<f64>,
}

/// What a watching bot asks for, again as soon as the last one ended:
/// the last this many seconds, at real time.
pub const BOT_REPLAY_S: f32 = 10.0;
/// The least time between two of a watching bot's requests, s (the
/// server takes one a second).
const BOT_REPLAY_GAP: Duration = Duration::from_millis(1100);

/// `inertia-bench bot …`: one bot process (started by the suites).
#[derive(Debug, Parser)]
#[command(name = "inertia-bench bot")]
pub struct BotArgs {
    /// The dev-mode server's credentials file.
    #[arg(long)]
    pub credentials: PathBuf,
    /// The first client id; the process's clients take the next ones.
    #[arg(long)]
    pub client_id: u64,
    /// Clients this process hosts.
    #[arg(long, default_value_t = 1)]
    pub count: u64,
    /// Give up and exit after this many seconds whatever happens.
    #[arg(long, default_value_t = 120.0)]
    pub seconds: f64,
    /// How many of this process's clients (the first ones) watch
    /// kill-cams while counting: each asks for the last
    /// [`BOT_REPLAY_S`] s again as soon as its last one ended.
    #[arg(long, default_value_t = 0)]
    pub replays: u64,
}

/// This process's user + system CPU time so far, s (`/proc/self/stat`).
pub(crate) fn process_cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    stat_cpu(&stat).map_or(f64::NAN, |(_, s)| s)
}

/// The command (or thread) name of one `/proc/<pid>/stat` or
/// `/proc/<pid>/task/<tid>/stat` text, and the fields after it (field
/// `n` of the file is at `n - 3`).
pub(crate) fn stat_fields(stat: &str) -> Option<(&str, Vec<&str>)> {
    // The name is in brackets and may hold spaces; the fields follow it.
    let (head, rest) = stat.rsplit_once(')')?;
    let name = head.split_once('(').map_or("", |(_, n)| n);
    Some((name, rest.split_whitespace().collect()))
}

/// The command (or thread) name and the user + system CPU time, s, of one
/// `/proc/<pid>/stat` or `/proc/<pid>/task/<tid>/stat` text.
pub(crate) fn stat_cpu(stat: &str) -> Option<(&str, f64)> {
    let (name, f) = stat_fields(stat)?;
    // utime and stime are fields 14 and 15 of the file: 11 and 12 here.
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok());
    // USER_HZ is 100 on every Linux the bench runs on.
    Some((name, (ticks(11)? + ticks(12)?) / 100.0))
}

/// Where a bot process's clients are in the count.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Playing, not counting yet.
    Playing,
    /// Counting.
    Counting,
    /// Told to stop (or out of time).
    Stop,
}

/// Runs one bot process: its clients connect, say they are ready, play
/// until `stop` on stdin (counting from `start`), print their
/// [`BotReport`]s and leave.
pub fn bot_main(args: &[String]) -> Result<(), BenchError> {
    let args = BotArgs::try_parse_from(args)?;
    if args.count == 0 {
        return Err("--count takes at least 1 client".into());
    }
    // Before any other thread starts, so that they all inherit it (best
    // effort).
    let _ = inertia_server::priority::adjust_this_thread(BOT_NICE);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    runtime.block_on(play(args))
}

async fn play(args: BotArgs) -> Result<(), BenchError> {
    let began = Instant::now();
    let (phase_tx, phase) = tokio::sync::watch::channel(Phase::Playing);
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            match line.trim() {
                "start" => {
                    let _ = phase_tx.send(Phase::Counting);
                }
                "stop" => break,
                _ => {}
            }
        }
        // `stop`, or EOF: the suite went away.
        let _ = phase_tx.send(Phase::Stop);
    });
    let mut clients = tokio::task::JoinSet::new();
    let connecting = std::sync::Arc::new(tokio::sync::Semaphore::new(CONNECTS_AT_ONCE));
    let (first_id, replays) = (args.client_id, args.replays);
    for id in args.client_id..args.client_id + args.count {
        let credentials = args.credentials.clone();
        let phase = phase.clone();
        let connecting = connecting.clone();
        clients.spawn(async move {
            let options = ConnectOptions {
                input_hz: Some(BOT_INPUT_HZ),
                input_redundancy: Some(BOT_INPUT_REDUNDANCY),
                ..ConnectOptions::default()
            };
            let client = {
                let _turn = connecting.acquire().await.map_err(|e| e.to_string())?;
                let mut attempt = 1;
                loop {
                    // A fresh token each time: a token is good for one
                    // connection.
                    let (addr, token, _) =
                        dev_token(&credentials, Some(id)).map_err(|e| format!("bot {id}: {e}"))?;
                    match Client::connect_with(addr, &token, options.clone()).await {
                        Ok(client) => break client,
                        Err(_) if attempt < CONNECT_ATTEMPTS => {
                            attempt += 1;
                            tokio::time::sleep(CONNECT_RETRY).await;
                        }
                        Err(e) => return Err(format!("bot {id}: {e}")),
                    }
                }
            };
            {
                let mut out = std::io::stdout().lock();
                let _ = writeln!(out, "{{\"ready\":{id}}}");
                let _ = out.flush();
            }
            let watches = id < first_id + replays;
            Ok::<_, String>(bot(id, client, phase, watches).await)
        });
    }
    // The process's CPU over the count, shared out over its clients.
    let mut phase_rx = phase.clone();
    let lifetime = Duration::from_secs_f64(args.seconds.max(0.0));
    let cpu = async {
        let mut from = None;
        loop {
            match *phase_rx.borrow_and_update() {
                Phase::Counting if from.is_none() => from = Some((Instant::now(), process_cpu_s())),
                Phase::Stop => break,
                _ => {}
            }
            if phase_rx.changed().await.is_err() {
                break;
            }
        }
        from.map(|(t0, c0)| (process_cpu_s() - c0) / t0.elapsed().as_secs_f64().max(1e-9) * 100.0)
    };
    let (cpu, reports) = tokio::select! {
        both = async { tokio::join!(cpu, async {
            let mut reports = Vec::new();
            while let Some(r) = clients.join_next().await {
                reports.push(r);
            }
            reports
        }) } => both,
        _ = tokio::time::sleep(lifetime.saturating_sub(began.elapsed())) => {
            return Err(format!("out of time after {} s", args.seconds).into());
        }
    };
    let share = cpu.unwrap_or(0.0) / args.count as f64;
    let mut out = std::io::stdout().lock();
    for r in reports {
        let mut report = r.map_err(|e| format!("a bot task failed: {e}"))??;
        report.cpu_percent = share;
        writeln!(out, "{}", serde_json::to_string(&report)?)?;
    }
    out.flush()?;
    Ok(())
}

/// One client's play, until the phase says stop: its report.
async fn bot(
    id: u64,
    client: Client,
    mut phase: tokio::sync::watch::Receiver<Phase>,
    watches: bool,
) -> BotReport {
    let began = Instant::now();
    let mut timer = tokio::time::interval(Duration::from_secs_f64(1.0 / BOT_FRAME_HZ));
    timer.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let sample_every = (BOT_FRAME_HZ / BOT_SAMPLE_HZ).round().max(1.0) as u64;
    let mut frames = 0u64;
    let mut from: Option<(Instant, ClientStats, u64)> = None;
    let mut watcher = Watcher::default();
    // Each bot walks its own pattern.
    let phase_offset = (id % 97) as f32 * 0.37;
    loop {
        tokio::select! {
            _ = timer.tick() => {}
            changed = phase.changed() => if changed.is_err() { break },
        }
        match *phase.borrow_and_update() {
            Phase::Counting if from.is_none() => {
                from = Some((Instant::now(), client.stats(), frames))
            }
            Phase::Stop => break,
            _ => {}
        }
        let t = began.elapsed().as_secs_f32() + phase_offset;
        let movement = [(0.7 * t).sin(), (0.45 * t).cos()];
        let yaw = (0.3 * t).sin() * std::f32::consts::PI;
        let frame = (t * BOT_FRAME_HZ as f32) as u64;
        if watches && from.is_some() {
            watcher.frame(&client);
        }
        let mut pressed = 0;
        // Jump for a frame every 2 s, push every 1.5 s.
        if frame % 120 == 0 {
            pressed |= buttons::JUMP;
        }
        if frame % 90 == 45 {
            pressed |= buttons::PUSH;
        }
        // The capacity scene runs the sandbox: its input always fits.
        let _ = client.set_input(movement, yaw, pressed);
        if frames % sample_every == 0 {
            std::hint::black_box(client.sample().entities.len());
        }
        frames += 1;
    }
    let now = Instant::now();
    let s = client.stats();
    let (t0, s0, f0) = from.unwrap_or((began, ClientStats::default(), 0));
    let seconds = (now - t0).as_secs_f64().max(1e-9);
    let snapshots = s.snapshots_received - s0.snapshots_received;
    let report = BotReport {
        client_id: id,
        seconds,
        snapshots_received: snapshots,
        snapshots_hz: snapshots as f64 / seconds,
        kbps: (s.bytes_received - s0.bytes_received) as f64 * 8.0 / 1000.0 / seconds,
        loss: s.loss,
        stalls: s.stalls - s0.stalls,
        extrapolations: s.extrapolations - s0.extrapolations,
        cpu_percent: 0.0,
        frames: frames - f0,
        disconnected: client.disconnected().is_some(),
        replays_asked: watcher.asked,
        replays_refused: watcher.refused,
        replay_first_ms: watcher.first_ms,
    };
    client.close().await;
    report
}

/// A watching bot's kill-cams: when it asked last, and what it saw.
#[derive(Debug, Default)]
struct Watcher {
    /// When the last request went, and whether its first snapshot came.
    asked_at: Option<(Instant, bool)>,
    asked: u64,
    refused: u64,
    first_ms: Vec<f64>,
}

impl Watcher {
    /// One frame: notes the first snapshot of the replay asked for, and
    /// asks for the next once the last one is over.
    fn frame(&mut self, client: &Client) {
        use inertia_client::ReplayStatus;
        let status = client.replay_status();
        if let Some((at, false)) = self.asked_at {
            if client.replay_tick().is_some() {
                self.first_ms.push(at.elapsed().as_secs_f64() * 1e3);
                self.asked_at = Some((at, true));
            } else if let ReplayStatus::Refused(_) = status {
                self.refused += 1;
                self.asked_at = Some((at, true));
            }
        }
        let busy = matches!(status, ReplayStatus::Asked | ReplayStatus::Playing { .. });
        let rested = self
            .asked_at
            .is_none_or(|(at, _)| at.elapsed() >= BOT_REPLAY_GAP);
        if !busy && rested && client.kill_cam(BOT_REPLAY_S, 1.0, None).is_ok() {
            self.asked += 1;
            self.asked_at = Some((Instant::now(), false));
        }
    }
}

/// A line from a bot process, or its end.
enum BotLine {
    Line(String),
    Closed(usize),
}

/// The bot processes of one step, hosting one client per id; killed when
/// dropped.
pub(crate) struct Bots {
    children: Vec<Child>,
    stdins: Vec<Option<ChildStdin>>,
    lines: Receiver<BotLine>,
    clients: usize,
}

impl Bots {
    /// Starts clients `ids` (consecutive runs of ids share a process, at
    /// most [`BOTS_PER_PROCESS`] to one), each giving up after
    /// `lifetime_s`.
    pub(crate) fn spawn(
        credentials: &Path,
        ids: &[u64],
        lifetime_s: f64,
    ) -> Result<Self, BenchError> {
        Self::spawn_watching(credentials, ids, 0, lifetime_s)
    }

    /// [`Bots::spawn`], the first `replays` of `ids` watching kill-cams
    /// while counting ([`BotArgs::replays`]).
    pub(crate) fn spawn_watching(
        credentials: &Path,
        ids: &[u64],
        replays: usize,
        lifetime_s: f64,
    ) -> Result<Self, BenchError> {
        let exe = std::env::current_exe()?;
        let (tx, lines) = mpsc::channel();
        let mut bots = Bots {
            children: Vec::new(),
            stdins: Vec::new(),
            lines,
            clients: ids.len(),
        };
        // The watchers in processes of their own, as players on machines
        // of their own: a request's answer then waits for the server, not
        // behind a hundred other clients' snapshots in a busy bot.
        let replays = replays.min(ids.len());
        let (watching, playing) = ids.split_at(replays);
        let groups = runs(watching, BOTS_PER_PROCESS)
            .into_iter()
            .map(|(first, count)| (first, count, count))
            .chain(
                runs(playing, BOTS_PER_PROCESS)
                    .into_iter()
                    .map(|(first, count)| (first, count, 0)),
            );
        for (i, (first, count, watching)) in groups.enumerate() {
            let mut child = Command::new(&exe)
                .arg("bot")
                .arg("--credentials")
                .arg(credentials)
                .arg("--client-id")
                .arg(first.to_string())
                .arg("--count")
                .arg(count.to_string())
                .arg("--seconds")
                .arg(format!("{lifetime_s:.0}"))
                .arg("--replays")
                .arg(watching.to_string())
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()?;
            let stdout = child.stdout.take().ok_or("bot stdout")?;
            bots.stdins.push(child.stdin.take());
            bots.children.push(child);
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stdout).lines() {
                    let Ok(line) = line else { break };
                    if tx.send(BotLine::Line(line)).is_err() {
                        return;
                    }
                }
                let _ = tx.send(BotLine::Closed(i));
            });
        }
        Ok(bots)
    }

    /// Bot processes running.
    pub(crate) fn processes(&self) -> usize {
        self.children.len()
    }

    /// Sends a command line to every bot process.
    pub(crate) fn tell(&mut self, what: &str) {
        for stdin in self.stdins.iter_mut().flatten() {
            let _ = writeln!(stdin, "{what}");
            let _ = stdin.flush();
        }
    }

    /// What bot process `i` wrote on stderr (after it ended or was killed).
    fn stderr_of(&mut self, i: usize) -> String {
        let mut s = String::new();
        if let Some(e) = self.children.get_mut(i).and_then(|c| c.stderr.as_mut()) {
            let _ = e.read_to_string(&mut s);
        }
        s.trim().to_string()
    }

    /// Waits until every client said it is ready.
    pub(crate) fn wait_ready(&mut self, timeout: Duration) -> Result<(), BenchError> {
        let deadline = Instant::now() + timeout;
        let mut ready = 0usize;
        while ready < self.clients {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(BotLine::Line(l)) if l.starts_with("{\"ready\"") => ready += 1,
                Ok(BotLine::Line(_)) => {}
                Ok(BotLine::Closed(i)) => {
                    self.kill();
                    let why = self.stderr_of(i);
                    return Err(format!("bot process {i} ended before it connected: {why}").into());
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(format!(
                        "only {ready} of {} bots connected within {timeout:?}",
                        self.clients
                    )
                    .into());
                }
                Err(RecvTimeoutError::Disconnected) => return Err("bot readers ended".into()),
            }
        }
        Ok(())
    }

    /// Tells every bot to stop and collects their reports, by client id.
    pub(crate) fn stop(&mut self) -> Result<Vec<BotReport>, BenchError> {
        self.tell("stop");
        let deadline = Instant::now() + REPORT_TIMEOUT;
        let mut reports = BTreeMap::new();
        let mut closed = vec![false; self.children.len()];
        while reports.len() < self.clients {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(BotLine::Line(l)) => {
                    if let Ok(r) = serde_json::from_str::<BotReport>(&l) {
                        reports.insert(r.client_id, r);
                    }
                }
                Ok(BotLine::Closed(i)) => {
                    closed[i] = true;
                    if closed.iter().all(|c| *c) && reports.len() < self.clients {
                        let why = self.stderr_of(i);
                        return Err(format!(
                            "bot processes ended with {} of {} reports: {why}",
                            reports.len(),
                            self.clients
                        )
                        .into());
                    }
                }
                Err(_) => {
                    return Err(format!(
                        "only {} of {} bots reported in time",
                        reports.len(),
                        self.clients
                    )
                    .into());
                }
            }
        }
        // Let them leave; whoever lingers is killed on drop.
        let deadline = Instant::now() + Duration::from_secs(5);
        for c in &mut self.children {
            while Instant::now() < deadline {
                if let Ok(Some(_)) = c.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        Ok(reports.into_values().collect())
    }

    fn kill(&mut self) {
        for c in &mut self.children {
            if let Ok(None) = c.try_wait() {
                let _ = c.kill();
            }
            let _ = c.wait();
        }
    }
}

impl Drop for Bots {
    fn drop(&mut self) {
        self.kill();
    }
}

/// `ids` as runs of consecutive ids, each at most `most` long: (first id,
/// count).
fn runs(ids: &[u64], most: usize) -> Vec<(u64, usize)> {
    let mut out: Vec<(u64, usize)> = Vec::new();
    for &id in ids {
        match out.last_mut() {
            Some((first, n)) if *first + *n as u64 == id && *n < most => *n += 1,
            _ => out.push((id, 1)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bot_reports_round_trip() {
        let r = BotReport {
            client_id: 7,
            snapshots_hz: 30.0,
            ..BotReport::default()
        };
        let s = serde_json::to_string(&r).unwrap();
        assert_eq!(serde_json::from_str::<BotReport>(&s).unwrap(), r);
    }

    #[test]
    fn ids_share_processes_in_consecutive_runs() {
        let ids: Vec<u64> = (10..310).chain([400, 401, 900]).collect();
        assert_eq!(
            runs(&ids, 128),
            vec![(10, 128), (138, 128), (266, 44), (400, 2), (900, 1)]
        );
        assert_eq!(runs(&[], 128), vec![]);
    }

    #[test]
    fn the_cpu_counter_reads() {
        assert!(process_cpu_s() >= 0.0);
    }
}
