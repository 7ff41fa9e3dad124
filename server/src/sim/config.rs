//! How the tick loop runs: rates, channel capacities, limits, recording
//! and the seek memory budget, derived from the server's configuration.

use crate::config::ServerConfig;
use crate::metrics::Metrics;
use crate::record::RecorderConfig;
use crate::rules::ControlLimits;

/// Default interval of the in-memory checkpoints seeks start from, ticks.
pub const DEFAULT_CHECKPOINT_TICKS: u64 = 10;

/// How the tick loop runs.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// Ticks per simulation second, Hz.
    pub tick_hz: u32,
    /// Most ticks one loop runs to catch up.
    pub max_catch_up_ticks: u32,
    /// Most clients at once.
    pub max_clients: u32,
    /// Caps on what rules may do to bodies.
    pub limits: ControlLimits,
    /// Capacity of the control channel, commands.
    pub control_capacity: usize,
    /// Capacity of the input channel, inputs.
    pub input_capacity: usize,
    /// Most control commands handled per loop.
    pub max_control_per_loop: usize,
    /// Most inputs handled per loop.
    pub max_inputs_per_loop: usize,
    /// Where to report tick durations, overruns, bodies and clients.
    pub metrics: Option<Metrics>,
    /// Where and how to record; `None`: this simulation cannot record.
    pub recording: Option<RecorderConfig>,
    /// Start recording as the simulation starts (needs `recording`).
    pub record_at_start: bool,
    /// Most bytes of keyframes and checkpoints held in memory for seeking
    /// (every tick's hash and journal entry are held beyond it; see
    /// [`crate::replay::history`]).
    pub history_budget: usize,
    /// While recording, a checkpoint of the whole state is held in memory
    /// every this many ticks (0: none), so a seek re-simulates at most
    /// that many ticks.
    pub checkpoint_ticks: u64,
    /// Ask for real-time priority for the tick thread and its physics
    /// workers ([`crate::priority::raise_tick_thread`]).
    pub tick_realtime: bool,
    /// The most game rules may look back when they answer a player's
    /// input against the world the player saw (lag compensation), ms
    /// (default 1000). The window kept is what the rules ask for
    /// ([`crate::rules::GameRules::rewind_window_ms`]) up to this; see
    /// [`super::pose_history`]. A view older than the window is answered
    /// at the oldest tick kept.
    pub max_rewind_ms: u32,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self::from(&ServerConfig::default())
    }
}

impl From<&ServerConfig> for SimConfig {
    fn from(c: &ServerConfig) -> Self {
        SimConfig {
            tick_hz: c.tick_hz,
            max_catch_up_ticks: c.max_catch_up_ticks,
            max_clients: c.max_clients,
            limits: ControlLimits::default(),
            control_capacity: 256,
            // Four seconds of 60 Hz inputs from every client.
            input_capacity: (c.max_clients as usize * 240).max(1024),
            max_control_per_loop: 64,
            max_inputs_per_loop: (c.max_clients as usize * 8).max(256),
            metrics: None,
            recording: None,
            record_at_start: false,
            history_budget: usize::try_from(c.seek_memory_mb << 20).unwrap_or(usize::MAX),
            checkpoint_ticks: c.checkpoint_ticks,
            tick_realtime: c.tick_realtime,
            max_rewind_ms: super::pose_history::DEFAULT_MAX_REWIND_MS,
        }
    }
}
