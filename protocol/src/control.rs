//! The reliable control channel: the hello and its answer, spawns and
//! despawns, game events and goodbyes, carried on a QUIC stream.
//!
//! Messages are serde types encoded with postcard. Each travels as a frame,
//! a `u32` little-endian length followed by that many postcard bytes, at
//! most [`MAX_CONTROL_FRAME`]. [`FrameDecoder`] is sans-IO: stream bytes go
//! in as they arrive, whole messages come out.
//!
//! Serde bounds the shape of a message but not its sizes, so every decoded
//! message is then [`ControlMessage::validate`]d: counts, string lengths,
//! finite floats, triangle indices, sensible rates. The sender validates
//! too ([`encode_frame`]), so a message the peer would refuse is never
//! sent.
//!
//! One bound is enforced while decoding rather than after: a compound
//! shape inside a compound. [`ShapeDesc`] is recursive, so a frame of
//! nested compounds would recurse through serde once per level (thousands
//! of levels fit in a frame) and could overflow the stack before any
//! validation ran. Spawns are therefore decoded through a private mirror of
//! [`EntityDesc`] whose grammar stops at one level of nesting.

use serde::{de::DeserializeOwned, Deserialize, Deserializer, Serialize};
use thiserror::Error;

use crate::entity::{EntityDesc, EntityId, EntityKind, ShapeDesc};
use crate::quantize::PositionGrid;
use crate::snapshot::SnapshotConfig;
use crate::token::{self, OpenedToken, ReplayGuard, TokenError, TokenKey, MAX_TOKEN_BYTES};

/// The version of the whole wire protocol (control, datagrams and tokens).
/// A client and server speak only when theirs are equal.
pub const PROTOCOL_VERSION: u16 = 4;
/// The QUIC ALPN protocol id of the game connection.
pub const ALPN: &[u8] = b"inertia";

/// The ALPN of HTTP/3, on which browsers open WebTransport sessions; the
/// game port takes it beside [`ALPN`].
pub const WEB_TRANSPORT_ALPN: &[u8] = b"h3";

/// The path of the game's WebTransport session
/// (`https://HOST:PORT/inertia`). Inside it the protocol is the same as on
/// raw QUIC: the client opens one bidirectional control stream, and
/// snapshots and inputs travel as datagrams.
pub const WEB_TRANSPORT_PATH: &str = "/inertia";
/// Largest postcard payload of one control frame, bytes (the length
/// prefix's 4 bytes not included).
pub const MAX_CONTROL_FRAME: usize = 64 * 1024;
/// Bytes a [`FrameDecoder`] holds at most: room for one whole frame still
/// being received plus one more push of up to [`MAX_CONTROL_FRAME`] bytes.
pub const MAX_DECODER_BUFFER: usize = 2 * (4 + MAX_CONTROL_FRAME);
/// Longest entity name, bytes of UTF-8.
pub const MAX_ENTITY_NAME_BYTES: usize = 64;
/// Longest server version string in a welcome, bytes.
pub const MAX_VERSION_BYTES: usize = 64;
/// Longest text of a [`GameEvent::Message`], bytes.
pub const MAX_MESSAGE_BYTES: usize = 1024;
/// Longest name of a [`GameEvent::Custom`], bytes.
pub const MAX_EVENT_NAME_BYTES: usize = 64;
/// Longest data of a [`GameEvent::Custom`], bytes.
pub const MAX_EVENT_DATA_BYTES: usize = 16 * 1024;
/// Longest reason or description in a refusal or goodbye, bytes.
pub const MAX_REASON_BYTES: usize = 256;
/// Most bits a position axis may take on the grid a welcome announces
/// (the snapshot codec's limit).
pub const MAX_POSITION_BITS: u32 = 32;

/// What a client says on the control stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ClientControl {
    /// The first message: the client's protocol version and its connect
    /// token's bytes (at most [`MAX_TOKEN_BYTES`]).
    Hello {
        /// The client's [`PROTOCOL_VERSION`].
        version: u16,
        /// The connect token, as [`crate::token::ConnectToken::to_bytes`].
        token: Vec<u8>,
    },
    /// The client is leaving.
    Goodbye,
}

/// What a server says on the control stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ServerControl {
    /// The hello was accepted.
    Welcome {
        /// The client's id (from its token).
        client_id: u64,
        /// The server's current tick.
        tick: u64,
        /// Physics ticks per second of simulation time, Hz.
        tick_hz: u32,
        /// Snapshots per second of wall time, Hz.
        snapshot_hz: u32,
        /// Snapshot position grid step, m.
        position_resolution: f64,
        /// Largest snapshot coordinate magnitude, m.
        position_bound: f64,
        /// The rest of the snapshot coding.
        snapshot: SnapshotParams,
        /// The server build, for logs (at most [`MAX_VERSION_BYTES`]).
        server_version: String,
    },
    /// The hello was refused; the server closes the connection next.
    Refused(Refusal),
    /// An entity entered the client's view.
    Spawn(#[serde(deserialize_with = "deserialize_entity")] EntityDesc),
    /// An entity left the client's view or the world.
    Despawn {
        /// The entity.
        id: EntityId,
    },
    /// Something happened that the client should show.
    Event(GameEvent),
    /// The server is closing the connection.
    Goodbye(DisconnectReason),
    /// How the client's inputs have been arriving against the ticks they
    /// are for: sent about once a second while it changes, so the client
    /// can run as far ahead as its inputs need to arrive in time.
    InputTiming(InputReport),
}

/// How a client's inputs have been arriving, as the server counted them
/// since the client joined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct InputReport {
    /// Inputs that arrived before their tick and were applied on it.
    pub on_time: u64,
    /// Inputs that arrived after their tick and were applied at once.
    pub late: u64,
    /// Inputs refused: too far ahead, or too many waiting.
    pub refused: u64,
    /// The least lead over the last second: the input's tick minus the
    /// server's tick when it arrived, ticks (negative: late; the server
    /// steps tick `t` to `t + 1` with the inputs for `t`). `None` when no
    /// input arrived in that second.
    pub min_lead: Option<i32>,
}

/// How the server codes snapshots, beyond the position grid: what the
/// client's [`SnapshotDecoder`](crate::snapshot::SnapshotDecoder) needs to
/// read them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SnapshotParams {
    /// Bits per smallest-three rotation component.
    pub rotation_bits: u8,
    /// Velocity grid step, m/s, when velocities are sent.
    pub velocity_resolution: Option<f64>,
    /// Largest velocity component magnitude, m/s.
    pub velocity_bound: f64,
    /// The largest snapshot datagram, bytes.
    pub max_datagram: u16,
}

impl Default for SnapshotParams {
    fn default() -> Self {
        Self::from_config(&SnapshotConfig::default())
    }
}

impl SnapshotParams {
    /// The parameters of `config` (its position grid travels separately).
    pub fn from_config(config: &SnapshotConfig) -> Self {
        Self {
            rotation_bits: config.rotation_bits.min(255) as u8,
            velocity_resolution: config.velocities.then_some(config.velocity_grid.resolution),
            velocity_bound: config.velocity_grid.bound,
            max_datagram: config.max_datagram.min(usize::from(u16::MAX)) as u16,
        }
    }

    /// The full snapshot configuration with the position grid
    /// `resolution` (m) and `bound` (m). Check it with
    /// [`SnapshotConfig::validate`].
    pub fn config(&self, resolution: f64, bound: f64) -> SnapshotConfig {
        let default = SnapshotConfig::default();
        SnapshotConfig {
            grid: PositionGrid { resolution, bound },
            rotation_bits: u32::from(self.rotation_bits),
            velocities: self.velocity_resolution.is_some(),
            velocity_grid: PositionGrid {
                resolution: self
                    .velocity_resolution
                    .unwrap_or(default.velocity_grid.resolution),
                bound: self.velocity_bound,
            },
            max_datagram: usize::from(self.max_datagram),
        }
    }
}

/// Why a hello was refused.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// Client and server speak different protocol versions.
    VersionMismatch {
        /// The server's version.
        server: u16,
        /// The client's version.
        client: u16,
    },
    /// The connect token was refused.
    Token(TokenRefusal),
    /// No room for another client; try later or elsewhere.
    ServerFull,
    /// The server is shutting down.
    ShuttingDown,
    /// The first message was not a well-formed hello.
    Malformed,
    /// A connection with this client id is already in the game.
    AlreadyConnected,
    /// The server's simulation is too busy to take the join now; retry in
    /// a moment.
    Busy,
    /// The server's simulation has stopped (it is about to restart).
    SimulationStopped,
    /// The game's rules refused the join, for their own reason (at most
    /// [`MAX_REASON_BYTES`]).
    Rejected {
        /// Why, for the player.
        reason: String,
    },
}

/// Why a connect token was refused, as told to the client: the
/// [`TokenError`] without anything the client should not learn.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum TokenRefusal {
    /// The bytes are not a token of this protocol version.
    Malformed,
    /// The token does not verify under the server's key.
    Forged,
    /// The token has expired; fetch a new one.
    Expired {
        /// Its expiry, unix seconds.
        expires_at: u64,
        /// The server's clock, unix seconds.
        now: u64,
    },
    /// The token is for another server.
    WrongServer {
        /// The address in the token (at most [`MAX_REASON_BYTES`]).
        token: String,
        /// This server's address (at most [`MAX_REASON_BYTES`]).
        ours: String,
    },
    /// The token already opened another connection.
    Reused,
}

impl From<TokenError> for Refusal {
    fn from(e: TokenError) -> Self {
        match e {
            TokenError::Malformed(_) => Refusal::Token(TokenRefusal::Malformed),
            TokenError::Forged => Refusal::Token(TokenRefusal::Forged),
            TokenError::Expired { expires_at, now } => {
                Refusal::Token(TokenRefusal::Expired { expires_at, now })
            }
            TokenError::WrongServer { token, ours } => {
                Refusal::Token(TokenRefusal::WrongServer { token, ours })
            }
            TokenError::Reused { .. } => Refusal::Token(TokenRefusal::Reused),
            TokenError::ReplayGuardFull { .. } => Refusal::ServerFull,
        }
    }
}

/// The QUIC application close codes of a game connection; the reason
/// text beside them is for people, the code is what a client maps to a
/// [`DisconnectReason`] ([`DisconnectReason::from_close`]).
pub mod close_code {
    /// A normal goodbye.
    pub const GOODBYE: u32 = 0;
    /// The hello was refused.
    pub const REFUSED: u32 = 1;
    /// The peer broke the protocol on its control stream.
    pub const PROTOCOL: u32 = 2;
    /// The server is shutting down.
    pub const SHUTDOWN: u32 = 3;
    /// An operator kicked the client.
    pub const KICKED: u32 = 4;
    /// The simulation failed; the server is about to restart. The reason
    /// text is `simulation stopped: <what failed>`.
    pub const SIMULATION_STOPPED: u32 = 5;
    /// Nothing was heard from the client for too long.
    pub const TIMEOUT: u32 = 6;
    /// The match is over (its time is up, or the game rules ended it);
    /// the reason text says why.
    pub const MATCH_OVER: u32 = 7;
}

/// The prefix of the reason text of a [`close_code::SIMULATION_STOPPED`]
/// close, before what failed.
pub const SIMULATION_STOPPED_PREFIX: &str = "simulation stopped: ";

impl DisconnectReason {
    /// Why the server closed a game connection with application close
    /// `code` and `reason` text (untrusted: cut to [`MAX_REASON_BYTES`]).
    /// A code this protocol does not define reads as a kick, with the
    /// text as its reason.
    pub fn from_close(code: u64, reason: &[u8]) -> DisconnectReason {
        let mut text = String::from_utf8_lossy(reason).into_owned();
        truncate_utf8(&mut text, MAX_REASON_BYTES);
        match u32::try_from(code) {
            Ok(close_code::SIMULATION_STOPPED) => DisconnectReason::SimulationStopped {
                reason: text
                    .strip_prefix(SIMULATION_STOPPED_PREFIX)
                    .unwrap_or(&text)
                    .to_string(),
            },
            Ok(close_code::SHUTDOWN) => DisconnectReason::ServerShutdown,
            Ok(close_code::PROTOCOL) => DisconnectReason::ProtocolError { what: text },
            Ok(close_code::GOODBYE) => DisconnectReason::ClientLeft,
            Ok(close_code::TIMEOUT) => DisconnectReason::Timeout,
            Ok(close_code::MATCH_OVER) => DisconnectReason::MatchOver { reason: text },
            _ => DisconnectReason::Kicked { reason: text },
        }
    }

    /// The application close code and reason text that say this reason
    /// on their own, for a client that sees the close before the goodbye
    /// (a close discards what is still in flight): the inverse of
    /// [`DisconnectReason::from_close`]. The text is at most
    /// [`MAX_REASON_BYTES`] plus the simulation-stopped prefix.
    pub fn to_close(&self) -> (u32, String) {
        let mut text = match self {
            DisconnectReason::ServerShutdown => "server shutting down".to_string(),
            DisconnectReason::Kicked { reason } => reason.clone(),
            DisconnectReason::Timeout => "timed out".to_string(),
            DisconnectReason::ClientLeft => "goodbye".to_string(),
            DisconnectReason::ProtocolError { what } => what.clone(),
            DisconnectReason::SimulationStopped { reason } => reason.clone(),
            DisconnectReason::MatchOver { reason } => reason.clone(),
        };
        truncate_utf8(&mut text, MAX_REASON_BYTES);
        match self {
            DisconnectReason::ServerShutdown => (close_code::SHUTDOWN, text),
            DisconnectReason::Kicked { .. } => (close_code::KICKED, text),
            DisconnectReason::Timeout => (close_code::TIMEOUT, text),
            DisconnectReason::ClientLeft => (close_code::GOODBYE, text),
            DisconnectReason::ProtocolError { .. } => (close_code::PROTOCOL, text),
            DisconnectReason::MatchOver { .. } => (close_code::MATCH_OVER, text),
            DisconnectReason::SimulationStopped { .. } => (
                close_code::SIMULATION_STOPPED,
                format!("{SIMULATION_STOPPED_PREFIX}{text}"),
            ),
        }
    }
}

/// Why a connection ended.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum DisconnectReason {
    /// The server is stopping.
    ServerShutdown,
    /// An operator or the game removed the client.
    Kicked {
        /// Why, for the player (at most [`MAX_REASON_BYTES`]).
        reason: String,
    },
    /// Nothing was heard from the peer for too long.
    Timeout,
    /// The client said goodbye.
    ClientLeft,
    /// The peer broke the protocol.
    ProtocolError {
        /// What it did (at most [`MAX_REASON_BYTES`]).
        what: String,
    },
    /// The server's simulation failed and stopped; the server restarts
    /// (and resumes from its recording), so reconnecting later works.
    SimulationStopped {
        /// What failed, for logs (at most [`MAX_REASON_BYTES`]).
        reason: String,
    },
    /// The match is over: its time is up, or the game rules ended it. The
    /// server drains and stops (under Agones, its game server is deleted).
    MatchOver {
        /// Why, for the player (at most [`MAX_REASON_BYTES`]).
        reason: String,
    },
}

/// Something that happened in the world, sent reliably to the clients that
/// should show it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum GameEvent {
    /// Two entities hit each other hard enough to matter.
    Contact {
        /// One entity.
        a: EntityId,
        /// The other.
        b: EntityId,
        /// The impulse exchanged, N·s.
        impulse: f32,
    },
    /// An explosion.
    Explosion {
        /// Its centre, m.
        position: [f64; 3],
        /// Its radius, m.
        radius: f32,
    },
    /// A text message (at most [`MAX_MESSAGE_BYTES`]).
    Message {
        /// The text.
        text: String,
    },
    /// A game-defined event.
    Custom {
        /// Its name (at most [`MAX_EVENT_NAME_BYTES`]).
        name: String,
        /// Its payload (at most [`MAX_EVENT_DATA_BYTES`]).
        data: Vec<u8>,
    },
}

/// Why a control frame could not be encoded or decoded.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ControlError {
    /// A frame longer than [`MAX_CONTROL_FRAME`]. On decoding this is
    /// fatal: the stream cannot be resynchronised.
    #[error("control frame of {len} bytes, the most is {max}")]
    FrameTooLarge {
        /// Its length, bytes.
        len: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// A push that would take the decoder past [`MAX_DECODER_BUFFER`];
    /// drain it with [`FrameDecoder::next`] first.
    #[error("decoder holds {buffered} bytes, {pushed} more would pass {max}")]
    BufferFull {
        /// Bytes already held.
        buffered: usize,
        /// Bytes pushed.
        pushed: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// The bytes are not a message of the expected type.
    #[error("control message does not decode: {0}")]
    Decode(postcard::Error),
    /// The message could not be serialized.
    #[error("control message does not encode: {0}")]
    Encode(postcard::Error),
    /// The frame holds bytes after its message.
    #[error("{extra} bytes after the control message")]
    TrailingBytes {
        /// How many.
        extra: usize,
    },
    /// A string or byte field longer than its bound.
    #[error("{what} is {len} bytes, the most is {max}")]
    TooLong {
        /// The field.
        what: &'static str,
        /// Its length, bytes.
        len: usize,
        /// The bound, bytes.
        max: usize,
    },
    /// A list with more items than its bound.
    #[error("{what} has {len} items, the most is {max}")]
    TooMany {
        /// The list.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The bound.
        max: usize,
    },
    /// A number that is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// The field.
        what: &'static str,
    },
    /// A number outside its range (a negative size, a zero rate).
    #[error("{what} is out of range")]
    OutOfRange {
        /// The field.
        what: &'static str,
    },
    /// A triangle names a vertex the mesh does not have.
    #[error("triangle vertex index {index} with {vertices} vertices")]
    BadIndex {
        /// The index.
        index: u32,
        /// The mesh's vertex count.
        vertices: usize,
    },
    /// A compound shape inside a compound shape.
    #[error("compound shapes may not nest")]
    NestedCompound,
}

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
            ClientControl::Goodbye => Ok(()),
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
                server_version,
                ..
            } => {
                snapshot
                    .config(*position_resolution, *position_bound)
                    .validate()
                    .map_err(|_| ControlError::OutOfRange {
                        what: "snapshot coding",
                    })?;
                check_len("server version", server_version.len(), MAX_VERSION_BYTES)?;
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
            ServerControl::Refused(_)
            | ServerControl::Despawn { .. }
            | ServerControl::InputTiming(_) => Ok(()),
            ServerControl::Spawn(e) => validate_entity(e),
            ServerControl::Event(event) => match event {
                GameEvent::Contact { impulse, .. } => check_finite("contact impulse", &[*impulse]),
                GameEvent::Explosion { position, radius } => {
                    check_finite("explosion position", position)?;
                    check_size("explosion radius", *radius)
                }
                GameEvent::Message { text } => {
                    check_len("message text", text.len(), MAX_MESSAGE_BYTES)
                }
                GameEvent::Custom { name, data } => {
                    check_len("event name", name.len(), MAX_EVENT_NAME_BYTES)?;
                    check_len("event data", data.len(), MAX_EVENT_DATA_BYTES)
                }
            },
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

/// Cuts `s` to at most `max` bytes at a character boundary: how a
/// string too long for its wire bound (a reason, a name) is made to fit
/// rather than refused.
pub fn truncate_utf8(s: &mut String, max: usize) {
    if s.len() > max {
        let mut end = max;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        s.truncate(end);
    }
}

/// Validates `msg` and encodes it as one frame: its postcard length as a
/// `u32` little-endian, then the postcard bytes. Refuses messages that
/// fail validation or exceed [`MAX_CONTROL_FRAME`] (a triangle mesh near
/// [`ShapeDesc::MAX_POINTS`] can), since the peer would refuse them.
pub fn encode_frame<T: ControlMessage>(msg: &T) -> Result<Vec<u8>, ControlError> {
    msg.validate()?;
    let mut out = postcard::to_extend(msg, vec![0u8; 4]).map_err(ControlError::Encode)?;
    let len = out.len() - 4;
    if len > MAX_CONTROL_FRAME {
        return Err(ControlError::FrameTooLarge {
            len,
            max: MAX_CONTROL_FRAME,
        });
    }
    out[..4].copy_from_slice(&(len as u32).to_le_bytes());
    Ok(out)
}

/// Decodes one frame's payload (without its length prefix) and validates
/// the message.
pub fn decode_payload<T: ControlMessage>(payload: &[u8]) -> Result<T, ControlError> {
    if payload.len() > MAX_CONTROL_FRAME {
        return Err(ControlError::FrameTooLarge {
            len: payload.len(),
            max: MAX_CONTROL_FRAME,
        });
    }
    let (msg, rest) = postcard::take_from_bytes::<T>(payload).map_err(ControlError::Decode)?;
    if !rest.is_empty() {
        return Err(ControlError::TrailingBytes { extra: rest.len() });
    }
    msg.validate()?;
    Ok(msg)
}

/// Splits a control stream into messages, without I/O: [`Self::push`] the
/// bytes as they arrive, then call [`Self::next`] until it returns `None`.
///
/// A frame that fails to decode or validate is consumed and reported; the
/// stream stays in step and the caller decides whether to go on (usually
/// it closes with [`DisconnectReason::ProtocolError`]). A frame whose
/// length passes [`MAX_CONTROL_FRAME`] leaves the stream out of step, so
/// the decoder reports that error from then on.
#[derive(Debug, Default, Clone)]
pub struct FrameDecoder {
    buf: Vec<u8>,
    /// Bytes of `buf` already consumed.
    start: usize,
    /// The fatal error, once one happened.
    failed: Option<ControlError>,
}

impl FrameDecoder {
    /// An empty decoder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Bytes held and not yet decoded.
    pub fn buffered(&self) -> usize {
        self.buf.len() - self.start
    }

    /// Appends stream bytes. Refuses (keeping nothing of `bytes`) a push
    /// that would hold more than [`MAX_DECODER_BUFFER`]; a push of at most
    /// [`MAX_CONTROL_FRAME`] bytes after draining with [`Self::next`]
    /// always fits.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), ControlError> {
        if let Some(e) = &self.failed {
            return Err(e.clone());
        }
        let buffered = self.buffered();
        if buffered + bytes.len() > MAX_DECODER_BUFFER {
            return Err(ControlError::BufferFull {
                buffered,
                pushed: bytes.len(),
                max: MAX_DECODER_BUFFER,
            });
        }
        if self.start > 0 {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
        Ok(())
    }

    /// The next whole message, if one has arrived: `None` while a frame is
    /// incomplete.
    #[allow(clippy::should_implement_trait)]
    pub fn next<T: ControlMessage>(&mut self) -> Option<Result<T, ControlError>> {
        if let Some(e) = &self.failed {
            return Some(Err(e.clone()));
        }
        let held = &self.buf[self.start..];
        let header: [u8; 4] = held.get(..4)?.try_into().ok()?;
        let len = u32::from_le_bytes(header) as usize;
        if len > MAX_CONTROL_FRAME {
            let e = ControlError::FrameTooLarge {
                len,
                max: MAX_CONTROL_FRAME,
            };
            self.failed = Some(e.clone());
            self.buf = Vec::new();
            self.start = 0;
            return Some(Err(e));
        }
        let payload = held.get(4..4 + len)?;
        let result = decode_payload(payload);
        self.start += 4 + len;
        if self.start == self.buf.len() {
            self.buf.clear();
            self.start = 0;
        }
        Some(result)
    }
}

/// Answers a client's first message, without I/O: checks the protocol
/// version first (so an old client learns it is old, whatever its token),
/// then opens the connect token with `key` at `now_unix` (unix seconds)
/// for the server at `our_addr`, and admits it on `connection_id` through
/// `guard`. On success the server sends [`ServerControl::Welcome`]; on
/// failure, [`ServerControl::Refused`] with the refusal.
pub fn handshake(
    hello: &ClientControl,
    now_unix: u64,
    key: &TokenKey,
    our_addr: &str,
    connection_id: u64,
    guard: &mut ReplayGuard,
) -> Result<OpenedToken, Refusal> {
    let ClientControl::Hello { version, token } = hello else {
        return Err(Refusal::Malformed);
    };
    if *version != PROTOCOL_VERSION {
        return Err(Refusal::VersionMismatch {
            server: PROTOCOL_VERSION,
            client: *version,
        });
    }
    Ok(token::verify(
        token,
        key,
        now_unix,
        our_addr,
        connection_id,
        guard,
    )?)
}

// ---------------------------------------------------------------------------
// The spawn mirror: EntityDesc and ShapeDesc as the decoder reads them, with
// at most one level of compound. Field and variant order must match
// entity.rs exactly (postcard encodes by position); the round-trip tests
// pin that.

/// Reads an [`EntityDesc`] with at most one level of compound in its
/// shape, without recursing further however the bytes nest (for stored
/// entity tables as well as spawns).
pub fn deserialize_entity<'de, D: Deserializer<'de>>(d: D) -> Result<EntityDesc, D::Error> {
    WireEntityDesc::deserialize(d).map(Into::into)
}

/// Reads a [`ShapeDesc`] with at most one level of compound, without
/// recursing further however the bytes nest: for every message that
/// carries a shape (spawns here, the admin channel's live edits).
pub(crate) fn deserialize_shape<'de, D: Deserializer<'de>>(d: D) -> Result<ShapeDesc, D::Error> {
    WireShape::<WireShape<NoNesting>>::deserialize(d).map(Into::into)
}

#[derive(Deserialize)]
struct WireEntityDesc {
    id: EntityId,
    kind: EntityKind,
    shape: WireShape<WireShape<NoNesting>>,
    color: [u8; 4],
    owner: Option<u64>,
    name: String,
    position: [f64; 3],
    rotation: [f64; 4],
}

impl From<WireEntityDesc> for EntityDesc {
    fn from(w: WireEntityDesc) -> Self {
        EntityDesc {
            id: w.id,
            kind: w.kind,
            shape: w.shape.into(),
            color: w.color,
            owner: w.owner,
            name: w.name,
            position: w.position,
            rotation: w.rotation,
        }
    }
}

/// [`ShapeDesc`] with compound parts of type `P`.
#[derive(Deserialize)]
enum WireShape<P> {
    Sphere {
        radius: f32,
    },
    Cuboid {
        half_extents: [f32; 3],
    },
    Capsule {
        half_height: f32,
        radius: f32,
    },
    Cylinder {
        half_height: f32,
        radius: f32,
    },
    ConvexHull {
        points: Vec<[f32; 3]>,
    },
    TriMesh {
        vertices: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
    },
    Compound {
        parts: Vec<([f32; 3], [f32; 4], P)>,
    },
    Particle {
        radius: f32,
    },
    Ground,
    HeightField {
        rows: u32,
        cols: u32,
        size: [f32; 2],
        heights: Vec<f32>,
    },
    PointSet {
        points: u32,
        radius: f32,
        triangles: Vec<[u32; 3]>,
        lines: Vec<[u32; 2]>,
    },
}

impl<P: Into<ShapeDesc>> From<WireShape<P>> for ShapeDesc {
    fn from(w: WireShape<P>) -> Self {
        match w {
            WireShape::Sphere { radius } => ShapeDesc::Sphere { radius },
            WireShape::Cuboid { half_extents } => ShapeDesc::Cuboid { half_extents },
            WireShape::Capsule {
                half_height,
                radius,
            } => ShapeDesc::Capsule {
                half_height,
                radius,
            },
            WireShape::Cylinder {
                half_height,
                radius,
            } => ShapeDesc::Cylinder {
                half_height,
                radius,
            },
            WireShape::ConvexHull { points } => ShapeDesc::ConvexHull { points },
            WireShape::TriMesh {
                vertices,
                triangles,
            } => ShapeDesc::TriMesh {
                vertices,
                triangles,
            },
            WireShape::Compound { parts } => ShapeDesc::Compound {
                parts: parts
                    .into_iter()
                    .map(|(offset, rotation, part)| (offset, rotation, part.into()))
                    .collect(),
            },
            WireShape::Particle { radius } => ShapeDesc::Particle { radius },
            WireShape::Ground => ShapeDesc::Ground,
            WireShape::HeightField {
                rows,
                cols,
                size,
                heights,
            } => ShapeDesc::HeightField {
                rows,
                cols,
                size,
                heights,
            },
            WireShape::PointSet {
                points,
                radius,
                triangles,
                lines,
            } => ShapeDesc::PointSet {
                points,
                radius,
                triangles,
                lines,
            },
        }
    }
}

/// The part of a nested compound: never decodes, so the grammar stops
/// there. (An empty nested compound decodes, holding no parts, and is
/// refused by validation as [`ControlError::NestedCompound`].)
enum NoNesting {}

impl<'de> Deserialize<'de> for NoNesting {
    fn deserialize<D: Deserializer<'de>>(_: D) -> Result<Self, D::Error> {
        Err(serde::de::Error::custom("compound shapes may not nest"))
    }
}

impl From<NoNesting> for ShapeDesc {
    fn from(n: NoNesting) -> Self {
        match n {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::token::mint;

    fn entity(shape: ShapeDesc) -> EntityDesc {
        EntityDesc {
            id: 3,
            kind: EntityKind::Dynamic,
            shape,
            color: [1, 2, 3, 4],
            owner: Some(9),
            name: "crate".into(),
            position: [1.0, 2.0, 3.0],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }

    fn round_trip(msg: &ServerControl) -> ServerControl {
        let bytes = encode_frame(msg).unwrap();
        let mut d = FrameDecoder::new();
        d.push(&bytes).unwrap();
        let out = d.next::<ServerControl>().unwrap().unwrap();
        assert!(d.next::<ServerControl>().is_none());
        out
    }

    #[test]
    fn frames_split_anywhere_reassemble() {
        let msgs = vec![
            ServerControl::Despawn { id: 7 },
            ServerControl::Spawn(entity(ShapeDesc::Compound {
                parts: vec![
                    (
                        [0.0; 3],
                        [0.0, 0.0, 0.0, 1.0],
                        ShapeDesc::Sphere { radius: 1.0 },
                    ),
                    ([1.0; 3], [0.0, 0.0, 0.0, 1.0], ShapeDesc::Ground),
                ],
            })),
            ServerControl::Event(GameEvent::Message {
                text: "hello".into(),
            }),
        ];
        let stream: Vec<u8> = msgs.iter().flat_map(|m| encode_frame(m).unwrap()).collect();
        for chunk in 1..stream.len() {
            let mut d = FrameDecoder::new();
            let mut got = Vec::new();
            for piece in stream.chunks(chunk) {
                d.push(piece).unwrap();
                while let Some(m) = d.next::<ServerControl>() {
                    got.push(m.unwrap());
                }
            }
            assert_eq!(got, msgs, "chunks of {chunk}");
            assert_eq!(d.buffered(), 0);
        }
    }

    #[test]
    fn oversized_frames_are_fatal_and_the_buffer_is_bounded() {
        let mut d = FrameDecoder::new();
        d.push(&(MAX_CONTROL_FRAME as u32 + 1).to_le_bytes())
            .unwrap();
        let e = ControlError::FrameTooLarge {
            len: MAX_CONTROL_FRAME + 1,
            max: MAX_CONTROL_FRAME,
        };
        assert_eq!(d.next::<ClientControl>(), Some(Err(e.clone())));
        assert_eq!(d.next::<ClientControl>(), Some(Err(e.clone())));
        assert_eq!(d.push(&[0]), Err(e));

        let mut d = FrameDecoder::new();
        d.push(&(MAX_CONTROL_FRAME as u32).to_le_bytes()).unwrap();
        d.push(&vec![0; MAX_CONTROL_FRAME - 1]).unwrap();
        assert!(d.next::<ClientControl>().is_none());
        assert!(matches!(
            d.push(&vec![0; MAX_CONTROL_FRAME + 8]),
            Err(ControlError::BufferFull { .. })
        ));
    }

    #[test]
    fn a_bad_frame_is_reported_and_the_next_still_decodes() {
        let mut d = FrameDecoder::new();
        d.push(&[1, 0, 0, 0, 0xFF]).unwrap();
        d.push(&encode_frame(&ClientControl::Goodbye).unwrap())
            .unwrap();
        assert!(matches!(
            d.next::<ClientControl>(),
            Some(Err(ControlError::Decode(_)))
        ));
        assert_eq!(d.next::<ClientControl>(), Some(Ok(ClientControl::Goodbye)));
    }

    #[test]
    fn validation_refuses_what_serde_accepts() {
        let too_many = ShapeDesc::ConvexHull {
            points: vec![[0.0; 3]; ShapeDesc::MAX_POINTS + 1],
        };
        assert!(matches!(
            validate_entity(&entity(too_many)),
            Err(ControlError::TooMany { .. })
        ));
        let nan = ShapeDesc::Sphere { radius: f32::NAN };
        assert!(matches!(
            validate_entity(&entity(nan)),
            Err(ControlError::NotFinite { .. })
        ));
        let bad_index = ShapeDesc::TriMesh {
            vertices: vec![[0.0; 3]; 3],
            triangles: vec![[0, 1, 3]],
        };
        assert_eq!(
            validate_entity(&entity(bad_index)),
            Err(ControlError::BadIndex {
                index: 3,
                vertices: 3
            })
        );
        let mut named = entity(ShapeDesc::Ground);
        named.name = "x".repeat(65);
        assert!(matches!(
            validate_entity(&named),
            Err(ControlError::TooLong { .. })
        ));
        let mut welcome = ServerControl::Welcome {
            client_id: 1,
            tick: 0,
            tick_hz: 0,
            snapshot_hz: 30,
            position_resolution: 0.001,
            position_bound: 1000.0,
            snapshot: SnapshotParams::default(),
            server_version: "0.1.0".into(),
        };
        assert!(matches!(
            encode_frame(&welcome),
            Err(ControlError::OutOfRange { .. })
        ));
        let ServerControl::Welcome { tick_hz, .. } = &mut welcome else {
            unreachable!()
        };
        *tick_hz = 60;
        assert!(encode_frame(&welcome).is_ok());
        // A grid finer than the snapshot codec's 32 bits an axis.
        let ServerControl::Welcome {
            position_resolution,
            ..
        } = &mut welcome
        else {
            unreachable!()
        };
        *position_resolution = 1e-9;
        assert!(matches!(
            encode_frame(&welcome),
            Err(ControlError::OutOfRange { .. })
        ));
    }

    #[test]
    fn point_sets_are_bounded_and_their_indices_checked() {
        let set =
            |points: u32, triangles: Vec<[u32; 3]>, lines: Vec<[u32; 2]>| ShapeDesc::PointSet {
                points,
                radius: 0.02,
                triangles,
                lines,
            };
        let ok = entity(set(4, vec![[0, 1, 2], [1, 3, 2]], vec![[0, 3]]));
        assert_eq!(
            round_trip(&ServerControl::Spawn(ok.clone())),
            ServerControl::Spawn(ok.clone())
        );
        assert_eq!(ok.point_id(0), Some(4));
        assert_eq!(ok.point_id(3), Some(7));
        assert_eq!(ok.point_id(4), None, "past the points");
        assert_eq!(ok.point_index(7), Some(3));
        assert_eq!(ok.point_index(3), None, "the set's own id");
        assert_eq!(ok.point_index(8), None);
        assert_eq!(entity(ShapeDesc::Sphere { radius: 1.0 }).point_id(0), None);
        // The largest set whose last point id is u32::MAX is fine; one
        // more point is not.
        let mut last = entity(set(ShapeDesc::MAX_SET_POINTS, vec![], vec![]));
        last.id = u32::MAX - ShapeDesc::MAX_SET_POINTS;
        assert_eq!(validate_entity(&last), Ok(()));
        last.id += 1;
        assert!(matches!(
            validate_entity(&last),
            Err(ControlError::OutOfRange { .. })
        ));
        for bad in [
            set(0, vec![], vec![]),
            set(ShapeDesc::MAX_SET_POINTS + 1, vec![], vec![]),
            ShapeDesc::PointSet {
                points: 3,
                radius: f32::NAN,
                triangles: vec![],
                lines: vec![],
            },
        ] {
            assert!(
                encode_frame(&ServerControl::Spawn(entity(bad.clone()))).is_err(),
                "{bad:?}"
            );
        }
        assert_eq!(
            validate_entity(&entity(set(3, vec![[0, 1, 3]], vec![]))),
            Err(ControlError::BadIndex {
                index: 3,
                vertices: 3
            })
        );
        assert_eq!(
            validate_entity(&entity(set(3, vec![], vec![[2, 5]]))),
            Err(ControlError::BadIndex {
                index: 5,
                vertices: 3
            })
        );
        let inside = ShapeDesc::Compound {
            parts: vec![([0.0; 3], [0.0, 0.0, 0.0, 1.0], set(2, vec![], vec![]))],
        };
        assert!(validate_entity(&entity(inside)).is_err());
        // The largest set fits one control frame.
        let full = entity(ShapeDesc::PointSet {
            points: ShapeDesc::MAX_SET_POINTS,
            radius: 0.01,
            triangles: vec![[16_383, 16_382, 16_381]; ShapeDesc::MAX_SET_TRIANGLES],
            lines: vec![[16_383, 16_382]; ShapeDesc::MAX_SET_LINES],
        });
        let frame = encode_frame(&ServerControl::Spawn(full)).unwrap();
        assert!(
            frame.len() <= MAX_CONTROL_FRAME + 4,
            "{} bytes",
            frame.len()
        );
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
        let msg = ServerControl::Spawn(entity(shape));
        assert_eq!(encode_frame(&msg), Err(ControlError::NestedCompound));
        let bytes = postcard::to_allocvec(&msg).unwrap();
        assert!(matches!(
            decode_payload::<ServerControl>(&bytes),
            Err(ControlError::Decode(_))
        ));
        // An empty compound inside a compound decodes, then fails
        // validation.
        let msg = ServerControl::Spawn(entity(ShapeDesc::Compound {
            parts: vec![(leaf.0, leaf.1, ShapeDesc::Compound { parts: vec![] })],
        }));
        let bytes = postcard::to_allocvec(&msg).unwrap();
        assert_eq!(
            decode_payload::<ServerControl>(&bytes),
            Err(ControlError::NestedCompound)
        );

        // A frame full of nesting: thousands of levels, decoded on a small
        // stack.
        // Spawn (variant 2), id 3, kind Dynamic (1), then compound after
        // compound, each with one part: 30 bytes a level.
        let mut deep = vec![2u8, 3, 1];
        while deep.len() < MAX_CONTROL_FRAME - 30 {
            deep.extend_from_slice(&[6, 1]);
            deep.extend_from_slice(&[0; 28]);
        }
        let handle = std::thread::Builder::new()
            .stack_size(64 * 1024)
            .spawn(move || decode_payload::<ServerControl>(&deep).is_err())
            .unwrap();
        assert!(handle.join().unwrap());
    }

    #[test]
    fn every_message_round_trips() {
        for msg in [
            ServerControl::Welcome {
                client_id: 5,
                tick: 1 << 40,
                tick_hz: 60,
                snapshot_hz: 30,
                position_resolution: 1.0 / 1024.0,
                position_bound: 4096.0,
                snapshot: SnapshotParams::default(),
                server_version: "0.1.0".into(),
            },
            ServerControl::Refused(Refusal::VersionMismatch {
                server: 1,
                client: 2,
            }),
            ServerControl::Spawn(entity(ShapeDesc::TriMesh {
                vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                triangles: vec![[0, 1, 2]],
            })),
            ServerControl::Event(GameEvent::Custom {
                name: "score".into(),
                data: vec![1, 2, 3],
            }),
            ServerControl::Goodbye(DisconnectReason::Kicked {
                reason: "afk".into(),
            }),
        ] {
            assert_eq!(round_trip(&msg), msg);
        }
    }

    #[test]
    fn handshake_checks_version_then_token() {
        let key = TokenKey::from_bytes([1; 32]);
        let addr = "127.0.0.1:7777";
        let now = 1_000_000;
        let token = mint(&key, 77, addr, [0; 32], 60, b"", now)
            .unwrap()
            .to_bytes();
        let mut guard = ReplayGuard::new(16);
        let old = ClientControl::Hello {
            version: PROTOCOL_VERSION + 1,
            token: vec![0; 3],
        };
        assert_eq!(
            handshake(&old, now, &key, addr, 1, &mut guard),
            Err(Refusal::VersionMismatch {
                server: PROTOCOL_VERSION,
                client: PROTOCOL_VERSION + 1
            })
        );
        let hello = ClientControl::Hello {
            version: PROTOCOL_VERSION,
            token,
        };
        assert_eq!(
            handshake(&hello, now, &key, addr, 1, &mut guard).map(|o| o.client_id),
            Ok(77)
        );
        assert_eq!(
            handshake(&hello, now, &key, addr, 2, &mut guard),
            Err(Refusal::Token(TokenRefusal::Reused))
        );
        assert_eq!(
            handshake(&ClientControl::Goodbye, now, &key, addr, 3, &mut guard),
            Err(Refusal::Malformed)
        );
        let mut full = ReplayGuard::new(0);
        assert_eq!(
            handshake(&hello, now, &key, addr, 1, &mut full),
            Err(Refusal::ServerFull)
        );
    }
}
