//! `inertia-server`: runs one world and serves it until SIGTERM or Ctrl-C,
//! then shuts down within
//! [`SHUTDOWN_DEADLINE`](inertia_server::server::SHUTDOWN_DEADLINE) and
//! exits.

use std::process::ExitCode;
use std::time::Duration;

use inertia_server::config::{LogFormat, ServerConfig};
use tracing_subscriber::EnvFilter;

fn main() -> ExitCode {
    let config = match ServerConfig::from_process() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("inertia-server: {e}");
            return ExitCode::from(2);
        }
    };
    let filter = EnvFilter::try_from_env("INERTIA_LOG").unwrap_or_else(|_| EnvFilter::new("info"));
    match config.log_format {
        LogFormat::Json => tracing_subscriber::fmt()
            .json()
            .with_env_filter(filter)
            .init(),
        LogFormat::Text => tracing_subscriber::fmt().with_env_filter(filter).init(),
    }
    let runtime = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .thread_name("inertia-io")
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("inertia-server: cannot start the I/O runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    let code = runtime.block_on(async move {
        let server = match inertia_server::server::start(config).await {
            Ok(s) => s,
            Err(e) => {
                eprintln!("inertia-server: {e}");
                return ExitCode::FAILURE;
            }
        };
        if let Some(path) = server.credentials_path() {
            eprintln!(
                "inertia-server: dev mode on {} (metrics on http://{}); credentials in {}",
                server.addr(),
                server.metrics_addr(),
                path.display()
            );
        }
        wait_for_stop().await;
        server.shutdown().await;
        ExitCode::SUCCESS
    });
    // Blocking work still running (a save's file, say) does not hold up
    // the exit: shutdown has already had its deadline.
    runtime.shutdown_timeout(EXIT_GRACE);
    code
}

/// How long blocking tasks still running at exit are waited for.
const EXIT_GRACE: Duration = Duration::from_secs(1);

/// Waits for SIGTERM or Ctrl-C.
async fn wait_for_stop() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = term.recv() => {}
                    _ = tokio::signal::ctrl_c() => {}
                }
            }
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}
