//! `inertia-server` under [`FaultRules`](inertia_tests::fault::FaultRules):
//! the sandbox game, failing `INERTIA_FAULT_AFTER_TICKS` ticks (default 60)
//! after the first client joins. The supervision tests run it to check the
//! process fails its health checks, tells its clients and exits non-zero.

use std::process::ExitCode;

use inertia_tests::fault::FaultRules;

fn main() -> ExitCode {
    let after = std::env::var("INERTIA_FAULT_AFTER_TICKS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    inertia_server::process::run(move |_| Box::new(FaultRules::new(after)))
}
