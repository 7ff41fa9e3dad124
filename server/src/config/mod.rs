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

//!
//! One concept a file: the settings resolved ([`ServerConfig`]) and what
//! the server derives from them, here; `layer.rs` one source's settings
//! ([`ConfigLayer`]), the command line, the environment and the TOML
//! file; `choices.rs` the settings that pick one of a few ways; `error.rs`
//! why a configuration is refused.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;

use inertia_protocol::connection::ServerConnectionConfig;

use crate::orchestrator::{Orchestrating, OrchestratorMode};
use crate::sim::SimConfig;

mod choices;
mod error;
mod layer;
#[cfg(test)]
mod tests;

pub use choices::{LogFormat, PhysicsPinning};
pub use error::ConfigError;
use layer::{agones_sdk_port, env_layer};
pub use layer::{binary_name, parse_toml, version_line, ConfigLayer, ServerArgs};

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
/// Default recent past kept for players' replays, s.
pub const DEFAULT_REPLAY_WINDOW_S: u32 = 30;
/// Longest recent past kept for players' replays, s.
pub const MAX_REPLAY_WINDOW_S: u32 = 300;
/// Default players' replays playing at once.
pub const DEFAULT_MAX_REPLAYS: u32 = 10;
/// Most players' replays playing at once that may be configured.
pub const MAX_REPLAYS_LIMIT: u32 = 256;
/// The share of the seeking memory the frames held for replays may take:
/// one part in this many.
pub const REPLAY_SHARE_OF_SEEK_MEMORY: u64 = 4;
/// Smallest accepted retention limit, bytes (1 MiB).
pub const MIN_RECORD_MAX_BYTES: u64 = 1024 * 1024;
/// Highest accepted tick rate, Hz.
pub const MAX_TICK_HZ: u32 = 1000;
/// Highest accepted client count.
pub const MAX_CLIENTS_LIMIT: u32 = 4096;
/// Highest accepted `retry_above_per_sec`.
pub const MAX_RETRY_ABOVE_PER_SEC: u32 = 100_000;

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
    /// Recent past kept for players' replays, s (0: no replays).
    pub replay_window_s: u32,
    /// Players' replays playing at once, at most.
    pub max_replays: u32,
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
            replay_window_s: DEFAULT_REPLAY_WINDOW_S,
            max_replays: DEFAULT_MAX_REPLAYS,
            frame_history: 0,
            connection: ServerConnectionConfig::default(),
        }
    }
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
        let args = ServerArgs::parse_command_line(args)?;
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
            replay_window_s: layer.replay_window_s.unwrap_or(self.replay_window_s),
            max_replays: layer.max_replays.unwrap_or(self.max_replays),
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
        if self.replay_window_s > MAX_REPLAY_WINDOW_S {
            return Err(ConfigError::ReplayWindow(self.replay_window_s));
        }
        if self.max_replays > MAX_REPLAYS_LIMIT {
            return Err(ConfigError::MaxReplays(self.max_replays));
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

    /// The memory the frames held for players' replays may take, bytes: a
    /// share of the seeking memory ([`REPLAY_SHARE_OF_SEEK_MEMORY`]),
    /// none without replays.
    pub fn replay_window_bytes(&self) -> usize {
        if self.replay_window_s == 0 || self.max_replays == 0 {
            return 0;
        }
        usize::try_from((self.seek_memory_mb << 20) / REPLAY_SHARE_OF_SEEK_MEMORY)
            .unwrap_or(usize::MAX)
    }

    /// Players' replays as the snapshot stage keeps and plays them.
    pub fn replays(&self) -> crate::net::streaming::ReplaySettings {
        crate::net::streaming::ReplaySettings {
            window_s: if self.max_replays == 0 {
                0
            } else {
                self.replay_window_s
            },
            window_bytes: self.replay_window_bytes(),
            max_playing: self.max_replays as usize,
        }
    }

    /// How snapshots are coded: velocities sent (they let clients
    /// interpolate with Hermite curves and extrapolate over a lost
    /// snapshot, and cost little for the bodies at rest, which send none),
    /// positions on the configured grid.
    pub fn snapshot_config(&self) -> inertia_protocol::snapshot::SnapshotConfig {
        let default = inertia_protocol::snapshot::SnapshotConfig::default();
        inertia_protocol::snapshot::SnapshotConfig {
            velocities: true,
            grid: inertia_protocol::PositionGrid {
                resolution: self.position_resolution_mm / 1000.0,
                // Finer grids cover less ground within the codec's 32 bits
                // an axis.
                bound: default
                    .grid
                    .bound
                    .min(self.position_resolution_mm / 1000.0 * f64::from(u32::MAX) / 2.0 * 0.99),
            },
            ..default
        }
    }

    /// The per-client budget in bytes per wall second.
    pub fn client_budget_bytes_per_sec(&self) -> u64 {
        u64::from(self.client_budget_kbps) * 1000 / 8
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
            history_budget: usize::try_from(
                (c.seek_memory_mb << 20) - c.replay_window_bytes() as u64,
            )
            .unwrap_or(usize::MAX),
            checkpoint_ticks: c.checkpoint_ticks,
            tick_realtime: c.tick_realtime,
            max_rewind_ms: crate::pose_history::DEFAULT_MAX_REWIND_MS,
        }
    }
}
