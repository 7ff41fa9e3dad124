//! Counters the tick thread keeps and anyone may read at any time.

use std::sync::atomic::AtomicU64;
use std::time::Duration;

/// Ticks whose durations [`Simulation::tick_p99`] looks at.
pub const TICK_WINDOW: usize = 600;
/// Wall time over which [`Simulation::achieved_rate`] counts ticks.
pub const RATE_WINDOW: Duration = Duration::from_secs(1);

/// Counters shared with the tick thread (read at any time).
#[derive(Debug, Default)]
pub struct SimStats {
    /// Ticks run.
    pub ticks: AtomicU64,
    /// Turns of the tick thread's loop, paused or not: a count that stops
    /// moving means the loop is stuck (what the orchestrator's health
    /// pings watch).
    pub loops: AtomicU64,
    /// Loops that hit the catch-up cap.
    pub overruns: AtomicU64,
    /// Simulation ticks dropped by overruns.
    pub dropped_ticks: AtomicU64,
    /// Wall time of the last tick, ns.
    pub last_tick_ns: AtomicU64,
    /// Inputs refused by the rules.
    pub inputs_rejected: AtomicU64,
    /// Queries the rules answered against the world as a player saw it
    /// (lag compensation: [`crate::rules::SimContext::cast_ray_at`]).
    pub rewinds: AtomicU64,
    /// Of those, the ones whose view was older than the pose window and
    /// were answered at its oldest tick (the rewind cap).
    pub rewinds_clamped: AtomicU64,
    /// Commands refused because a channel was full.
    pub commands_dropped: AtomicU64,
    /// Rigid bodies in the world.
    pub bodies: AtomicU64,
    /// Clients in the game.
    pub clients: AtomicU64,
    /// Physics steps that returned an error (should stay 0).
    pub step_errors: AtomicU64,
    /// Why the game rules ended the match, once they have
    /// ([`crate::rules::GameRules::match_over`]).
    pub match_over: tokio::sync::watch::Sender<Option<String>>,
    /// Recordings stopped because the recorder dropped a record.
    pub record_gaps: AtomicU64,
}
