//! A browser's way in, acted by a WebTransport client in the test: the
//! page's session from `/play/session` (a dev server's, to a loopback
//! peer), then on the game port HTTP/3 (ALPN `h3`) beside raw QUIC: a
//! session at `/inertia` with the dev certificate pinned by its hash (as a
//! browser's `serverCertificateHashes` pins it) joins like any client with
//! the session's token, and snapshots and inputs travel as the session's
//! datagrams.

use inertia_protocol::input::GameInput;
use std::time::Duration;

use inertia_protocol::client_session::{ClientConfig, ClientSession};
use inertia_protocol::control::{
    encode_frame, ClientControl, FrameDecoder, ServerControl, PROTOCOL_VERSION, WEB_TRANSPORT_PATH,
};
use inertia_protocol::credentials::DevCredentials;
use inertia_protocol::MAX_REDUNDANT_INPUTS;
use inertia_tests::server::{http_get, start_server, test_config};

fn url(port: u16, path: &str) -> url::Url {
    format!("https://127.0.0.1:{port}{path}")
        .parse()
        .expect("a URL")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_15_a_web_transport_session_joins_on_the_game_port_and_gets_snapshots() {
    let server = start_server(test_config(None, "web-transport")).await;
    let path = server.credentials_path().expect("dev mode");
    let creds: DevCredentials =
        serde_json::from_slice(&std::fs::read(path).expect("written")).expect("JSON");
    let (status, body) = http_get(server.metrics_addr(), "/play/session").await;
    assert_eq!(status, 200, "{body}");
    let session: serde_json::Value = serde_json::from_str(&body).expect("JSON");
    let field = |name: &str| session[name].as_str().expect(name).to_string();
    assert_eq!(
        field("cert_hash"),
        creds.cert_fingerprint,
        "the certificate to pin"
    );
    let hash = creds.fingerprint().expect("a SHA-256");
    let addr = server.addr();
    assert_eq!(
        field("url"),
        format!("https://127.0.0.1:{}{WEB_TRANSPORT_PATH}", addr.port())
    );
    let token = hex::decode(field("token")).expect("hex");
    let session_client = session["client_id"].as_u64().expect("a client id");
    assert!(session_client < 1 << 53, "a JavaScript number holds it");
    let client = web_transport_quinn::ClientBuilder::new()
        .with_server_certificate_hashes(vec![hash.to_vec()])
        .expect("a client");

    // Another path is not the game's.
    let refused = client.connect(url(addr.port(), "/elsewhere")).await;
    assert!(refused.is_err(), "a session at /elsewhere was opened");

    let session = tokio::time::timeout(
        Duration::from_secs(10),
        client.connect(url(addr.port(), WEB_TRANSPORT_PATH)),
    )
    .await
    .expect("in time")
    .expect("the session opens");
    let (mut send, mut recv) = session.open_bi().await.expect("a control stream");
    let hello = ClientControl::Hello {
        version: PROTOCOL_VERSION,
        token,
    };
    send.write_all(&encode_frame(&hello).expect("encodes"))
        .await
        .expect("sent");
    let mut frames = FrameDecoder::new();
    let mut buf = [0u8; 4096];
    let welcome = loop {
        if let Some(msg) = frames.next::<ServerControl>() {
            break msg.expect("a valid message");
        }
        let n = tokio::time::timeout(Duration::from_secs(10), recv.read(&mut buf))
            .await
            .expect("in time")
            .expect("reads")
            .expect("open");
        frames.push(&buf[..n]).expect("framed");
    };
    let ServerControl::Welcome {
        client_id,
        tick,
        tick_hz,
        position_resolution,
        position_bound,
        snapshot,
        properties,
        ..
    } = welcome
    else {
        panic!("expected a welcome, got {welcome:?}");
    };
    assert_eq!(client_id, session_client);
    let mut game = ClientSession::new(
        ClientConfig {
            snapshot: snapshot.config(position_resolution, position_bound),
            input_hz: tick_hz,
            input_redundancy: MAX_REDUNDANT_INPUTS,
            properties: std::sync::Arc::new(properties),
        },
        tick,
    )
    .expect("a session");

    // Snapshots arrive as the session's datagrams and decode; inputs go
    // back the same way (they carry the acknowledgements that let the
    // server send deltas).
    let mut decoded = 0;
    let mut largest_view = 0;
    let start = std::time::Instant::now();
    while decoded < 60 {
        let bytes = tokio::time::timeout(Duration::from_secs(5), session.read_datagram())
            .await
            .expect("a snapshot in time")
            .expect("the session lives");
        let snap = game.on_datagram(&bytes).expect("a snapshot that decodes");
        let (newest, sequence, snap_tick) = (snap.newest, snap.sequence, snap.tick);
        if newest {
            let view = game.decoder().entities(sequence).map_or(0, |e| e.len());
            largest_view = largest_view.max(view);
        }
        decoded += 1;
        game.set_input(
            inertia_sandbox::SandboxInput {
                movement: [1.0, 0.0],
                yaw: 0.0,
                buttons: 0,
            }
            .to_payload(),
        );
        let now = start.elapsed().as_secs_f64();
        if let Some(input) = game.poll_input(now, Some(snap_tick)) {
            session.send_datagram(input.into()).expect("sent");
        }
    }
    assert!(
        largest_view > 100,
        "the demo's bodies: {largest_view} in view"
    );
    assert_eq!(server.clients(), 1);

    send.write_all(&encode_frame(&ClientControl::Goodbye).expect("encodes"))
        .await
        .expect("sent");
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while server.clients() > 0 && std::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert_eq!(server.clients(), 0, "the goodbye ended the session");
    server.shutdown().await;
}
