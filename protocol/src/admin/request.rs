//! What an operator may ask a running server: the requests and the names
//! and descriptions they carry.

use super::*;

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

impl ControlMessage for AdminCall {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.request.check()?)
    }
}
