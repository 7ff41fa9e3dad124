//! A game connection's life, free of I/O, as quinn-proto's `Connection`
//! is: bytes of the control stream, datagram arrivals, the server's
//! answers and `now` go in; the control-stream bytes to write, when to
//! finish the stream, the next deadline, events and the close come out.
//! The tokio tasks around it only move bytes and timers, so the tests
//! drive the very code that ships, on a virtual clock.
//!
//! # The client's side ([`ClientConnection`])
//!
//! ```text
//!  Hello ──welcome──▶ Live ──leave──▶ Leaving (goodbye, finish) ──▶ Closed
//!    │ refused, no      │ goodbye or
//!    │ welcome in time, │ stream ended
//!    │ bad bytes        ▼
//!    └──────────▶ Closed ◀── Draining (the server's close, or the drain wait)
//! ```
//!
//! The hello leaves with the connection; the welcome is due within
//! [`HANDSHAKE_TIMEOUT`] of the start (the QUIC handshake included). A
//! refusal, a message other than the welcome first, or bytes that are no
//! message (a welcome with a zero rate is one: the decoder refuses it)
//! end it with their reason; after the welcome, the
//! server's messages go to the game, and a second welcome or a refusal is
//! a protocol error. A goodbye, or the end of the server's stream, leaves
//! the client waiting [`client::DRAIN_WAIT`] at most for the server's
//! close. A client that leaves says goodbye, finishes its stream and
//! closes, within [`client::CLIENT_GOODBYE_WAIT`] and
//! [`client::CLIENT_FINISH_WAIT`].
//!
//! # The server's side ([`ServerConnection`])
//!
//! ```text
//!  Hello ──hello──▶ Deciding ──admit──▶ Welcoming ──written──▶ Live
//!    │ ╲               │                  │                    │ ╲
//!    │  ╲ a bad first  │ refuse           │                    │  ╲ silence, stall, kick,
//!    │   ╲ message     ▼                  │                    │   ╲ shutdown, bad bytes
//!    │    ╰──────▶ Closing ◀──────────────┼────────────────────┼────╯
//!    │             (last words,           │                    │
//!    │              finish, wait)         │ not taken          │ goodbye,
//!    │ no hello in time,  │               │ in time            │ stream ended
//!    │ stream ended       ▼               ▼                    ▼
//!    ╰──────────────▶  Closed ◀───────────┴────────────────────╯
//! ```
//!
//! Every state but one has a deadline: the client has
//! [`ServerConnectionConfig::hello`] from the end of the QUIC handshake to say
//! hello, and as long again to take its welcome; a live client that sends
//! no datagram for [`ServerConnectionConfig::silence`], or leaves its control
//! stream unread for [`ServerConnectionConfig::control_stall`] while something
//! waits for it (or more than [`ServerConnectionConfig::outbox_limit`] bytes
//! wait), is let go; last words wait at most [`ServerConnectionConfig::goodbye`]
//! for the client's window and [`ServerConnectionConfig::finish`] for the
//! client to take them. The one state without a deadline, `Deciding`, is
//! the server's own part (checking the token, asking the tick thread for
//! room): the connection waits for the tick thread's answer, which comes
//! within a tick or, when the simulation has stopped, as the question
//! dropped.
//!
//! A control stream that ends or is reset before a whole hello can never
//! complete it: the connection is closed at once, not left to the hello
//! timeout (nor, as once happened, held open for as long as the peer
//! answered keep-alives).

pub mod client;
mod last_words;
pub mod outbox;
pub mod server;

use std::time::Duration;

use crate::message::MessageLimits;

pub use client::{
    ClientConnection, ClientConnectionConfig, ClientConnectionEnd, ClientConnectionEvent,
    ServerInfo, HANDSHAKE_TIMEOUT,
};
pub use outbox::Outbox;
pub use server::{
    Close, ReceivedMessage, ServerConnection, ServerConnectionEnd, ServerConnectionEvent,
};

/// How long a client has to open its control stream and say hello, and
/// then again to take the answer.
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(5);
/// Longest a joined client may send no datagram (its acknowledgements and
/// inputs, which the SDK sends at its input rate whatever the player
/// does). QUIC keep-alives do not count: a client that stops playing but
/// keeps its connection open would hold a slot, an avatar and full
/// snapshots without a baseline forever.
pub const SILENT_TIMEOUT: Duration = Duration::from_secs(10);
/// Longest a client may leave its control stream unread while the server
/// has something for it.
pub const CONTROL_STALL: Duration = Duration::from_secs(10);
/// Most control-stream bytes that may wait for a client; beyond, it is
/// let go as too far behind (a full catalog of the most bodies a server
/// takes is well under this).
pub const OUTBOX_LIMIT: usize = 16 << 20;
/// Longest last words (a refusal, a goodbye, and what is queued before
/// them) wait for the client's window.
pub const GOODBYE_WAIT: Duration = Duration::from_secs(1);
/// Longest the finished control stream waits for the client to take it
/// before the connection is closed under it.
pub const FINISH_WAIT: Duration = Duration::from_millis(500);
/// Inputs a connection remembers for reordering and de-duplication.
pub const INPUT_BUFFER: usize = 128;

/// The deadlines and limits of a connection's life.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServerConnectionConfig {
    /// To say hello, and then to take the welcome.
    pub hello: Duration,
    /// Longest a live client may send no datagram.
    pub silence: Duration,
    /// Longest the control stream may stay unread while bytes wait.
    pub control_stall: Duration,
    /// Most control-stream bytes that may wait, bytes.
    pub outbox_limit: usize,
    /// Longest last words wait for the client's window.
    pub goodbye: Duration,
    /// Longest the finished stream waits to be taken.
    pub finish: Duration,
    /// Inputs remembered for reordering and de-duplication.
    pub input_buffer: usize,
    /// Bytes of every input's payload, as the game declares them
    /// ([`GameInput::BYTES`](crate::input::GameInput::BYTES)): a datagram
    /// with inputs of another size is refused whole
    /// ([`InputError::WrongPayloadSize`](crate::input::InputError::WrongPayloadSize)).
    /// `None` takes any size and leaves the check to the game's decoder.
    pub input_bytes: Option<usize>,
    /// How fast the client may send game messages; more are refused and
    /// counted ([`MessageRefusal::RateLimited`](crate::message::MessageRefusal::RateLimited)).
    pub messages: MessageLimits,
}

impl Default for ServerConnectionConfig {
    fn default() -> Self {
        ServerConnectionConfig {
            hello: HELLO_TIMEOUT,
            silence: SILENT_TIMEOUT,
            control_stall: CONTROL_STALL,
            outbox_limit: OUTBOX_LIMIT,
            goodbye: GOODBYE_WAIT,
            finish: FINISH_WAIT,
            input_buffer: INPUT_BUFFER,
            input_bytes: None,
            messages: MessageLimits::default(),
        }
    }
}
