//! The browser's way in: a WebTransport session over HTTP/3 (ALPN `h3`) on
//! the game port. The HTTP/3 handshake and the CONNECT request are
//! web-transport-quinn's; a request for [`WEB_TRANSPORT_PATH`] becomes a
//! game connection like any other ([`super::connection::serve`]), and any
//! other path is answered 404.

use std::sync::Arc;
use std::time::Duration;

use inertia_protocol::control::WEB_TRANSPORT_PATH;
use tracing::debug;
use web_transport_quinn::http::StatusCode;

use super::link::Link;
use super::NetShared;

/// How long the HTTP/3 handshake and the CONNECT request may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// Bidirectional streams a browser may open: the CONNECT request, then the
/// game's control stream inside the session.
const BIDI_STREAMS: u32 = 2;

/// Serves one HTTP/3 connection: its WebTransport session, if it asks for
/// one at the game's path.
pub async fn serve(connection: quinn::Connection, id: u64, shared: Arc<NetShared>) {
    let remote = connection.remote_address();
    // The endpoint grants every connection one bidirectional stream (the
    // raw QUIC protocols need no more); HTTP/3 needs a second.
    connection.set_max_concurrent_bi_streams(BIDI_STREAMS.into());
    let request = match tokio::time::timeout(
        CONNECT_TIMEOUT,
        web_transport_quinn::Request::accept(connection.clone()),
    )
    .await
    {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => {
            debug!(connection = id, %remote, error = %e, "WebTransport handshake failed");
            shared.metrics.refused("web_transport_handshake");
            connection.close(0u32.into(), b"WebTransport handshake failed");
            return;
        }
        Err(_) => {
            debug!(connection = id, %remote, "WebTransport handshake timed out");
            shared.metrics.refused("handshake_timeout");
            connection.close(0u32.into(), b"no CONNECT in time");
            return;
        }
    };
    if request.url.path() != WEB_TRANSPORT_PATH {
        debug!(connection = id, %remote, path = request.url.path(), "WebTransport path not served");
        shared.metrics.refused("web_transport_path");
        let _ = request.reject(StatusCode::NOT_FOUND).await;
        return;
    }
    match request.ok().await {
        Ok(session) => {
            super::connection::serve(Link::WebTransport(Box::new(session)), id, shared).await
        }
        Err(e) => debug!(connection = id, %remote, error = %e, "WebTransport session not opened"),
    }
}
