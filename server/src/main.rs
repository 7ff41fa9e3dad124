//! `inertia-server`: runs one world under the sandbox rules and serves it
//! until SIGTERM or Ctrl-C, then shuts down within
//! [`SHUTDOWN_DEADLINE`](inertia_server::server::SHUTDOWN_DEADLINE) (see
//! [`inertia_server::process`] for the exit status).

use std::process::ExitCode;

use inertia_server::rules::{SandboxRules, SandboxSettings};

fn main() -> ExitCode {
    inertia_server::process::run(|_| Box::new(SandboxRules::new(SandboxSettings::default())))
}
