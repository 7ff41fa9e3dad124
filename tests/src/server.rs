//! Starting a real server in the test process, on ephemeral loopback
//! ports, with its data directory under the system's temporary folder.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use inertia_client::dev::dev_token;
use inertia_protocol::token::ConnectToken;
use inertia_server::config::ServerConfig;
use inertia_server::server::{start, RunningServer};

static NEXT_DIR: AtomicU64 = AtomicU64::new(0);

/// The scenes shipped with the tests.
pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// A fresh, empty data directory.
pub fn temp_data_dir(what: &str) -> PathBuf {
    let n = NEXT_DIR.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("inertia-e2e-{what}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Frames a test server keeps for [`RunningServer::frame_at`].
pub const TEST_FRAME_HISTORY: usize = 600;

/// A dev-mode server's configuration on ephemeral loopback ports, with
/// `scene` (a file under `tests/scenes`, or the demo when `None`), keeping
/// the last [`TEST_FRAME_HISTORY`] frames.
pub fn test_config(scene: Option<&str>, what: &str) -> ServerConfig {
    ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        scene: scene.map(scene_path),
        data_dir: temp_data_dir(what),
        frame_history: TEST_FRAME_HISTORY,
        ..ServerConfig::default()
    }
}

/// Starts a dev-mode server with `config`.
pub async fn start_server(config: ServerConfig) -> RunningServer {
    start(config).await.expect("the test server starts")
}

/// A fresh connect token for `client_id` from `server`'s dev credentials,
/// and the address to reach it.
pub fn token(server: &RunningServer, client_id: u64) -> (SocketAddr, ConnectToken) {
    let path = server.credentials_path().expect("a dev-mode server");
    let (addr, token, _) = dev_token(path, Some(client_id)).expect("dev credentials");
    (addr, token)
}

/// A plain HTTP/1.1 GET of `path` from `addr` (the metrics and health
/// server): the status code (0 when the answer has none) and the body.
pub async fn http_get(addr: SocketAddr, path: &str) -> (u16, String) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut s = tokio::net::TcpStream::connect(addr)
        .await
        .expect("connects");
    let req = format!("GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n");
    s.write_all(req.as_bytes()).await.expect("writes");
    let mut buf = String::new();
    s.read_to_string(&mut buf).await.expect("reads");
    let status = buf
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (
        status,
        buf.split("\r\n\r\n").nth(1).unwrap_or("").to_string(),
    )
}
