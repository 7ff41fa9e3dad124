//! How the client predicts its own player: the same run and jump the rules
//! give it ([`crate::rules::FootballRules`]'s `before_tick`), run on the
//! client at once and corrected by the server's snapshots
//! (`inertia_client::predict`). Kicks move the ball, which the client does
//! not predict: it draws the ball from snapshots.

use inertia_client::predict::{AvatarController, ControlStep, PredictionError};
use inertia_physics::character::WalkSettings;
use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_protocol::input::GameInput;

use crate::input::buttons;
use crate::Play;

/// A player's capsule, as the client runs it.
#[derive(Debug, Clone, Copy)]
pub struct Runner {
    walk: WalkSettings,
    /// Buttons of the previous play, for press edges.
    held: u8,
    /// No jump before this tick.
    jump_ready_at: u64,
}

impl Runner {
    /// A runner with the rules' capsule and stride
    /// ([`crate::FootballSettings::walk`]).
    pub fn new(walk: WalkSettings) -> Self {
        Self {
            walk,
            held: 0,
            jump_ready_at: 0,
        }
    }
}

impl Default for Runner {
    fn default() -> Self {
        Self::new(WalkSettings::default())
    }
}

impl AvatarController for Runner {
    fn body(&self, at: DVec3) -> Result<RigidBodyDesc, PredictionError> {
        Ok(self.walk.body_desc(at)?)
    }

    fn control(&mut self, step: ControlStep<'_>) {
        let ControlStep {
            world,
            avatar,
            input,
            tick,
            dt,
        } = step;
        // A play the game does not define runs nowhere, as on the server.
        let play = Play::from_payload(input).unwrap_or_default();
        let pressed = play.buttons & !self.held;
        self.held = play.buttons;
        let Some(b) = world.body(avatar) else { return };
        let (v, com) = (b.linear_velocity(), b.center_of_mass());
        let walk = self.walk;
        let grounded = {
            let world = &*world;
            walk.grounded(com, |from, dir, reach| {
                world
                    .cast_ray(from, dir, reach, |other, body| {
                        other != avatar && !body.is_sensor()
                    })
                    .ok()
                    .flatten()
                    .is_some()
            })
        };
        let _ = world.set_body_control(
            avatar,
            walk.walk_force(play.movement(), v, grounded),
            DVec3::ZERO,
        );
        let jump = pressed & buttons::JUMP != 0;
        if let Some(j) = walk.jump(jump, grounded, tick, self.jump_ready_at, v, dt) {
            if world.apply_body_impulse(avatar, j.impulse, com).is_ok() {
                self.jump_ready_at = j.ready_at;
            }
        }
    }

    fn memory(&self) -> Vec<u8> {
        let mut out = vec![self.held];
        out.extend_from_slice(&self.jump_ready_at.to_le_bytes());
        out
    }

    fn recall(&mut self, memory: &[u8]) {
        let (held, ready) = match memory {
            [held, rest @ ..] if rest.len() == 8 => {
                let mut b = [0u8; 8];
                b.copy_from_slice(rest);
                (*held, u64::from_le_bytes(b))
            }
            _ => (0, 0),
        };
        self.held = held;
        self.jump_ready_at = ready;
    }
}
