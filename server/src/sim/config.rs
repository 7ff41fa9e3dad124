//! How the tick loop runs: rates, channel capacities, limits, recording
//! and the seek memory budget (the server's configuration derives it:
//! [`crate::config`]).

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
    /// [`crate::pose_history`]. A view older than the window is answered
    /// at the oldest tick kept.
    pub max_rewind_ms: u32,
}
