//! Prometheus metrics and the health endpoints.
//!
//! [`Metrics`] holds one handle per metric (cheap to clone: the handles
//! share their values) and the registry they are exposed from. [`serve`]
//! answers on TCP (default 127.0.0.1:9100):
//!
//! * `GET /metrics` — the OpenMetrics text exposition;
//! * `GET /healthz` — `200 ok` while the process runs;
//! * `GET /readyz` — `200 ready` once the readiness flag is set (scene
//!   built, endpoint bound), `503 not ready` before and while draining.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;
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
    /// Datagrams dropped because they did not decode.
    pub malformed_datagrams: Counter,
    /// Inputs refused by validation (NaN, out of window, out of order).
    pub inputs_rejected: Counter,
    /// Connection attempts refused (bad token, server full, handshake error).
    pub refused_connections: Counter,
    /// Admin actions by `action` (the request, or `hello`) and `outcome`
    /// (`ok`, an error kind, or why a hello was refused).
    pub admin_actions: Family<Vec<(String, String)>, Counter>,
    /// Records the recorder could not take (its channel was full); each
    /// one stops the recording, since a recording with a gap cannot be
    /// replayed.
    pub record_dropped: Counter,
    /// Memory held for seeking by `part`: `keyframes` and `checkpoints`
    /// (within `--seek-memory-mb`), `hashes` and `journal` (every recorded
    /// tick's, outside it), bytes.
    pub seek_memory: Family<[(&'static str, &'static str); 1], Gauge>,
    registry: Arc<Registry>,
}

impl Default for Metrics {
    fn default() -> Self {
        Self::new()
    }
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
            malformed_datagrams: Counter::default(),
            inputs_rejected: Counter::default(),
            refused_connections: Counter::default(),
            admin_actions: Family::default(),
            record_dropped: Counter::default(),
            seek_memory: Family::default(),
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
            "malformed_datagrams_dropped",
            "Datagrams dropped because they did not decode",
            m.malformed_datagrams.clone(),
        );
        r.register(
            "inputs_rejected",
            "Player inputs refused by validation",
            m.inputs_rejected.clone(),
        );
        r.register(
            "refused_connections",
            "Connection attempts refused (bad token, full, failed handshake)",
            m.refused_connections.clone(),
        );
        r.register(
            "admin_actions",
            "Admin channel actions by action and outcome, refused hellos included",
            m.admin_actions.clone(),
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
        Metrics {
            registry: Arc::new(r),
            ..m
        }
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

    /// Sets the memory held for seeking, by part.
    pub fn set_seek_memory(&self, held: &crate::replay::HeldBytes) {
        for (part, bytes) in [
            ("keyframes", held.keyframes),
            ("checkpoints", held.checkpoints),
            ("hashes", held.hashes),
            ("journal", held.journal),
        ] {
            self.seek_memory
                .get_or_create(&[("part", part)])
                .set(i64::try_from(bytes).unwrap_or(i64::MAX));
        }
    }

    /// The OpenMetrics text exposition of every metric.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        // Writing into a String cannot fail.
        let _ = encode(&mut out, &self.registry);
        out
    }
}

fn admin_labels(action: &str, outcome: &str) -> Vec<(String, String)> {
    vec![
        ("action".to_string(), action.to_string()),
        ("outcome".to_string(), outcome.to_string()),
    ]
}

#[derive(Debug, Clone)]
struct AppState {
    metrics: Metrics,
    ready: Arc<AtomicBool>,
}

/// The HTTP routes: `/metrics`, `/healthz`, `/readyz`.
pub fn router(metrics: Metrics, ready: Arc<AtomicBool>) -> Router {
    Router::new()
        .route("/metrics", get(metrics_handler))
        .route("/healthz", get(|| async { "ok\n" }))
        .route("/readyz", get(ready_handler))
        .with_state(AppState { metrics, ready })
}

async fn metrics_handler(State(s): State<AppState>) -> impl IntoResponse {
    (
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        s.metrics.encode(),
    )
}

async fn ready_handler(State(s): State<AppState>) -> impl IntoResponse {
    if s.ready.load(Ordering::Acquire) {
        (StatusCode::OK, "ready\n")
    } else {
        (StatusCode::SERVICE_UNAVAILABLE, "not ready\n")
    }
}

/// Binds `addr` and serves the routes until the future is dropped. Binding
/// happens when the future is first polled; bind errors end it.
pub async fn serve(
    addr: SocketAddr,
    metrics: Metrics,
    ready: Arc<AtomicBool>,
) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await?;
    serve_on(listener, metrics, ready).await
}

/// Serves the routes on an already bound listener (lets a caller bind port
/// 0 and learn the port first).
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    metrics: Metrics,
    ready: Arc<AtomicBool>,
) -> std::io::Result<()> {
    axum::serve(listener, router(metrics, ready)).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    async fn get(addr: SocketAddr, path: &str) -> (u16, String) {
        let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
        let req = format!("GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n");
        s.write_all(req.as_bytes()).await.unwrap();
        let mut buf = String::new();
        s.read_to_string(&mut buf).await.unwrap();
        let status = buf
            .split_whitespace()
            .nth(1)
            .and_then(|c| c.parse().ok())
            .unwrap_or(0);
        let body = buf.split("\r\n\r\n").nth(1).unwrap_or("").to_string();
        (status, body)
    }

    #[tokio::test]
    async fn endpoints_answer_on_an_ephemeral_port() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let metrics = Metrics::new();
        let ready = Arc::new(AtomicBool::new(false));
        let server = tokio::spawn(serve_on(listener, metrics.clone(), ready.clone()));

        let (status, body) = get(addr, "/healthz").await;
        assert_eq!((status, body.trim()), (200, "ok"));
        assert_eq!(get(addr, "/readyz").await.0, 503);
        ready.store(true, Ordering::Release);
        assert_eq!(get(addr, "/readyz").await.0, 200);

        metrics.tick_duration.observe(0.002);
        metrics.tick_overruns.inc();
        metrics.bodies.set(126);
        metrics.bytes_sent.inc_by(1500);
        metrics.snapshot_size.observe(900.0);
        metrics.snapshot_encode.observe(40e-6);
        metrics.malformed_datagrams.inc();
        metrics.set_seek_memory(&crate::replay::HeldBytes {
            keyframes: 4096,
            checkpoints: 512,
            hashes: 0,
            journal: 64,
        });
        let (status, body) = get(addr, "/metrics").await;
        assert_eq!(status, 200);
        for needle in [
            "inertia_tick_duration_seconds_count 1",
            "inertia_tick_overruns_total 1",
            "inertia_bodies 126",
            "inertia_connected_clients 0",
            "inertia_sent_bytes_total 1500",
            "inertia_received_bytes_total 0",
            "inertia_sent_packets_total 0",
            "inertia_received_packets_total 0",
            "inertia_snapshot_size_bytes_count 1",
            "inertia_snapshot_encode_seconds_count 1",
            "inertia_malformed_datagrams_dropped_total 1",
            "inertia_seek_memory_bytes{part=\"keyframes\"} 4096",
            "inertia_seek_memory_bytes{part=\"checkpoints\"} 512",
            "inertia_seek_memory_bytes{part=\"journal\"} 64",
        ] {
            assert!(body.contains(needle), "missing {needle} in\n{body}");
        }
        assert_eq!(get(addr, "/nope").await.0, 404);
        server.abort();
    }
}
