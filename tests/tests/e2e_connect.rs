//! Joining and leaving a real server: good and bad tokens, protocol
//! versions, reconnecting, and datagrams that do not decode.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use inertia_client::{Client, ClientError, ConnectOptions};
use inertia_protocol::control::{Refusal, TokenRefusal};
use inertia_protocol::credentials::DevCredentials;
use inertia_protocol::token::{mint, ConnectToken, TokenKey};
use inertia_server::server::RunningServer;
use inertia_tests::server::{start_server, test_config, token};

fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .expect("after 1970")
        .as_secs()
}

fn dev_credentials(server: &RunningServer) -> DevCredentials {
    let path = server.credentials_path().expect("dev mode");
    serde_json::from_slice(&std::fs::read(path).expect("credentials file")).expect("valid JSON")
}

/// A token minted with the server's key but any address, lifetime and
/// minting time.
fn custom_token(server: &RunningServer, addr: &str, ttl: u64, minted_at: u64) -> ConnectToken {
    let creds = dev_credentials(server);
    let key = TokenKey::from_bytes(creds.token_key_bytes().expect("key"));
    mint(
        &key,
        99,
        addr,
        creds.fingerprint().expect("fingerprint"),
        ttl,
        b"",
        minted_at,
    )
    .expect("mints")
}

async fn refusal(server: &RunningServer, token: &ConnectToken) -> Refusal {
    match Client::connect(server.addr(), token).await {
        Err(ClientError::Refused(r)) => r,
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_tokens_and_versions_are_refused_with_a_reason() {
    let server = start_server(test_config(Some("moving.ron"), "tokens")).await;
    let addr = server.addr().to_string();

    let expired = custom_token(&server, &addr, 60, unix_now() - 3600);
    assert!(matches!(
        refusal(&server, &expired).await,
        Refusal::Token(TokenRefusal::Expired { .. })
    ));

    let mut forged = custom_token(&server, &addr, 600, unix_now());
    forged.sealed[3] ^= 0x40;
    assert_eq!(
        refusal(&server, &forged).await,
        Refusal::Token(TokenRefusal::Forged)
    );

    let elsewhere = custom_token(&server, "127.0.0.1:1", 600, unix_now());
    assert!(matches!(
        refusal(&server, &elsewhere).await,
        Refusal::Token(TokenRefusal::WrongServer { .. })
    ));

    let (_, good) = token(&server, 5);
    let options = ConnectOptions {
        protocol_version: 999,
        ..ConnectOptions::default()
    };
    match Client::connect_with(server.addr(), &good, options).await {
        Err(ClientError::VersionMismatch { server: s, client }) => {
            assert_eq!(client, 999);
            assert_eq!(s, inertia_protocol::PROTOCOL_VERSION);
        }
        other => panic!("expected a version mismatch, got {other:?}"),
    }

    // The good token still works (the refused hello did not use it up),
    // but only on one connection.
    let client = Client::connect(server.addr(), &good).await.expect("joins");
    assert!(matches!(
        refusal(&server, &good).await,
        Refusal::Token(TokenRefusal::Reused)
    ));
    // Each refusal is counted under its real reason.
    let m = server.metrics();
    for reason in [
        "token_expired",
        "token_forged",
        "token_wrong_server",
        "version_mismatch",
        "token_reused",
    ] {
        assert!(m.refused_count(reason) >= 1, "{reason}");
    }
    client.close().await;
    server.shutdown().await;
}

async fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    for _ in 0..300 {
        if done() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("timed out waiting for {what}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn clients_leave_and_come_back() {
    let server = start_server(test_config(Some("moving.ron"), "reconnect")).await;
    let (addr, first) = token(&server, 11);
    let client = Client::connect(addr, &first).await.expect("joins");
    wait_for("the avatar", || {
        server.frame().catalog.values().any(|e| e.owner == Some(11))
    })
    .await;
    client.close().await;
    wait_for("the client to leave", || {
        server.clients() == 0 && server.frame().catalog.values().all(|e| e.owner != Some(11))
    })
    .await;

    // Back with a fresh token: the same id joins again and is served.
    let (_, second) = token(&server, 11);
    let client = Client::connect(addr, &second).await.expect("joins again");
    wait_for("snapshots", || client.stats().snapshots_received > 10).await;
    assert_eq!(server.clients(), 1);
    assert!(client.disconnected().is_none());
    client.close().await;
    server.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_datagrams_are_dropped_and_counted_and_the_connection_lives() {
    let server = start_server(test_config(Some("moving.ron"), "malformed")).await;
    let (addr, token) = token(&server, 21);
    let client = Client::connect(addr, &token).await.expect("joins");
    wait_for("snapshots", || client.stats().snapshots_received > 5).await;
    let before = server.metrics().malformed_datagrams.get();
    let mut bad: Vec<Vec<u8>> = vec![
        vec![],
        vec![0x49],
        vec![0x49, 0xff, 0xff, 0xff],
        vec![0x53; 40],
        vec![0xff; 1100],
        b"GET / HTTP/1.1\r\n\r\n".to_vec(),
    ];
    let mut x = 0x1234_5678u32;
    for len in [3usize, 17, 64, 300, 900] {
        bad.push(
            (0..len)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    (x >> 24) as u8
                })
                .collect(),
        );
    }
    let sent = bad.len() as u64;
    for bytes in bad {
        client.send_raw_datagram(bytes).expect("fits a datagram");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    wait_for("the server to count them", || {
        server.metrics().malformed_datagrams.get() >= before + sent
    })
    .await;
    let received = client.stats().snapshots_received;
    wait_for("more snapshots", || {
        client.stats().snapshots_received > received + 10
    })
    .await;
    assert!(client.disconnected().is_none());
    assert_eq!(server.clients(), 1);
    client.close().await;
    server.shutdown().await;
}

/// A client may send fewer redundant inputs per datagram than the eight
/// it sends by default: the server then receives smaller datagrams.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn input_redundancy_is_configurable() {
    let server = start_server(test_config(None, "redundancy")).await;
    let mut per_datagram = Vec::new();
    for (id, redundancy) in [(1u64, 8usize), (2, 1)] {
        let (addr, good) = token(&server, id);
        let options = ConnectOptions {
            input_redundancy: Some(redundancy),
            ..ConnectOptions::default()
        };
        let m = server.metrics();
        let (bytes, packets) = (m.bytes_received.get(), m.packets_received.get());
        let client = Client::connect_with(addr, &good, options)
            .await
            .expect("joins");
        // No input is made before the game sets one.
        client
            .set_input([0.0, 0.0], 0.0, 0)
            .expect("the sandbox's input");
        tokio::time::sleep(Duration::from_millis(1000)).await;
        client.close().await;
        let (bytes, packets) = (
            m.bytes_received.get() - bytes,
            m.packets_received.get() - packets,
        );
        assert!(packets > 20, "{packets} datagrams in a second");
        per_datagram.push(bytes as f64 / packets as f64);
    }
    // Eight inputs against one. The stick stands still, so each of the
    // seven repeats costs 11 bits (two step bits, the same-payload bit, a
    // one-group view), not its 5-byte payload again (measured: about 24.5
    // bytes against 14.9, with the acks and the length counted).
    let repeats = per_datagram[0] - per_datagram[1];
    assert!(
        (7.0..20.0).contains(&repeats),
        "bytes per datagram: {per_datagram:?}"
    );
    server.shutdown().await;
}
