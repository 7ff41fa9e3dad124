//! Secrets are reloaded without a restart: a new token key is current at
//! once while the replaced one still admits tokens minted before the
//! rotation; a new certificate serves new connections as soon as its
//! files change (the server watches them, as a mounted Kubernetes Secret
//! changes); bad files change nothing.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use inertia_protocol::credentials::to_hex;
use inertia_protocol::token::{mint, TokenKey};
use inertia_server::config::ServerConfig;
use inertia_server::secrets::WATCH_PERIOD;
use inertia_server::server::{start, RunningServer};

use crate::common::player::Player;

fn temp_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inertia-secrets-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    dir
}

/// Writes `text` to `path` the way a Secret update lands: whole, at once.
fn replace(path: &Path, text: &str) {
    let tmp = path.with_extension("new");
    std::fs::write(&tmp, text).expect("write");
    std::fs::rename(&tmp, path).expect("rename");
}

/// A fresh certificate and key in `dir`; its fingerprint.
fn certificate(dir: &Path) -> [u8; 32] {
    let certified = rcgen::generate_simple_self_signed(vec!["localhost".into()]).expect("cert");
    replace(&dir.join("cert.pem"), &certified.cert.pem());
    replace(&dir.join("key.pem"), &certified.signing_key.serialize_pem());
    inertia_protocol::token::cert_fingerprint(certified.cert.der())
}

async fn production(dir: &Path, key: [u8; 32]) -> (RunningServer, [u8; 32]) {
    let fingerprint = certificate(dir);
    replace(&dir.join("token.key"), &to_hex(&key));
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir.join("data"),
        key_file: Some(dir.join("token.key")),
        cert_file: Some(dir.join("cert.pem")),
        cert_key_file: Some(dir.join("key.pem")),
        record: false,
        ..ServerConfig::default()
    };
    (start(config).await.expect("starts"), fingerprint)
}

/// Whether a client holding a token sealed with `key`, naming the
/// certificate `fingerprint`, gets into `server`.
async fn admitted(server: &RunningServer, key: [u8; 32], fingerprint: [u8; 32], id: u64) -> bool {
    let addr = server.addr();
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_secs();
    let token = mint(
        &TokenKey::from_bytes(key),
        id,
        &addr.to_string(),
        fingerprint,
        60,
        &[],
        now,
    )
    .expect("minted");
    // The client (and its runtime) ends on the blocking pool.
    tokio::task::spawn_blocking(move || Player::join(addr, &token).is_ok())
        .await
        .expect("tried")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_rotated_token_key_admits_old_and_new_tokens() {
    let dir = temp_dir("key");
    let (old, new) = ([7u8; 32], [9u8; 32]);
    let (server, fingerprint) = production(&dir, old).await;
    let secrets = server.secrets().expect("outside dev mode");
    assert!(admitted(&server, old, fingerprint, 1).await);
    assert!(!admitted(&server, new, fingerprint, 2).await, "not yet");

    replace(&dir.join("token.key"), &to_hex(&new));
    let r = tokio::task::spawn_blocking({
        let secrets = secrets.clone();
        move || secrets.reload()
    })
    .await
    .unwrap()
    .expect("reloaded");
    // The watch may have seen the new file first (then this reload finds
    // the key current already); the certificate did not change either way.
    assert!(!r.certificate, "{r:?}");
    assert!(admitted(&server, new, fingerprint, 3).await, "the new key");
    assert!(
        admitted(&server, old, fingerprint, 4).await,
        "the old key, within its grace period"
    );
    assert!(
        !admitted(&server, [1u8; 32], fingerprint, 5).await,
        "no other key"
    );

    // A bad key file is refused and changes nothing.
    replace(&dir.join("token.key"), "not a key");
    let bad = tokio::task::spawn_blocking(move || secrets.reload())
        .await
        .unwrap();
    assert!(bad.is_err());
    assert!(admitted(&server, new, fingerprint, 6).await);
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_changed_certificate_is_served_without_a_restart_or_a_signal() {
    let dir = temp_dir("cert");
    let key = [7u8; 32];
    let (server, first) = production(&dir, key).await;
    assert!(admitted(&server, key, first, 1).await);
    let second = certificate(&dir);
    assert_ne!(first, second);
    let deadline = std::time::Instant::now() + 3 * WATCH_PERIOD + Duration::from_secs(2);
    let mut id = 2;
    while !admitted(&server, key, second, id).await {
        assert!(
            std::time::Instant::now() < deadline,
            "the new certificate was not served"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
        id += 1;
    }
    assert!(
        !admitted(&server, key, first, 100).await,
        "a client pinning the old certificate no longer gets in"
    );
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}
