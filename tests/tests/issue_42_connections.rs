//! Issue 42, the server tried as an attacker would:
//!
//! - a client that opened its control stream and ended it (or reset it)
//!   before a whole hello was neither refused nor closed: the server's
//!   keep-alives held it open for as long as the peer answered (200 such
//!   connections were all still open after 20 s). Such a connection can
//!   never complete its hello, and is closed at once;
//! - `/play/session` handed a fresh connect token to any loopback peer,
//!   whatever the `Host` header: a page of another origin could reach it
//!   through DNS rebinding. A request that does not name this server is
//!   refused.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use inertia_protocol::control::{close_code, encode_frame, ClientControl, PROTOCOL_VERSION};
use inertia_tests::raw::{endpoint, game_config};
use inertia_tests::server::{start_server, test_config, token};

/// How many hostile connections each case opens.
const CONNECTIONS: usize = 40;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_42_a_control_stream_ended_before_the_hello_is_closed_at_once() {
    let server = start_server(test_config(None, "issue42-ended")).await;
    let addr = server.addr();
    let before = server.metrics().refused_count("stream_ended_before_hello");
    let (_, t) = token(&server, 42);
    let hello = encode_frame(&ClientControl::Hello {
        version: PROTOCOL_VERSION,
        token: t.to_bytes(),
    })
    .expect("encodes");
    let client = endpoint(game_config(&server));
    let started = Instant::now();
    let mut tasks = tokio::task::JoinSet::new();
    for i in 0..CONNECTIONS {
        let client = client.clone();
        // Nothing, part of a hello, all of it but its last byte; ended
        // with a FIN or a reset.
        let sent = match i % 3 {
            0 => 0,
            1 => 7,
            _ => hello.len() - 1,
        };
        let bytes = hello[..sent].to_vec();
        let reset = i % 2 == 1;
        tasks.spawn(async move {
            let connection = client
                .connect(addr, "localhost")
                .expect("connects")
                .await
                .expect("the QUIC handshake");
            let (mut send, _recv) = connection.open_bi().await.expect("a stream");
            // With nothing written, the FIN or the reset alone opens the
            // stream at the server.
            send.write_all(&bytes).await.expect("writes");
            if reset {
                let _ = send.reset(9u32.into());
            } else {
                let _ = send.finish();
            }
            let closed = tokio::time::timeout(Duration::from_secs(3), connection.closed()).await;
            (i, closed.ok())
        });
    }
    let mut closed = 0;
    while let Some(done) = tasks.join_next().await {
        let (i, reason) = done.expect("ran");
        match reason {
            Some(quinn::ConnectionError::ApplicationClosed(close)) => {
                assert_eq!(
                    close.error_code,
                    close_code::REFUSED.into(),
                    "connection {i}"
                );
                closed += 1;
            }
            other => panic!("connection {i} was not closed by the server in 3 s: {other:?}"),
        }
    }
    let took = started.elapsed();
    let counted = server.metrics().refused_count("stream_ended_before_hello") - before;
    eprintln!(
        "{closed} connections ended before their hello, all closed in {took:?}; counted {counted}"
    );
    assert!(
        took < inertia_server::net::connection::HELLO_TIMEOUT,
        "closed at once, not at the hello timeout: {took:?}"
    );
    assert_eq!(
        counted as usize, CONNECTIONS,
        "each counted under its reason"
    );
    assert_eq!(server.clients(), 0);
    client.close(0u32.into(), b"done");
    server.shutdown().await;
}

/// A GET of `/play/session` with `headers`: the status code.
async fn session_status(addr: SocketAddr, headers: &str) -> u16 {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut s = tokio::net::TcpStream::connect(addr)
        .await
        .expect("connects");
    let req = format!("GET /play/session HTTP/1.1\r\n{headers}Connection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("writes");
    let mut buf = String::new();
    s.read_to_string(&mut buf).await.expect("reads");
    buf.split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_42_play_session_goes_only_to_requests_that_name_this_server() {
    let server = start_server(test_config(None, "issue42-rebinding")).await;
    let addr = server.metrics_addr();
    let port = addr.port();
    for (headers, expected) in [
        (format!("Host: 127.0.0.1:{port}\r\n"), 200),
        (format!("Host: localhost:{port}\r\n"), 200),
        (
            format!("Host: localhost:{port}\r\nOrigin: http://localhost:{port}\r\n"),
            200,
        ),
        // DNS rebinding: the attacker's name, resolved to loopback.
        (format!("Host: rebind.evil.example:{port}\r\n"), 403),
        ("Host: rebind.evil.example\r\n".to_string(), 403),
        (
            format!("Host: 127.0.0.1:{port}\r\nOrigin: http://evil.example\r\n"),
            403,
        ),
        (format!("Host: 127.0.0.1:{}\r\n", port.wrapping_add(1)), 403),
        // HTTP/1.1 without a host at all.
        (String::new(), 403),
    ] {
        let status = session_status(addr, &headers).await;
        if expected == 200 {
            assert_eq!(status, 200, "{headers:?}");
        } else {
            // Refused, by the page (403) or by HTTP itself (400).
            assert!(status == 403 || status == 400, "{headers:?}: {status}");
        }
    }
    server.shutdown().await;
}
