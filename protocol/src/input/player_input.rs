//! One tick's worth of a player's intent, as the datagram carries it.

use serde::{Deserialize, Serialize};

use super::payload::InputPayload;

/// One tick's worth of a player's intent: what the game's input says
/// ([`payload`](Self::payload)), for which tick, and what the player saw.
/// The rules decode and validate the payload before acting on it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PlayerInput {
    /// The client's input sequence number, increasing by one per input.
    pub sequence: u32,
    /// The server tick the client meant this input for (its estimate).
    pub tick: u64,
    /// The game's input, as its bytes ([`GameInput`](super::GameInput)).
    pub payload: InputPayload,
    /// How far behind `tick` the world the player saw was when this input
    /// was made, ticks (fractional, ≥ 0): the client's interpolation render
    /// tick is `tick − view_behind` ([`PlayerInput::view_tick`]). Rules use
    /// it to ask what the player aimed at (lag compensation). Travels in
    /// 1/16 tick steps, capped at
    /// [`MAX_VIEW_BEHIND`](super::MAX_VIEW_BEHIND); 0 means "the
    /// world as it is" (no rewind).
    ///
    /// Kept relative to `tick` rather than as an absolute tick so that it is
    /// exact at every tick (an `f64` tick loses 1/16 steps past 2⁴⁹) and
    /// the bounds a server checks (finite, not ahead, not too far back)
    /// are bounds on this one number.
    pub view_behind: f32,
}

impl PlayerInput {
    /// The (fractional) server tick the player was drawing when it made
    /// this input: `tick − view_behind`, ticks.
    pub fn view_tick(&self) -> f64 {
        self.tick as f64 - f64::from(self.view_behind)
    }
}
