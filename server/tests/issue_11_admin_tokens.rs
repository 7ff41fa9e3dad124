//! Issue 11: the admin channel outside dev mode. Operators come from
//! `--admin-token-file`, each admitted with their own token only and
//! audited under their own name; the file is reloaded (a bad file keeps
//! the operators in use, and SIGHUP reloads a running process); and an
//! address that keeps sending wrong credentials is refused at once for a
//! back-off, while other addresses are not.

#![cfg(unix)]

use crate::common;

use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use common::wait_for;
use inertia_admin_client::{AdminClient, AdminClientError};
use inertia_protocol::admin::{AdminRefusal, AdminRequest, AdminResponse};
use inertia_protocol::credentials::to_hex;
use inertia_server::admin::tokens::{LineProblem, TokenFileError};
use inertia_server::config::ServerConfig;
use inertia_server::server::{RunningServer, StartError};

const ALICE: &str = "alice-0123456789abcdefghijklmnopqrstuvwxyz";
const BOB: &str = "bob-0123456789abcdefghijklmnopqrstuvwxyz01";
const CAROL: &str = "carol-0123456789abcdefghijklmnopqrstuvwxyz";

/// Everything the `inertia::admin` target logs in this test process.
static LOG: Mutex<Vec<u8>> = Mutex::new(Vec::new());

struct Capture;

impl Write for Capture {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        LOG.lock()
            .unwrap_or_else(|e| e.into_inner())
            .extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn capture_logs() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        let _ = tracing_subscriber::fmt()
            .with_env_filter("inertia::admin=info")
            .with_ansi(false)
            .with_writer(|| Capture)
            .try_init();
    });
}

fn logged() -> String {
    String::from_utf8_lossy(&LOG.lock().unwrap_or_else(|e| e.into_inner())).into_owned()
}

/// A fresh directory for one test.
fn temp_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inertia-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("the test directory");
    dir
}

/// Writes `text` to `path` as an operator would: a new file, mode 0600,
/// renamed over the old one.
fn write_private(path: &Path, text: &str) {
    use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
    let tmp = path.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(&tmp)
        .expect("create");
    f.write_all(text.as_bytes()).expect("write");
    drop(f);
    std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(0o600)).expect("chmod");
    std::fs::rename(&tmp, path).expect("rename");
}

/// Production credentials in `dir`: a token key, a certificate and its
/// key; the certificate's fingerprint.
fn production_files(dir: &Path) -> [u8; 32] {
    let certified = rcgen::generate_simple_self_signed(vec!["localhost".into()]).expect("cert");
    std::fs::write(dir.join("cert.pem"), certified.cert.pem()).expect("cert");
    write_private(&dir.join("key.pem"), &certified.signing_key.serialize_pem());
    write_private(&dir.join("token.key"), &to_hex(&[7u8; 32]));
    inertia_protocol::token::cert_fingerprint(certified.cert.der())
}

fn production_config(dir: &Path, tokens: Option<PathBuf>) -> ServerConfig {
    ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        scene: Some(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/pyramid.json")),
        data_dir: dir.join("data"),
        key_file: Some(dir.join("token.key")),
        cert_file: Some(dir.join("cert.pem")),
        cert_key_file: Some(dir.join("key.pem")),
        admin_token_file: tokens,
        record: false,
        ..ServerConfig::default()
    }
}

/// A server outside dev mode whose admin token file holds `tokens`.
struct Production {
    server: RunningServer,
    fingerprint: [u8; 32],
    tokens: PathBuf,
    dir: PathBuf,
}

impl Production {
    async fn start(what: &str, tokens: &str) -> Production {
        capture_logs();
        let dir = temp_dir(what);
        let fingerprint = production_files(&dir);
        let path = dir.join("admin-tokens");
        write_private(&path, tokens);
        let server = inertia_server::server::start(production_config(&dir, Some(path.clone())))
            .await
            .expect("the server starts");
        assert!(server.credentials_path().is_none(), "not dev mode");
        assert_eq!(server.admin_token(), "", "no dev token");
        Production {
            server,
            fingerprint,
            tokens: path,
            dir,
        }
    }

    async fn admin(&self, operator: &str, token: &str) -> Result<AdminClient, AdminClientError> {
        AdminClient::connect(self.server.addr(), self.fingerprint, token, operator).await
    }

    async fn admin_from(
        &self,
        local: &str,
        operator: &str,
        token: &str,
    ) -> Result<AdminClient, AdminClientError> {
        let local: SocketAddr = local.parse().expect("an address");
        AdminClient::connect_from(local, self.server.addr(), self.fingerprint, token, operator)
            .await
    }

    async fn stop(self) {
        self.server.shutdown().await;
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

async fn admitted(client: Result<AdminClient, AdminClientError>, what: &str) -> AdminClient {
    let mut client = client.unwrap_or_else(|e| panic!("{what}: not admitted: {e}"));
    match client.call(AdminRequest::Status).await {
        Ok(AdminResponse::Status(_)) => client,
        other => panic!("{what}: status answered {other:?}"),
    }
}

fn refusal(client: Result<AdminClient, AdminClientError>, what: &str) -> AdminRefusal {
    match client {
        Err(AdminClientError::Refused(r)) => r,
        Err(e) => panic!("{what}: failed otherwise: {e}"),
        Ok(_) => panic!("{what}: admitted"),
    }
}

/// The audit lines saying `operator` was admitted.
fn admissions_of(operator: &str) -> usize {
    let needle = format!("operator={operator} ");
    logged()
        .lines()
        .filter(|l| l.contains("admin hello accepted") && l.contains(&needle))
        .count()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_operators_are_admitted_with_their_own_tokens_and_audited_by_name() {
    let p = Production::start(
        "issue11-operators",
        &format!("# operators\nalice-ops {ALICE}\n\nbob-ops\t{BOB}\n"),
    )
    .await;
    let alice = admitted(p.admin("alice-ops", ALICE).await, "alice").await;
    let bob = admitted(p.admin("bob-ops", BOB).await, "bob").await;
    // Both sessions at once, each audited under its own name.
    assert_eq!(admissions_of("alice-ops"), 1);
    assert_eq!(admissions_of("bob-ops"), 1);
    let log = logged();
    let action = log
        .lines()
        .find(|l| l.contains("admin action") && l.contains("operator=bob-ops"))
        .expect("bob's status call is audited");
    assert!(action.contains("action=\"status\""), "{action}");

    // Another operator's token, an unknown operator, a near miss.
    for (operator, token) in [
        ("alice-ops", BOB),
        ("bob-ops", ALICE),
        ("carol-ops", ALICE),
        ("alice-ops", &ALICE[..ALICE.len() - 1]),
    ] {
        assert_eq!(
            refusal(p.admin(operator, token).await, operator),
            AdminRefusal::BadCredential,
            "{operator}"
        );
    }
    let m = p.server.metrics();
    assert_eq!(m.admin_action_count("hello", "ok"), 2);
    assert_eq!(m.admin_action_count("hello", "refused_credential"), 4);
    assert_eq!(m.refused_count("admin_refused_credential"), 4);
    assert_eq!(m.admin_operators.get(), 2);
    // The log never holds a token.
    let log = logged();
    for token in [ALICE, BOB] {
        assert!(!log.contains(token), "a token was logged");
    }
    alice.close().await;
    bob.close().await;
    p.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_without_a_token_file_outside_dev_mode_no_one_is_admitted() {
    capture_logs();
    let dir = temp_dir("issue11-no-file");
    let fingerprint = production_files(&dir);
    let server = inertia_server::server::start(production_config(&dir, None))
        .await
        .expect("the server starts");
    for token in ["", ALICE] {
        let client = AdminClient::connect(server.addr(), fingerprint, token, "anyone").await;
        assert_eq!(refusal(client, "anyone"), AdminRefusal::BadCredential);
    }
    assert!(matches!(
        server.reload_admin_tokens(),
        Err(TokenFileError::NotConfigured)
    ));
    server.shutdown().await;

    // A bad file refuses the start, naming the line and not the token.
    let path = dir.join("admin-tokens");
    write_private(&path, &format!("alice {ALICE}\nbob {BOB} {CAROL}\n"));
    let err = inertia_server::server::start(production_config(&dir, Some(path.clone())))
        .await
        .expect_err("a bad token file is refused");
    match &err {
        StartError::AdminTokens(TokenFileError::Line { line, problem, .. }) => {
            assert_eq!((*line, problem), (2, &LineProblem::Fields(3)));
        }
        other => panic!("{other}"),
    }
    let shown = err.to_string();
    assert!(shown.contains("admin-tokens, line 2"), "{shown}");
    for token in [ALICE, BOB, CAROL] {
        assert!(!shown.contains(token), "{shown}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_dev_mode_admits_the_dev_token_beside_the_file() {
    capture_logs();
    let dir = temp_dir("issue11-dev-file");
    let path = dir.join("admin-tokens");
    write_private(&path, &format!("dana {ALICE}\n"));
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        scene: Some(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/pyramid.json")),
        data_dir: dir.join("data"),
        admin_token_file: Some(path),
        record: false,
        ..ServerConfig::default()
    };
    let server = inertia_server::server::start(config)
        .await
        .expect("the server starts");
    let creds =
        inertia_admin_client::read_credentials(server.credentials_path().expect("dev mode"))
            .expect("dev credentials");
    let fingerprint = creds.fingerprint().expect("fingerprint");
    assert_eq!(creds.admin_token, server.admin_token());
    let connect = |operator: &'static str, token: String| {
        let addr = server.addr();
        async move { AdminClient::connect(addr, fingerprint, &token, operator).await }
    };
    admitted(connect("dana", ALICE.into()).await, "dana")
        .await
        .close()
        .await;
    admitted(
        connect("dev-anyone", creds.admin_token.clone()).await,
        "dev",
    )
    .await
    .close()
    .await;
    assert_eq!(
        refusal(connect("erin", ALICE.into()).await, "erin"),
        AdminRefusal::BadCredential
    );
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_reload_replaces_the_operators_and_a_bad_file_keeps_them() {
    let p = Production::start("issue11-reload", &format!("frank {ALICE}\n")).await;
    let mut frank = admitted(p.admin("frank", ALICE).await, "frank").await;

    write_private(&p.tokens, &format!("grace {BOB}\nheidi {CAROL}\n"));
    assert_eq!(p.server.reload_admin_tokens().expect("reloaded"), 2);
    assert_eq!(
        refusal(p.admin("frank", ALICE).await, "frank after the reload"),
        AdminRefusal::BadCredential
    );
    admitted(p.admin("grace", BOB).await, "grace")
        .await
        .close()
        .await;
    admitted(p.admin("heidi", CAROL).await, "heidi")
        .await
        .close()
        .await;
    // The session frank opened before the reload ends at its next call.
    let after = frank.call(AdminRequest::Status).await;
    assert!(after.is_err(), "a revoked session answered: {after:?}");
    assert!(logged().contains("admin credential revoked by a reload"));

    // A bad file: refused with its line, the operators in use stay.
    write_private(&p.tokens, &format!("grace {BOB}\nheidi short\n"));
    match p.server.reload_admin_tokens() {
        Err(TokenFileError::Line {
            line: 2,
            problem: LineProblem::ShortToken,
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    admitted(p.admin("heidi", CAROL).await, "heidi after a bad reload")
        .await
        .close()
        .await;
    let m = p.server.metrics();
    assert_eq!(m.admin_token_reload_count("ok"), 1);
    assert_eq!(m.admin_token_reload_count("error"), 1);
    assert!(logged().contains("admin token file not reloaded"));
    p.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_failed_hellos_are_throttled_per_address() {
    let p = Production::start("issue11-throttle", &format!("ivan {ALICE}\n")).await;
    for i in 0..5 {
        assert_eq!(
            refusal(p.admin("ivan", BOB).await, "a wrong token"),
            AdminRefusal::BadCredential,
            "failure {i}"
        );
    }
    // Now even the right token is refused at once, for about a second.
    let retry_after_ms = match refusal(p.admin("ivan", ALICE).await, "throttled") {
        AdminRefusal::Throttled { retry_after_ms } => retry_after_ms,
        other => panic!("expected a throttled refusal, got {other:?}"),
    };
    assert!((1..=1000).contains(&retry_after_ms), "{retry_after_ms}");
    let m = p.server.metrics();
    assert_eq!(m.admin_action_count("hello", "refused_throttled"), 1);
    assert_eq!(m.refused_count("admin_refused_throttled"), 1);

    // Another address is not throttled: its right token is admitted, and
    // a wrong one is refused as wrong.
    #[cfg(target_os = "linux")]
    {
        admitted(
            p.admin_from("127.0.0.2:0", "ivan", ALICE).await,
            "another address",
        )
        .await
        .close()
        .await;
        assert_eq!(
            refusal(
                p.admin_from("127.0.0.2:0", "ivan", BOB).await,
                "another address"
            ),
            AdminRefusal::BadCredential
        );
    }

    // After the back-off, the right token is admitted again, and the
    // success clears the address's count.
    tokio::time::sleep(Duration::from_millis(u64::from(retry_after_ms) + 100)).await;
    admitted(p.admin("ivan", ALICE).await, "after the back-off")
        .await
        .close()
        .await;
    for _ in 0..4 {
        assert_eq!(
            refusal(p.admin("ivan", BOB).await, "a wrong token"),
            AdminRefusal::BadCredential
        );
    }
    admitted(
        p.admin("ivan", ALICE).await,
        "four failures after a success",
    )
    .await
    .close()
    .await;
    assert!(logged().contains("too many wrong admin credentials from this address"));
    p.stop().await;
}

// The process: SIGHUP reloads the file, and `inertia-admin` reaches a
// server outside dev mode with --server, --cert-file or --fingerprint, and
// --token-file or INERTIA_ADMIN_TOKEN.

struct Process {
    child: Child,
    dir: PathBuf,
    addr: String,
}

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

impl Process {
    fn admin(&self, auth: &[&str], env_token: Option<&str>, args: &[&str]) -> Output {
        let mut command = Command::new(env!("CARGO_BIN_EXE_inertia-admin"));
        command
            .args(["--server", &self.addr, "--credentials"])
            .arg(self.dir.join("no-dev-credentials.json"))
            .args(auth)
            .args(args)
            .env_remove("INERTIA_ADMIN_TOKEN");
        if let Some(token) = env_token {
            command.env("INERTIA_ADMIN_TOKEN", token);
        }
        command.output().expect("inertia-admin runs")
    }

    /// What the server logged, without colours.
    fn log(&self) -> String {
        let raw = std::fs::read_to_string(self.dir.join("server.log")).unwrap_or_default();
        let mut plain = String::with_capacity(raw.len());
        let mut chars = raw.chars();
        while let Some(c) = chars.next() {
            if c == '\u{1b}' {
                // An escape sequence: `ESC [` up to its final letter.
                for c in chars.by_ref() {
                    if c.is_ascii_alphabetic() {
                        break;
                    }
                }
            } else {
                plain.push(c);
            }
        }
        plain
    }

    fn hangup(&self) {
        let status = Command::new("kill")
            .args(["-HUP", &self.child.id().to_string()])
            .status()
            .expect("kill runs");
        assert!(status.success());
    }
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn issue_11_sighup_reloads_the_token_file_of_a_running_server() {
    let dir = temp_dir("issue11-sighup");
    let fingerprint = production_files(&dir);
    let tokens = dir.join("admin-tokens");
    write_private(&tokens, &format!("judy {ALICE}\n"));
    // Each operator's own file: their line of the server's file.
    write_private(&dir.join("judy.token"), &format!("judy {ALICE}\n"));
    write_private(&dir.join("ken.token"), &format!("# ken's\n{BOB}\n"));
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free port")
        .port();
    let addr = format!("127.0.0.1:{port}");
    let log = std::fs::File::create(dir.join("server.log")).expect("the log");
    let child = Command::new(env!("CARGO_BIN_EXE_inertia-server"))
        .args([
            "--listen",
            &addr,
            "--metrics",
            "127.0.0.1:0",
            "--record",
            "false",
        ])
        .arg("--data-dir")
        .arg(dir.join("data"))
        .arg("--scene")
        .arg(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/pyramid.json"))
        .arg("--key-file")
        .arg(dir.join("token.key"))
        .arg("--cert-file")
        .arg(dir.join("cert.pem"))
        .arg("--cert-key-file")
        .arg(dir.join("key.pem"))
        .arg("--admin-token-file")
        .arg(&tokens)
        .env("INERTIA_LOG", "warn,inertia::admin=info")
        .stdout(Stdio::from(log.try_clone().expect("the log")))
        .stderr(Stdio::from(log))
        .spawn()
        .expect("the server binary starts");
    let mut server = Process {
        child,
        dir: dir.clone(),
        addr,
    };
    let cert = dir.join("cert.pem");
    let cert = cert.to_str().expect("UTF-8");
    let judy_file = dir.join("judy.token");
    let judy = [
        "--cert-file",
        cert,
        "--token-file",
        judy_file.to_str().expect("UTF-8"),
    ];
    let start = Instant::now();
    let mut out = server.admin(&judy, None, &["status", "--json"]);
    while !out.status.success() && start.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(100));
        out = server.admin(&judy, None, &["status", "--json"]);
    }
    assert!(out.status.success(), "judy: {}", stderr(&out));

    // Ken replaces judy; SIGHUP.
    write_private(&tokens, &format!("ken {BOB}\n"));
    server.hangup();
    wait_for("the reload", Duration::from_secs(10), || {
        server.log().contains("admin token file reloaded")
    });
    let out = server.admin(&judy, None, &["status", "--json"]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "judy is refused: {}",
        stderr(&out)
    );
    assert!(stderr(&out).contains("credential"), "{}", stderr(&out));
    let ken_file = dir.join("ken.token");
    let ken = [
        "--cert-file",
        cert,
        "--token-file",
        ken_file.to_str().expect("UTF-8"),
        "--operator",
        "ken",
    ];
    let out = server.admin(&ken, None, &["status", "--json"]);
    assert!(out.status.success(), "ken: {}", stderr(&out));
    // The token from the environment, the certificate by fingerprint.
    let hex = to_hex(&fingerprint);
    let by_env = ["--fingerprint", hex.as_str(), "--operator", "ken"];
    let out = server.admin(&by_env, Some(BOB), &["status", "--json"]);
    assert!(out.status.success(), "ken by env: {}", stderr(&out));

    // A bad file on SIGHUP: logged, ken stays, the process goes on.
    write_private(&tokens, &format!("ken {BOB}\nken {ALICE}\n"));
    server.hangup();
    wait_for("the failed reload", Duration::from_secs(10), || {
        server.log().contains("admin token file not reloaded")
    });
    let out = server.admin(&ken, None, &["status", "--json"]);
    assert!(
        out.status.success(),
        "ken after a bad reload: {}",
        stderr(&out)
    );
    let log = server.log();
    assert!(log.contains("line 2"), "{log}");
    assert!(log.contains("operator=ken"), "{log}");
    for token in [ALICE, BOB] {
        assert!(!log.contains(token), "a token was logged");
    }
    assert!(
        server.child.try_wait().expect("wait").is_none(),
        "the server survives SIGHUP"
    );
}
