//! What the viewer's keys send and what its HUD headlines, by the game the
//! server says it runs (its welcome names it): the sandbox's walk, jump and
//! push; football's run, jump and kick, aimed along the camera and lobbed
//! with Shift; for any other game the viewer only watches.

use inertia_client::BlockingClient;
use inertia_football::properties::{Phase, Team};
use inertia_football::Play;
use inertia_protocol::property::PropertyValue;
use inertia_sandbox::buttons;

/// What the keys held ask for this frame, in the world's terms.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wish {
    /// Movement in the horizontal plane (x, z), length ≤ 1.
    pub movement: [f32; 2],
    /// The camera's facing about +y, rad (0 faces +z).
    pub yaw: f32,
    /// Space: jump.
    pub jump: bool,
    /// E: the game's action (the sandbox's push, football's kick).
    pub action: bool,
    /// Shift: football's kick goes high.
    pub lob: bool,
}

/// Kick pitches, degrees: along the grass, and lobbed.
const KICK_PITCH: f64 = 10.0;
const LOB_PITCH: f64 = 40.0;

/// The games the viewer plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Controls {
    /// The stock server's sandbox.
    Sandbox,
    /// `inertia-football`.
    Football,
    /// A game the viewer has no controls for: it watches.
    Watch,
}

impl Controls {
    /// The controls for the game named `game` in the welcome.
    pub fn for_game(game: &str) -> Controls {
        match game {
            "sandbox" => Controls::Sandbox,
            "football" => Controls::Football,
            _ => Controls::Watch,
        }
    }

    /// Sends this frame's wish as the game's input (nothing when
    /// watching; a refusal leaves the input as it was).
    pub fn send(self, client: &BlockingClient, wish: Wish) {
        match self {
            Controls::Sandbox => {
                let mut pressed = 0;
                if wish.jump {
                    pressed |= buttons::JUMP;
                }
                if wish.action {
                    pressed |= buttons::PUSH;
                }
                let _ = client.set_input(wish.movement, wish.yaw, pressed);
            }
            Controls::Football => {
                let mut pressed = 0;
                if wish.jump {
                    pressed |= inertia_football::input::buttons::JUMP;
                }
                if wish.action {
                    pressed |= inertia_football::input::buttons::KICK;
                }
                let pitch = if wish.lob { LOB_PITCH } else { KICK_PITCH };
                let [x, z] = wish.movement.map(f64::from);
                let play = Play::new([x, z], f64::from(wish.yaw), pitch, pressed);
                let _ = client.set_game_input(&play);
            }
            Controls::Watch => {}
        }
    }

    /// The game's headline for the HUD, as of the tick drawn: football's
    /// score, clock and phase.
    pub fn headline(self, client: &BlockingClient) -> Option<String> {
        match self {
            Controls::Football => {
                let uint = |name: &str| match client.match_property(name) {
                    Some(PropertyValue::UInt(n)) => Some(n),
                    _ => None,
                };
                let clock = match client.match_property("clock") {
                    Some(PropertyValue::F32(s)) => s.max(0.0) as u64,
                    _ => 0,
                };
                Some(football_headline(
                    [uint("score_red")?, uint("score_blue")?],
                    clock,
                    Phase::from_code(uint("phase")?)?,
                    uint("winner").and_then(Team::from_code),
                ))
            }
            Controls::Sandbox | Controls::Watch => None,
        }
    }
}

/// `red 1 – 0 blue · 2:31 · playing`, or who won.
pub fn football_headline(
    score: [u64; 2],
    clock: u64,
    phase: Phase,
    winner: Option<Team>,
) -> String {
    let state = match (phase, winner) {
        (Phase::Over, Some(team)) => format!("{} wins", team.name()),
        (Phase::Waiting, _) => "waiting for a player on each team".into(),
        (Phase::Kickoff, _) => "kickoff".into(),
        (Phase::Playing, _) if clock == 0 => "golden goal".into(),
        _ => "playing".into(),
    };
    format!(
        "red {} – {} blue · {}:{:02} · {state}",
        score[0],
        score[1],
        clock / 60,
        clock % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_game_in_the_welcome_picks_the_controls_and_the_headline_reads_the_match() {
        assert_eq!(Controls::for_game("football"), Controls::Football);
        assert_eq!(Controls::for_game("sandbox"), Controls::Sandbox);
        assert_eq!(Controls::for_game("orbs"), Controls::Watch);
        assert_eq!(
            football_headline([1, 0], 151, Phase::Playing, None),
            "red 1 – 0 blue · 2:31 · playing"
        );
        assert_eq!(
            football_headline([2, 3], 0, Phase::Over, Some(Team::Blue)),
            "red 2 – 3 blue · 0:00 · blue wins"
        );
    }
}
