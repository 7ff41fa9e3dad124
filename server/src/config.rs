//! Server configuration: command line, environment, TOML file, defaults.
//!
//! Each setting is taken from the first source that has it, in this order:
//!
//! 1. the command line (`--tick-hz 120`),
//! 2. the environment (`INERTIA_TICK_HZ=120`),
//! 3. the TOML file named by `--config FILE` (or `INERTIA_CONFIG`),
//! 4. the defaults below.
//!
//! Every source is parsed into the same all-optional [`ConfigLayer`], the
//! layers are merged field by field, and the result is checked once
//! ([`ServerConfig::validate`]). The environment is passed in as a lookup
//! function rather than read from the process, so precedence is testable
//! without touching global state; [`ServerConfig::from_process`] is the
//! one-line entry point for `main`.
//!
//! Credentials decide the mode: with no token key and no certificate the
//! server runs in **dev mode** (self-signed certificate, dev connect tokens)
//! and listens on loopback unless told otherwise; with them it listens on
//! every interface.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};

use clap::Parser;
use inertia_protocol::connection::ServerConnectionConfig;

use crate::orchestrator::{Orchestrating, OrchestratorMode};
use crate::sim::SimConfig;
use serde::Deserialize;

/// Default UDP port of the QUIC game and admin endpoint.
pub const DEFAULT_PORT: u16 = 7777;
/// Default simulation rate, ticks per second of simulation time.
pub const DEFAULT_TICK_HZ: u32 = 60;
/// Default snapshot rate, snapshots per wall second per client.
pub const DEFAULT_SNAPSHOT_HZ: u32 = 30;
/// Default per-client downstream budget, kbit/s (512 kbit/s = 64 kB/s: room
/// for a few hundred moving entities at 30 Hz after delta compression).
pub const DEFAULT_CLIENT_BUDGET_KBPS: u32 = 512;
/// Default snapshot position grid step, mm.
pub const DEFAULT_POSITION_RESOLUTION_MM: f64 = 1.0;
/// Default most clients connected at once.
pub const DEFAULT_MAX_CLIENTS: u32 = 64;
/// Default most rigid bodies in the world at once: the scene, spawns,
/// avatars and loaded states together.
pub const DEFAULT_MAX_BODIES: usize = 20_000;
/// Highest accepted body limit.
pub const MAX_BODIES_LIMIT: usize = 10_000_000;
/// The most threads `physics_threads` may ask for.
pub const MAX_PHYSICS_THREADS: usize = 256;
/// Default most ticks run in one loop of the tick thread before it gives up
/// on catching up and counts an overrun.
pub const DEFAULT_MAX_CATCH_UP_TICKS: u32 = 5;
/// Default keyframe interval of the recording, ticks (10 s at 60 Hz).
pub const DEFAULT_KEYFRAME_TICKS: u64 = crate::record::recorder::DEFAULT_KEYFRAME_TICKS;
/// Default retention limit of the recording, bytes (2 GiB).
pub const DEFAULT_RECORD_MAX_BYTES: u64 = crate::record::recorder::DEFAULT_RECORD_MAX_BYTES;
/// Highest accepted keyframe interval, ticks.
pub const MAX_KEYFRAME_TICKS: u64 = 1_000_000;
/// Default memory for seeking (keyframes and checkpoints held), MiB.
pub const DEFAULT_SEEK_MEMORY_MB: u64 = (crate::replay::DEFAULT_KEYFRAME_BUDGET >> 20) as u64;
/// Least and most memory for seeking, MiB.
pub const SEEK_MEMORY_MB_RANGE: std::ops::RangeInclusive<u64> = 16..=1_048_576;
/// Default interval of the in-memory checkpoints, ticks.
pub const DEFAULT_CHECKPOINT_TICKS: u64 = crate::sim::DEFAULT_CHECKPOINT_TICKS;
/// Smallest accepted retention limit, bytes (1 MiB).
pub const MIN_RECORD_MAX_BYTES: u64 = 1024 * 1024;
/// Highest accepted tick rate, Hz.
pub const MAX_TICK_HZ: u32 = 1000;
/// Highest accepted client count.
pub const MAX_CLIENTS_LIMIT: u32 = 4096;
/// Highest accepted `retry_above_per_sec`.
pub const MAX_RETRY_ABOVE_PER_SEC: u32 = 100_000;

/// How log lines are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum LogFormat {
    /// Human-readable lines.
    #[default]
    Text,
    /// One JSON object per line (for log collectors).
    Json,
}

impl std::str::FromStr for LogFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "text" => Ok(LogFormat::Text),
            "json" => Ok(LogFormat::Json),
            _ => Err(format!("expected `text` or `json`, got `{s}`")),
        }
    }
}

/// Whether the physics workers are pinned one to a core
/// ([`inertia_physics::ThreadPinning`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PhysicsPinning {
    /// Where the process may run on no more cores than it has physics
    /// threads (it owns them: dedicated cores, a pod under Kubernetes'
    /// static CPU manager policy).
    #[default]
    Auto,
    /// Never: the OS places the workers.
    Never,
    /// Always, worker `k` to the `k`-th core the process may run on.
    Always,
}

impl std::str::FromStr for PhysicsPinning {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(PhysicsPinning::Auto),
            "never" => Ok(PhysicsPinning::Never),
            "always" => Ok(PhysicsPinning::Always),
            _ => Err(format!("expected `auto`, `never` or `always`, got `{s}`")),
        }
    }
}

impl From<PhysicsPinning> for inertia_physics::ThreadPinning {
    fn from(p: PhysicsPinning) -> Self {
        match p {
            PhysicsPinning::Auto => Self::Auto,
            PhysicsPinning::Never => Self::Never,
            PhysicsPinning::Always => Self::Always,
        }
    }
}

/// One source's settings: every field optional. The command line, the
/// environment and the TOML file each produce one; see the module docs for
/// units and meanings (they are those of [`ServerConfig`]).
#[derive(Debug, Clone, Default, PartialEq, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub struct ConfigLayer {
    /// UDP address for QUIC (default 127.0.0.1:7777 in dev mode, else 0.0.0.0:7777).
    #[arg(long)]
    pub listen: Option<SocketAddr>,
    /// Scene file (.ron or .json); none = the built-in demo.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Simulation ticks per second of simulation time (1..=1000, default 60).
    #[arg(long)]
    pub tick_hz: Option<u32>,
    /// Snapshots per wall second per client (1..=tick_hz, default 30).
    #[arg(long)]
    pub snapshot_hz: Option<u32>,
    /// Per-client downstream bandwidth budget, kbit/s (default 512).
    #[arg(long)]
    pub client_budget_kbps: Option<u32>,
    /// Most clients at once (1..=4096, default 64).
    #[arg(long)]
    pub max_clients: Option<u32>,
    /// QUIC address validation: above this many new connections a second,
    /// an address that has not proven itself gets a Retry (one round trip
    /// more) before any handshake work; 0 (the default): always
    /// (0..=100000).
    #[arg(long)]
    pub retry_above_per_sec: Option<u32>,
    /// Most rigid bodies in the world at once: a scene with more is
    /// refused at start, and spawns, avatars and loads beyond it are
    /// refused (1..=10000000, default 20000).
    #[arg(long)]
    pub max_bodies: Option<usize>,
    /// Directory for recordings and other data (default ./inertia-data).
    #[arg(long)]
    pub data_dir: Option<PathBuf>,
    /// Directory of the admin channel's `save` and `load` checkpoints,
    /// which name files in it and nowhere else (default
    /// <data-dir>/checkpoints, made mode 0700 on the first save).
    #[arg(long)]
    pub checkpoint_dir: Option<PathBuf>,
    /// TCP address of /metrics, /healthz and /readyz (default 127.0.0.1:9100).
    #[arg(long)]
    pub metrics: Option<SocketAddr>,
    /// Connect-token key file; absent (with no certificate) = dev mode.
    #[arg(long)]
    pub key_file: Option<PathBuf>,
    /// TLS certificate chain (PEM); needs --cert-key-file.
    #[arg(long)]
    pub cert_file: Option<PathBuf>,
    /// TLS private key (PEM) of --cert-file.
    #[arg(long)]
    pub cert_key_file: Option<PathBuf>,
    /// Admin operators and their tokens: one `NAME TOKEN` a line (tokens of
    /// at least 32 characters; `#` comment lines), mode 0600. Re-read on
    /// SIGHUP. Without it, outside dev mode, the admin channel admits no
    /// one (see docs/admin.md).
    #[arg(long, value_name = "FILE")]
    pub admin_token_file: Option<PathBuf>,
    /// Log line format: text or json (default text).
    #[arg(long, value_enum)]
    pub log_format: Option<LogFormat>,
    /// Who runs this process: auto (Agones when AGONES_SDK_HTTP_PORT is
    /// set, else standalone), standalone or agones (default auto).
    #[arg(long, value_enum)]
    pub orchestrator: Option<OrchestratorMode>,
    /// Where finished matches' recordings are kept and served from
    /// (default <data-dir>/matches). A volume shared by a fleet's game
    /// servers keeps every match's recording past its pod.
    #[arg(long, value_name = "DIR")]
    pub matches_dir: Option<PathBuf>,
    /// Directory of the scenes an Agones allocation may ask for by name
    /// (`inertia.dev/scene`: a file name in it, `.ron` or `.json`); none:
    /// an allocation's scene is not applied.
    #[arg(long, value_name = "DIR")]
    pub scenes_dir: Option<PathBuf>,
    /// Directory of the browser page's modules (`web/`'s TypeScript build,
    /// `web/dist/src`), served at `/play` on the metrics listener (default:
    /// `web/dist/src` when it exists under the working directory).
    #[arg(long, value_name = "DIR")]
    pub web_dir: Option<PathBuf>,
    /// The match ends (drain, goodbye `MatchOver`, exit 0) this many
    /// seconds after the start, or under Agones after the allocation,
    /// unless the allocation sets its own length (1..=86400; default: no
    /// limit).
    #[arg(long)]
    pub match_seconds: Option<u64>,
    /// Most ticks one loop of the tick thread may run to catch up (1..=1000,
    /// default 5); beyond it the backlog is dropped and an overrun counted.
    #[arg(long)]
    pub max_catch_up_ticks: Option<u32>,
    /// Snapshot position grid step, mm (0.01..=100, default 1): positions
    /// reach clients within half a step per axis.
    #[arg(long)]
    pub position_resolution_mm: Option<f64>,
    /// Record the session into <data-dir>/recording (default true;
    /// `--record false` turns it off).
    #[arg(long, value_name = "BOOL", num_args = 0..=1, default_missing_value = "true")]
    pub record: Option<bool>,
    /// Run the tick thread and its physics workers at real-time priority
    /// (SCHED_FIFO 10; needs CAP_SYS_NICE or an RLIMIT_RTPRIO that allows
    /// it, else the tick falls back to a raised nice value), and the
    /// snapshot encoders below it (SCHED_FIFO 5): a steady tick and steady
    /// snapshot slots on a machine whose cores are all busy (default
    /// false). At fast forward the tick then takes a whole core.
    #[arg(long, value_name = "BOOL", num_args = 0..=1, default_missing_value = "true")]
    pub tick_realtime: Option<bool>,
    /// Threads that step the physics (0..=256; default 0: half the
    /// machine's cores, at least one, leaving the rest to the snapshot
    /// encoders and the network). One thread steps inline, with no
    /// hand-off between threads.
    #[arg(long)]
    pub physics_threads: Option<usize>,
    /// Pin the physics threads one to a core: auto (where the process may
    /// run on no more cores than it has physics threads), never or always
    /// (default auto). Pinning changes where they run, never the results.
    #[arg(long, value_enum)]
    pub physics_pin_threads: Option<PhysicsPinning>,
    /// A keyframe (the full saved world) every this many ticks
    /// (1..=1000000, default 900).
    #[arg(long)]
    pub keyframe_ticks: Option<u64>,
    /// Most bytes the recording keeps on disk; the oldest segments go
    /// first (at least 1048576, default 2 GiB).
    #[arg(long)]
    pub record_max_bytes: Option<u64>,
    /// Memory for seeking: keyframes and checkpoints held, MiB
    /// (16..=1048576, default 1024); past it the oldest are thinned.
    /// Held beyond it: every tick's hash (8 bytes; 1.7 MB an hour at
    /// 60 Hz) and journal entry (48 bytes, and 64 for each tick with any:
    /// nothing while idle; at 60 Hz 14 MB an hour while inputs arrive, and
    /// 10 MB an hour for each client sending one every tick), and up to 18
    /// whole states on their way to being packed.
    #[arg(long)]
    pub seek_memory_mb: Option<u64>,
    /// A checkpoint of the whole state in memory every this many ticks
    /// while recording, so a seek re-simulates at most that many (0: none;
    /// at most 1000000; default 10).
    #[arg(long)]
    pub checkpoint_ticks: Option<u64>,
    /// Carry on from the recording in <data-dir>/recording (after a crash:
    /// its newest keyframe, re-simulated to the last tick on disk).
    #[arg(long, value_name = "BOOL", num_args = 0..=1, default_missing_value = "true")]
    pub resume: Option<bool>,
}

/// The command line: a [`ConfigLayer`] plus `--config FILE`. `main` may
/// parse this itself (or flatten it into a larger parser) and hand it to
/// [`ServerConfig::resolve`].
#[derive(Debug, Clone, Default, PartialEq, Parser)]
#[command(
    name = "inertia-server",
    about = "The authoritative Inertia physics server"
)]
pub struct ServerArgs {
    /// TOML configuration file (also INERTIA_CONFIG); keys as the long
    /// options with `_` for `-`.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Settings that override the environment and the file.
    #[command(flatten)]
    pub layer: ConfigLayer,
}

/// The settings the server runs with, every field resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct ServerConfig {
    /// UDP address for QUIC as configured; `None` = by mode (see
    /// [`ServerConfig::listen_addr`]).
    pub listen: Option<SocketAddr>,
    /// Scene file (.ron or .json); `None` = the built-in demo scene.
    pub scene: Option<PathBuf>,
    /// Simulation ticks per second of simulation time, Hz; `dt = 1 / tick_hz` s.
    pub tick_hz: u32,
    /// Snapshots per wall second per client, Hz (≤ `tick_hz`).
    pub snapshot_hz: u32,
    /// Per-client downstream bandwidth budget, kbit/s (1000 bit/s units).
    pub client_budget_kbps: u32,
    /// Most clients connected at once.
    pub max_clients: u32,
    /// New connections per second above which unproven addresses get a
    /// QUIC Retry first; 0: always ([`crate::net::gate`]).
    pub retry_above_per_sec: u32,
    /// Most rigid bodies in the world at once.
    pub max_bodies: usize,
    /// Directory for recordings and other data.
    pub data_dir: PathBuf,
    /// Directory of `save` and `load` checkpoints as configured; `None` =
    /// `<data_dir>/checkpoints` (see [`ServerConfig::checkpoint_dir`]).
    pub checkpoint_dir: Option<PathBuf>,
    /// TCP address of the health and Prometheus endpoints.
    pub metrics: SocketAddr,
    /// Connect-token key file; `None` with no certificate = dev mode.
    pub key_file: Option<PathBuf>,
    /// TLS certificate chain (PEM).
    pub cert_file: Option<PathBuf>,
    /// TLS private key (PEM) of `cert_file`.
    pub cert_key_file: Option<PathBuf>,
    /// The admin token file (see [`crate::admin::tokens`]); `None`: outside
    /// dev mode the admin channel admits no one.
    pub admin_token_file: Option<PathBuf>,
    /// Log line format.
    pub log_format: LogFormat,
    /// How the orchestrator is chosen ([`crate::orchestrator`]).
    pub orchestrator: OrchestratorMode,
    /// Length of the match, s (see [`ConfigLayer::match_seconds`]).
    pub match_seconds: Option<u64>,
    /// Scenes an allocation may ask for (see [`ConfigLayer::scenes_dir`]).
    pub scenes_dir: Option<PathBuf>,
    /// The browser page's modules (see [`ConfigLayer::web_dir`]).
    pub web_dir: Option<PathBuf>,
    /// Kept matches' directory, when not <data-dir>/matches (see
    /// [`ConfigLayer::matches_dir`]).
    pub matches_dir: Option<PathBuf>,
    /// The Agones SDK server's REST port, from `AGONES_SDK_HTTP_PORT`
    /// (which Agones sets; not a setting of its own).
    pub agones_sdk_port: Option<u16>,
    /// Most ticks one loop of the tick thread may run to catch up.
    pub max_catch_up_ticks: u32,
    /// Snapshot position grid step, mm.
    pub position_resolution_mm: f64,
    /// Record the session into [`ServerConfig::recording_dir`].
    pub record: bool,
    /// Ask for real-time priority for the tick thread and its physics
    /// workers, and below them for the snapshot stage
    /// ([`crate::priority`]).
    pub tick_realtime: bool,
    /// Threads that step the physics; 0: half the machine's cores, at
    /// least one ([`ServerConfig::physics_threads_now`]).
    pub physics_threads: usize,
    /// Whether the physics threads are pinned one to a core.
    pub physics_pin_threads: PhysicsPinning,
    /// A keyframe every this many ticks.
    pub keyframe_ticks: u64,
    /// Retention limit of the recording, bytes.
    pub record_max_bytes: u64,
    /// Start from the recording instead of the scene's initial state.
    pub resume: bool,
    /// Memory for seeking, MiB.
    pub seek_memory_mb: u64,
    /// In-memory checkpoint interval, ticks (0: none).
    pub checkpoint_ticks: u64,
    /// Published frames kept by tick for [`crate::RunningServer::frame_at`]
    /// (tests and tools comparing what clients saw with the truth); 0,
    /// the default, keeps none. Not a command-line setting: each frame
    /// holds every entity's state (about 120 KB at 1000 bodies).
    pub frame_history: usize,
    /// The deadlines of a game connection's life (the protocol's
    /// defaults). Not a command-line setting: tests shorten them to see a
    /// deadline pass without waiting its full length.
    pub connection: ServerConnectionConfig,
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            listen: None,
            scene: None,
            tick_hz: DEFAULT_TICK_HZ,
            snapshot_hz: DEFAULT_SNAPSHOT_HZ,
            client_budget_kbps: DEFAULT_CLIENT_BUDGET_KBPS,
            max_clients: DEFAULT_MAX_CLIENTS,
            retry_above_per_sec: 0,
            max_bodies: DEFAULT_MAX_BODIES,
            data_dir: PathBuf::from("./inertia-data"),
            checkpoint_dir: None,
            metrics: SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), 9100),
            key_file: None,
            cert_file: None,
            cert_key_file: None,
            admin_token_file: None,
            log_format: LogFormat::Text,
            orchestrator: OrchestratorMode::Auto,
            match_seconds: None,
            scenes_dir: None,
            web_dir: None,
            matches_dir: None,
            agones_sdk_port: None,
            max_catch_up_ticks: DEFAULT_MAX_CATCH_UP_TICKS,
            position_resolution_mm: DEFAULT_POSITION_RESOLUTION_MM,
            record: true,
            tick_realtime: false,
            physics_threads: 0,
            physics_pin_threads: PhysicsPinning::Auto,
            keyframe_ticks: DEFAULT_KEYFRAME_TICKS,
            record_max_bytes: DEFAULT_RECORD_MAX_BYTES,
            resume: false,
            seek_memory_mb: DEFAULT_SEEK_MEMORY_MB,
            checkpoint_ticks: DEFAULT_CHECKPOINT_TICKS,
            frame_history: 0,
            connection: ServerConnectionConfig::default(),
        }
    }
}

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

/// Prefix of every environment variable the server reads.
pub const ENV_PREFIX: &str = "INERTIA_";

impl ServerConfig {
    /// Parses the process's command line and environment (and the file they
    /// name) into a checked configuration.
    pub fn from_process() -> Result<ServerConfig, ConfigError> {
        let env: BTreeMap<String, String> = std::env::vars()
            .filter(|(k, _)| k.starts_with(ENV_PREFIX))
            .collect();
        Self::from_args(std::env::args_os(), |k| env.get(k).cloned())
    }

    /// Parses `args` (program name first) with the environment looked up
    /// through `env` (e.g. `|k| map.get(k).cloned()`).
    pub fn from_args<I, T>(
        args: I,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<ServerConfig, ConfigError>
    where
        I: IntoIterator<Item = T>,
        T: Into<OsString> + Clone,
    {
        let args = ServerArgs::try_parse_from(args)?;
        Self::resolve(&args, env)
    }

    /// Merges parsed command-line `args` over the environment over the file
    /// over the defaults, and validates the result.
    pub fn resolve(
        args: &ServerArgs,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<ServerConfig, ConfigError> {
        let env_layer = env_layer(&env)?;
        let file = args.config.clone().or_else(|| {
            env("INERTIA_CONFIG")
                .filter(|s| !s.is_empty())
                .map(PathBuf::from)
        });
        let file_layer = match file {
            Some(path) => {
                let text = std::fs::read_to_string(&path).map_err(|source| ConfigError::Io {
                    path: path.clone(),
                    source,
                })?;
                parse_toml(&path, &text)?
            }
            None => ConfigLayer::default(),
        };
        let merged = args.layer.clone().or(env_layer).or(file_layer);
        let mut config = ServerConfig::default().with(merged);
        config.agones_sdk_port = agones_sdk_port(&env)?;
        config.validate()?;
        Ok(config)
    }

    /// The defaults with every setting `layer` has replaced.
    pub fn with(self, layer: ConfigLayer) -> ServerConfig {
        ServerConfig {
            listen: layer.listen.or(self.listen),
            scene: layer.scene.or(self.scene),
            tick_hz: layer.tick_hz.unwrap_or(self.tick_hz),
            snapshot_hz: layer.snapshot_hz.unwrap_or(self.snapshot_hz),
            client_budget_kbps: layer.client_budget_kbps.unwrap_or(self.client_budget_kbps),
            max_clients: layer.max_clients.unwrap_or(self.max_clients),
            retry_above_per_sec: layer
                .retry_above_per_sec
                .unwrap_or(self.retry_above_per_sec),
            max_bodies: layer.max_bodies.unwrap_or(self.max_bodies),
            data_dir: layer.data_dir.unwrap_or(self.data_dir),
            checkpoint_dir: layer.checkpoint_dir.or(self.checkpoint_dir),
            metrics: layer.metrics.unwrap_or(self.metrics),
            key_file: layer.key_file.or(self.key_file),
            cert_file: layer.cert_file.or(self.cert_file),
            cert_key_file: layer.cert_key_file.or(self.cert_key_file),
            admin_token_file: layer.admin_token_file.or(self.admin_token_file),
            log_format: layer.log_format.unwrap_or(self.log_format),
            orchestrator: layer.orchestrator.unwrap_or(self.orchestrator),
            match_seconds: layer.match_seconds.or(self.match_seconds),
            scenes_dir: layer.scenes_dir.or(self.scenes_dir),
            web_dir: layer.web_dir.or(self.web_dir),
            matches_dir: layer.matches_dir.or(self.matches_dir),
            agones_sdk_port: self.agones_sdk_port,
            max_catch_up_ticks: layer.max_catch_up_ticks.unwrap_or(self.max_catch_up_ticks),
            position_resolution_mm: layer
                .position_resolution_mm
                .unwrap_or(self.position_resolution_mm),
            record: layer.record.unwrap_or(self.record),
            tick_realtime: layer.tick_realtime.unwrap_or(self.tick_realtime),
            physics_threads: layer.physics_threads.unwrap_or(self.physics_threads),
            physics_pin_threads: layer
                .physics_pin_threads
                .unwrap_or(self.physics_pin_threads),
            keyframe_ticks: layer.keyframe_ticks.unwrap_or(self.keyframe_ticks),
            record_max_bytes: layer.record_max_bytes.unwrap_or(self.record_max_bytes),
            resume: layer.resume.unwrap_or(self.resume),
            seek_memory_mb: layer.seek_memory_mb.unwrap_or(self.seek_memory_mb),
            checkpoint_ticks: layer.checkpoint_ticks.unwrap_or(self.checkpoint_ticks),
            frame_history: self.frame_history,
            connection: self.connection,
        }
    }

    /// Checks every range and pairing; see [`ConfigError`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(1..=MAX_TICK_HZ).contains(&self.tick_hz) {
            return Err(ConfigError::TickHz(self.tick_hz));
        }
        if let Some(s) = self.match_seconds {
            if !(1..=crate::orchestrator::allocation::MAX_MATCH_SECONDS).contains(&s) {
                return Err(ConfigError::MatchSeconds(s));
            }
        }
        if self.snapshot_hz == 0 || self.snapshot_hz > self.tick_hz {
            return Err(ConfigError::SnapshotHz {
                snapshot_hz: self.snapshot_hz,
                tick_hz: self.tick_hz,
            });
        }
        if self.client_budget_kbps == 0 {
            return Err(ConfigError::ClientBudget);
        }
        if !(0.01..=100.0).contains(&self.position_resolution_mm) {
            return Err(ConfigError::PositionResolution(self.position_resolution_mm));
        }
        if !(1..=MAX_CLIENTS_LIMIT).contains(&self.max_clients) {
            return Err(ConfigError::MaxClients(self.max_clients));
        }
        if self.retry_above_per_sec > MAX_RETRY_ABOVE_PER_SEC {
            return Err(ConfigError::RetryAbove(self.retry_above_per_sec));
        }
        if !(1..=MAX_BODIES_LIMIT).contains(&self.max_bodies) {
            return Err(ConfigError::MaxBodies(self.max_bodies));
        }
        if self.physics_threads > MAX_PHYSICS_THREADS {
            return Err(ConfigError::PhysicsThreads(self.physics_threads));
        }
        if !(1..=1000).contains(&self.max_catch_up_ticks) {
            return Err(ConfigError::CatchUp(self.max_catch_up_ticks));
        }
        if !SEEK_MEMORY_MB_RANGE.contains(&self.seek_memory_mb) {
            return Err(ConfigError::SeekMemory(self.seek_memory_mb));
        }
        if self.checkpoint_ticks > MAX_KEYFRAME_TICKS {
            return Err(ConfigError::CheckpointTicks(self.checkpoint_ticks));
        }
        if !(1..=MAX_KEYFRAME_TICKS).contains(&self.keyframe_ticks) {
            return Err(ConfigError::KeyframeTicks(self.keyframe_ticks));
        }
        if self.record_max_bytes < MIN_RECORD_MAX_BYTES {
            return Err(ConfigError::RecordMaxBytes(self.record_max_bytes));
        }
        if self.cert_file.is_some() != self.cert_key_file.is_some() {
            return Err(ConfigError::CertPair);
        }
        let listen = self.listen_addr();
        // Port 0 asks the system for any free port, so it never clashes.
        if listen == self.metrics && listen.port() != 0 {
            return Err(ConfigError::SameAddress(listen));
        }
        Ok(())
    }

    /// Dev mode: no connect-token key and no certificate. The server then
    /// makes a self-signed certificate and accepts dev tokens.
    pub fn dev_mode(&self) -> bool {
        self.key_file.is_none() && self.cert_file.is_none()
    }

    /// The UDP address to bind: as configured, else 127.0.0.1:7777 in dev
    /// mode (nothing outside the machine can join an unauthenticated
    /// server) and 0.0.0.0:7777 otherwise.
    pub fn listen_addr(&self) -> SocketAddr {
        self.listen.unwrap_or_else(|| {
            let ip = if self.dev_mode() {
                Ipv4Addr::LOCALHOST
            } else {
                Ipv4Addr::UNSPECIFIED
            };
            SocketAddr::new(IpAddr::V4(ip), DEFAULT_PORT)
        })
    }

    /// Where the session is recorded: `<data_dir>/recording`.
    pub fn recording_dir(&self) -> PathBuf {
        self.data_dir.join("recording")
    }

    /// The physics world's settings: the body limit, the threads and their
    /// pinning.
    pub fn world_config(&self) -> inertia_physics::WorldConfig {
        inertia_physics::WorldConfig {
            max_bodies: self.max_bodies,
            threads: self.physics_threads_now(),
            pin_threads: self.physics_pin_threads.into(),
            ..inertia_physics::WorldConfig::default()
        }
    }

    /// Where finished matches' recordings are kept
    /// ([`crate::record::matches`]).
    pub fn matches_dir(&self) -> PathBuf {
        self.matches_dir
            .clone()
            .unwrap_or_else(|| self.data_dir.join("matches"))
    }

    /// The orchestrator this server works with: [`Self::orchestrator`]
    /// with the Agones environment.
    pub fn orchestrating(&self) -> Orchestrating {
        Orchestrating::choose(self.orchestrator, self.agones_sdk_port)
    }

    /// The threads that step the physics: as configured, else half the
    /// machine's cores, at least one. On a machine of few cores shared
    /// with the snapshot encoders and the network a second thread costs
    /// more than it saves: at 200 clients on 2 cores the tick took 26-28 %
    /// of a core stepping on one thread against 33-45 % on two, its p99
    /// 8-9 ms either way (`inertia-bench capacity`), the difference spent
    /// handing work between threads that wait for a core.
    pub fn physics_threads_now(&self) -> usize {
        if self.physics_threads > 0 {
            return self.physics_threads;
        }
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores / 2).max(1)
    }

    /// Where `save` and `load` keep checkpoints: as configured, else
    /// `<data_dir>/checkpoints`.
    pub fn checkpoint_dir(&self) -> PathBuf {
        self.checkpoint_dir
            .clone()
            .unwrap_or_else(|| self.data_dir.join("checkpoints"))
    }

    /// The recorder's settings (whether or not `record` is on: `record on`
    /// can start it later). Segments are at most an eighth of the
    /// retention limit (and at most the store's default), so retention,
    /// which deletes whole segments, can keep within a small limit.
    pub fn recorder_config(&self) -> crate::record::RecorderConfig {
        crate::record::RecorderConfig {
            keyframe_ticks: self.keyframe_ticks,
            max_bytes: self.record_max_bytes,
            segment_bytes: (self.record_max_bytes / 8)
                .clamp(64 * 1024, crate::record::DEFAULT_SEGMENT_BYTES),
            ..crate::record::RecorderConfig::new(self.recording_dir())
        }
    }

    /// Simulation time of one tick, s.
    pub fn dt(&self) -> f64 {
        1.0 / f64::from(self.tick_hz)
    }

    /// The per-client budget in bytes per wall second.
    pub fn client_budget_bytes_per_sec(&self) -> u64 {
        u64::from(self.client_budget_kbps) * 1000 / 8
    }
}

impl ConfigLayer {
    /// This layer with every unset field taken from `lower`.
    pub fn or(self, lower: ConfigLayer) -> ConfigLayer {
        ConfigLayer {
            listen: self.listen.or(lower.listen),
            scene: self.scene.or(lower.scene),
            tick_hz: self.tick_hz.or(lower.tick_hz),
            snapshot_hz: self.snapshot_hz.or(lower.snapshot_hz),
            client_budget_kbps: self.client_budget_kbps.or(lower.client_budget_kbps),
            max_clients: self.max_clients.or(lower.max_clients),
            retry_above_per_sec: self.retry_above_per_sec.or(lower.retry_above_per_sec),
            max_bodies: self.max_bodies.or(lower.max_bodies),
            data_dir: self.data_dir.or(lower.data_dir),
            checkpoint_dir: self.checkpoint_dir.or(lower.checkpoint_dir),
            metrics: self.metrics.or(lower.metrics),
            key_file: self.key_file.or(lower.key_file),
            cert_file: self.cert_file.or(lower.cert_file),
            cert_key_file: self.cert_key_file.or(lower.cert_key_file),
            admin_token_file: self.admin_token_file.or(lower.admin_token_file),
            log_format: self.log_format.or(lower.log_format),
            orchestrator: self.orchestrator.or(lower.orchestrator),
            match_seconds: self.match_seconds.or(lower.match_seconds),
            scenes_dir: self.scenes_dir.or(lower.scenes_dir),
            web_dir: self.web_dir.or(lower.web_dir),
            matches_dir: self.matches_dir.or(lower.matches_dir),
            max_catch_up_ticks: self.max_catch_up_ticks.or(lower.max_catch_up_ticks),
            position_resolution_mm: self.position_resolution_mm.or(lower.position_resolution_mm),
            record: self.record.or(lower.record),
            tick_realtime: self.tick_realtime.or(lower.tick_realtime),
            physics_threads: self.physics_threads.or(lower.physics_threads),
            physics_pin_threads: self.physics_pin_threads.or(lower.physics_pin_threads),
            keyframe_ticks: self.keyframe_ticks.or(lower.keyframe_ticks),
            record_max_bytes: self.record_max_bytes.or(lower.record_max_bytes),
            resume: self.resume.or(lower.resume),
            seek_memory_mb: self.seek_memory_mb.or(lower.seek_memory_mb),
            checkpoint_ticks: self.checkpoint_ticks.or(lower.checkpoint_ticks),
        }
    }
}

/// Parses a TOML configuration file's text; errors carry the key path.
pub fn parse_toml(path: &Path, text: &str) -> Result<ConfigLayer, ConfigError> {
    let err = |key: String, message: String| ConfigError::Toml {
        path: path.to_path_buf(),
        key,
        message,
    };
    let de = toml::Deserializer::parse(text).map_err(|e| err(".".into(), e.to_string()))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        err(key, e.into_inner().message().trim().to_string())
    })
}

/// The `INERTIA_*` variables as a layer. Empty values count as unset.
fn env_layer(env: &impl Fn(&str) -> Option<String>) -> Result<ConfigLayer, ConfigError> {
    fn get<T: std::str::FromStr>(
        env: &impl Fn(&str) -> Option<String>,
        var: &str,
    ) -> Result<Option<T>, ConfigError>
    where
        T::Err: std::fmt::Display,
    {
        match env(var).filter(|v| !v.trim().is_empty()) {
            None => Ok(None),
            Some(value) => value
                .trim()
                .parse::<T>()
                .map(Some)
                .map_err(|e| ConfigError::Env {
                    var: var.to_string(),
                    value: value.clone(),
                    why: e.to_string(),
                }),
        }
    }
    Ok(ConfigLayer {
        listen: get(env, "INERTIA_LISTEN")?,
        scene: get(env, "INERTIA_SCENE")?,
        tick_hz: get(env, "INERTIA_TICK_HZ")?,
        snapshot_hz: get(env, "INERTIA_SNAPSHOT_HZ")?,
        client_budget_kbps: get(env, "INERTIA_CLIENT_BUDGET_KBPS")?,
        max_clients: get(env, "INERTIA_MAX_CLIENTS")?,
        retry_above_per_sec: get(env, "INERTIA_RETRY_ABOVE_PER_SEC")?,
        max_bodies: get(env, "INERTIA_MAX_BODIES")?,
        data_dir: get(env, "INERTIA_DATA_DIR")?,
        checkpoint_dir: get(env, "INERTIA_CHECKPOINT_DIR")?,
        metrics: get(env, "INERTIA_METRICS")?,
        key_file: get(env, "INERTIA_KEY_FILE")?,
        cert_file: get(env, "INERTIA_CERT_FILE")?,
        cert_key_file: get(env, "INERTIA_CERT_KEY_FILE")?,
        admin_token_file: get(env, "INERTIA_ADMIN_TOKEN_FILE")?,
        log_format: get(env, "INERTIA_LOG_FORMAT")?,
        orchestrator: get(env, "INERTIA_ORCHESTRATOR")?,
        match_seconds: get(env, "INERTIA_MATCH_SECONDS")?,
        scenes_dir: get(env, "INERTIA_SCENES_DIR")?,
        web_dir: get(env, "INERTIA_WEB_DIR")?,
        matches_dir: get(env, "INERTIA_MATCHES_DIR")?,
        position_resolution_mm: get(env, "INERTIA_POSITION_RESOLUTION_MM")?,
        max_catch_up_ticks: get(env, "INERTIA_MAX_CATCH_UP_TICKS")?,
        record: get(env, "INERTIA_RECORD")?,
        tick_realtime: get(env, "INERTIA_TICK_REALTIME")?,
        physics_threads: get(env, "INERTIA_PHYSICS_THREADS")?,
        physics_pin_threads: get(env, "INERTIA_PHYSICS_PIN_THREADS")?,
        keyframe_ticks: get(env, "INERTIA_KEYFRAME_TICKS")?,
        record_max_bytes: get(env, "INERTIA_RECORD_MAX_BYTES")?,
        resume: get(env, "INERTIA_RESUME")?,
        seek_memory_mb: get(env, "INERTIA_SEEK_MEMORY_MB")?,
        checkpoint_ticks: get(env, "INERTIA_CHECKPOINT_TICKS")?,
    })
}

/// `AGONES_SDK_HTTP_PORT`, which Agones sets in a game server's
/// container: its SDK server's REST port.
fn agones_sdk_port(env: &impl Fn(&str) -> Option<String>) -> Result<Option<u16>, ConfigError> {
    const VAR: &str = "AGONES_SDK_HTTP_PORT";
    match env(VAR).filter(|v| !v.trim().is_empty()) {
        None => Ok(None),
        Some(value) => match value.trim().parse::<u16>() {
            Ok(port) if port > 0 => Ok(Some(port)),
            _ => Err(ConfigError::Env {
                var: VAR.to_string(),
                value,
                why: "expected a port number, 1..=65535".to_string(),
            }),
        },
    }
}

/// The tick loop's defaults are the server's.
impl Default for SimConfig {
    fn default() -> Self {
        Self::from(&ServerConfig::default())
    }
}

/// How the tick loop runs under this configuration (without metrics or a
/// recorder: the server adds its own).
impl From<&ServerConfig> for SimConfig {
    fn from(c: &ServerConfig) -> Self {
        SimConfig {
            tick_hz: c.tick_hz,
            max_catch_up_ticks: c.max_catch_up_ticks,
            max_clients: c.max_clients,
            limits: crate::rules::ControlLimits::default(),
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
            max_rewind_ms: crate::pose_history::DEFAULT_MAX_REWIND_MS,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env_of(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: BTreeMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| map.get(k).cloned()
    }

    fn temp_file(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("inertia-config-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn the_orchestrator_is_agones_where_agones_sets_its_port() {
        let none = ServerConfig::from_args(["inertia-server"], env_of(&[])).unwrap();
        assert_eq!(none.orchestrating(), Orchestrating::Standalone);
        let agones_env = [("AGONES_SDK_HTTP_PORT", "9400")];
        let auto = ServerConfig::from_args(["inertia-server"], env_of(&agones_env)).unwrap();
        assert_eq!(
            auto.orchestrating(),
            Orchestrating::Agones { sdk_port: 9400 }
        );
        let off = ServerConfig::from_args(
            ["inertia-server", "--orchestrator", "standalone"],
            env_of(&agones_env),
        )
        .unwrap();
        assert_eq!(off.orchestrating(), Orchestrating::Standalone);
        let asked = ServerConfig::from_args(
            ["inertia-server"],
            env_of(&[("INERTIA_ORCHESTRATOR", "agones")]),
        )
        .unwrap();
        assert_eq!(
            asked.orchestrating(),
            Orchestrating::Agones {
                sdk_port: crate::orchestrator::sdk::DEFAULT_HTTP_PORT
            }
        );
        for bad in ["0", "70000", "port"] {
            let e = ServerConfig::from_args(
                ["inertia-server"],
                env_of(&[("AGONES_SDK_HTTP_PORT", bad)]),
            )
            .unwrap_err();
            assert!(e.to_string().contains("AGONES_SDK_HTTP_PORT"), "{e}");
        }
        assert!(
            ServerConfig::from_args(["inertia-server", "--orchestrator", "k8s"], env_of(&[]))
                .is_err()
        );
        let timed =
            ServerConfig::from_args(["inertia-server", "--match-seconds", "900"], env_of(&[]))
                .unwrap();
        assert_eq!(timed.match_seconds, Some(900));
        for bad in ["0", "86401"] {
            let e =
                ServerConfig::from_args(["inertia-server", "--match-seconds", bad], env_of(&[]))
                    .unwrap_err();
            assert!(e.to_string().contains("match_seconds"), "{e}");
        }
    }

    #[test]
    fn defaults_are_dev_mode_on_loopback() {
        let c = ServerConfig::from_args(["inertia-server"], env_of(&[])).unwrap();
        assert_eq!(c, ServerConfig::default());
        assert!(c.dev_mode());
        assert_eq!(c.listen_addr(), "127.0.0.1:7777".parse().unwrap());
        assert_eq!(c.metrics, "127.0.0.1:9100".parse().unwrap());
        assert_eq!(
            (c.tick_hz, c.snapshot_hz, c.max_catch_up_ticks),
            (60, 30, 5)
        );
    }

    #[test]
    fn credentials_leave_dev_mode_and_listen_everywhere() {
        let c = ServerConfig::from_args(
            [
                "s",
                "--key-file",
                "k",
                "--cert-file",
                "c",
                "--cert-key-file",
                "ck",
            ],
            env_of(&[]),
        )
        .unwrap();
        assert!(!c.dev_mode());
        assert_eq!(c.listen_addr(), "0.0.0.0:7777".parse().unwrap());
    }

    #[test]
    fn command_line_beats_environment_beats_file_beats_default() {
        let file = temp_file(
            "layers.toml",
            "tick_hz = 100\nsnapshot_hz = 20\nmax_clients = 10\nlog_format = \"json\"\n",
        );
        let file_s = file.to_str().unwrap();
        let env = env_of(&[
            ("INERTIA_TICK_HZ", "120"),
            ("INERTIA_SNAPSHOT_HZ", "40"),
            (
                "INERTIA_CONFIG",
                "/nonexistent/ignored-because-cli-names-one.toml",
            ),
        ]);
        let c =
            ServerConfig::from_args(["s", "--config", file_s, "--tick-hz", "200"], env).unwrap();
        assert_eq!(c.tick_hz, 200, "command line wins");
        assert_eq!(c.snapshot_hz, 40, "environment beats the file");
        assert_eq!(c.max_clients, 10, "file beats the default");
        assert_eq!(c.log_format, LogFormat::Json);
        assert_eq!(c.client_budget_kbps, DEFAULT_CLIENT_BUDGET_KBPS, "default");
    }

    #[test]
    fn config_file_can_come_from_the_environment() {
        let file = temp_file("env.toml", "scene = \"scenes/pyramid.json\"\n");
        let env = env_of(&[("INERTIA_CONFIG", file.to_str().unwrap())]);
        let c = ServerConfig::from_args(["s"], env).unwrap();
        assert_eq!(c.scene, Some(PathBuf::from("scenes/pyramid.json")));
    }

    #[test]
    fn bad_toml_names_the_key() {
        let e = parse_toml(Path::new("x.toml"), "tick_hz = \"fast\"\n").unwrap_err();
        match e {
            ConfigError::Toml { key, .. } => assert_eq!(key, "tick_hz"),
            e => panic!("{e}"),
        }
        let e = parse_toml(Path::new("x.toml"), "tick_hz = 60\nspeed = 3\n").unwrap_err();
        assert!(e.to_string().contains("speed"), "{e}");
        let e = parse_toml(Path::new("x.toml"), "listen = \"nowhere\"\n").unwrap_err();
        match e {
            ConfigError::Toml { key, .. } => assert_eq!(key, "listen"),
            e => panic!("{e}"),
        }
    }

    #[test]
    fn bad_environment_names_the_variable() {
        let e =
            ServerConfig::from_args(["s"], env_of(&[("INERTIA_LISTEN", "port 7")])).unwrap_err();
        assert!(
            matches!(&e, ConfigError::Env { var, .. } if var == "INERTIA_LISTEN"),
            "{e}"
        );
    }

    #[test]
    fn ranges_are_checked() {
        let run = |args: &[&str]| {
            let mut a = vec!["s"];
            a.extend_from_slice(args);
            ServerConfig::from_args(a, env_of(&[]))
        };
        assert!(matches!(
            run(&["--tick-hz", "0"]),
            Err(ConfigError::TickHz(0))
        ));
        assert!(matches!(
            run(&["--tick-hz", "1001"]),
            Err(ConfigError::TickHz(1001))
        ));
        assert!(matches!(
            run(&["--tick-hz", "20", "--snapshot-hz", "30"]),
            Err(ConfigError::SnapshotHz { .. })
        ));
        assert!(matches!(
            run(&["--max-clients", "0"]),
            Err(ConfigError::MaxClients(0))
        ));
        assert!(!run(&[]).unwrap().tick_realtime, "off by default");
        let auto = run(&[]).unwrap();
        assert_eq!(auto.physics_threads, 0);
        assert!(auto.physics_threads_now() >= 1);
        assert_eq!(
            run(&["--physics-threads", "3"])
                .unwrap()
                .physics_threads_now(),
            3
        );
        assert!(matches!(
            run(&["--physics-threads", "257"]),
            Err(ConfigError::PhysicsThreads(257))
        ));
        assert_eq!(
            ServerConfig::from_args(["s"], env_of(&[("INERTIA_PHYSICS_THREADS", "1")]))
                .unwrap()
                .physics_threads,
            1
        );
        assert_eq!(auto.physics_pin_threads, PhysicsPinning::Auto);
        assert_eq!(
            run(&["--physics-pin-threads", "never"])
                .unwrap()
                .world_config()
                .pin_threads,
            inertia_physics::ThreadPinning::Never
        );
        assert_eq!(
            ServerConfig::from_args(["s"], env_of(&[("INERTIA_PHYSICS_PIN_THREADS", "always")]))
                .unwrap()
                .physics_pin_threads,
            PhysicsPinning::Always
        );
        assert!(run(&["--physics-pin-threads", "sometimes"]).is_err());
        assert!(run(&["--tick-realtime"]).unwrap().tick_realtime);
        assert!(
            ServerConfig::from_args(["s"], env_of(&[("INERTIA_TICK_REALTIME", "true")]))
                .unwrap()
                .tick_realtime
        );
        assert!(matches!(
            run(&["--retry-above-per-sec", "100001"]),
            Err(ConfigError::RetryAbove(100_001))
        ));
        assert_eq!(
            run(&["--retry-above-per-sec", "50"])
                .unwrap()
                .retry_above_per_sec,
            50
        );
        assert!(matches!(
            run(&["--max-catch-up-ticks", "0"]),
            Err(ConfigError::CatchUp(0))
        ));
        assert!(matches!(
            run(&["--cert-file", "c.pem"]),
            Err(ConfigError::CertPair)
        ));
        assert!(matches!(
            run(&["--client-budget-kbps", "0"]),
            Err(ConfigError::ClientBudget)
        ));
        assert!(matches!(run(&["--tick-hz", "x"]), Err(ConfigError::Cli(_))));
        assert!(matches!(
            run(&["--listen", "127.0.0.1:9100"]),
            Err(ConfigError::SameAddress(_))
        ));
        for bad in ["0", "1000", "NaN"] {
            assert!(matches!(
                run(&["--position-resolution-mm", bad]),
                Err(ConfigError::PositionResolution(_))
            ));
        }
        assert_eq!(
            run(&["--position-resolution-mm", "0.5"])
                .unwrap()
                .position_resolution_mm,
            0.5
        );
    }

    #[test]
    fn recording_settings_come_from_every_layer() {
        let c = ServerConfig::from_args(["s"], env_of(&[])).unwrap();
        assert!(c.record);
        assert_eq!(c.keyframe_ticks, DEFAULT_KEYFRAME_TICKS);
        assert_eq!(c.record_max_bytes, DEFAULT_RECORD_MAX_BYTES);
        assert_eq!(
            c.recording_dir(),
            PathBuf::from("./inertia-data").join("recording")
        );
        let c = ServerConfig::from_args(
            [
                "s",
                "--record",
                "false",
                "--keyframe-ticks",
                "120",
                "--record-max-bytes",
                "10000000",
            ],
            env_of(&[]),
        )
        .unwrap();
        assert!(!c.record);
        assert_eq!(c.keyframe_ticks, 120);
        assert_eq!(c.record_max_bytes, 10_000_000);
        assert_eq!(c.recorder_config().keyframe_ticks, 120);
        assert_eq!(c.recorder_config().max_bytes, 10_000_000);
        assert_eq!(c.recorder_config().segment_bytes, 1_250_000);
        assert_eq!(
            ServerConfig::default().recorder_config().segment_bytes,
            crate::record::DEFAULT_SEGMENT_BYTES
        );
        let c = ServerConfig::from_args(["s", "--record"], env_of(&[("INERTIA_RECORD", "false")]))
            .unwrap();
        assert!(
            c.record,
            "a bare --record means true and beats the environment"
        );
        let c = ServerConfig::from_args(
            ["s"],
            env_of(&[
                ("INERTIA_RECORD", "false"),
                ("INERTIA_KEYFRAME_TICKS", "30"),
                ("INERTIA_RECORD_MAX_BYTES", "2000000"),
            ]),
        )
        .unwrap();
        assert_eq!(
            (c.record, c.keyframe_ticks, c.record_max_bytes),
            (false, 30, 2_000_000)
        );
        let file = temp_file(
            "record.toml",
            "record = false\nkeyframe_ticks = 60\nrecord_max_bytes = 5000000\n",
        );
        let c = ServerConfig::from_args(["s", "--config", file.to_str().unwrap()], env_of(&[]))
            .unwrap();
        assert_eq!(
            (c.record, c.keyframe_ticks, c.record_max_bytes),
            (false, 60, 5_000_000)
        );
        let e = ServerConfig::from_args(["s"], env_of(&[("INERTIA_RECORD", "maybe")])).unwrap_err();
        assert!(
            matches!(&e, ConfigError::Env { var, .. } if var == "INERTIA_RECORD"),
            "{e}"
        );
        for bad in ["0", "1000001"] {
            assert!(matches!(
                ServerConfig::from_args(["s", "--keyframe-ticks", bad], env_of(&[])),
                Err(ConfigError::KeyframeTicks(_))
            ));
        }
        assert!(matches!(
            ServerConfig::from_args(["s", "--record-max-bytes", "1000"], env_of(&[])),
            Err(ConfigError::RecordMaxBytes(1000))
        ));
        // Seeking's memory and checkpoints.
        let c = ServerConfig::from_args(
            ["s", "--seek-memory-mb", "64"],
            env_of(&[("INERTIA_CHECKPOINT_TICKS", "30")]),
        )
        .unwrap();
        assert_eq!((c.seek_memory_mb, c.checkpoint_ticks), (64, 30));
        let sim = SimConfig::from(&c);
        assert_eq!((sim.history_budget, sim.checkpoint_ticks), (64 << 20, 30));
        assert!(matches!(
            ServerConfig::from_args(["s", "--seek-memory-mb", "1"], env_of(&[])),
            Err(ConfigError::SeekMemory(1))
        ));
        assert!(matches!(
            ServerConfig::from_args(["s", "--checkpoint-ticks", "2000000"], env_of(&[])),
            Err(ConfigError::CheckpointTicks(2_000_000))
        ));
    }

    #[test]
    fn issue_11_checkpoint_dir_comes_from_every_layer() {
        let c = ServerConfig::from_args(["s", "--data-dir", "/srv/inertia"], env_of(&[])).unwrap();
        assert_eq!(c.checkpoint_dir, None);
        assert_eq!(
            c.checkpoint_dir(),
            PathBuf::from("/srv/inertia/checkpoints"),
            "under the data directory by default"
        );
        let file = temp_file("checkpoints.toml", "checkpoint_dir = \"/from/file\"\n");
        let file = file.to_str().unwrap();
        let c = ServerConfig::from_args(["s", "--config", file], env_of(&[])).unwrap();
        assert_eq!(c.checkpoint_dir(), PathBuf::from("/from/file"));
        let env = || env_of(&[("INERTIA_CHECKPOINT_DIR", "/from/env")]);
        let c = ServerConfig::from_args(["s", "--config", file], env()).unwrap();
        assert_eq!(c.checkpoint_dir(), PathBuf::from("/from/env"));
        let c = ServerConfig::from_args(
            ["s", "--config", file, "--checkpoint-dir", "/from/cli"],
            env(),
        )
        .unwrap();
        assert_eq!(c.checkpoint_dir(), PathBuf::from("/from/cli"));
    }

    #[test]
    fn issue_11_admin_token_file_comes_from_every_layer() {
        let c = ServerConfig::from_args(["s"], env_of(&[])).unwrap();
        assert_eq!(c.admin_token_file, None);
        let file = temp_file("admin.toml", "admin_token_file = \"/from/file\"\n");
        let file = file.to_str().unwrap();
        let c = ServerConfig::from_args(["s", "--config", file], env_of(&[])).unwrap();
        assert_eq!(c.admin_token_file, Some(PathBuf::from("/from/file")));
        let env = || env_of(&[("INERTIA_ADMIN_TOKEN_FILE", "/from/env")]);
        let c = ServerConfig::from_args(["s", "--config", file], env()).unwrap();
        assert_eq!(c.admin_token_file, Some(PathBuf::from("/from/env")));
        let c = ServerConfig::from_args(
            ["s", "--config", file, "--admin-token-file", "/from/cli"],
            env(),
        )
        .unwrap();
        assert_eq!(c.admin_token_file, Some(PathBuf::from("/from/cli")));
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let e = ServerConfig::from_args(["s", "--config", "/no/such/inertia.toml"], env_of(&[]))
            .unwrap_err();
        assert!(matches!(e, ConfigError::Io { .. }), "{e}");
    }
}
