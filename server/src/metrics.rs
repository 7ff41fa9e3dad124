//! Prometheus metrics.
//!
//! [`Metrics`] holds one handle per metric (cheap to clone: the handles
//! share their values) and the registry they are exposed from, as
//! OpenMetrics or the classic text format; [`crate::http`] serves them at
//! `/metrics`.

use std::sync::Arc;

use prometheus_client::encoding::text::encode;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::Registry;

/// Every metric the server exports, by handle. Clones share the values.
#[derive(Debug, Clone)]
pub struct Metrics {
    /// Wall time of one tick (rules and physics step), s.
    pub tick_duration: Histogram,
    /// Loops of the tick thread that hit the catch-up cap (ticks dropped).
    pub tick_overruns: Counter,
    /// Rigid bodies in the world.
    pub bodies: Gauge,
    /// Clients connected.
    pub connected_clients: Gauge,
    /// UDP payload bytes sent, bytes.
    pub bytes_sent: Counter,
    /// UDP payload bytes received, bytes.
    pub bytes_received: Counter,
    /// Datagrams and stream messages sent.
    pub packets_sent: Counter,
    /// Datagrams and stream messages received.
    pub packets_received: Counter,
    /// Size of one encoded snapshot, bytes.
    pub snapshot_size: Histogram,
    /// Wall time of encoding one snapshot for one client (priorities,
    /// delta, bit packing), s.
    pub snapshot_encode: Histogram,
    /// Snapshots replaced unsent by the client's next one, because its
    /// connection task had not run for a whole snapshot period.
    pub snapshots_superseded: Counter,
    /// Clients served at a lower snapshot rate because the server could
    /// not serve everyone at full rate (see [`crate::net::governor`]).
    pub snapshot_clients_degraded: Gauge,
    /// Steps of the snapshot rate policy by `direction`: `degrade` (more
    /// clients at the lower rate) or `restore` (fewer).
    pub snapshot_rate_steps: Family<[(&'static str, &'static str); 1], Counter>,
    /// Datagrams dropped because they did not decode.
    pub malformed_datagrams: Counter,
    /// Inputs refused (by the input schedule, the game's decoder or its
    /// rules), all clients together.
    pub inputs_rejected: Counter,
    /// Inputs refused per connected `client` and `reason` (see
    /// [`INPUT_REFUSAL_REASONS`]); a client's series go when it leaves.
    pub inputs_refused: Family<Vec<(String, String)>, Counter>,
    /// Clients' game messages the rules took, by `delivery` (`reliable`,
    /// `unreliable`).
    pub messages_received: Family<[(&'static str, &'static str); 1], Counter>,
    /// Clients' game messages refused per connected `client` and `reason`
    /// (see [`MESSAGE_REFUSAL_REASONS`]); a client's series go when it
    /// leaves.
    pub messages_refused: Family<Vec<(String, String)>, Counter>,
    /// The rules' messages a client missed: its snapshot slots fell
    /// further behind than the recent messages a frame carries
    /// ([`crate::sim::RECENT_MESSAGES`]).
    pub messages_missed: Counter,
    /// Connection attempts refused or failed before they were served, by
    /// `reason`: `tls` (no common ALPN, bad certificate), `handshake`,
    /// `handshake_timeout`, `handshake_limit`, `hello_timeout` (no hello,
    /// or the welcome not taken, in time),
    /// `malformed_hello`, a hello's refusal (`token_forged`, `server_full`,
    /// ...), or an admin hello's (`admin_<outcome>`:
    /// `admin_refused_credential`, `admin_refused_throttled`, ...).
    pub refused_connections: Family<Vec<(String, String)>, Counter>,
    /// Incoming connections answered with a QUIC Retry (address
    /// validation, before any handshake work; see [`crate::net::gate`]).
    pub handshake_retries: Counter,
    /// Admin actions by `action` (the request, or `hello`) and `outcome`
    /// (`ok`, an error kind, or why a hello was refused).
    pub admin_actions: Family<Vec<(String, String)>, Counter>,
    /// Reloads of the admin token file by `outcome`: `ok` (the new set
    /// replaced the old) or `error` (the old set was kept).
    pub admin_token_reloads: Family<[(&'static str, &'static str); 1], Counter>,
    /// Entries in the admin token set now (operators, and the shared dev
    /// or bare token if there is one).
    pub admin_operators: Gauge,
    /// Records the recorder could not take (its channel was full); each
    /// one stops the recording, since a recording with a gap cannot be
    /// replayed.
    pub record_dropped: Counter,
    /// Memory held for seeking by `part`: `keyframes` and `checkpoints`
    /// (within `--seek-memory-mb`), `replay_window` (the frames held for
    /// players' replays, within a quarter of it), `hashes` and `journal`
    /// (every recorded tick's, outside it), bytes.
    pub seek_memory: Family<[(&'static str, &'static str); 1], Gauge>,
    /// Players' replays playing now ([`crate::net::replays`]).
    pub replays_playing: Gauge,
    /// Players' replay requests waiting for room now.
    pub replays_waiting: Gauge,
    /// Players' replays by `outcome`: `started`, a refusal's reason
    /// ([`inertia_protocol::replay::ReplayRefusal::reason`]), or how one
    /// ended (`finished`, `cancelled`, `replaced`, `window_passed`).
    pub replays: Family<[(&'static str, &'static str); 1], Counter>,
    /// Replay snapshots sent.
    pub replay_snapshots: Counter,
    registry: Arc<Registry>,
}

impl Default for Metrics {
    fn default() -> Self {
        Self::new()
    }
}

/// Why an input was refused, as `/metrics` labels it: `not_joined`, `stale`
/// (for a tick long past), `future` (too far ahead), `backlog` (too many
/// waiting), `undecodable` (the game's decoder refused its payload),
/// `wrong_size` (a datagram of inputs of another size than the game's).
pub const INPUT_REFUSAL_REASONS: [&str; 6] = [
    "not_joined",
    "stale",
    "future",
    "backlog",
    "undecodable",
    "wrong_size",
];

/// Why a client's message was refused, as `/metrics` labels it:
/// `too_long` (past the size bound), `rate` (over the client's rate),
/// `malformed` (a message datagram that is not one), `not_connected` (the
/// client has left), `backlog` (too many waiting for the tick),
/// `undecodable` (the game's decoder refused it), `rules` (the game's
/// rules refused what it asks).
pub const MESSAGE_REFUSAL_REASONS: [&str; 7] = [
    "too_long",
    "rate",
    "malformed",
    "not_connected",
    "backlog",
    "undecodable",
    "rules",
];

fn client_labels(client: u64, reason: &str) -> Vec<(String, String)> {
    vec![
        ("client".to_string(), client.to_string()),
        ("reason".to_string(), reason.to_string()),
    ]
}

impl Metrics {
    /// Fresh metrics, registered under the `inertia_` prefix.
    pub fn new() -> Self {
        // 50 µs … ~0.4 s: a healthy 60 Hz tick is well under 16.7 ms, and
        // the tail shows how far a bad one went.
        let tick_duration = Histogram::new(exponential_buckets(50e-6, 2.0, 14));
        // 16 B … 64 KiB: from an empty delta to a full keyframe.
        let snapshot_size = Histogram::new(exponential_buckets(16.0, 2.0, 13));
        // 1 µs … ~33 ms: a delta of a few entities up to a full world on a
        // loaded machine.
        let snapshot_encode = Histogram::new(exponential_buckets(1e-6, 2.0, 16));
        let m = Metrics {
            tick_duration,
            tick_overruns: Counter::default(),
            bodies: Gauge::default(),
            connected_clients: Gauge::default(),
            bytes_sent: Counter::default(),
            bytes_received: Counter::default(),
            packets_sent: Counter::default(),
            packets_received: Counter::default(),
            snapshot_size,
            snapshot_encode,
            snapshots_superseded: Counter::default(),
            snapshot_clients_degraded: Gauge::default(),
            snapshot_rate_steps: Family::default(),
            malformed_datagrams: Counter::default(),
            inputs_rejected: Counter::default(),
            inputs_refused: Family::default(),
            messages_received: Family::default(),
            messages_refused: Family::default(),
            messages_missed: Counter::default(),
            refused_connections: Family::default(),
            handshake_retries: Counter::default(),
            admin_actions: Family::default(),
            admin_token_reloads: Family::default(),
            admin_operators: Gauge::default(),
            record_dropped: Counter::default(),
            seek_memory: Family::default(),
            replays_playing: Gauge::default(),
            replays_waiting: Gauge::default(),
            replays: Family::default(),
            replay_snapshots: Counter::default(),
            registry: Arc::new(Registry::default()),
        };
        let mut r = Registry::with_prefix("inertia");
        r.register(
            "tick_duration_seconds",
            "Wall time of one simulation tick (rules and physics), seconds",
            m.tick_duration.clone(),
        );
        r.register(
            "tick_overruns",
            "Tick-loop iterations that hit the catch-up cap and dropped simulation time",
            m.tick_overruns.clone(),
        );
        r.register("bodies", "Rigid bodies in the world", m.bodies.clone());
        r.register(
            "connected_clients",
            "Clients connected",
            m.connected_clients.clone(),
        );
        r.register(
            "sent_bytes",
            "Payload bytes sent to clients",
            m.bytes_sent.clone(),
        );
        r.register(
            "received_bytes",
            "Payload bytes received from clients",
            m.bytes_received.clone(),
        );
        r.register(
            "sent_packets",
            "Datagrams and messages sent to clients",
            m.packets_sent.clone(),
        );
        r.register(
            "received_packets",
            "Datagrams and messages received from clients",
            m.packets_received.clone(),
        );
        r.register(
            "snapshot_size_bytes",
            "Encoded size of one snapshot, bytes",
            m.snapshot_size.clone(),
        );
        r.register(
            "snapshot_encode_seconds",
            "Wall time of encoding one snapshot for one client, seconds",
            m.snapshot_encode.clone(),
        );
        r.register(
            "snapshots_superseded",
            "Snapshots replaced unsent by the client's next one (its connection task had not run for a snapshot period)",
            m.snapshots_superseded.clone(),
        );
        r.register(
            "snapshot_clients_degraded",
            "Clients served at a lower snapshot rate because the server could not serve everyone at full rate",
            m.snapshot_clients_degraded.clone(),
        );
        r.register(
            "snapshot_rate_steps",
            "Steps of the snapshot rate policy, by direction (degrade, restore)",
            m.snapshot_rate_steps.clone(),
        );
        r.register(
            "malformed_datagrams_dropped",
            "Datagrams dropped because they did not decode",
            m.malformed_datagrams.clone(),
        );
        r.register(
            "inputs_rejected",
            "Player inputs refused, all clients together",
            m.inputs_rejected.clone(),
        );
        r.register(
            "inputs_refused",
            "Player inputs refused, by connected client and reason",
            m.inputs_refused.clone(),
        );
        r.register(
            "messages_received",
            "Clients' game messages the rules took, by delivery",
            m.messages_received.clone(),
        );
        r.register(
            "messages_refused",
            "Clients' game messages refused, by connected client and reason",
            m.messages_refused.clone(),
        );
        r.register(
            "messages_missed",
            "Messages of the rules a client missed, its slots too far behind",
            m.messages_missed.clone(),
        );
        r.register(
            "refused_connections",
            "Connection attempts refused or failed before being served, by reason",
            m.refused_connections.clone(),
        );
        r.register(
            "handshake_retries",
            "Incoming connections asked to validate their address (QUIC Retry)",
            m.handshake_retries.clone(),
        );
        r.register(
            "admin_actions",
            "Admin channel actions by action and outcome, refused hellos included",
            m.admin_actions.clone(),
        );
        r.register(
            "admin_token_reloads",
            "Reloads of the admin token file by outcome (ok: replaced; error: the old set kept)",
            m.admin_token_reloads.clone(),
        );
        r.register(
            "admin_operators",
            "Entries in the admin token set now",
            m.admin_operators.clone(),
        );
        r.register(
            "record_dropped",
            "Records dropped because the recorder was behind (each stops the recording)",
            m.record_dropped.clone(),
        );
        r.register(
            "seek_memory_bytes",
            "Memory held for seeking by part, bytes: keyframes and checkpoints (within --seek-memory-mb), hashes and journal (every recorded tick's, outside it)",
            m.seek_memory.clone(),
        );
        r.register(
            "replays_playing",
            "Players' replays of the recent past playing now",
            m.replays_playing.clone(),
        );
        r.register(
            "replays_waiting",
            "Players' replay requests waiting for room now",
            m.replays_waiting.clone(),
        );
        r.register(
            "replays",
            "Players' replays by outcome: started, a refusal's reason, or how one ended",
            m.replays.clone(),
        );
        r.register(
            "replay_snapshots",
            "Snapshots of players' replays sent",
            m.replay_snapshots.clone(),
        );
        Metrics {
            registry: Arc::new(r),
            ..m
        }
    }

    /// Counts one player's replay by `outcome` (see [`Self::replays`]).
    pub fn replay_outcome(&self, outcome: &'static str) {
        self.replays.get_or_create(&[("outcome", outcome)]).inc();
    }

    /// Counts one refused or failed connection attempt.
    pub fn refused(&self, reason: &str) {
        self.refused_connections
            .get_or_create(&vec![("reason".to_string(), reason.to_string())])
            .inc();
    }

    /// Counts one input of `client` refused for `reason` (one of
    /// [`INPUT_REFUSAL_REASONS`]).
    pub fn input_refused(&self, client: u64, reason: &'static str) {
        self.inputs_rejected.inc();
        self.inputs_refused
            .get_or_create(&client_labels(client, reason))
            .inc();
    }

    /// Inputs of `client` refused so far for `reason` (0 for none, or a
    /// client that left).
    pub fn inputs_refused_count(&self, client: u64, reason: &'static str) -> u64 {
        self.inputs_refused
            .get(&client_labels(client, reason))
            .map_or(0, |c| c.get())
    }

    /// Counts one message of `client` refused for `reason` (one of
    /// [`MESSAGE_REFUSAL_REASONS`]).
    pub fn message_refused(&self, client: u64, reason: &'static str) {
        self.messages_refused
            .get_or_create(&client_labels(client, reason))
            .inc();
    }

    /// Messages of `client` refused so far for `reason` (0 for none, or a
    /// client that left).
    pub fn messages_refused_count(&self, client: u64, reason: &'static str) -> u64 {
        self.messages_refused
            .get(&client_labels(client, reason))
            .map_or(0, |c| c.get())
    }

    /// Counts one message the rules took, by how it came.
    pub fn message_received(&self, delivery: &'static str) {
        self.messages_received
            .get_or_create(&[("delivery", delivery)])
            .inc();
    }

    /// `client` left: its input and message series go (a server sees many
    /// clients come and go; their series must not pile up).
    pub fn forget_client(&self, client: u64) {
        for reason in INPUT_REFUSAL_REASONS {
            self.inputs_refused.remove(&client_labels(client, reason));
        }
        for reason in MESSAGE_REFUSAL_REASONS {
            self.messages_refused.remove(&client_labels(client, reason));
        }
    }

    /// Connection attempts refused so far for `reason`.
    pub fn refused_count(&self, reason: &str) -> u64 {
        self.refused_connections
            .get_or_create(&vec![("reason".to_string(), reason.to_string())])
            .get()
    }

    /// Counts one admin action with its outcome.
    pub fn admin_action(&self, action: &str, outcome: &str) {
        self.admin_actions
            .get_or_create(&admin_labels(action, outcome))
            .inc();
    }

    /// Admin actions counted so far with this action and outcome.
    pub fn admin_action_count(&self, action: &str, outcome: &str) -> u64 {
        self.admin_actions
            .get_or_create(&admin_labels(action, outcome))
            .get()
    }

    /// Counts one reload of the admin token file (`ok` or `error`).
    pub fn admin_token_reload(&self, outcome: &'static str) {
        self.admin_token_reloads
            .get_or_create(&[("outcome", outcome)])
            .inc();
    }

    /// Reloads of the admin token file counted so far with `outcome`.
    pub fn admin_token_reload_count(&self, outcome: &'static str) -> u64 {
        self.admin_token_reloads
            .get_or_create(&[("outcome", outcome)])
            .get()
    }

    /// Sets the memory held for seeking by one part (`keyframes`,
    /// `checkpoints`, `hashes` or `journal`), bytes.
    pub fn set_seek_memory(&self, part: &'static str, bytes: usize) {
        self.seek_memory
            .get_or_create(&[("part", part)])
            .set(i64::try_from(bytes).unwrap_or(i64::MAX));
    }

    /// The OpenMetrics text exposition of every metric.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        // Writing into a String cannot fail.
        let _ = encode(&mut out, &self.registry);
        out
    }

    /// The classic Prometheus text exposition (format 0.0.4) of every
    /// metric: what `promtool check metrics` and scrapers that do not ask
    /// for OpenMetrics read.
    pub fn encode_text(&self) -> String {
        openmetrics_to_text(&self.encode())
    }
}

/// Content type of [`Metrics::encode`].
pub const OPENMETRICS_CONTENT_TYPE: &str =
    "application/openmetrics-text; version=1.0.0; charset=utf-8";
/// Content type of [`Metrics::encode_text`].
pub const TEXT_CONTENT_TYPE: &str = "text/plain; version=0.0.4; charset=utf-8";

/// Rewrites an OpenMetrics exposition as Prometheus text 0.0.4. The two
/// differ where counters are named: OpenMetrics gives a counter's family
/// name (`inertia_tick_overruns`) in `# HELP` and `# TYPE` and its sample
/// as `_total`, while the text format names the sample itself in both, so
/// a text parser finds counters without help (promtool's "no help text").
/// `# UNIT` lines and the closing `# EOF` have no text-format equivalent.
fn openmetrics_to_text(open: &str) -> String {
    let mut counters = std::collections::BTreeSet::new();
    for line in open.lines() {
        if let Some(rest) = line.strip_prefix("# TYPE ") {
            if let Some(name) = rest.strip_suffix(" counter") {
                counters.insert(name.to_string());
            }
        }
    }
    let mut out = String::with_capacity(open.len());
    for line in open.lines() {
        if line == "# EOF" || line.starts_with("# UNIT ") {
            continue;
        }
        let meta = ["# HELP ", "# TYPE "]
            .iter()
            .find_map(|p| line.strip_prefix(p).map(|rest| (p, rest)));
        match meta {
            Some((prefix, rest)) => {
                let (name, tail) = rest.split_once(' ').unwrap_or((rest, ""));
                if counters.contains(name) {
                    out.push_str(&format!("{prefix}{name}_total {tail}"));
                } else {
                    out.push_str(line);
                }
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

fn admin_labels(action: &str, outcome: &str) -> Vec<(String, String)> {
    vec![
        ("action".to_string(), action.to_string()),
        ("outcome".to_string(), outcome.to_string()),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pins issue 11: `promtool check metrics` failed ("no help text") on
    /// every counter of the exposition. Runs promtool where it is
    /// installed (CI installs it; elsewhere the test says it skipped).
    #[test]
    fn issue_11_exposition_passes_promtool() {
        let metrics = Metrics::new();
        metrics.tick_overruns.inc();
        metrics.admin_action("pause", "ok");
        metrics.tick_duration.observe(0.003);
        let text = metrics.encode_text();
        let run = std::process::Command::new("promtool")
            .args(["check", "metrics"])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn();
        let mut child = match run {
            Ok(c) => c,
            Err(e) => {
                assert!(
                    std::env::var_os("CI").is_none(),
                    "promtool must be installed in CI: {e}"
                );
                eprintln!("promtool not installed ({e}); skipped");
                return;
            }
        };
        use std::io::Write;
        child
            .stdin
            .take()
            .expect("stdin")
            .write_all(text.as_bytes())
            .expect("write");
        let out = child.wait_with_output().expect("promtool runs");
        let said = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.status.success() && said.trim().is_empty(),
            "{said}\n{text}"
        );
    }
}
