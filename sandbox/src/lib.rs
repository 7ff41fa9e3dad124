//! The sandbox game, as its rules (in `inertia-server`) and its clients
//! (the SDK, the viewer, the bots) share it: its input, what its players
//! may ask of the rules, and the events its rules tell every client.
//!
//! The sandbox is the stock server's game: every client walks a capsule
//! avatar around the scene, jumps, and pushes things. It is built on the
//! same game-defined input and messages as any studio's game
//! ([`GameInput`], [`GameMessage`]); nothing of it is the protocol's.
//!
//! [`GameInput`]: inertia_protocol::input::GameInput
//! [`GameMessage`]: inertia_protocol::message::GameMessage

mod event;
mod input;
mod request;

pub use event::{ClientId, Removal, SandboxEvent};
pub use input::{buttons, SandboxInput, SANDBOX_INPUT_BYTES};
pub use request::{SandboxRequest, MAX_CHAT_BYTES};
