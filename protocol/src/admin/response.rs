//! What the server answers an operator: replies, the status report, kept
//! matches.

use super::*;

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

impl ControlMessage for AdminReply {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.response.check()?)
    }
}
