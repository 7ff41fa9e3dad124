//! The reliable control channel: the hello and its answer, spawns and
//! despawns, the game's reliable messages both ways and goodbyes, carried
//! on a QUIC stream.
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
//!
//! The module's parts, one concept each: the messages and their limits
//! here; `hello.rs` the hello's answer ([`handshake`], [`Refusal`]);
//! `disconnect.rs` why a connection ends and the close codes that say it;
//! `validate.rs` the bounds every message is checked against
//! ([`ControlMessage`]); `framing.rs` frames on the stream
//! ([`encode_frame`], [`FrameDecoder`]); `wire_entity.rs` the spawn
//! mirror that stops at one level of compound.

mod disconnect;
mod framing;
mod hello;
mod validate;
mod wire_entity;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::entity::{EntityDesc, EntityId};
use crate::property::PropertySchema;
use crate::quantize::PositionGrid;
use crate::snapshot::SnapshotConfig;

pub use disconnect::{close_code, DisconnectReason, SIMULATION_STOPPED_PREFIX};
pub use framing::{decode_payload, encode_frame, FrameDecoder};
pub use hello::{handshake, Refusal, TokenRefusal};
pub use validate::{validate_entity, ControlMessage};
pub use wire_entity::deserialize_entity;
pub(crate) use wire_entity::deserialize_shape;

pub use crate::version::PROTOCOL_VERSION;
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

/// The longest game name a welcome carries, bytes of UTF-8.
pub const MAX_GAME_NAME_BYTES: usize = 32;
pub use crate::message::MAX_MESSAGE_BYTES;
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
    /// A reliable message of the game's (its bytes, at most
    /// [`MAX_MESSAGE_BYTES`]; see [`crate::message`]).
    Message(Vec<u8>),
    /// Show me this stretch of the recent past, beside the live match
    /// (see [`crate::replay`]); it replaces any replay playing.
    Replay(crate::replay::ReplayRequest),
    /// Stop the replay playing, if any.
    CancelReplay,
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
        /// Bytes of every input's payload, as the game declares them
        /// ([`GameInput::BYTES`](crate::input::GameInput::BYTES), at most
        /// [`MAX_INPUT_BYTES`](crate::input::MAX_INPUT_BYTES)): a client
        /// whose game input has another size is not playing this game.
        input_bytes: u16,
        /// The server build, for logs (at most [`MAX_VERSION_BYTES`]).
        server_version: String,
        /// The game's name (its rules' `name`, at most
        /// [`MAX_GAME_NAME_BYTES`]; empty when the rules give none): a
        /// client picks its controls and its HUD by it.
        game: String,
        /// The game's properties, per entity and per match, as every
        /// snapshot carries them (see [`crate::property`]).
        properties: PropertySchema,
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
    /// A reliable message of the game's (its bytes, at most
    /// [`MAX_MESSAGE_BYTES`]; see [`crate::message`]).
    Message(Vec<u8>),
    /// The server is closing the connection.
    Goodbye(DisconnectReason),
    /// How the client's inputs have been arriving against the ticks they
    /// are for: sent about once a second while it changes, so the client
    /// can run as far ahead as its inputs need to arrive in time.
    InputTiming(InputReport),
    /// About the replay the client asked for (see [`crate::replay`]).
    Replay(crate::replay::ReplayAnswer),
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

#[cfg(test)]
mod tests;
