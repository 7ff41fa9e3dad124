//! QUIC and TLS set-up for the game port: rustls with the ring provider,
//! TLS 1.3 only, the game's and the admin channel's ALPNs, and transport limits sized for snapshot
//! datagrams.

use std::sync::Arc;
use std::time::Duration;

use inertia_protocol::admin::ADMIN_ALPN;
use inertia_protocol::control::{ALPN, MAX_CONTROL_FRAME, WEB_TRANSPORT_ALPN};

use crate::credentials::Credentials;

/// How long a connection may stay silent before it is dropped.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(10);

/// Builds the quinn server configuration from the server's credentials.
pub fn server_config(creds: &Credentials) -> Result<quinn::ServerConfig, String> {
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let mut tls = rustls::ServerConfig::builder_with_provider(provider)
        .with_protocol_versions(&[&rustls::version::TLS13])
        .map_err(|e| e.to_string())?
        .with_no_client_auth()
        .with_single_cert(vec![creds.cert.clone()], creds.cert_key.clone_key())
        .map_err(|e| format!("certificate or key rejected: {e}"))?;
    tls.alpn_protocols = vec![
        ALPN.to_vec(),
        ADMIN_ALPN.to_vec(),
        WEB_TRANSPORT_ALPN.to_vec(),
    ];
    tls.max_early_data_size = 0;
    let crypto =
        quinn::crypto::rustls::QuicServerConfig::try_from(tls).map_err(|e| e.to_string())?;
    let mut config = quinn::ServerConfig::with_crypto(Arc::new(crypto));
    config.transport_config(Arc::new(server_transport()));
    Ok(config)
}

/// Stream data a peer may send ahead of the server reading it, bytes: one
/// largest legal control or admin frame and its length prefix.
pub const STREAM_WINDOW: u32 = MAX_CONTROL_FRAME as u32 + 4;

/// The server's transport limits: [`transport`], with only the streams the
/// protocols use and receive windows of one largest legal frame (for the
/// whole connection too). The game client and the admin tool open one
/// bidirectional control stream and no unidirectional one; a browser's
/// HTTP/3 connection needs three unidirectional streams (its control
/// stream and QPACK's two), which browsers insist on from the handshake,
/// before the protocol is known. So three are granted to every
/// connection, and on a raw QUIC connection each one opened is stopped at
/// once, unread ([`super::refuse_uni_streams`]). A browser's connection
/// is granted its second bidirectional stream once it has chosen HTTP/3
/// ([`super::web_transport`]).
pub fn server_transport() -> quinn::TransportConfig {
    let mut t = transport();
    t.max_concurrent_bidi_streams(1u32.into());
    t.max_concurrent_uni_streams(3u32.into());
    t.stream_receive_window(STREAM_WINDOW.into());
    t.receive_window(STREAM_WINDOW.into());
    t
}

/// Transport limits shared by both ends: a bounded idle time, keep-alives
/// well inside it, a few streams per connection and room for a second of
/// snapshot datagrams.
pub fn transport() -> quinn::TransportConfig {
    let mut t = quinn::TransportConfig::default();
    t.max_idle_timeout(Some(
        quinn::IdleTimeout::try_from(IDLE_TIMEOUT).expect("10 s is a valid idle timeout"),
    ));
    t.keep_alive_interval(Some(Duration::from_secs(2)));
    t.max_concurrent_bidi_streams(4u32.into());
    t.max_concurrent_uni_streams(4u32.into());
    t.datagram_receive_buffer_size(Some(1 << 20));
    t.datagram_send_buffer_size(1 << 20);
    t
}
