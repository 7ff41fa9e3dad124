//! The Inertia client SDK: what a game links to join an Inertia server.
//!
//! ```no_run
//! # async fn run() -> Result<(), Box<dyn std::error::Error>> {
//! use inertia_client::{dev, Client};
//! let (addr, token, _) = dev::dev_token(dev::DEV_CREDENTIALS_PATH.as_ref(), None)?;
//! let client = Client::connect(addr, &token).await?;
//! client.set_input([1.0, 0.0], 0.0, 0);
//! for (id, position, rotation) in client.sample().iter() {
//!     // draw entity `id` at `position`, turned by `rotation`
//! #   let _ = (id, position, rotation);
//! }
//! # Ok(()) }
//! ```
//!
//! - [`net`]: [`Client`], the connection (async).
//! - [`blocking`]: [`BlockingClient`], the same without async.
//! - [`dev`]: tokens from a dev-mode server's credentials file.
//! - [`lead`]: how far ahead of the server inputs are stamped, so that
//!   each arrives before its tick.
//! - [`point_sets`]: soft bodies and fluids as vertex and point sets to
//!   draw.
//! - [`predict`]: client-side prediction of the own avatar (opt-in,
//!   [`ConnectOptions::predict`]).

pub mod blocking;
mod by_id;
pub mod clock;
pub mod dev;
pub mod entities;
pub mod interp;
pub mod lead;
pub mod net;
pub mod point_sets;
pub mod predict;
pub mod properties;
pub mod replay;
pub mod stats;

pub use blocking::BlockingClient;
pub use net::{Client, ClientError, ClientEvent, ConnectOptions, ControllerFactory, ServerInfo};
pub use replay::{ReplayEvent, ReplayStatus};
