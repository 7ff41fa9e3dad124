//! The admin protocol: an operator's typed requests to a running server
//! and its answers, over QUIC with its own ALPN ([`ADMIN_ALPN`]) on the
//! game port.
//!
//! A session is one bidirectional stream. The operator's tool sends an
//! [`AdminHello`] carrying the admin credential; the server answers with
//! an [`AdminHandshake`]: [`AdminWelcome`], or an [`AdminRefusal`] and the
//! end of the connection. Until a hello passes [`admin_handshake`],
//! nothing else is answered. After the welcome the tool sends
//! [`AdminCall`]s and the server answers each with an [`AdminReply`]
//! carrying the call's id.
//!
//! Every message is framed, decoded and validated like the control
//! channel's: [`encode_frame`](crate::control::encode_frame) and
//! [`FrameDecoder`](crate::control::FrameDecoder) work unchanged, since
//! each type here is a [`ControlMessage`]. Each message also has a
//! `check` method that names what is wrong as an
//! [`AdminValidationError`], which the server can send back as an
//! [`AdminError`] of kind [`AdminErrorKind::Invalid`].
//!
//! Spawn shapes are decoded through a private mirror of [`ShapeDesc`]
//! whose grammar stops at one level of compound nesting, for the reason
//! [`crate::control`] gives: a frame of nested compounds would otherwise
//! recurse through serde once per level before validation could refuse
//! it.

use ring::hmac;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::control::{
    truncate_utf8, validate_entity, ControlError, ControlMessage, MAX_ENTITY_NAME_BYTES,
    MAX_REASON_BYTES, MAX_VERSION_BYTES,
};
use crate::entity::{EntityDesc, EntityId, EntityKind, ShapeDesc};

/// The QUIC ALPN protocol id of the admin connection (on the game port,
/// beside [`crate::control::ALPN`]).
pub const ADMIN_ALPN: &[u8] = b"inertia-admin";
/// The version of the admin protocol. A tool and a server speak only when
/// theirs are equal. Version 3 added [`AdminRefusal::Throttled`].
pub const ADMIN_PROTOCOL_VERSION: u16 = 3;
/// Longest admin credential in a hello, bytes.
pub const MAX_CREDENTIAL_BYTES: usize = 256;
/// Longest operator name in a hello, bytes of UTF-8.
pub const MAX_OPERATOR_BYTES: usize = 64;
/// Longest checkpoint name in a save or load request, bytes (of
/// [`CheckpointName`]'s ASCII alphabet).
pub const MAX_CHECKPOINT_NAME_BYTES: usize = 128;
/// Longest kick reason, bytes (the reason travels on to the player in a
/// [`DisconnectReason::Kicked`](crate::control::DisconnectReason::Kicked)).
pub const MAX_KICK_REASON_BYTES: usize = MAX_REASON_BYTES;
/// Longest message of an [`AdminError`], bytes.
pub const MAX_ADMIN_ERROR_BYTES: usize = 1024;
/// Largest time scale an operator may ask for (simulated seconds per wall
/// second).
pub const MAX_TIME_SCALE: f64 = 64.0;
/// Smallest time scale above zero an operator may ask for (simulated
/// seconds per wall second; zero is pause): one tick of 60 Hz every 17 wall
/// seconds. Slower than that is a pause with extra steps, and the wall time
/// between ticks (`dt / scale`) must stay a representable `Duration`
/// (`speed 1e-300` once asked for 10²⁹⁸ seconds).
pub const MIN_TIME_SCALE: f64 = 1.0 / 1024.0;

/// The first message on an admin stream, from the operator's tool.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdminHello {
    /// The tool's [`ADMIN_PROTOCOL_VERSION`].
    pub version: u16,
    /// The admin credential (at most [`MAX_CREDENTIAL_BYTES`]).
    pub token: String,
    /// Who is acting, for the audit log (at most [`MAX_OPERATOR_BYTES`], no
    /// control characters).
    pub operator: String,
}

/// The server's answer to an [`AdminHello`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum AdminHandshake {
    /// The hello was accepted; calls may follow.
    Welcome(AdminWelcome),
    /// The hello was refused; the server closes the connection next.
    Refused(AdminRefusal),
}

/// What the server tells an admitted operator about itself.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdminWelcome {
    /// The server's [`ADMIN_PROTOCOL_VERSION`].
    pub version: u16,
    /// The server build, for logs (at most [`MAX_VERSION_BYTES`]).
    pub server_version: String,
    /// Physics ticks per second of simulation time, Hz (not zero).
    pub tick_hz: u32,
}

/// Why an [`AdminHello`] was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AdminRefusal {
    /// Tool and server speak different admin protocol versions.
    VersionMismatch {
        /// The server's version.
        server: u16,
        /// The tool's version.
        client: u16,
    },
    /// The credential is not the server's admin credential (or the server
    /// has none).
    BadCredential,
    /// The first message was not a well-formed hello.
    Malformed,
    /// Too many hellos from this address had a wrong credential lately;
    /// the server answers none from it until the back-off has passed.
    Throttled {
        /// How long until the server reads a hello from this address
        /// again, ms.
        retry_after_ms: u32,
    },
}

/// One request with the id its answer will carry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdminCall {
    /// Chosen by the tool; the [`AdminReply`] to this call carries it.
    pub id: u32,
    /// What is asked.
    pub request: AdminRequest,
}

/// What an operator may ask of a running server.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AdminRequest {
    /// Report the server's state ([`AdminResponse::Status`]).
    Status,
    /// Stop running ticks (time scale 0); clients keep their connections.
    Pause,
    /// Run ticks again at the time scale before the pause.
    Resume,
    /// Run exactly `ticks` ticks, then stay paused.
    Step {
        /// How many ticks (at least 1; a server refuses, as out of range,
        /// more than an hour of simulation queued).
        ticks: u64,
    },
    /// Run at `scale` simulated seconds per wall second. When the machine
    /// cannot keep up the server runs as fast as it can and reports the
    /// rate it reaches in [`StatusReport::achieved_rate`].
    Speed {
        /// Time scale, [`MIN_TIME_SCALE`] ≤ `scale` ≤ [`MAX_TIME_SCALE`].
        scale: f64,
    },
    /// Run until tick `tick`, then pause.
    RunTo {
        /// The tick to stop at (ahead, by at most an hour of simulation;
        /// a server refuses more as out of range).
        tick: u64,
    },
    /// Jump to tick `tick` of the recording (restore the keyframe at or
    /// before it, then re-simulate), and pause there.
    Seek {
        /// The tick to show.
        tick: u64,
    },
    /// Play the recording backwards from the current tick (by seeking,
    /// never by integrating backwards).
    Reverse {
        /// Time scale, [`MIN_TIME_SCALE`] ≤ `speed` ≤ [`MAX_TIME_SCALE`] (1 is real time).
        speed: f64,
    },
    /// Play the recorded ticks `from..=to` to the clients like a live
    /// world.
    Replay {
        /// The first tick.
        from: u64,
        /// The last tick (not before `from`).
        to: u64,
        /// Time scale, [`MIN_TIME_SCALE`] ≤ `speed` ≤ [`MAX_TIME_SCALE`] (1 is real time).
        speed: f64,
    },
    /// Write the world's full state to a checkpoint in the server's
    /// checkpoint directory.
    Save {
        /// The checkpoint's name (a name in that directory, never a path).
        name: CheckpointName,
        /// Replace a checkpoint already saved under `name`; without it an
        /// existing one is kept and the save refused.
        overwrite: bool,
    },
    /// Replace the world's state with a checkpoint from the server's
    /// checkpoint directory.
    Load {
        /// The checkpoint's name.
        name: CheckpointName,
    },
    /// Start or stop recording keyframes and inputs.
    Record {
        /// True to record, false to stop.
        on: bool,
    },
    /// Add a body to the live world ([`AdminResponse::Spawned`] names it).
    Spawn {
        /// What to add.
        desc: SpawnDesc,
    },
    /// Remove a body from the live world.
    Despawn {
        /// The entity.
        id: EntityId,
    },
    /// Apply an impulse to a body.
    Impulse {
        /// The entity.
        id: EntityId,
        /// The impulse, N·s (world frame).
        impulse: [f64; 3],
        /// Where it acts, m (world frame); `None` is the centre of mass.
        point: Option<[f64; 3]>,
    },
    /// Disconnect a client.
    Kick {
        /// The client's id.
        client: u64,
        /// Why, shown to the player (at most [`MAX_KICK_REASON_BYTES`]).
        reason: String,
    },
    /// Report the state hash at a tick ([`AdminResponse::Hash`]).
    Hash {
        /// The tick; `None` is the current one. A past tick is
        /// re-simulated from the recording.
        tick: Option<u64>,
    },
    /// List the finished matches whose recordings the server keeps
    /// ([`AdminResponse::Matches`]).
    Matches,
    /// Read part of a kept match's recording
    /// ([`AdminResponse::RecordingPart`]): file `file` (its files in name
    /// order, from 0), from byte `offset`.
    FetchRecording {
        /// The match.
        name: MatchName,
        /// Which file of its recording.
        file: u32,
        /// From which byte.
        offset: u64,
    },
}

/// The name of a checkpoint in the server's checkpoint directory: 1 to
/// [`MAX_CHECKPOINT_NAME_BYTES`] characters of `A-Z a-z 0-9 . _ -`, not
/// starting with `.`. So it is never a path: no `/`, no `..`, nothing
/// absolute, no hidden file (the server keeps its temporary files under
/// names starting with `.`).
///
/// [`CheckpointName::new`] checks a name. One decoded off the wire is
/// checked after decoding, with the rest of the request
/// ([`AdminRequest::check`], which the framing runs for every
/// [`AdminCall`]); [`CheckpointName::check`] checks it again wherever it
/// is about to name a file.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct CheckpointName(String);

impl CheckpointName {
    /// `name`, if it is a valid checkpoint name.
    pub fn new(name: impl Into<String>) -> Result<CheckpointName, AdminValidationError> {
        let name = CheckpointName(name.into());
        name.check()?;
        Ok(name)
    }

    /// Checks the name (see the type's docs).
    pub fn check(&self) -> Checked {
        check_file_name("checkpoint name", &self.0)
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

/// Checks a name that will name a file or directory inside one of the
/// server's directories: 1 to [`MAX_CHECKPOINT_NAME_BYTES`] characters of
/// `A-Z a-z 0-9 . _ -`, not starting with `.` (so never a path).
fn check_file_name(what: &'static str, name: &str) -> Checked {
    if name.is_empty() {
        return Err(AdminValidationError::EmptyName);
    }
    check_len(what, name.len(), MAX_CHECKPOINT_NAME_BYTES)?;
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-')))
    {
        return Err(AdminValidationError::NameCharacter(c));
    }
    if name.starts_with('.') {
        return Err(AdminValidationError::NameStartsWithDot);
    }
    Ok(())
}

/// The name of a finished match's recording, kept in the server's
/// matches directory (`<data-dir>/matches/<name>/`); the rules of a
/// [`CheckpointName`], so it is never a path either.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct MatchName(String);

impl MatchName {
    /// `name`, if it is a valid match name.
    pub fn new(name: impl Into<String>) -> Result<MatchName, AdminValidationError> {
        let name = MatchName(name.into());
        name.check()?;
        Ok(name)
    }

    /// Checks the name (see the type's docs).
    pub fn check(&self) -> Checked {
        check_file_name("match name", &self.0)
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for MatchName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// A finished match whose recording the server keeps.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeptMatch {
    /// Its name.
    pub name: MatchName,
    /// Files in its recording.
    pub files: u32,
    /// Their bytes in all.
    pub bytes: u64,
}

/// Most matches one [`AdminResponse::Matches`] lists (the newest, by
/// name): a listing fits one control frame.
pub const MAX_MATCHES_LISTED: usize = 256;
/// Most bytes of a recording one [`AdminResponse::RecordingPart`] carries.
pub const MAX_RECORDING_PART: usize = 32 * 1024;

impl std::fmt::Display for CheckpointName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::str::FromStr for CheckpointName {
    type Err = AdminValidationError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        CheckpointName::new(s)
    }
}

/// A body for [`AdminRequest::Spawn`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpawnDesc {
    /// What kind of thing it is.
    pub kind: EntityKind,
    /// Its shape (validated as a spawn on the control channel is; compounds
    /// do not nest).
    #[serde(deserialize_with = "crate::control::deserialize_shape")]
    pub shape: ShapeDesc,
    /// How heavy it is.
    pub mass: MassSpec,
    /// Position of the body's origin, m.
    pub position: [f64; 3],
    /// Orientation (x, y, z, w); need not be unit, but not zero (the
    /// server normalises it).
    pub rotation: [f64; 4],
    /// Linear velocity, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity, rad/s (world frame).
    pub angular_velocity: [f64; 3],
    /// RGBA colour for the clients.
    pub color: [u8; 4],
    /// A name for debugging and tools (at most [`MAX_ENTITY_NAME_BYTES`]).
    pub name: String,
}

/// How the mass of a spawned body is given.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum MassSpec {
    /// Density, kg/m³ (above zero); the mass follows from the shape.
    Density(f64),
    /// Total mass, kg (above zero).
    Mass(f64),
}

impl SpawnDesc {
    /// The description clients receive when the spawned body, numbered
    /// `id`, enters their view.
    pub fn entity(&self, id: EntityId) -> EntityDesc {
        EntityDesc {
            id,
            kind: self.kind,
            shape: self.shape.clone(),
            color: self.color,
            owner: None,
            name: self.name.clone(),
            position: self.position,
            rotation: self.rotation,
        }
    }
}

/// The server's answer to one [`AdminCall`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdminReply {
    /// The [`AdminCall::id`] answered.
    pub id: u32,
    /// The answer.
    pub response: AdminResponse,
}

/// What the server answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AdminResponse {
    /// The answer to [`AdminRequest::Status`].
    Status(StatusReport),
    /// Done (or, for long runs such as [`AdminRequest::RunTo`], started).
    Ok,
    /// The answer to [`AdminRequest::Hash`].
    Hash {
        /// The tick hashed.
        tick: u64,
        /// The 64-bit state hash of the world at that tick.
        state_hash: u64,
        /// The hash the recording stored for that tick, if it has one.
        recorded_hash: Option<u64>,
    },
    /// The answer to [`AdminRequest::Spawn`].
    Spawned {
        /// The new entity.
        id: EntityId,
    },
    /// The answer to [`AdminRequest::Matches`], newest last (at most
    /// [`MAX_MATCHES_LISTED`]).
    Matches(Vec<KeptMatch>),
    /// The answer to [`AdminRequest::FetchRecording`].
    RecordingPart {
        /// Files in the recording.
        files: u32,
        /// This file's name (a [`MatchName`]'s characters).
        file_name: String,
        /// This file's length, bytes.
        file_len: u64,
        /// Where `data` starts in it.
        offset: u64,
        /// At most [`MAX_RECORDING_PART`] bytes; empty at the file's end.
        data: Vec<u8>,
    },
    /// The request was not carried out.
    Error(AdminError),
}

/// The server's state, as [`AdminResponse::Status`] reports it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StatusReport {
    /// The current tick.
    pub tick: u64,
    /// Simulation time at that tick, s (not negative).
    pub sim_time: f64,
    /// The server's wall clock, unix seconds.
    pub wall_time_unix: f64,
    /// The time scale asked for, simulated seconds per wall second, 0 to
    /// [`MAX_TIME_SCALE`] (0 while paused).
    pub time_scale: f64,
    /// Ticks actually run per wall second lately, Hz (not negative); below
    /// `time_scale × tick_hz` when the machine cannot keep up.
    pub achieved_rate: f64,
    /// True while paused.
    pub paused: bool,
    /// Connected game clients.
    pub clients: u32,
    /// Bodies in the world.
    pub bodies: u32,
    /// The 99th percentile of recent tick durations, ms (not negative).
    pub tick_ms_p99: f64,
    /// The 64-bit state hash of the current tick.
    pub state_hash: u64,
    /// True while keyframes and inputs are being recorded.
    pub recording: bool,
    /// The live world's tick (equal to `tick` unless history is shown).
    pub live_tick: u64,
    /// What is shown.
    pub mode: TimeMode,
}

/// What a server shows its clients.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum TimeMode {
    /// The live world.
    #[default]
    Live,
    /// A recorded tick, paused.
    History,
    /// History playing forward (it becomes live at the live tick).
    Forward,
    /// History playing backwards.
    Reverse,
    /// A replay of a stretch of history, after which the live world comes
    /// back where it was left.
    Replay,
}

impl TimeMode {
    /// Its name in tools and logs.
    pub fn name(self) -> &'static str {
        match self {
            TimeMode::Live => "live",
            TimeMode::History => "history",
            TimeMode::Forward => "forward",
            TimeMode::Reverse => "reverse",
            TimeMode::Replay => "replay",
        }
    }
}

/// Why a request was not carried out.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdminError {
    /// What kind of failure.
    pub kind: AdminErrorKind,
    /// What happened, for the operator (at most [`MAX_ADMIN_ERROR_BYTES`]).
    pub message: String,
}

/// The kinds of [`AdminError`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AdminErrorKind {
    /// The request is malformed or makes no sense now.
    Invalid,
    /// The entity, client or file named does not exist.
    NotFound,
    /// A tick, speed or value outside what the server can do.
    OutOfRange,
    /// The tick asked for was not recorded.
    NotRecorded,
    /// Another long-running request is in progress.
    Busy,
    /// Reading or writing a file failed.
    Io,
    /// This server does not do that.
    Unsupported,
}

/// What is wrong with an admin message, as its `check` method finds it.
/// [`ControlMessage::validate`] reports the same failures as
/// [`ControlError`]s.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AdminValidationError {
    /// A number that is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// The field.
        what: &'static str,
    },
    /// A time scale outside [`MIN_TIME_SCALE`] ≤ scale ≤ [`MAX_TIME_SCALE`].
    #[error("{what} {scale} is outside {min}..={max}")]
    TimeScale {
        /// The field.
        what: &'static str,
        /// The value asked for.
        scale: f64,
        /// [`MIN_TIME_SCALE`].
        min: f64,
        /// [`MAX_TIME_SCALE`].
        max: f64,
    },
    /// A replay that ends before it starts.
    #[error("replay from tick {from} to tick {to} runs backwards")]
    ReplayBackwards {
        /// The first tick.
        from: u64,
        /// The last tick.
        to: u64,
    },
    /// An empty checkpoint name.
    #[error("the checkpoint name is empty")]
    EmptyName,
    /// A checkpoint name with a character outside `A-Z a-z 0-9 . _ -`
    /// (a `/` among them: checkpoints are named, not found by path).
    #[error(
        "the checkpoint name holds {0:?}: a name is letters, digits, `.`, `_` and `-` \
         (a name in the server's checkpoint directory, not a path)"
    )]
    NameCharacter(char),
    /// A checkpoint name starting with `.` (`..`, or a hidden file).
    #[error("the checkpoint name starts with `.`")]
    NameStartsWithDot,
    /// A control character in the operator name (it goes to the audit log
    /// as is).
    #[error("the operator name holds a control character")]
    ControlCharacter,
    /// A string longer than its bound.
    #[error("{what} is {len} bytes, the most is {max}")]
    TooLong {
        /// The field.
        what: &'static str,
        /// Its length, bytes.
        len: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// A number outside its range (zero ticks, a mass not above zero, a
    /// zero rotation).
    #[error("{what} is out of range")]
    OutOfRange {
        /// The field.
        what: &'static str,
    },
    /// The spawn's shape or name fails the control channel's checks.
    #[error("spawn: {0}")]
    Spawn(ControlError),
}

impl From<AdminValidationError> for ControlError {
    fn from(e: AdminValidationError) -> Self {
        use AdminValidationError as E;
        match e {
            E::NotFinite { what } => ControlError::NotFinite { what },
            E::TooLong { what, len, max } => ControlError::TooLong { what, len, max },
            E::TimeScale { what, .. } | E::OutOfRange { what } => ControlError::OutOfRange { what },
            E::ReplayBackwards { .. } => ControlError::OutOfRange {
                what: "replay range",
            },
            E::EmptyName | E::NameCharacter(_) | E::NameStartsWithDot => ControlError::OutOfRange {
                what: "checkpoint name",
            },
            E::ControlCharacter => ControlError::OutOfRange {
                what: "operator name",
            },
            E::Spawn(e) => e,
        }
    }
}

impl From<AdminValidationError> for AdminError {
    /// The answer to a request that fails its check: kind
    /// [`AdminErrorKind::Invalid`], the failure as the message.
    fn from(e: AdminValidationError) -> Self {
        let mut message = e.to_string();
        truncate_utf8(&mut message, MAX_ADMIN_ERROR_BYTES);
        AdminError {
            kind: AdminErrorKind::Invalid,
            message,
        }
    }
}

impl AdminError {
    /// An error of `kind` with `message`, cut to
    /// [`MAX_ADMIN_ERROR_BYTES`] at a character boundary.
    pub fn new(kind: AdminErrorKind, message: impl Into<String>) -> Self {
        let mut message = message.into();
        truncate_utf8(&mut message, MAX_ADMIN_ERROR_BYTES);
        AdminError { kind, message }
    }
}

type Checked = Result<(), AdminValidationError>;

fn check_len(what: &'static str, len: usize, max: usize) -> Checked {
    if len > max {
        return Err(AdminValidationError::TooLong { what, len, max });
    }
    Ok(())
}

fn check_finite(what: &'static str, v: &[f64]) -> Checked {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(AdminValidationError::NotFinite { what })
    }
}

/// Finite and not negative.
fn check_non_negative(what: &'static str, v: f64) -> Checked {
    check_finite(what, &[v])?;
    if v < 0.0 {
        return Err(AdminValidationError::OutOfRange { what });
    }
    Ok(())
}

fn check_scale(what: &'static str, scale: f64) -> Checked {
    check_finite(what, &[scale])?;
    if !(MIN_TIME_SCALE..=MAX_TIME_SCALE).contains(&scale) {
        return Err(AdminValidationError::TimeScale {
            what,
            scale,
            min: MIN_TIME_SCALE,
            max: MAX_TIME_SCALE,
        });
    }
    Ok(())
}

/// Checks an operator name: at most [`MAX_OPERATOR_BYTES`] of UTF-8, no
/// control characters (the name goes to the audit log as is). The rule
/// of [`AdminHello::check`], for anything else that names operators.
pub fn check_operator_name(name: &str) -> Checked {
    check_len("operator name", name.len(), MAX_OPERATOR_BYTES)?;
    if name.chars().any(char::is_control) {
        return Err(AdminValidationError::ControlCharacter);
    }
    Ok(())
}

impl AdminHello {
    /// Checks the credential's and operator name's bounds.
    pub fn check(&self) -> Checked {
        check_len("admin credential", self.token.len(), MAX_CREDENTIAL_BYTES)?;
        check_operator_name(&self.operator)
    }
}

impl AdminHandshake {
    /// Checks the welcome's bounds (a refusal has none).
    pub fn check(&self) -> Checked {
        match self {
            AdminHandshake::Welcome(w) => {
                check_len("server version", w.server_version.len(), MAX_VERSION_BYTES)?;
                if w.tick_hz == 0 {
                    return Err(AdminValidationError::OutOfRange { what: "tick rate" });
                }
                Ok(())
            }
            AdminHandshake::Refused(_) => Ok(()),
        }
    }
}

impl SpawnDesc {
    /// Checks the body: finite numbers, a positive mass or density, a
    /// rotation that is not zero, and the shape and name as the control
    /// channel checks a spawn.
    pub fn check(&self) -> Checked {
        check_finite("spawn position", &self.position)?;
        check_finite("spawn rotation", &self.rotation)?;
        check_finite("spawn velocity", &self.velocity)?;
        check_finite("spawn angular velocity", &self.angular_velocity)?;
        let norm2: f64 = self.rotation.iter().map(|x| x * x).sum();
        if !(norm2 > 0.0 && norm2.is_finite()) {
            return Err(AdminValidationError::OutOfRange {
                what: "spawn rotation",
            });
        }
        let (what, m) = match self.mass {
            MassSpec::Density(d) => ("spawn density", d),
            MassSpec::Mass(m) => ("spawn mass", m),
        };
        check_finite(what, &[m])?;
        if m <= 0.0 {
            return Err(AdminValidationError::OutOfRange { what });
        }
        check_len("entity name", self.name.len(), MAX_ENTITY_NAME_BYTES)?;
        validate_entity(&self.entity(0)).map_err(AdminValidationError::Spawn)
    }
}

impl AdminRequest {
    /// Checks the request's bounds: finite numbers, time scales in
    /// [`MIN_TIME_SCALE`]..=[`MAX_TIME_SCALE`], replays that run forwards,
    /// valid checkpoint names, bounded strings, valid spawns.
    pub fn check(&self) -> Checked {
        match self {
            AdminRequest::Status
            | AdminRequest::Pause
            | AdminRequest::Resume
            | AdminRequest::RunTo { .. }
            | AdminRequest::Seek { .. }
            | AdminRequest::Record { .. }
            | AdminRequest::Despawn { .. }
            | AdminRequest::Hash { .. }
            | AdminRequest::Matches => Ok(()),
            AdminRequest::FetchRecording { name, .. } => name.check(),
            AdminRequest::Step { ticks } => {
                if *ticks == 0 {
                    return Err(AdminValidationError::OutOfRange { what: "step ticks" });
                }
                Ok(())
            }
            AdminRequest::Speed { scale } => check_scale("time scale", *scale),
            AdminRequest::Reverse { speed } => check_scale("reverse speed", *speed),
            AdminRequest::Replay { from, to, speed } => {
                check_scale("replay speed", *speed)?;
                if from > to {
                    return Err(AdminValidationError::ReplayBackwards {
                        from: *from,
                        to: *to,
                    });
                }
                Ok(())
            }
            AdminRequest::Save { name, .. } | AdminRequest::Load { name } => name.check(),
            AdminRequest::Spawn { desc } => desc.check(),
            AdminRequest::Impulse { impulse, point, .. } => {
                check_finite("impulse", impulse)?;
                match point {
                    Some(p) => check_finite("impulse point", p),
                    None => Ok(()),
                }
            }
            AdminRequest::Kick { reason, .. } => {
                check_len("kick reason", reason.len(), MAX_KICK_REASON_BYTES)
            }
        }
    }
}

impl StatusReport {
    /// Checks the report: finite numbers, times and rates not negative, a
    /// time scale from 0 to [`MAX_TIME_SCALE`].
    pub fn check(&self) -> Checked {
        check_non_negative("sim time", self.sim_time)?;
        check_finite("wall time", &[self.wall_time_unix])?;
        check_non_negative("time scale", self.time_scale)?;
        if self.time_scale > MAX_TIME_SCALE {
            return Err(AdminValidationError::TimeScale {
                what: "time scale",
                scale: self.time_scale,
                min: 0.0,
                max: MAX_TIME_SCALE,
            });
        }
        check_non_negative("achieved rate", self.achieved_rate)?;
        check_non_negative("tick p99", self.tick_ms_p99)
    }
}

impl AdminResponse {
    /// Checks the response's bounds.
    pub fn check(&self) -> Checked {
        match self {
            AdminResponse::Status(report) => report.check(),
            AdminResponse::Ok | AdminResponse::Hash { .. } | AdminResponse::Spawned { .. } => {
                Ok(())
            }
            AdminResponse::Matches(list) => {
                check_len("matches listed", list.len(), MAX_MATCHES_LISTED)?;
                list.iter().try_for_each(|m| m.name.check())
            }
            AdminResponse::RecordingPart {
                file_name, data, ..
            } => {
                check_file_name("recording file name", file_name)?;
                check_len("recording part", data.len(), MAX_RECORDING_PART)
            }
            AdminResponse::Error(e) => {
                check_len("admin error", e.message.len(), MAX_ADMIN_ERROR_BYTES)
            }
        }
    }
}

impl ControlMessage for AdminHello {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.check()?)
    }
}

impl ControlMessage for AdminHandshake {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.check()?)
    }
}

impl ControlMessage for AdminCall {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.request.check()?)
    }
}

impl ControlMessage for AdminReply {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.response.check()?)
    }
}

/// True when `given` is the admin credential `expected`, compared in time
/// that does not depend on where they differ, nor on `given`'s length:
/// both are reduced to HMAC-SHA256 tags first and the tags compared in
/// constant time. An empty `expected` matches nothing, so a server without
/// a credential admits no one.
pub fn credential_matches(expected: &str, given: &str) -> bool {
    if expected.is_empty() {
        return false;
    }
    // The key only makes both sides fixed-length; it is not a secret.
    let key = hmac::Key::new(hmac::HMAC_SHA256, b"inertia admin credential");
    let tag = hmac::sign(&key, expected.as_bytes());
    hmac::verify(&key, given.as_bytes(), tag.as_ref()).is_ok()
}

/// Answers an admin tool's first message against one credential, without
/// I/O: checks the protocol version first (so an old tool learns it is
/// old), then the hello's bounds, then its credential against `expected`
/// with [`credential_matches`]. On success a server sends
/// [`AdminHandshake::Welcome`] and logs `hello.operator`; on failure,
/// [`AdminHandshake::Refused`] and it closes the connection. (The
/// Inertia server checks the same things in the same order against its
/// table of operators, and throttles addresses that keep failing.)
pub fn admin_handshake(hello: &AdminHello, expected: &str) -> Result<(), AdminRefusal> {
    if hello.version != ADMIN_PROTOCOL_VERSION {
        return Err(AdminRefusal::VersionMismatch {
            server: ADMIN_PROTOCOL_VERSION,
            client: hello.version,
        });
    }
    if hello.check().is_err() {
        return Err(AdminRefusal::Malformed);
    }
    if !credential_matches(expected, &hello.token) {
        return Err(AdminRefusal::BadCredential);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::{decode_payload, encode_frame, MAX_CONTROL_FRAME};

    /// Fails to compile when [`ShapeDesc`] gains a variant the mirror
    /// lacks.
    #[allow(dead_code)]
    fn mirror_is_complete(s: ShapeDesc) {
        match s {
            ShapeDesc::Sphere { .. }
            | ShapeDesc::Cuboid { .. }
            | ShapeDesc::Capsule { .. }
            | ShapeDesc::Cylinder { .. }
            | ShapeDesc::ConvexHull { .. }
            | ShapeDesc::TriMesh { .. }
            | ShapeDesc::Compound { .. }
            | ShapeDesc::Particle { .. }
            | ShapeDesc::Ground
            | ShapeDesc::HeightField { .. }
            | ShapeDesc::PointSet { .. } => {}
        }
    }

    fn spawn(shape: ShapeDesc) -> AdminCall {
        AdminCall {
            id: 1,
            request: AdminRequest::Spawn {
                desc: SpawnDesc {
                    kind: EntityKind::Dynamic,
                    shape,
                    mass: MassSpec::Density(1000.0),
                    position: [0.0, 5.0, 0.0],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                    velocity: [0.0; 3],
                    angular_velocity: [0.0; 3],
                    color: [255; 4],
                    name: "crate".into(),
                },
            },
        }
    }

    #[test]
    fn nested_compounds_are_refused_without_recursing() {
        let leaf = ([0.0f32; 3], [0.0f32, 0.0, 0.0, 1.0]);
        let mut shape = ShapeDesc::Sphere { radius: 1.0 };
        for _ in 0..3 {
            shape = ShapeDesc::Compound {
                parts: vec![(leaf.0, leaf.1, shape)],
            };
        }
        let msg = spawn(shape);
        assert_eq!(encode_frame(&msg), Err(ControlError::NestedCompound));
        let bytes = postcard::to_allocvec(&msg).unwrap();
        assert!(matches!(
            decode_payload::<AdminCall>(&bytes),
            Err(ControlError::Decode(_))
        ));
        let msg = spawn(ShapeDesc::Compound {
            parts: vec![(leaf.0, leaf.1, ShapeDesc::Compound { parts: vec![] })],
        });
        let bytes = postcard::to_allocvec(&msg).unwrap();
        assert_eq!(
            decode_payload::<AdminCall>(&bytes),
            Err(ControlError::NestedCompound)
        );

        // A frame full of nesting, decoded on a small stack: call id 1,
        // Spawn (variant 12), kind Dynamic (1), then compound after
        // compound, each with one part: 30 bytes a level.
        let mut deep = vec![1u8, 12, 1];
        while deep.len() < MAX_CONTROL_FRAME - 30 {
            deep.extend_from_slice(&[6, 1]);
            deep.extend_from_slice(&[0; 28]);
        }
        let handle = std::thread::Builder::new()
            .stack_size(64 * 1024)
            .spawn(move || decode_payload::<AdminCall>(&deep).is_err())
            .unwrap();
        assert!(handle.join().unwrap());
    }

    #[test]
    fn validation_errors_become_invalid_admin_errors() {
        let e = AdminError::from(AdminValidationError::EmptyName);
        assert_eq!(e.kind, AdminErrorKind::Invalid);
        assert_eq!(e.message, "the checkpoint name is empty");
        let long = AdminError::new(AdminErrorKind::Io, "é".repeat(MAX_ADMIN_ERROR_BYTES));
        assert!(long.message.len() <= MAX_ADMIN_ERROR_BYTES);
        assert!(AdminResponse::Error(long).check().is_ok());
    }
}
