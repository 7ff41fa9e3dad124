//! What every admin connection of a server shares: the simulation, the
//! credentials and their throttle, where checkpoints and matches are kept,
//! and the clients an operator may kick.

use std::sync::{Arc, Mutex};

use inertia_protocol::control::DisconnectReason;
use tokio::sync::watch;

use super::kicks::Kicks;
use super::throttle::{HelloThrottle, ThrottleConfig};
use super::tokens::AdminTokenStore;
use crate::metrics::Metrics;
use crate::record::matches::MatchesDir;
use crate::replay::checkpoint::CheckpointDir;
use crate::sim::SimHandle;

/// State shared by a server's admin connections.
#[derive(Debug)]
pub struct AdminShared {
    /// The simulation.
    pub sim: Arc<SimHandle>,
    /// Metrics.
    pub metrics: Metrics,
    /// Physics ticks per simulation second, Hz (told in the welcome).
    pub tick_hz: u32,
    /// Becomes the reason every connection is given when the server stops.
    pub shutdown: watch::Receiver<Option<DisconnectReason>>,
    /// Who the admin channel admits (none by default).
    pub tokens: Arc<AdminTokenStore>,
    /// Failed admin hellos by source address.
    pub throttle: Mutex<HelloThrottle>,
    /// Where `save` and `load` keep checkpoints.
    pub checkpoints: CheckpointDir,
    /// Where finished matches' recordings are kept.
    pub matches: MatchesDir,
    /// The connected clients an operator may kick.
    pub kicks: Arc<Kicks>,
}

impl AdminShared {
    /// Admin state for a server: no credentials, the default throttle,
    /// and checkpoints and matches kept where `checkpoints` and `matches`
    /// say.
    pub fn new(
        sim: Arc<SimHandle>,
        metrics: Metrics,
        tick_hz: u32,
        shutdown: watch::Receiver<Option<DisconnectReason>>,
        checkpoints: CheckpointDir,
        matches: MatchesDir,
    ) -> Self {
        Self {
            sim,
            tokens: Arc::new(AdminTokenStore::none(metrics.clone())),
            metrics,
            tick_hz,
            shutdown,
            throttle: Mutex::new(HelloThrottle::default()),
            checkpoints,
            matches,
            kicks: Arc::default(),
        }
    }

    /// The same, admitting admin connections with the credentials of
    /// `tokens`.
    pub fn with_tokens(mut self, tokens: Arc<AdminTokenStore>) -> Self {
        self.tokens = tokens;
        self
    }

    /// The same, throttling failed admin hellos with `config`.
    pub fn with_throttle(mut self, config: ThrottleConfig) -> Self {
        self.throttle = Mutex::new(HelloThrottle::new(config));
        self
    }
}
