//! Orbs, a game on Inertia to copy: each player rolls a ball around an
//! arena and collects orbs; whoever holds the most when the last is taken
//! or the clock runs out wins.
//!
//! What a game is made of, one file each:
//! - [`input`]: what a player wants each tick ([`Drive`]), the type its
//!   rules and its clients share;
//! - [`messages`]: what players ask the rules ([`Ask`]) and what the rules
//!   tell them ([`Tell`]);
//! - [`properties`]: what every client sees of the game's state (each
//!   ball's score; the orbs left, the clock and the phase);
//! - [`rules`]: the rules themselves ([`OrbsRules`]);
//! - [`predict`]: the client's prediction of its own ball ([`predict::Roller`]);
//! - `main.rs`: the server process around them.

pub mod input;
pub mod messages;
pub mod predict;
pub mod properties;
pub mod rules;

pub use input::Drive;
pub use messages::{Ask, Tell};
pub use rules::OrbsRules;
