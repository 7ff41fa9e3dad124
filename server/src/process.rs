//! The `inertia-server` process around a [`GameRules`]: configuration from
//! the command line, environment and TOML, logging, the I/O runtime, serving
//! until SIGTERM, Ctrl-C or the end of the match, re-reading the secrets
//! on SIGHUP ([`crate::secrets`]; only the admin token file in dev mode,
//! [`AdminTokenStore::reload`]), and the exit status an orchestrator acts
//! on.
//! A studio's own server binary is its rules and this process:
//!
//! ```no_run
//! # use inertia_server::rules::SandboxRules;
//! fn main() -> std::process::ExitCode {
//!     inertia_server::process::Game::new(|_config| Box::new(SandboxRules::default()))
//!         .default_scene(inertia_server::scene::demo::DEMO_RON)
//!         .run()
//! }
//! ```
//!
//! ([`run`] is the same with the built-in demo scene), best with the
//! allocator `inertia-server` declares
//! (`#[global_allocator] static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;`):
//! the capacity figures are measured with it, and glibc's allocator
//! serialises the tick thread and the network workers on its arena locks.
//!
//! Exit status: 0 after a requested stop; 1 when the server could not
//! start; 2 for a bad configuration; 3 when the simulation failed while
//! serving (health checks fail first and clients are told, then the
//! process exits so an orchestrator restarts it, with `--resume` to carry
//! on from the recording).

use std::process::ExitCode;

use clap::error::ErrorKind;
use tracing_subscriber::EnvFilter;

use crate::admin::tokens::AdminTokenStore;
use crate::config::{binary_name, ConfigError, LogFormat, ServerConfig};
use crate::rules::GameRules;
use crate::secrets::Secrets;

/// Exit status after the simulation failed while serving.
pub const EXIT_SIMULATION_FAILED: u8 = 3;

/// A game's server process: its rules and the scene it plays when the
/// configuration names none, run as `inertia-server` runs (every option,
/// dev mode, signals, Agones, recording, admin, metrics).
pub struct Game<F> {
    make_rules: F,
    default_scene: &'static str,
}

impl<F> std::fmt::Debug for Game<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Game")
            .field("default_scene", &self.default_scene.len())
            .finish_non_exhaustive()
    }
}

impl<F: FnOnce(&ServerConfig) -> Box<dyn GameRules>> Game<F> {
    /// The game whose rules `make_rules` builds (called once, after the
    /// configuration is read), on the built-in demo scene until
    /// [`Game::default_scene`] names its own.
    pub fn new(make_rules: F) -> Self {
        Self {
            make_rules,
            default_scene: crate::scene::demo::DEMO_RON,
        }
    }

    /// The scene (RON text, see `docs/scene-format.md`) the game plays
    /// when `--scene` names none: typically `include_str!` of the game's
    /// own file.
    pub fn default_scene(mut self, ron: &'static str) -> Self {
        self.default_scene = ron;
        self
    }

    /// Runs the process until it is stopped or the match ends; the exit
    /// status as the module docs say.
    pub fn run(self) -> ExitCode {
        run_game(self.make_rules, self.default_scene)
    }
}

/// Runs the server process with the rules `make_rules` builds on the
/// built-in demo scene (unless `--scene` names one): [`Game::new`] then
/// [`Game::run`]. See the module docs for the exit status.
pub fn run(make_rules: impl FnOnce(&ServerConfig) -> Box<dyn GameRules>) -> ExitCode {
    Game::new(make_rules).run()
}

fn run_game(
    make_rules: impl FnOnce(&ServerConfig) -> Box<dyn GameRules>,
    default_scene: &'static str,
) -> ExitCode {
    // The running binary's name, for its messages: `inertia-server` or a
    // game's own.
    let name = binary_name(std::env::args_os().next().as_deref());
    let config = match ServerConfig::from_process() {
        Ok(c) => c,
        // Asked for: to standard output, and done.
        Err(ConfigError::Cli(e))
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) =>
        {
            return print_asked(&name, &e.to_string());
        }
        Err(ConfigError::Cli(e)) => {
            // clap's own rendering: the usage and a hint.
            eprint!("{e}");
            return ExitCode::from(2);
        }
        Err(e) => {
            eprintln!("{name}: {e}");
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
            eprintln!("{name}: cannot start the I/O runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    let rules = make_rules(&config);
    let code = runtime.block_on(async move {
        // Listened for before the server starts, so a SIGHUP that comes
        // once it serves never falls to the default action (ending it).
        let hangups = hangups();
        let server = match crate::server::start_game(config, rules, default_scene).await {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{name}: {e}");
                return ExitCode::FAILURE;
            }
        };
        if let Some(path) = server.credentials_path() {
            eprintln!(
                "{}: dev mode on {} (metrics on http://{}); credentials in {}",
                name,
                server.addr(),
                server.metrics_addr(),
                path.display()
            );
        }
        let reloads = tokio::spawn(reload_on_hangup(
            hangups,
            server.secrets(),
            server.admin_tokens(),
        ));
        let mut ended = None;
        let code = tokio::select! {
            () = wait_for_stop() => ExitCode::SUCCESS,
            why = server.match_over() => {
                ended = Some(why);
                ExitCode::SUCCESS
            }
            why = server.failed() => {
                eprintln!("{name}: {why}; exiting for a restart");
                ExitCode::from(EXIT_SIMULATION_FAILED)
            }
        };
        reloads.abort();
        match ended {
            Some(why) => {
                server.end_match(why).await;
            }
            None => server.shutdown().await,
        }
        code
    });
    // Blocking work still running (a save's file, say) does not hold up
    // the exit: shutdown has already had its deadline.
    runtime.shutdown_timeout(EXIT_GRACE);
    code
}

/// Prints what was asked for (the help, the version) to standard output:
/// status 0, or, when the output cannot take it, a line on standard error
/// and status 1. A reader that went away (`--help | head -1`) is not an
/// error: status 0, and nothing said.
fn print_asked(name: &str, text: &str) -> ExitCode {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{name}: cannot write to standard output: {e}");
            ExitCode::FAILURE
        }
    }
}

/// How long blocking tasks still running at exit are waited for.
const EXIT_GRACE: std::time::Duration = std::time::Duration::from_secs(1);

/// The stream of SIGHUPs, where there is one.
#[cfg(unix)]
type Hangups = Option<tokio::signal::unix::Signal>;
#[cfg(not(unix))]
type Hangups = Option<()>;

fn hangups() -> Hangups {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        match signal(SignalKind::hangup()) {
            Ok(s) => Some(s),
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen for SIGHUP; the admin token file will not be reloaded");
                None
            }
        }
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// At each SIGHUP, reads the secrets again (outside dev mode: token key,
/// certificate, and the admin token file; see [`crate::secrets`]), or
/// only the admin token file in dev mode. On the blocking pool; each
/// reload logs its outcome.
async fn reload_on_hangup(
    hangups: Hangups,
    secrets: Option<std::sync::Arc<Secrets>>,
    tokens: std::sync::Arc<AdminTokenStore>,
) {
    #[cfg(unix)]
    {
        let Some(mut hangups) = hangups else { return };
        while hangups.recv().await.is_some() {
            tracing::info!(target: "inertia::admin", "SIGHUP: reloading the secrets");
            let (secrets, tokens) = (secrets.clone(), tokens.clone());
            let _ = tokio::task::spawn_blocking(move || match secrets {
                Some(secrets) => secrets.reload_logged(),
                None => {
                    let _ = tokens.reload();
                }
            })
            .await;
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (hangups, secrets, tokens);
    }
}

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
