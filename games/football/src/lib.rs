//! Physics football on Inertia, an example of a whole game built on the
//! server as a library, as a studio would build one. Players are capsules
//! who run, jump and kick the ball along their yaw and pitch; the goals are
//! sensors in the scene; score, clock, phase and winner are replicated
//! properties; a kickoff follows every goal; the first team to five, or
//! the one ahead when the clock runs out (then the next goal), wins.
//!
//! One file a part:
//! - [`input`]: what a player wants each tick ([`Play`]);
//! - [`messages`]: what players ask ([`Ask`]) and the rules tell ([`Tell`]);
//! - [`properties`]: what every client sees of the match;
//! - [`pitch`]: the measurements the scene, the rules and the bots share;
//! - [`rules`]: the rules ([`FootballRules`]);
//! - [`predict`]: the client's prediction of its own player;
//! - [`bot`]: a bot that plays from what any client sees;
//! - `main.rs`: the server; `bin/football_bots.rs`: bots to play against.

pub mod bot;
pub mod input;
pub mod messages;
pub mod pitch;
pub mod predict;
pub mod properties;
pub mod rules;

pub use input::Play;
pub use messages::{Ask, Tell};
pub use rules::{FootballRules, FootballSettings};

/// The pitch's scene, the server's default.
pub const PITCH: &str = include_str!("../scenes/pitch.ron");
