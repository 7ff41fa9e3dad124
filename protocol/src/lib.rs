//! Inertia's wire protocol, free of I/O: everything here turns values into
//! bytes and untrusted bytes back into values, and is tested without
//! sockets.
//!
//! - [`entity`]: what an entity is, looks like and where it is; player input.
//! - [`credentials`]: the dev-mode credentials file.
//! - [`bits`]: the bit packer every message is written with.
//! - [`quantize`]: positions on a grid and orientations as smallest three.
//! - [`sim_link`]: a simulated lossy link on a virtual clock, for tests.
//! - [`token`]: connect tokens, sealed with the server key, and the replay
//!   guard.
//! - [`connection`]: a game connection's life (hello, live, closing) and
//!   every deadline in it, as state machines the server and the SDK drive.
//! - [`control`]: the reliable control channel (hello, spawns, messages,
//!   goodbyes) and its framing.
//! - [`input`]: the client's input datagram and the server's input buffer.
//! - [`message`]: a game's messages both ways, their datagram and the
//!   rate a client may send them at.
//! - [`admin`]: the admin protocol (an operator's requests to a running
//!   server and its answers), framed like the control channel.
//! - [`property`]: the game's replicated state (per entity and per
//!   match), as the snapshot carries it.
//! - [`snapshot`]: the snapshot datagram, delta-coded against acknowledged
//!   views and fitted to a budget by [`priority`] and [`interest`].

pub mod admin;
pub mod bits;
pub mod client_session;
pub mod connection;
pub mod control;
pub mod credentials;
#[cfg(feature = "physics")]
pub mod engine_shape;
pub mod entity;
pub mod input;
pub mod interest;
pub mod message;
pub mod priority;
pub mod property;
pub mod quantize;
pub mod replay;
pub mod rng;
pub mod session;
pub mod sim_link;
pub mod snapshot;
pub mod token;
pub mod version;

pub use admin::{
    AdminCall, AdminError, AdminErrorKind, AdminHandshake, AdminHello, AdminRefusal, AdminReply,
    AdminRequest, AdminResponse, AdminWelcome, CheckpointName, StatusReport, ADMIN_ALPN,
    ADMIN_PROTOCOL_VERSION,
};
pub use bits::{BitError, BitReader, BitWriter};
pub use client_session::{ClientConfig, ClientSession};
pub use control::{
    encode_frame, handshake, ClientControl, ControlError, ControlMessage, DisconnectReason,
    FrameDecoder, Refusal, ServerControl, SnapshotParams, TokenRefusal, ALPN, MAX_CONTROL_FRAME,
    PROTOCOL_VERSION,
};
pub use entity::{EntityDesc, EntityId, EntityKind, EntityState, ShapeDesc};
pub use input::PlayerInput;
pub use input::{InputBuffer, InputDatagram, InputError, MAX_REDUNDANT_INPUTS};
pub use interest::Interest;
pub use message::{Delivery, GameMessage, MessageDecodeError, MessageRefusal, MAX_MESSAGE_BYTES};
pub use priority::{PriorityAccumulator, PriorityWeights, Standing};
pub use quantize::{read_rotation, write_rotation, PositionGrid};
pub use session::{ServerSession, SessionConfig};
pub use sim_link::{SimLink, SimLinkConfig, SimLinkError, SimLinkStats};
pub use snapshot::{
    DecodedSnapshot, SnapshotConfig, SnapshotDecoder, SnapshotEncoder, SnapshotError, View,
    ViewEntity,
};
pub use token::{ConnectToken, OpenedToken, ReplayGuard, TokenError, TokenIssuer, TokenKey};
