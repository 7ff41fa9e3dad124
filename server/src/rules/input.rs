//! An input from the network, checked before any field of it is read.
//! Its tick was checked against the server's before it reached the rules,
//! by the simulation's input schedule ([`crate::sim::input_schedule`]);
//! its payload is the game's, read by the game's decoder
//! ([`GameInput::from_payload`](inertia_protocol::input::GameInput::from_payload)),
//! which refuses anything the game does not define.

use inertia_protocol::input::{InputDecodeError, MAX_VIEW_BEHIND};
use inertia_protocol::PlayerInput;

use super::ClientId;

/// Why an input was refused (it is then ignored; the client's previous
/// input stays in force).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputRefusal {
    /// The client has not joined.
    #[error("client {0} has not joined")]
    NotJoined(ClientId),
    /// The game's decoder refused the payload.
    #[error("{0}")]
    Undecodable(#[from] InputDecodeError),
    /// Meant for a tick too long ago (refused by the input schedule).
    #[error("input for tick {tick} is too old (now {now})")]
    Stale {
        /// The input's tick.
        tick: u64,
        /// The server's tick.
        now: u64,
    },
    /// Meant for a tick too far ahead (refused by the input schedule).
    #[error("input for tick {tick} is too far ahead (now {now})")]
    Future {
        /// The input's tick.
        tick: u64,
        /// The server's tick.
        now: u64,
    },
    /// The client already has as many inputs waiting for their ticks as
    /// the server holds.
    #[error("the client has {max} inputs waiting already")]
    Backlog {
        /// The most held per client.
        max: usize,
    },
}

impl InputRefusal {
    /// The refusal's label in `/metrics` (one of
    /// [`INPUT_REFUSAL_REASONS`](crate::metrics::INPUT_REFUSAL_REASONS)).
    pub fn reason(&self) -> &'static str {
        match self {
            InputRefusal::NotJoined(_) => "not_joined",
            InputRefusal::Undecodable(_) => "undecodable",
            InputRefusal::Stale { .. } => "stale",
            InputRefusal::Future { .. } => "future",
            InputRefusal::Backlog { .. } => "backlog",
        }
    }
}

/// Clamps what every input carries whatever the game: the view offset
/// ([`PlayerInput::view_behind`]) is clamped, never refused, so a bad
/// view costs the player the compensation of that one input, not the
/// input: NaN, infinite or negative (a view ahead of the input's tick)
/// becomes 0, "the world as it is"; more than [`MAX_VIEW_BEHIND`] becomes
/// that. The rewind itself is capped later, by the pose window
/// ([`SimContext::cast_ray_at`](super::SimContext::cast_ray_at)), which
/// knows how far back the server keeps poses. The payload is left to the
/// game's decoder.
pub fn validate_input(input: &PlayerInput) -> PlayerInput {
    PlayerInput {
        view_behind: if input.view_behind.is_finite() && input.view_behind > 0.0 {
            input.view_behind.min(MAX_VIEW_BEHIND)
        } else {
            0.0
        },
        ..*input
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_refusal_has_a_label_the_metrics_forget() {
        // A client's series are removed by these labels when it leaves: a
        // reason missing from the list would pile up.
        for refusal in [
            InputRefusal::NotJoined(1),
            InputRefusal::Undecodable(InputDecodeError::Invalid("x".into())),
            InputRefusal::Stale { tick: 1, now: 2 },
            InputRefusal::Future { tick: 3, now: 2 },
            InputRefusal::Backlog { max: 4 },
        ] {
            assert!(crate::metrics::INPUT_REFUSAL_REASONS.contains(&refusal.reason()));
        }
    }

    #[test]
    fn bad_views_are_clamped_and_the_payload_kept() {
        let input = PlayerInput {
            sequence: 1,
            tick: 100,
            payload: inertia_protocol::input::InputPayload::new(&[7, 9]).unwrap(),
            view_behind: 0.0,
        };
        let view = |view_behind| {
            let v = validate_input(&PlayerInput {
                view_behind,
                ..input
            });
            assert_eq!(v.payload, input.payload);
            v.view_behind
        };
        for (bad, want) in [
            (f32::NAN, 0.0),
            (f32::INFINITY, 0.0),
            (f32::NEG_INFINITY, 0.0),
            // Ahead of the input's own tick.
            (-3.0, 0.0),
            (-0.0, 0.0),
            (1e9, MAX_VIEW_BEHIND),
            (6.5, 6.5),
        ] {
            assert_eq!(view(bad), want, "{bad}");
        }
        let v = validate_input(&PlayerInput {
            view_behind: 2.5,
            ..input
        });
        assert_eq!(v.view_tick(), 97.5);
    }
}
