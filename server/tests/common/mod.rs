//! Running the `inertia-server` binary in dev mode for the process tests.

#![allow(dead_code)] // each test file uses its own subset

pub mod player;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A flat ground and one ball: the smallest scene that records something.
pub const FLAT: &str = r#"(
    name: "flat",
    spawn_points: [(0.0, 1.0, 0.0), (3.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (50.0, 0.5, 50.0)), position: (0.0, -0.5, 0.0)),
        (name: "ball", shape: Sphere(radius: 0.3), position: (2.0, 3.0, 2.0)),
    ],
)"#;

/// Runs `inertia-admin --credentials <credentials> <args>`.
pub fn admin(credentials: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_inertia-admin"))
        .arg("--credentials")
        .arg(credentials)
        .args(args)
        .output()
        .expect("inertia-admin runs")
}

/// Polls `done` every 20 ms until it holds; fails the test after
/// `timeout`, naming `what`.
pub fn wait_for(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A dev-mode server process on ephemeral loopback ports with the pyramid
/// scene, its data directory under the system's temporary folder. Dropping
/// it kills the process and removes the directory.
pub struct DevServer {
    /// The process.
    pub child: Child,
    /// Its data directory.
    pub dir: PathBuf,
    /// Its dev credentials file (written once it has started).
    pub credentials: PathBuf,
}

impl DevServer {
    /// Starts the server (data directory named after `what`) and waits for
    /// its credentials file.
    pub fn start(what: &str) -> DevServer {
        let dir = std::env::temp_dir().join(format!("inertia-{what}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        Self::start_in(dir, &[])
    }

    /// Starts the server on an existing data directory with `extra`
    /// arguments (`--resume`, say) and waits for its credentials file.
    pub fn start_in(dir: PathBuf, extra: &[&str]) -> DevServer {
        Self::start_with(dir, extra, None)
    }

    /// [`DevServer::start_in`], the process running in `cwd` when given
    /// (where relative paths it is handed would land).
    pub fn start_with(dir: PathBuf, extra: &[&str], cwd: Option<&Path>) -> DevServer {
        let _ = std::fs::remove_file(dir.join("dev-credentials.json"));
        let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/pyramid.json");
        let mut command = Command::new(env!("CARGO_BIN_EXE_inertia-server"));
        if let Some(cwd) = cwd {
            command.current_dir(cwd);
        }
        let child = command
            .args([
                "--listen",
                "127.0.0.1:0",
                "--metrics",
                "127.0.0.1:0",
                "--data-dir",
            ])
            .arg(&dir)
            .arg("--scene")
            .arg(&scene)
            .args(extra)
            .env("INERTIA_LOG", "warn")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("the server binary starts");
        let credentials = dir.join("dev-credentials.json");
        let server = DevServer {
            child,
            dir,
            credentials,
        };
        wait_for("the credentials file", Duration::from_secs(30), || {
            server.credentials.exists()
        });
        server
    }
}

impl Drop for DevServer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
