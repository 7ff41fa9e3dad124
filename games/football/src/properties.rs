//! What every client sees of the match: each player's team and goals, and
//! the score, the clock, the phase and the winner. The rules declare them
//! ([`schema`]) and set them by these indices; clients read them by name.

use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema};
use serde::{Deserialize, Serialize};

/// A player's team (entity property): [`Team::code`].
pub const TEAM: usize = 0;
/// A player's goals this match (entity property).
pub const GOALS: usize = 1;

/// Red's goals (match property).
pub const SCORE_RED: usize = 0;
/// Blue's goals (match property).
pub const SCORE_BLUE: usize = 1;
/// Seconds of play left (match property; 0 in golden goal).
pub const CLOCK: usize = 2;
/// Where the match is (match property): [`Phase::code`].
pub const PHASE: usize = 3;
/// Who won (match property): 0 while playing, else [`Team::code`].
pub const WINNER: usize = 4;

/// One side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Team {
    /// Defends −x, attacks +x.
    Red,
    /// Defends +x, attacks −x.
    Blue,
}

impl Team {
    /// The team's code in properties and messages: red 1, blue 2.
    pub fn code(self) -> u8 {
        match self {
            Team::Red => 1,
            Team::Blue => 2,
        }
    }

    /// The team of a code, if it is one.
    pub fn from_code(code: u64) -> Option<Team> {
        match code {
            1 => Some(Team::Red),
            2 => Some(Team::Blue),
            _ => None,
        }
    }

    /// The other team.
    pub fn other(self) -> Team {
        match self {
            Team::Red => Team::Blue,
            Team::Blue => Team::Red,
        }
    }

    /// Which way along x the team attacks: +1 or −1.
    pub fn attacks(self) -> f64 {
        match self {
            Team::Red => 1.0,
            Team::Blue => -1.0,
        }
    }

    /// Its name, as the HUD writes it.
    pub fn name(self) -> &'static str {
        match self {
            Team::Red => "red",
            Team::Blue => "blue",
        }
    }
}

/// Where a match is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Phase {
    /// Waiting for a player on each team.
    Waiting,
    /// Everyone in place, the ball on the centre spot, play about to start.
    Kickoff,
    /// The ball in play, the clock running (or at 0 in golden goal).
    Playing,
    /// A team won.
    Over,
}

impl Phase {
    /// The phase's code in the `phase` property: 0 to 3, as declared.
    pub fn code(self) -> u8 {
        match self {
            Phase::Waiting => 0,
            Phase::Kickoff => 1,
            Phase::Playing => 2,
            Phase::Over => 3,
        }
    }

    /// The phase of a code, if it is one.
    pub fn from_code(code: u64) -> Option<Phase> {
        match code {
            0 => Some(Phase::Waiting),
            1 => Some(Phase::Kickoff),
            2 => Some(Phase::Playing),
            3 => Some(Phase::Over),
            _ => None,
        }
    }
}

/// The game's properties, in the order of the indices above.
pub fn schema() -> PropertySchema {
    PropertySchema {
        entity: vec![
            PropertyDecl::new("team", PropertyKind::UInt { bits: 2 }),
            PropertyDecl::new("goals", PropertyKind::UInt { bits: 8 }),
        ],
        match_state: vec![
            PropertyDecl::new("score_red", PropertyKind::UInt { bits: 8 }),
            PropertyDecl::new("score_blue", PropertyKind::UInt { bits: 8 }),
            PropertyDecl::new("clock", PropertyKind::F32),
            PropertyDecl::new("phase", PropertyKind::UInt { bits: 2 }),
            PropertyDecl::new("winner", PropertyKind::UInt { bits: 2 }),
        ],
    }
}
