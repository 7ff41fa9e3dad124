//! Who runs this server process: nobody in particular (**standalone**: a
//! developer's machine, a plain Deployment, systemd), or **Agones**, the
//! game-server orchestrator on Kubernetes, through its SDK server sidecar.
//!
//! `--orchestrator auto` (the default) picks Agones when Agones's
//! environment is there (`AGONES_SDK_HTTP_PORT`, which Agones sets in every
//! game server container), standalone otherwise.
//!
//! Under Agones the server ([`agones`]):
//! - calls `Ready` once the scene is built and the game port bound,
//!   retrying until the sidecar answers (it may start after the server);
//! - pings `Health` every half health period while the tick loop is turning
//!   ([`heartbeat`]): a stalled tick stops the pings, and Agones marks the
//!   game server Unhealthy;
//! - watches the game server, and on `Allocated` reads the match's
//!   settings from its labels and annotations ([`allocation`]): the match
//!   length ends the match (drain, then `Shutdown`);
//! - keeps the counter and the list `players` (Agones's Counts and Lists)
//!   equal to the clients connected, when the game server declares them;
//! - calls `Shutdown` once the server has drained and stopped.
//!
//! An SDK server that goes away is logged once, and the server keeps
//! serving; calls resume when it is back.

pub mod allocation;
pub mod heartbeat;
pub mod sdk;

mod agones;

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::Deserialize;
use tokio::sync::watch;

pub use allocation::MatchSettings;

/// How the orchestrator is chosen (`--orchestrator`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum OrchestratorMode {
    /// Agones when `AGONES_SDK_HTTP_PORT` is set, else standalone.
    #[default]
    Auto,
    /// No orchestrator.
    Standalone,
    /// Agones (the SDK server on `AGONES_SDK_HTTP_PORT`, default 9358).
    Agones,
}

impl std::str::FromStr for OrchestratorMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(OrchestratorMode::Auto),
            "standalone" => Ok(OrchestratorMode::Standalone),
            "agones" => Ok(OrchestratorMode::Agones),
            _ => Err(format!(
                "expected `auto`, `standalone` or `agones`, got `{s}`"
            )),
        }
    }
}

/// The orchestrator the server works with, once chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orchestrating {
    /// None.
    Standalone,
    /// Agones, its SDK server's REST API on loopback at this port.
    Agones { sdk_port: u16 },
}

impl Orchestrating {
    /// The choice `mode` makes, with `agones_port` the value of
    /// `AGONES_SDK_HTTP_PORT` if set.
    pub fn choose(mode: OrchestratorMode, agones_port: Option<u16>) -> Orchestrating {
        match (mode, agones_port) {
            (OrchestratorMode::Standalone, _) | (OrchestratorMode::Auto, None) => {
                Orchestrating::Standalone
            }
            (OrchestratorMode::Agones | OrchestratorMode::Auto, port) => Orchestrating::Agones {
                sdk_port: port.unwrap_or(sdk::DEFAULT_HTTP_PORT),
            },
        }
    }
}

/// What the orchestrator reads of the running server.
#[derive(Clone)]
pub struct Probe {
    /// Turns of the tick loop so far ([`crate::sim::SimStats::loops`]).
    pub loops: Arc<dyn Fn() -> u64 + Send + Sync>,
    /// Ids of the clients connected now, ascending.
    pub players: Arc<dyn Fn() -> Vec<u64> + Send + Sync>,
    /// Most clients at once (the players' capacity).
    pub capacity: u32,
}

impl std::fmt::Debug for Probe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Probe")
            .field("capacity", &self.capacity)
            .finish_non_exhaustive()
    }
}

/// The match an allocation started.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Allocation {
    /// What it asked for.
    pub settings: MatchSettings,
    /// When the server saw it.
    pub at: Instant,
}

/// The orchestrator's side of a running server.
#[derive(Debug)]
pub struct Orchestrator {
    agones: Option<agones::Agones>,
    /// When the server became ready.
    started: Instant,
    allocation: watch::Receiver<Option<Allocation>>,
}

impl Orchestrator {
    /// Starts working with `how`, reading the server through `probe`.
    /// Called once the scene is built and the game port bound.
    pub fn start(how: Orchestrating, probe: Probe) -> Orchestrator {
        let (allocated, allocation) = watch::channel(None);
        let agones = match how {
            Orchestrating::Standalone => None,
            Orchestrating::Agones { sdk_port } => Some(agones::Agones::start(
                sdk::Sdk::on_port(sdk_port),
                probe,
                allocated,
            )),
        };
        Orchestrator {
            agones,
            started: Instant::now(),
            allocation,
        }
    }

    /// The allocation, to wait for.
    pub fn watch_allocation(&self) -> watch::Receiver<Option<Allocation>> {
        self.allocation.clone()
    }

    /// The match the server was allocated for, once it has been.
    pub fn allocation(&self) -> Option<Allocation> {
        self.allocation.borrow().clone()
    }

    /// Waits until the match's length has passed: under Agones from the
    /// allocation (its own length, else `length`), standalone from the
    /// start (`length`). Never returns for a match without a length, nor
    /// for a game server never allocated.
    pub async fn match_over(&self, length: Option<Duration>) {
        let end = if self.agones.is_none() {
            length.map(|l| self.started + l)
        } else {
            let mut allocation = self.allocation.clone();
            let allocated = match allocation.wait_for(Option::is_some).await {
                Ok(a) => a.clone(),
                Err(_) => None,
            };
            allocated.and_then(|a| Some(a.at + a.settings.length.or(length)?))
        };
        match end {
            Some(end) => tokio::time::sleep_until(end.into()).await,
            None => std::future::pending().await,
        }
    }

    /// The server has drained and stopped: stops the health pings and
    /// tells the orchestrator (Agones: `Shutdown`, once, within the SDK
    /// call's timeout).
    pub async fn shutdown(&self) {
        if let Some(agones) = &self.agones {
            agones.shutdown().await;
        }
    }
}
