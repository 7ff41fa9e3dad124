//! The bounds every control message is checked against after decoding
//! (and before encoding): counts, string lengths, finite floats, triangle
//! indices, sensible rates.

use serde::{de::DeserializeOwned, Serialize};

use crate::entity::{EntityDesc, ShapeDesc};
use crate::token::MAX_TOKEN_BYTES;

use super::*;

/// A message that travels on the control channel.
pub trait ControlMessage: Serialize + DeserializeOwned {
    /// Checks the bounds serde cannot: lengths, counts, finite floats,
    /// ranges.
    fn validate(&self) -> Result<(), ControlError>;
}

fn check_len(what: &'static str, len: usize, max: usize) -> Result<(), ControlError> {
    if len > max {
        return Err(ControlError::TooLong { what, len, max });
    }
    Ok(())
}

fn check_count(what: &'static str, len: usize, max: usize) -> Result<(), ControlError> {
    if len > max {
        return Err(ControlError::TooMany { what, len, max });
    }
    Ok(())
}

fn check_finite<const N: usize, F: Into<f64> + Copy>(
    what: &'static str,
    v: &[F; N],
) -> Result<(), ControlError> {
    if v.iter().all(|&x| x.into().is_finite()) {
        Ok(())
    } else {
        Err(ControlError::NotFinite { what })
    }
}

/// A size: finite and not negative.
fn check_size(what: &'static str, v: f32) -> Result<(), ControlError> {
    check_finite(what, &[v])?;
    if v < 0.0 {
        return Err(ControlError::OutOfRange { what });
    }
    Ok(())
}

/// Checks a shape description against [`ShapeDesc`]'s bounds. The match is
/// exhaustive on purpose: a new shape kind must be validated here and
/// mirrored in [`WireShape`] before this compiles.
fn validate_shape(shape: &ShapeDesc, nested: bool) -> Result<(), ControlError> {
    match shape {
        ShapeDesc::Sphere { radius } | ShapeDesc::Particle { radius } => {
            check_size("shape radius", *radius)
        }
        ShapeDesc::Cuboid { half_extents } => half_extents
            .iter()
            .try_for_each(|&h| check_size("cuboid half extent", h)),
        ShapeDesc::Capsule {
            half_height,
            radius,
        }
        | ShapeDesc::Cylinder {
            half_height,
            radius,
        } => {
            check_size("shape half height", *half_height)?;
            check_size("shape radius", *radius)
        }
        ShapeDesc::ConvexHull { points } => {
            check_count("hull points", points.len(), ShapeDesc::MAX_POINTS)?;
            points
                .iter()
                .try_for_each(|p| check_finite("hull point", p))
        }
        ShapeDesc::TriMesh {
            vertices,
            triangles,
        } => {
            check_count("mesh vertices", vertices.len(), ShapeDesc::MAX_POINTS)?;
            check_count("mesh triangles", triangles.len(), ShapeDesc::MAX_POINTS)?;
            vertices
                .iter()
                .try_for_each(|p| check_finite("mesh vertex", p))?;
            for &index in triangles.iter().flatten() {
                if index as usize >= vertices.len() {
                    return Err(ControlError::BadIndex {
                        index,
                        vertices: vertices.len(),
                    });
                }
            }
            Ok(())
        }
        ShapeDesc::Compound { parts } => {
            if nested {
                return Err(ControlError::NestedCompound);
            }
            check_count("compound parts", parts.len(), ShapeDesc::MAX_PARTS)?;
            for (offset, rotation, part) in parts {
                check_finite("compound part offset", offset)?;
                check_finite("compound part rotation", rotation)?;
                validate_shape(part, true)?;
            }
            Ok(())
        }
        ShapeDesc::Ground => Ok(()),
        ShapeDesc::HeightField {
            rows,
            cols,
            size,
            heights,
        } => {
            check_count("heightfield samples", heights.len(), ShapeDesc::MAX_POINTS)?;
            if *rows < 2 || *cols < 2 || u64::from(*rows) * u64::from(*cols) != heights.len() as u64
            {
                return Err(ControlError::OutOfRange {
                    what: "heightfield rows and columns",
                });
            }
            size.iter()
                .try_for_each(|&s| check_size("heightfield size", s))?;
            heights
                .iter()
                .try_for_each(|h| check_finite("heightfield height", &[*h]))
        }
        ShapeDesc::PointSet {
            points,
            radius,
            triangles,
            lines,
        } => {
            if nested {
                return Err(ControlError::OutOfRange {
                    what: "point set inside a compound",
                });
            }
            if *points == 0 || *points > ShapeDesc::MAX_SET_POINTS {
                return Err(ControlError::OutOfRange {
                    what: "point set points",
                });
            }
            check_size("point set radius", *radius)?;
            check_count(
                "point set triangles",
                triangles.len(),
                ShapeDesc::MAX_SET_TRIANGLES,
            )?;
            check_count("point set lines", lines.len(), ShapeDesc::MAX_SET_LINES)?;
            let indices = triangles.iter().flatten().chain(lines.iter().flatten());
            for &index in indices {
                if index >= *points {
                    return Err(ControlError::BadIndex {
                        index,
                        vertices: *points as usize,
                    });
                }
            }
            Ok(())
        }
    }
}

/// Checks an entity description against its bounds.
pub fn validate_entity(e: &EntityDesc) -> Result<(), ControlError> {
    check_len("entity name", e.name.len(), MAX_ENTITY_NAME_BYTES)?;
    check_finite("entity position", &e.position)?;
    check_finite("entity rotation", &e.rotation)?;
    if u64::from(e.id) + e.ids_taken() - 1 > u64::from(EntityId::MAX) {
        return Err(ControlError::OutOfRange {
            what: "point set ids past the last entity id",
        });
    }
    validate_shape(&e.shape, false)
}

impl ControlMessage for ClientControl {
    fn validate(&self) -> Result<(), ControlError> {
        match self {
            ClientControl::Hello { token, .. } => {
                check_len("connect token", token.len(), MAX_TOKEN_BYTES)
            }
            // Its length is the server connection's to check: a longer
            // message is refused and counted there, and the connection
            // lives on (the frame's own bound keeps it finite here).
            ClientControl::Message(_) | ClientControl::Goodbye => Ok(()),
            // Its shape and its stretch are the server's to check: a
            // refused replay is answered and counted, and the connection
            // lives on.
            ClientControl::Replay(_) | ClientControl::CancelReplay => Ok(()),
        }
    }
}

impl ControlMessage for ServerControl {
    fn validate(&self) -> Result<(), ControlError> {
        match self {
            ServerControl::Welcome {
                tick_hz,
                snapshot_hz,
                position_resolution,
                position_bound,
                snapshot,
                input_bytes,
                server_version,
                game,
                properties,
                ..
            } => {
                properties
                    .validate()
                    .map_err(|_| ControlError::OutOfRange {
                        what: "property schema",
                    })?;
                if usize::from(*input_bytes) > crate::input::MAX_INPUT_BYTES {
                    return Err(ControlError::OutOfRange {
                        what: "input payload size",
                    });
                }
                snapshot
                    .config(*position_resolution, *position_bound)
                    .validate()
                    .map_err(|_| ControlError::OutOfRange {
                        what: "snapshot coding",
                    })?;
                check_len("server version", server_version.len(), MAX_VERSION_BYTES)?;
                check_len("game name", game.len(), MAX_GAME_NAME_BYTES)?;
                if *tick_hz == 0 {
                    return Err(ControlError::OutOfRange { what: "tick rate" });
                }
                if *snapshot_hz == 0 {
                    return Err(ControlError::OutOfRange {
                        what: "snapshot rate",
                    });
                }
                check_finite("position grid", &[*position_resolution, *position_bound])?;
                if *position_resolution <= 0.0
                    || *position_bound <= 0.0
                    || (2.0 * *position_bound / *position_resolution).ceil()
                        >= (1u64 << MAX_POSITION_BITS) as f64
                {
                    return Err(ControlError::OutOfRange {
                        what: "position grid",
                    });
                }
                Ok(())
            }
            ServerControl::Refused(Refusal::Token(TokenRefusal::WrongServer { token, ours })) => {
                check_len("refused token address", token.len(), MAX_REASON_BYTES)?;
                check_len("refused server address", ours.len(), MAX_REASON_BYTES)
            }
            ServerControl::Refused(Refusal::Rejected { reason }) => {
                check_len("refusal reason", reason.len(), MAX_REASON_BYTES)
            }
            ServerControl::Replay(crate::replay::ReplayAnswer::Started { speed, .. })
                if !speed.is_finite() =>
            {
                Err(ControlError::OutOfRange {
                    what: "a replay's speed",
                })
            }
            ServerControl::Refused(_)
            | ServerControl::Replay(_)
            | ServerControl::Despawn { .. }
            | ServerControl::InputTiming(_) => Ok(()),
            ServerControl::Spawn(e) => validate_entity(e),
            ServerControl::Message(bytes) => {
                check_len("game message", bytes.len(), MAX_MESSAGE_BYTES)
            }
            ServerControl::Goodbye(reason) => match reason {
                DisconnectReason::Kicked { reason } => {
                    check_len("kick reason", reason.len(), MAX_REASON_BYTES)
                }
                DisconnectReason::ProtocolError { what } => {
                    check_len("protocol error", what.len(), MAX_REASON_BYTES)
                }
                DisconnectReason::SimulationStopped { reason } => {
                    check_len("failure reason", reason.len(), MAX_REASON_BYTES)
                }
                DisconnectReason::MatchOver { reason } => {
                    check_len("match-over reason", reason.len(), MAX_REASON_BYTES)
                }
                DisconnectReason::ServerShutdown
                | DisconnectReason::Timeout
                | DisconnectReason::ClientLeft => Ok(()),
            },
        }
    }
}
