//! Replay: re-simulating recorded history exactly.
//!
//! A recording (see [`crate::record`]) holds keyframes, each a
//! [`SimState`] (the world, the entity table, the clients and the game
//! rules' state), the [journal](journal) of every tick (joins, leaves,
//! inputs and live edits, in the order applied) and every tick's state
//! hash. Re-simulating from a keyframe at tick K to T applies the journal
//! of K (past what the keyframe already holds), steps, applies the journal
//! of K + 1, steps, and so on; the physics is deterministic, so the hash
//! at T equals the recorded one, bit for bit. Nothing ever integrates
//! backwards: reverse play is seeks over a cache of recent states.
//!
//! - [`state`]: the saved state and its encoding;
//! - [`journal`]: journal entries and their compact encoding;
//! - [`history`]: a recording held in memory for seeking;
//! - [`verify`]: re-simulating a recording directory and checking every
//!   stored hash (offline: `inertia-admin replay-file verify`).

pub mod checkpoint;
pub mod history;
pub mod journal;
pub mod state;

pub use history::{
    Damage, DamageKind, HeldBytes, HeldKeyframe, History, HistoryError, SalvageReport,
    DEFAULT_KEYFRAME_BUDGET,
};
pub use journal::{JournalEntry, JournalError, WorldEdit};
pub use state::{SimState, StateError};
