//! Issue 12: a joined client that sent nothing but QUIC keep-alives held
//! its slot, its avatar and a full snapshot (no baseline) every slot, for
//! as long as it liked. A client that sends no datagram (acknowledgements
//! and inputs, which the SDK sends at its input rate) for
//! the silent timeout is let go with a goodbye that says why (a goodbye
//! for a protocol error used to be dropped by the close right behind it).

use std::time::Duration;

use inertia_protocol::connection::ServerConnectionConfig;
use inertia_protocol::control::{close_code, DisconnectReason, ServerControl};
use inertia_tests::raw::{
    avatar_gone, endpoint, game_config, joined, owns_an_avatar, read_control,
};
use inertia_tests::server::{start_server, test_config};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_12_a_silent_client_is_let_go_and_its_avatar_leaves() {
    // The silence shortened from its 10 s: the deadline itself is pinned
    // on a virtual clock (protocol/tests/connection.rs); this test pins
    // that the server feeds it.
    let silence = Duration::from_secs(1);
    let config = inertia_server::config::ServerConfig {
        connection: ServerConnectionConfig {
            silence,
            ..ServerConnectionConfig::default()
        },
        ..test_config(None, "issue12-silent")
    };
    let server = start_server(config).await;
    let client = endpoint(game_config(&server));
    let (connection, _send, mut recv, mut frames) = joined(&client, &server, 77).await;
    // The avatar is in the first frame published after the join, which
    // may come a tick after the welcome.
    let deadline = std::time::Instant::now() + Duration::from_secs(2);
    while !owns_an_avatar(&server, 77) && std::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(owns_an_avatar(&server, 77), "joined with an avatar");

    // Read the control stream (the catalog, then the goodbye) but send
    // no datagram: QUIC keeps the connection alive on its own.
    let reader = tokio::spawn(async move {
        while let Some(msg) = read_control(&mut recv, &mut frames).await {
            if let ServerControl::Goodbye(reason) = msg {
                return Some(reason);
            }
        }
        None
    });
    let said = tokio::time::timeout(silence + Duration::from_secs(5), reader)
        .await
        .expect("let go within the silent timeout and a margin")
        .expect("the reader ran");
    match said {
        Some(DisconnectReason::ProtocolError { what }) => {
            assert!(what.starts_with("silent"), "{what}");
        }
        other => panic!("expected a goodbye saying it was silent, got {other:?}"),
    }
    let closed = tokio::time::timeout(Duration::from_secs(5), connection.closed())
        .await
        .expect("closed");
    match closed {
        quinn::ConnectionError::ApplicationClosed(close) => {
            assert_eq!(close.error_code, close_code::PROTOCOL.into());
        }
        other => panic!("expected the server's close, got {other:?}"),
    }
    assert!(
        avatar_gone(&server, 77, Duration::from_secs(3)).await,
        "the silent client's avatar left the world"
    );
    server.shutdown().await;
}
