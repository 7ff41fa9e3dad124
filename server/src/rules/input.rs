//! An input from the network, validated before any field of it is read:
//! refused when not finite, clamped otherwise. Its tick was checked
//! against the server's before it reached the rules, by the simulation's
//! input schedule ([`crate::sim::input_schedule`]).

use std::f64::consts::PI;

use inertia_protocol::entity::buttons;
use inertia_protocol::input::MAX_VIEW_BEHIND;
use inertia_protocol::PlayerInput;

use super::ClientId;

/// Why an input was refused (it is then ignored; the client's previous
/// input stays in force).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputRefusal {
    /// The client has not joined.
    #[error("client {0} has not joined")]
    NotJoined(ClientId),
    /// A field was NaN or infinite.
    #[error("input field {0} is not a finite number")]
    NonFinite(&'static str),
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

/// Checks and clamps one input: NaN or infinite fields are refused;
/// movement is clamped to [−1, 1] per axis and length 1, yaw wrapped into
/// (−π, π], and undefined button bits cleared.
///
/// The view offset ([`PlayerInput::view_behind`]) is clamped, never
/// refused, so a bad view costs the player the compensation of that one
/// input, not its movement: NaN, infinite or negative (a view ahead of the
/// input's tick) becomes 0, "the world as it is"; more than
/// [`MAX_VIEW_BEHIND`] becomes that. The rewind itself is capped later, by
/// the pose window ([`SimContext::cast_ray_at`]), which knows how far back
/// the server keeps poses.
pub fn validate_input(input: &PlayerInput) -> Result<PlayerInput, InputRefusal> {
    let [mx, mz] = input.movement;
    if !(mx.is_finite() && mz.is_finite()) {
        return Err(InputRefusal::NonFinite("movement"));
    }
    if !input.yaw.is_finite() {
        return Err(InputRefusal::NonFinite("yaw"));
    }
    let (mut mx, mut mz) = (mx.clamp(-1.0, 1.0), mz.clamp(-1.0, 1.0));
    let len = (mx * mx + mz * mz).sqrt();
    if len > 1.0 {
        mx /= len;
        mz /= len;
    }
    let yaw = f64::from(input.yaw);
    let mut yaw = (yaw + PI).rem_euclid(2.0 * PI) - PI;
    if yaw <= -PI {
        yaw += 2.0 * PI;
    }
    Ok(PlayerInput {
        sequence: input.sequence,
        tick: input.tick,
        movement: [mx, mz],
        yaw: yaw as f32,
        buttons: input.buttons & buttons::ALL,
        view_behind: if input.view_behind.is_finite() && input.view_behind > 0.0 {
            input.view_behind.min(MAX_VIEW_BEHIND)
        } else {
            0.0
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(movement: [f32; 2], yaw: f32, buttons: u8) -> PlayerInput {
        PlayerInput {
            sequence: 1,
            tick: 100,
            movement,
            yaw,
            buttons,
            view_behind: 0.0,
        }
    }

    #[test]
    fn non_finite_input_is_refused() {
        for bad in [
            input([f32::NAN, 0.0], 0.0, 0),
            input([0.0, f32::INFINITY], 0.0, 0),
            input([0.0, 0.0], f32::NAN, 0),
            input([0.0, 0.0], f32::NEG_INFINITY, 0),
        ] {
            assert!(matches!(
                validate_input(&bad),
                Err(InputRefusal::NonFinite(_))
            ));
        }
    }

    #[test]
    fn huge_input_is_clamped() {
        let v = validate_input(&input([1e30, -1e30], 1e9, 0xff)).unwrap();
        let len = (v.movement[0].powi(2) + v.movement[1].powi(2)).sqrt();
        assert!((len - 1.0).abs() < 1e-6, "{v:?}");
        assert!(v.yaw.abs() <= std::f32::consts::PI + 1e-6);
        assert_eq!(v.buttons, buttons::ALL);
        let v = validate_input(&input([0.3, 0.4], 0.5, 0)).unwrap();
        assert_eq!(v.movement, [0.3, 0.4]);
        assert_eq!(v.yaw, 0.5);
    }

    #[test]
    fn bad_views_are_clamped_not_refused() {
        let view = |view_behind| {
            validate_input(&PlayerInput {
                view_behind,
                ..input([0.5, 0.0], 0.0, 0)
            })
            .map(|v| (v.view_behind, v.movement))
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
            assert_eq!(view(bad), Ok((want, [0.5, 0.0])), "{bad}");
        }
        let v = validate_input(&PlayerInput {
            view_behind: 2.5,
            ..input([0.0, 0.0], 0.0, 0)
        })
        .unwrap();
        assert_eq!(v.view_tick(), 97.5);
    }
}
