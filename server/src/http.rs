//! The server's HTTP listener (default 127.0.0.1:9100), on tokio's
//! workers:
//!
//! * `GET /metrics` — the Prometheus text exposition, or OpenMetrics for a
//!   scraper that asks for it (`Accept: application/openmetrics-text`);
//! * `GET /healthz` — `200 ok` while the server works, `503` with the
//!   reason once it has failed (the tick thread stopped; see
//!   [`crate::health`]);
//! * `GET /readyz` — `200 ready` once the readiness flag is set (scene
//!   built, endpoint bound), `503 not ready` before, while draining and
//!   after a failure;
//! * the browser page's routes, `/play` and what it loads
//!   ([`crate::play`]).

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;

use crate::health::Health;
use crate::metrics::{Metrics, OPENMETRICS_CONTENT_TYPE, TEXT_CONTENT_TYPE};

#[derive(Debug, Clone)]
struct AppState {
    metrics: Metrics,
    health: Arc<Health>,
}

/// The HTTP routes: `/metrics`, `/healthz`, `/readyz`.
pub fn router(metrics: Metrics, health: Arc<Health>) -> Router {
    Router::new()
        .route("/metrics", get(metrics_handler))
        .route("/healthz", get(health_handler))
        .route("/readyz", get(ready_handler))
        .with_state(AppState { metrics, health })
}

async fn health_handler(State(s): State<AppState>) -> impl IntoResponse {
    match s.health.failure() {
        None => (StatusCode::OK, "ok\n".to_string()),
        Some(why) => (StatusCode::SERVICE_UNAVAILABLE, format!("failed: {why}\n")),
    }
}

/// OpenMetrics for scrapers that ask for it (Prometheus does), the
/// classic text format for everyone else.
async fn metrics_handler(
    State(s): State<AppState>,
    headers: axum::http::HeaderMap,
) -> impl IntoResponse {
    let wants_openmetrics = headers
        .get_all(header::ACCEPT)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .any(|v| v.contains("application/openmetrics-text"));
    if wants_openmetrics {
        (
            [(header::CONTENT_TYPE, OPENMETRICS_CONTENT_TYPE)],
            s.metrics.encode(),
        )
    } else {
        (
            [(header::CONTENT_TYPE, TEXT_CONTENT_TYPE)],
            s.metrics.encode_text(),
        )
    }
}

async fn ready_handler(State(s): State<AppState>) -> impl IntoResponse {
    if s.health.is_ready() {
        (StatusCode::OK, "ready\n")
    } else {
        (StatusCode::SERVICE_UNAVAILABLE, "not ready\n")
    }
}

/// Binds `addr` and serves the routes, and the page's
/// ([`crate::play`]), until the future is dropped. Binding happens when the
/// future is first polled; bind errors end it.
pub async fn serve(
    addr: SocketAddr,
    metrics: Metrics,
    health: Arc<Health>,
    play: crate::play::PlayConfig,
) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await?;
    serve_on(listener, metrics, health, play).await
}

/// Serves the routes, and the page's, on an already bound listener (lets a
/// caller bind port 0 and learn the port first).
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    metrics: Metrics,
    health: Arc<Health>,
    play: crate::play::PlayConfig,
) -> std::io::Result<()> {
    let app = router(metrics, health).merge(crate::play::router(play));
    axum::serve(
        listener,
        app.into_make_service_with_connect_info::<SocketAddr>(),
    )
    .await
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
        let health = Arc::new(Health::new());
        let server = tokio::spawn(serve_on(
            listener,
            metrics.clone(),
            health.clone(),
            crate::play::PlayConfig::default(),
        ));

        let (status, body) = get(addr, "/healthz").await;
        assert_eq!((status, body.trim()), (200, "ok"));
        // The page: always its HTML; no modules unless built, and no
        // session outside dev mode.
        let (status, body) = get(addr, "/play").await;
        assert_eq!(status, 200);
        assert!(body.contains("/play/play.js"), "{body}");
        let (status, body) = get(addr, "/play/play.js").await;
        assert_eq!(status, 404);
        assert!(body.contains("npm run build"), "{body}");
        assert_eq!(get(addr, "/play/session").await.0, 404);
        assert_eq!(get(addr, "/play/..%2fCargo.toml").await.0, 404);
        assert_eq!(get(addr, "/readyz").await.0, 503);
        health.set_ready(true);
        assert_eq!(get(addr, "/readyz").await.0, 200);

        metrics.tick_duration.observe(0.002);
        metrics.tick_overruns.inc();
        metrics.bodies.set(126);
        metrics.bytes_sent.inc_by(1500);
        metrics.snapshot_size.observe(900.0);
        metrics.snapshot_encode.observe(40e-6);
        metrics.malformed_datagrams.inc();
        let held = crate::replay::HeldBytes {
            keyframes: 4096,
            checkpoints: 512,
            hashes: 0,
            journal: 64,
        };
        for (part, bytes) in held.parts() {
            metrics.set_seek_memory(part, bytes);
        }
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
        assert!(!body.contains("# EOF"), "the text format by default");
        assert!(
            body.contains("# HELP inertia_tick_overruns_total "),
            "{body}"
        );

        health.fail("the tick thread stopped: boom");
        let (status, body) = get(addr, "/healthz").await;
        assert_eq!(
            (status, body.trim()),
            (503, "failed: the tick thread stopped: boom")
        );
        assert_eq!(get(addr, "/readyz").await.0, 503);
        health.set_ready(true);
        assert_eq!(get(addr, "/readyz").await.0, 503, "a failure is for good");
        server.abort();
    }
}
