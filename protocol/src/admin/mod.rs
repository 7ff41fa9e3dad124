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
//!
//! One concept a file: the limits and errors here; `handshake.rs` the
//! hello and its answer; `request.rs` what an operator may ask;
//! `response.rs` what the server answers.

mod handshake;
mod request;
mod response;

pub use handshake::*;
pub use request::*;
pub use response::*;

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
pub const MAX_TIME_SCALE: f64 = crate::snapshot::MAX_TIME_SCALE as f64;
/// Smallest time scale above zero an operator may ask for (simulated
/// seconds per wall second; zero is pause): one tick of 60 Hz every 17 wall
/// seconds. Slower than that is a pause with extra steps, and the wall time
/// between ticks (`dt / scale`) must stay a representable `Duration`
/// (`speed 1e-300` once asked for 10²⁹⁸ seconds).
pub const MIN_TIME_SCALE: f64 = 1.0 / 1024.0;

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

#[cfg(test)]
mod tests;
