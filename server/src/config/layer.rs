//! One source's settings, every field optional: the command line, the
//! environment (`INERTIA_*`) and the TOML file each give one, and the
//! layers are merged field by field, the first that has a setting winning.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use clap::{CommandFactory, FromArgMatches, Parser};
use serde::Deserialize;

use super::{ConfigError, LogFormat, PhysicsPinning};
use crate::orchestrator::OrchestratorMode;

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
    /// Players' replays: how much of the recent past the server keeps for
    /// them, s (0..=300, default 30; 0: no replays). The frames held take
    /// at most a quarter of --seek-memory-mb (about 70 bytes a moving
    /// entity a snapshot: 1000 moving bodies at 30 Hz hold 30 s in 63 MB);
    /// past it the window is shorter.
    #[arg(long)]
    pub replay_window_s: Option<u32>,
    /// Players' replays playing at once, at most (0..=256, default 10);
    /// more wait half a second in a queue, then are refused as busy.
    #[arg(long)]
    pub max_replays: Option<u32>,
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

impl ServerArgs {
    /// Parses `args` (program name first) as the binary named by the
    /// program name would: `--help` and `--version` speak of it, whatever
    /// game it serves. `--help` and `--version` come back as the error
    /// clap renders them with ([`clap::error::ErrorKind::DisplayHelp`],
    /// [`clap::error::ErrorKind::DisplayVersion`]), to print to standard
    /// output with status 0 ([`crate::process::run`] does).
    pub fn parse_command_line<I, T>(args: I) -> Result<ServerArgs, clap::Error>
    where
        I: IntoIterator<Item = T>,
        T: Into<std::ffi::OsString> + Clone,
    {
        let args: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
        let name = binary_name(args.first().map(|a| a.as_os_str()));
        let command = ServerArgs::command()
            .version(version_line(&name))
            .name(name.clone())
            .bin_name(name);
        let matches = command.try_get_matches_from(args)?;
        ServerArgs::from_arg_matches(&matches)
    }
}

/// The name a binary goes by, from its program name (`argv[0]`): the
/// file's stem, `inertia-server` when there is none.
pub fn binary_name(program: Option<&std::ffi::OsStr>) -> String {
    program
        .and_then(|a| Path::new(a).file_stem())
        .and_then(|n| n.to_str())
        .filter(|n| !n.is_empty())
        .unwrap_or("inertia-server")
        .to_string()
}

/// What `--version` prints after the name of binary `bin`: the server
/// library's version and the protocol version its clients must speak
/// (`0.1.0 (protocol 4)` for `inertia-server`; a game's own binary is
/// `built on inertia-server 0.1.0, protocol 4`).
pub fn version_line(bin: &str) -> String {
    let server = env!("CARGO_PKG_VERSION");
    let protocol = inertia_protocol::PROTOCOL_VERSION;
    if bin == "inertia-server" {
        format!("{server} (protocol {protocol})")
    } else {
        format!("built on inertia-server {server}, protocol {protocol}")
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
            replay_window_s: self.replay_window_s.or(lower.replay_window_s),
            max_replays: self.max_replays.or(lower.max_replays),
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
pub(super) fn env_layer(env: &impl Fn(&str) -> Option<String>) -> Result<ConfigLayer, ConfigError> {
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
        replay_window_s: get(env, "INERTIA_REPLAY_WINDOW_S")?,
        max_replays: get(env, "INERTIA_MAX_REPLAYS")?,
    })
}

/// `AGONES_SDK_HTTP_PORT`, which Agones sets in a game server's
/// container: its SDK server's REST port.
pub(super) fn agones_sdk_port(
    env: &impl Fn(&str) -> Option<String>,
) -> Result<Option<u16>, ConfigError> {
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
