//! What every client sees of the game's state: each ball's orbs, and the
//! round's orbs left, clock and phase. The rules declare them
//! ([`schema`]) and set them by these indices; clients read them by name.

use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema};

/// A ball's orbs collected this round (entity property).
pub const ORBS: usize = 0;

/// Orbs still on the floor (match property).
pub const ORBS_LEFT: usize = 0;
/// Seconds left in the round (match property).
pub const CLOCK: usize = 1;
/// Where the round is (match property): [`WAITING`], [`PLAYING`] or
/// [`OVER`].
pub const PHASE: usize = 2;

/// Waiting for every player to be ready.
pub const WAITING: u64 = 0;
/// Orbs on the floor, the clock running.
pub const PLAYING: u64 = 1;
/// Someone won.
pub const OVER: u64 = 2;

/// The game's properties, in the order of the indices above.
pub fn schema() -> PropertySchema {
    PropertySchema {
        entity: vec![PropertyDecl::new("orbs", PropertyKind::UInt { bits: 8 })],
        match_state: vec![
            PropertyDecl::new("orbs_left", PropertyKind::UInt { bits: 8 }),
            PropertyDecl::new("clock", PropertyKind::F32),
            PropertyDecl::new("phase", PropertyKind::UInt { bits: 2 }),
        ],
    }
}
