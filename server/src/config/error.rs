//! Why a configuration was refused.

use std::net::SocketAddr;
use std::path::PathBuf;

use super::{
    MAX_BODIES_LIMIT, MAX_CLIENTS_LIMIT, MAX_KEYFRAME_TICKS, MAX_PHYSICS_THREADS,
    MAX_REPLAYS_LIMIT, MAX_REPLAY_WINDOW_S, MAX_RETRY_ABOVE_PER_SEC, MAX_TICK_HZ,
    MIN_RECORD_MAX_BYTES,
};

/// Why the configuration was refused. Each says which setting and how to
/// fix it.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The command line did not parse (also `--help` and `--version`, which
    /// clap renders through this; call `.exit()` on the inner error).
    #[error(transparent)]
    Cli(#[from] clap::Error),
    /// The configuration file could not be read.
    #[error("cannot read config file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The configuration file is not valid TOML for these settings.
    #[error("config file {path}: at `{key}`: {message}")]
    Toml {
        /// The file.
        path: PathBuf,
        /// Dotted path of the offending key (`.` for the whole document).
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// An `INERTIA_*` environment variable did not parse.
    #[error("environment variable {var}={value:?}: {why}")]
    Env {
        /// The variable.
        var: String,
        /// Its value.
        value: String,
        /// Why it was refused.
        why: String,
    },
    /// `tick_hz` outside 1..=1000.
    #[error("tick_hz must be in 1..={MAX_TICK_HZ}, got {0}")]
    TickHz(u32),
    /// `match_seconds` out of range.
    #[error("match_seconds must be in 1..={max}, got {0}", max = crate::orchestrator::allocation::MAX_MATCH_SECONDS)]
    MatchSeconds(u64),
    /// `snapshot_hz` zero or above the tick rate (a snapshot between two
    /// ticks would repeat the last one).
    #[error("snapshot_hz must be in 1..=tick_hz ({tick_hz}), got {snapshot_hz}")]
    SnapshotHz {
        /// The snapshot rate given, Hz.
        snapshot_hz: u32,
        /// The tick rate, Hz.
        tick_hz: u32,
    },
    /// A snapshot grid step outside 0.01..=100 mm (or not a number).
    #[error("position_resolution_mm must be in 0.01..=100, got {0}")]
    PositionResolution(f64),
    /// A zero bandwidth budget.
    #[error("client_budget_kbps must be > 0")]
    ClientBudget,
    /// `max_clients` outside 1..=4096.
    #[error("max_clients must be in 1..={MAX_CLIENTS_LIMIT}, got {0}")]
    MaxClients(u32),
    /// `retry_above_per_sec` above 100000.
    #[error("retry_above_per_sec must be in 0..={MAX_RETRY_ABOVE_PER_SEC}, got {0}")]
    RetryAbove(u32),
    /// `max_bodies` outside 1..=10000000.
    #[error("max_bodies must be in 1..={MAX_BODIES_LIMIT}, got {0}")]
    MaxBodies(usize),
    /// `physics_threads` above 256.
    #[error("physics_threads must be in 0..={MAX_PHYSICS_THREADS}, got {0}")]
    PhysicsThreads(usize),
    /// `seek_memory_mb` outside 16..=1048576.
    #[error("seek_memory_mb must be in 16..=1048576, got {0}")]
    SeekMemory(u64),
    /// `replay_window_s` above 300.
    #[error("replay_window_s must be at most {MAX_REPLAY_WINDOW_S}, got {0}")]
    ReplayWindow(u32),
    /// `max_replays` above 256.
    #[error("max_replays must be at most {MAX_REPLAYS_LIMIT}, got {0}")]
    MaxReplays(u32),
    /// `checkpoint_ticks` above 1000000.
    #[error("checkpoint_ticks must be at most {MAX_KEYFRAME_TICKS}, got {0}")]
    CheckpointTicks(u64),
    /// `keyframe_ticks` outside 1..=1000000.
    #[error("keyframe_ticks must be in 1..={MAX_KEYFRAME_TICKS}, got {0}")]
    KeyframeTicks(u64),
    /// `record_max_bytes` under 1 MiB.
    #[error("record_max_bytes must be at least {MIN_RECORD_MAX_BYTES}, got {0}")]
    RecordMaxBytes(u64),
    /// `max_catch_up_ticks` outside 1..=1000.
    #[error("max_catch_up_ticks must be in 1..=1000, got {0}")]
    CatchUp(u32),
    /// Only one of `cert_file` and `cert_key_file` was given.
    #[error("cert_file and cert_key_file go together: give both or neither")]
    CertPair,
    /// The game and metrics endpoints share an address (an operator's
    /// slip: one is UDP, the other TCP, but they would be confused).
    #[error("listen and metrics addresses are both {0}")]
    SameAddress(SocketAddr),
}
