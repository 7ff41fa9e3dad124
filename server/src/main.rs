//! `inertia-server`: runs one world under the sandbox rules and serves it
//! until SIGTERM or Ctrl-C, then shuts down within
//! [`SHUTDOWN_DEADLINE`](inertia_server::server::SHUTDOWN_DEADLINE) (see
//! [`inertia_server::process`] for the exit status).

use std::process::ExitCode;

use inertia_server::rules::{SandboxRules, SandboxSettings};

/// The allocator the server is measured with (`inertia-bench` declares the
/// same): per-thread heaps, so the tick thread, the snapshot stage and the
/// network workers do not queue on one another's arena locks, and a frame
/// freed on another thread goes back to the heap of the thread that made
/// it. A studio's own binary picks its own; see [`inertia_server::process`].
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    inertia_server::process::run(|_| Box::new(SandboxRules::new(SandboxSettings::default())))
}
