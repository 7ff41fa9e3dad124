//! Issue 11: `save` and `load` work inside one checkpoint directory, by
//! name; reads are bounded and refuse what is not a regular file without
//! blocking; and shutdown finishes within its deadline whatever an admin
//! call or the tick thread is doing.
//!
//! The server processes run in their checkpoint directory, so a build
//! that still took names as paths (relative to its working directory)
//! would be caught by the same tests.

#![cfg(unix)]

use crate::common;

use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::DevServer;
use inertia_admin_client::{read_credentials, AdminClient};
use inertia_protocol::admin::{
    AdminCall, AdminErrorKind, AdminRequest, AdminResponse, CheckpointName,
};
use inertia_server::config::ServerConfig;
use inertia_server::replay::checkpoint::{CheckpointDir, CheckpointError, MAX_CHECKPOINT_BYTES};
use inertia_server::server::SHUTDOWN_DEADLINE;

/// A server whose working directory is its checkpoint directory, and a
/// directory outside it that must stay untouched.
struct Fixture {
    server: DevServer,
    checkpoints: PathBuf,
    outside: PathBuf,
}

impl Fixture {
    fn start(what: &str) -> Fixture {
        let tmp = std::env::temp_dir();
        let dir = tmp.join(format!("inertia-{what}-{}", std::process::id()));
        let outside = tmp.join(format!("inertia-{what}-outside-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::remove_dir_all(&outside);
        let checkpoints = dir.join("checkpoints");
        std::fs::create_dir_all(&checkpoints).expect("the checkpoint directory");
        std::fs::create_dir_all(&outside).expect("the outside directory");
        let server = DevServer::start_with(dir, &[], Some(&checkpoints));
        Fixture {
            server,
            checkpoints,
            outside,
        }
    }

    fn data_dir(&self) -> &Path {
        &self.server.dir
    }

    /// `inertia-admin` with `args`, killed after `limit`; `None` if it
    /// ran that long. Fails the test if the server's resident memory grows
    /// by more than `max_growth_mb` meanwhile (and stops the server, so a
    /// runaway read cannot take the machine).
    fn admin_within(&self, args: &[&str], limit: Duration, max_growth_mb: u64) -> Option<Output> {
        let pid = self.server.child.id();
        let base = rss_kb(pid);
        let mut child = Command::new(env!("CARGO_BIN_EXE_inertia-admin"))
            .arg("--credentials")
            .arg(&self.server.credentials)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("inertia-admin runs");
        let start = Instant::now();
        loop {
            let grown = rss_kb(pid).saturating_sub(base) / 1024;
            if grown > max_growth_mb {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{args:?}: the server grew by {grown} MB");
            }
            if child.try_wait().expect("wait").is_some() {
                return Some(child.wait_with_output().expect("output"));
            }
            if start.elapsed() > limit {
                let _ = child.kill();
                let _ = child.wait();
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// `inertia-admin` with `args`, which must answer within 10 s.
    fn admin(&self, args: &[&str]) -> Output {
        self.admin_within(args, Duration::from_secs(10), 512)
            .unwrap_or_else(|| panic!("{args:?} did not answer within 10 s"))
    }

    fn entries_outside(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(&self.outside)
            .expect("the outside directory")
            .map(|e| e.expect("an entry").path())
            .collect();
        v.sort();
        v
    }
}

impl Drop for Fixture {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.outside);
    }
}

/// The resident memory of process `pid`, kB.
fn rss_kb(pid: u32) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmRSS:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        })
        .unwrap_or(0)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn assert_ok(out: &Output, what: &str) {
    assert!(out.status.success(), "{what}: {}", stderr(out));
}

fn assert_refused(out: &Output, what: &str) {
    assert!(
        !out.status.success(),
        "{what} was carried out: {}",
        String::from_utf8_lossy(&out.stdout)
    );
}

fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(status.success(), "mkfifo {}", path.display());
}

#[test]
fn issue_11_save_and_load_take_names_inside_the_checkpoint_dir() {
    let f = Fixture::start("issue11-names");
    assert_ok(&f.admin(&["save", "first.ckpt"]), "save first.ckpt");
    assert!(
        f.checkpoints.join("first.ckpt").is_file(),
        "a name is saved in the checkpoint directory"
    );
    assert_ok(&f.admin(&["load", "first.ckpt"]), "load first.ckpt");

    let absolute = f.outside.join("absolute.ckpt");
    let absolute = absolute.to_str().expect("UTF-8");
    for bad in [
        absolute,
        "../escape.ckpt",
        "sub/x.ckpt",
        "",
        ".hidden",
        "..",
    ] {
        assert_refused(&f.admin(&["save", bad]), &format!("save {bad:?}"));
        assert_refused(&f.admin(&["load", bad]), &format!("load {bad:?}"));
    }
    assert_eq!(
        f.entries_outside(),
        Vec::<PathBuf>::new(),
        "nothing outside"
    );
    assert!(!f.data_dir().join("escape.ckpt").exists(), "no `..`");
    assert!(!f.checkpoints.join("sub").exists());
    assert!(!f.checkpoints.join(".hidden").exists());
}

#[test]
fn issue_11_save_replaces_an_existing_checkpoint_only_when_asked() {
    let f = Fixture::start("issue11-overwrite");
    let taken = f.checkpoints.join("taken.ckpt");
    std::fs::write(&taken, b"precious").expect("written");
    assert_refused(&f.admin(&["save", "taken.ckpt"]), "save over a file");
    assert_eq!(std::fs::read(&taken).expect("read"), b"precious");

    assert_ok(
        &f.admin(&["save", "taken.ckpt", "--overwrite"]),
        "save --overwrite",
    );
    assert_ne!(std::fs::read(&taken).expect("read"), b"precious");
    assert_ok(&f.admin(&["load", "taken.ckpt"]), "load the new checkpoint");
}

#[test]
fn issue_11_symlinks_in_the_checkpoint_dir_are_never_followed() {
    let f = Fixture::start("issue11-symlinks");
    // A valid checkpoint outside, and links to it and to a plain file.
    assert_ok(&f.admin(&["save", "real.ckpt"]), "save real.ckpt");
    let valid = f.outside.join("valid.ckpt");
    std::fs::copy(f.checkpoints.join("real.ckpt"), &valid).expect("copied");
    let target = f.outside.join("target");
    std::fs::write(&target, b"outside").expect("written");
    symlink(&target, f.checkpoints.join("link.ckpt")).expect("symlink");
    symlink(&valid, f.checkpoints.join("alias.ckpt")).expect("symlink");

    assert_refused(&f.admin(&["save", "link.ckpt"]), "save over a symlink");
    assert_refused(
        &f.admin(&["save", "link.ckpt", "--overwrite"]),
        "save --overwrite over a symlink",
    );
    assert_eq!(std::fs::read(&target).expect("read"), b"outside");
    assert!(f
        .checkpoints
        .join("link.ckpt")
        .symlink_metadata()
        .expect("still there")
        .file_type()
        .is_symlink());
    assert_refused(&f.admin(&["load", "alias.ckpt"]), "load through a symlink");
    assert_eq!(
        f.entries_outside(),
        vec![target.clone(), valid.clone()],
        "nothing new outside"
    );
}

#[test]
fn issue_11_save_never_follows_a_symlink_planted_at_the_temp_name() {
    let f = Fixture::start("issue11-planted");
    // Symlinks planted where a save's temporary file might go: the old
    // `<name>.partial`, and hidden names in the directory.
    let planted = f.outside.join("planted");
    let pid = f.server.child.id();
    let mut temps = vec!["p.ckpt.partial".to_string(), ".p.ckpt.partial".to_string()];
    temps.extend((0..64).map(|n| format!(".p.ckpt.{pid}.{n}.partial")));
    for t in &temps {
        symlink(&planted, f.checkpoints.join(t)).expect("symlink");
    }
    let out = f.admin(&["save", "p.ckpt"]);
    assert!(!planted.exists(), "a planted symlink was followed");
    if out.status.success() {
        let meta = f
            .checkpoints
            .join("p.ckpt")
            .symlink_metadata()
            .expect("saved");
        assert!(meta.file_type().is_file());
        assert_ok(&f.admin(&["load", "p.ckpt"]), "load p.ckpt");
    }
    assert_eq!(
        f.entries_outside(),
        Vec::<PathBuf>::new(),
        "nothing outside"
    );
}

#[test]
fn issue_11_load_of_a_device_or_fifo_is_refused_fast() {
    let f = Fixture::start("issue11-devices");
    symlink("/dev/zero", f.checkpoints.join("zero")).expect("symlink");
    mkfifo(&f.checkpoints.join("pipe"));
    let mut names = vec!["zero", "pipe", "/dev/zero"];
    // A device node in the directory itself, where the tests may make one.
    let made_device = Command::new("mknod")
        .arg(f.checkpoints.join("zdev"))
        .args(["c", "1", "5"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if made_device {
        names.push("zdev");
    }
    for name in names {
        let start = Instant::now();
        let out = f
            .admin_within(&["load", name], Duration::from_secs(5), 64)
            .unwrap_or_else(|| panic!("load {name} did not answer within 5 s"));
        assert_refused(&out, &format!("load {name}"));
        assert!(start.elapsed() < Duration::from_secs(5));
    }
    // Still serving.
    assert_ok(&f.admin(&["status"]), "status");
}

#[test]
fn issue_11_huge_sparse_checkpoint_is_refused_by_size() {
    let f = Fixture::start("issue11-sparse");
    for (name, len) in [("big.ckpt", 512u64 << 20), ("huge.ckpt", 8u64 << 30)] {
        let file = std::fs::File::create(f.checkpoints.join(name)).expect("created");
        file.set_len(len).expect("sparse");
        drop(file);
        let out = f
            .admin_within(&["load", name], Duration::from_secs(5), 64)
            .unwrap_or_else(|| panic!("load {name} did not answer within 5 s"));
        assert_refused(&out, &format!("load {name}"));
        assert!(
            stderr(&out).contains("larger than"),
            "load {name}: {}",
            stderr(&out)
        );
    }
}

#[test]
fn issue_11_sigterm_exits_while_a_load_waits_on_a_fifo() {
    let mut f = Fixture::start("issue11-sigterm");
    mkfifo(&f.checkpoints.join("pipe"));
    let mut load = Command::new(env!("CARGO_BIN_EXE_inertia-admin"))
        .arg("--credentials")
        .arg(&f.server.credentials)
        .args(["load", "pipe"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("inertia-admin runs");
    // Give the load time to reach the FIFO (or be refused).
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(2) && load.try_wait().expect("wait").is_none() {
        std::thread::sleep(Duration::from_millis(20));
    }

    let status = Command::new("kill")
        .args(["-TERM", &f.server.child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    let start = Instant::now();
    let exit = loop {
        if let Some(exit) = f.server.child.try_wait().expect("wait") {
            break Some(exit);
        }
        if start.elapsed() > Duration::from_secs(15) {
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let _ = load.kill();
    let out = load.wait_with_output().expect("the load's output");
    let exit = exit.expect("the server exits within 15 s of SIGTERM");
    assert!(exit.success(), "exit status {exit:?}");
    assert_refused(&out, "load of a FIFO");
}

/// A dev-mode server in this process, on ephemeral ports.
async fn in_process(what: &str) -> (inertia_server::server::RunningServer, PathBuf) {
    let dir = std::env::temp_dir().join(format!("inertia-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir.clone(),
        ..Default::default()
    };
    let server = inertia_server::server::start(config)
        .await
        .expect("the server starts");
    (server, dir)
}

async fn admin_of(server: &inertia_server::server::RunningServer) -> AdminClient {
    let fingerprint = read_credentials(server.credentials_path().expect("dev mode"))
        .expect("dev credentials")
        .fingerprint()
        .expect("fingerprint");
    AdminClient::connect(server.addr(), fingerprint, server.admin_token(), "issue11")
        .await
        .expect("admitted")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_shutdown_returns_within_its_deadline_while_the_tick_thread_is_blocked() {
    let (server, dir) = in_process("issue11-deadline").await;
    let mut admin = admin_of(&server).await;
    // The tick thread is stuck in a call for longer than any deadline,
    // and an admin call waits on it.
    let _stuck = server
        .sim()
        .call(|_| std::thread::sleep(Duration::from_secs(40)))
        .expect("sent");
    let waiting = tokio::spawn(async move { admin.call(AdminRequest::Status).await });
    tokio::time::sleep(Duration::from_millis(200)).await;
    let start = Instant::now();
    let done = tokio::time::timeout(Duration::from_secs(20), server.shutdown()).await;
    let took = start.elapsed();
    assert!(done.is_ok(), "shutdown did not return in 20 s");
    assert!(
        took <= SHUTDOWN_DEADLINE + Duration::from_secs(1),
        "shutdown took {took:?}"
    );
    // The admin call in flight was dropped with its connection.
    let answer = tokio::time::timeout(Duration::from_secs(5), waiting)
        .await
        .expect("the admin call ends")
        .expect("no panic");
    assert!(answer.is_err(), "{answer:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_11_names_that_are_paths_are_refused_off_the_wire() {
    let (server, dir) = in_process("issue11-wire").await;
    let mut admin = admin_of(&server).await;
    let before = match admin.call(AdminRequest::Pause).await.expect("paused") {
        AdminResponse::Ok => server.sim().frame().tick,
        other => panic!("{other:?}"),
    };
    let outside = dir.join("outside.ckpt");
    let outside = outside.to_str().expect("UTF-8");
    for bad in [outside, "../escape.ckpt", "a/b", "", "..", ".partial"] {
        // Checked after decoding, so a tool that does not check is
        // refused by the server: built by hand, as such a tool would.
        let name: CheckpointName =
            postcard::from_bytes(&postcard::to_allocvec(bad).expect("encodes")).expect("decodes");
        for request in [
            AdminRequest::Save {
                name: name.clone(),
                overwrite: true,
            },
            AdminRequest::Load { name },
        ] {
            let call = AdminCall { id: 7, request };
            let mut frame = postcard::to_allocvec(&call).expect("encodes");
            let len = (frame.len() as u32).to_le_bytes();
            frame.splice(0..0, len);
            let reply = admin.send_raw(&frame).await.expect("an answer");
            match reply.response {
                AdminResponse::Error(e) => {
                    assert_eq!(e.kind, AdminErrorKind::Invalid, "{bad:?}: {e:?}");
                    assert!(e.message.contains("checkpoint name"), "{bad:?}: {e:?}");
                }
                other => panic!("{bad:?}: {other:?}"),
            }
        }
    }
    assert!(!Path::new(outside).exists());
    assert!(!dir.join("escape.ckpt").exists());
    assert!(!server.checkpoints().path().exists(), "nothing was created");
    assert_eq!(server.sim().frame().tick, before, "nothing changed");
    admin.close().await;
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}

fn name(s: &str) -> CheckpointName {
    CheckpointName::new(s).expect("a checkpoint name")
}

/// A checkpoint directory under a fresh folder, a folder beside it, and a
/// valid saved state.
fn scratch(what: &str) -> (CheckpointDir, PathBuf, Vec<u8>) {
    let root = std::env::temp_dir().join(format!("inertia-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let outside = root.join("outside");
    std::fs::create_dir_all(&outside).expect("outside");
    let sim = inertia_server::sim::Simulation::new(
        inertia_server::scene::demo::demo_scene()
            .expect("the demo")
            .build()
            .expect("builds"),
        Box::new(inertia_server::rules::SandboxRules::default()),
        inertia_server::sim::SimConfig::default(),
    );
    (
        CheckpointDir::new(root.join("data").join("checkpoints")),
        outside,
        sim.checkpoint().encode(),
    )
}

#[test]
fn issue_11_checkpoint_dir_confines_saves_and_loads() {
    use std::os::unix::fs::PermissionsExt;
    let (dir, outside, state) = scratch("issue11-dir");
    let root = outside.parent().expect("root").to_path_buf();

    // Names only, checked again where they name a file.
    for bad in ["/etc/passwd", "../x", "a/b", "", "..", ".hidden"] {
        assert!(CheckpointName::new(bad).is_err(), "{bad:?}");
        let unchecked: CheckpointName =
            postcard::from_bytes(&postcard::to_allocvec(bad).unwrap()).unwrap();
        assert!(matches!(
            dir.write(&unchecked, &state, true),
            Err(CheckpointError::BadName { .. })
        ));
        assert!(matches!(
            dir.read(&unchecked),
            Err(CheckpointError::BadName { .. })
        ));
    }
    assert!(!dir.path().exists(), "a refusal creates nothing");
    assert!(matches!(
        dir.read(&name("a.ckpt")),
        Err(CheckpointError::NotFound { .. })
    ));

    // The first save makes the directory, private.
    dir.write(&name("a.ckpt"), &state, false).expect("saved");
    let mode = std::fs::metadata(dir.path()).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o700, "{mode:o}");
    let file = dir.path().join("a.ckpt");
    let mode = std::fs::metadata(&file).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o600, "{mode:o}");
    assert_eq!(dir.read(&name("a.ckpt")).expect("reads").encode(), state);

    // No overwrite unless asked; then only a regular file is replaced.
    std::fs::write(dir.path().join("kept.ckpt"), b"precious").unwrap();
    let e = dir.write(&name("kept.ckpt"), &state, false).unwrap_err();
    assert!(matches!(e, CheckpointError::Exists { .. }), "{e}");
    assert!(e.to_string().contains("--overwrite"), "{e}");
    assert_eq!(
        std::fs::read(dir.path().join("kept.ckpt")).unwrap(),
        b"precious"
    );
    dir.write(&name("kept.ckpt"), &state, true)
        .expect("replaced");
    assert_eq!(dir.read(&name("kept.ckpt")).expect("reads").encode(), state);
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    assert!(matches!(
        dir.write(&name("sub"), &state, true),
        Err(CheckpointError::NotRegular {
            kind: "directory",
            ..
        })
    ));
    assert!(matches!(
        dir.read(&name("sub")),
        Err(CheckpointError::NotRegular {
            kind: "directory",
            ..
        })
    ));

    // Links at a name are neither followed nor replaced.
    let target = outside.join("target");
    std::fs::write(&target, b"outside").unwrap();
    symlink(&target, dir.path().join("link.ckpt")).unwrap();
    symlink(&file, dir.path().join("alias.ckpt")).unwrap();
    for overwrite in [false, true] {
        assert!(matches!(
            dir.write(&name("link.ckpt"), &state, overwrite),
            Err(CheckpointError::Symlink { .. })
        ));
    }
    assert!(matches!(
        dir.read(&name("alias.ckpt")),
        Err(CheckpointError::Symlink { .. })
    ));
    assert_eq!(std::fs::read(&target).unwrap(), b"outside");

    // Links planted where temporary files might go are never followed.
    let planted = outside.join("planted");
    let pid = std::process::id();
    let mut temps = vec!["p.ckpt.partial".to_string(), ".p.ckpt.partial".to_string()];
    temps.extend((0..8).map(|n| format!(".p.ckpt.{pid}.{n}.partial")));
    for t in &temps {
        symlink(&planted, dir.path().join(t)).unwrap();
    }
    dir.write(&name("p.ckpt"), &state, false)
        .expect("saved beside the planted links");
    assert!(!planted.exists());
    assert!(std::fs::symlink_metadata(dir.path().join("p.ckpt"))
        .unwrap()
        .file_type()
        .is_file());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".partial") && !temps.contains(n))
        .collect();
    assert_eq!(leftovers, Vec::<String>::new(), "no temporary file is left");

    // A checkpoint directory that is a link is refused, for saves too.
    let linked = CheckpointDir::new(root.join("linked"));
    symlink(dir.path(), linked.path()).unwrap();
    assert!(matches!(
        linked.read(&name("a.ckpt")),
        Err(CheckpointError::Directory { .. })
    ));
    assert!(matches!(
        linked.write(&name("b.ckpt"), &state, false),
        Err(CheckpointError::Directory { .. })
    ));
    assert!(!dir.path().join("b.ckpt").exists());
    assert_eq!(
        std::fs::read_dir(&outside).unwrap().count(),
        1,
        "nothing new outside"
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn issue_11_checkpoint_reads_are_bounded_and_never_block() {
    let (dir, outside, state) = scratch("issue11-bounded");
    dir.write(&name("a.ckpt"), &state, false).expect("saved");
    symlink("/dev/zero", dir.path().join("zero")).unwrap();
    mkfifo(&dir.path().join("pipe"));
    let start = Instant::now();
    assert!(matches!(
        dir.read(&name("zero")),
        Err(CheckpointError::Symlink { .. })
    ));
    let e = dir.read(&name("pipe")).unwrap_err();
    assert!(
        matches!(e, CheckpointError::NotRegular { kind: "FIFO", .. }),
        "{e}"
    );
    assert!(e.to_string().contains("not a regular file"), "{e}");
    assert!(start.elapsed() < Duration::from_secs(1), "refused at once");

    // Too large by its size: refused before a byte is read.
    let big = std::fs::File::create(dir.path().join("big.ckpt")).unwrap();
    big.set_len(MAX_CHECKPOINT_BYTES + 1).unwrap();
    drop(big);
    let e = dir.read(&name("big.ckpt")).unwrap_err();
    assert!(
        matches!(e, CheckpointError::TooLarge { len, .. } if len == MAX_CHECKPOINT_BYTES + 1),
        "{e}"
    );
    // The bound is the largest state a save writes: one just within it
    // is read (and is no state).
    let edge = std::fs::File::create(dir.path().join("edge.ckpt")).unwrap();
    edge.set_len(MAX_CHECKPOINT_BYTES).unwrap();
    drop(edge);
    assert!(matches!(
        dir.read(&name("edge.ckpt")),
        Err(CheckpointError::State { .. })
    ));
    let too_big = vec![0u8; MAX_CHECKPOINT_BYTES as usize];
    assert!(matches!(
        dir.write(&name("too-big.ckpt"), &too_big, false),
        Err(CheckpointError::TooLarge { .. })
    ));
    assert!(!dir.path().join("too-big.ckpt").exists());
    let _ = std::fs::remove_dir_all(outside.parent().expect("root"));
}
