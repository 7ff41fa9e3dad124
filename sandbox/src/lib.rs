//! The sandbox game, as its rules (in `inertia-server`) and its clients
//! (the SDK, the viewer, the bots) share it: its input.
//!
//! The sandbox is the stock server's game: every client walks a capsule
//! avatar around the scene, jumps, and pushes things. It is built on the
//! same game-defined input as any studio's game ([`GameInput`]); nothing
//! of it is the protocol's.
//!
//! [`GameInput`]: inertia_protocol::input::GameInput

mod input;

pub use input::{buttons, SandboxInput, SANDBOX_INPUT_BYTES};
