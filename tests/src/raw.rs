//! Game connections made by hand on a test server's port: a QUIC client
//! endpoint pinned to the server's certificate, a hello with a fresh dev
//! token, and reading the control stream, for tests of what the server
//! does with clients that do not behave like the SDK.

use std::time::{Duration, Instant};

use inertia_admin_client::read_credentials;
use inertia_protocol::control::{
    encode_frame, ClientControl, FrameDecoder, ServerControl, PROTOCOL_VERSION,
};
use inertia_server::server::RunningServer;

use crate::server::token;

/// The SHA-256 fingerprint of a dev-mode server's certificate.
pub fn fingerprint(server: &RunningServer) -> [u8; 32] {
    read_credentials(server.credentials_path().expect("dev mode"))
        .expect("dev credentials")
        .fingerprint()
        .expect("fingerprint")
}

/// A client endpoint on loopback with `config`.
pub fn endpoint(config: quinn::ClientConfig) -> quinn::Endpoint {
    let mut e = quinn::Endpoint::client("127.0.0.1:0".parse().expect("literal")).expect("binds");
    e.set_default_client_config(config);
    e
}

/// The game's client configuration, pinned to the server.
pub fn game_config(server: &RunningServer) -> quinn::ClientConfig {
    inertia_tls::client_config(fingerprint(server)).expect("TLS")
}

/// The next control message on `recv`, or `None` when the stream ends or
/// what comes does not decode.
pub async fn read_control(
    recv: &mut quinn::RecvStream,
    frames: &mut FrameDecoder,
) -> Option<ServerControl> {
    let mut buf = [0u8; 2048];
    loop {
        if let Some(msg) = frames.next::<ServerControl>() {
            return msg.ok();
        }
        match recv.read(&mut buf).await {
            Ok(Some(n)) => frames.push(&buf[..n]).ok()?,
            _ => return None,
        }
    }
}

/// A game connection past its hello, made by hand: the QUIC connection,
/// its control stream, and the decoder that read the welcome (it may hold
/// the start of what came after).
pub async fn joined(
    endpoint: &quinn::Endpoint,
    server: &RunningServer,
    client: u64,
) -> (
    quinn::Connection,
    quinn::SendStream,
    quinn::RecvStream,
    FrameDecoder,
) {
    let (addr, t) = token(server, client);
    let connection = endpoint
        .connect(addr, "localhost")
        .expect("connects")
        .await
        .expect("the QUIC handshake");
    let (mut send, mut recv) = connection.open_bi().await.expect("the control stream");
    let hello = encode_frame(&ClientControl::Hello {
        version: PROTOCOL_VERSION,
        token: t.to_bytes(),
    })
    .expect("encodes");
    send.write_all(&hello).await.expect("hello sent");
    let mut frames = FrameDecoder::new();
    match tokio::time::timeout(
        Duration::from_secs(10),
        read_control(&mut recv, &mut frames),
    )
    .await
    {
        Ok(Some(ServerControl::Welcome { client_id, .. })) => assert_eq!(client_id, client),
        other => panic!("expected a welcome, got {other:?}"),
    }
    (connection, send, recv, frames)
}

/// Whether `client` owns an entity (its avatar) in the server's world.
pub fn owns_an_avatar(server: &RunningServer, client: u64) -> bool {
    server
        .frame()
        .catalog
        .values()
        .any(|e| e.owner == Some(client))
}

/// Waits up to `limit` for the server to close `connection`; how long it
/// took.
pub async fn closed_within(connection: &quinn::Connection, limit: Duration) -> Option<Duration> {
    let start = Instant::now();
    tokio::time::timeout(limit, connection.closed())
        .await
        .ok()
        .map(|_| start.elapsed())
}

/// Waits up to `limit` for `client`'s avatar to leave the world.
pub async fn avatar_gone(server: &RunningServer, client: u64, limit: Duration) -> bool {
    let deadline = Instant::now() + limit;
    while owns_an_avatar(server, client) {
        if Instant::now() >= deadline {
            return false;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    true
}
