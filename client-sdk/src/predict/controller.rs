//! How the game's rules move the own avatar, run again on the client: the
//! part of prediction that is the game's ([`AvatarController`]), and the
//! sandbox's walker ([`SandboxWalker`]), the default.

use glam::DVec3;
use inertia_physics::character::WalkSettings;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::{BodyHandle, World};
use inertia_protocol::input::{GameInput, InputPayload};
use inertia_sandbox::{buttons, SandboxInput};

use super::{PredictionConfig, PredictionError};

/// One tick for a controller: the local world, the avatar's body in it,
/// the game's input for the tick, and the tick.
#[derive(Debug)]
pub struct ControlStep<'a> {
    /// The local world (the avatar and its neighbours).
    pub world: &'a mut World,
    /// The avatar's body.
    pub avatar: BodyHandle,
    /// The game's input for this tick (its bytes, as the server's rules
    /// read them).
    pub input: &'a InputPayload,
    /// The tick being run.
    pub tick: u64,
    /// Its length, s.
    pub dt: f64,
}

/// How the game's rules move a player's avatar, for the client to run the
/// same: its body, and what one tick of the game's input does to it (the
/// forces and impulses the rules' `before_tick` gives it), with the
/// controller's memory between ticks (held buttons, cooldowns) put back
/// on every correction. A game whose rules move avatars their own way
/// gives its own ([`crate::ConnectOptions::controller`]); the default is
/// the sandbox's walker.
pub trait AvatarController: Send + std::fmt::Debug {
    /// The avatar's body as the rules make it, centred at `at`, m.
    fn body(&self, at: DVec3) -> Result<RigidBodyDesc, PredictionError>;

    /// Applies one tick's input to the avatar, as the rules do.
    fn control(&mut self, step: ControlStep<'_>);

    /// What the controller remembers between ticks, as bytes.
    fn memory(&self) -> Vec<u8>;

    /// Puts back memory [`Self::memory`] gave (empty: as new).
    fn recall(&mut self, memory: &[u8]);
}

/// The sandbox's walker: its capsule, walked by the shared controller
/// (`inertia_physics::character`) towards the stick, a jump on the press
/// of its button when standing, capped as the server's context caps it.
#[derive(Debug, Clone)]
pub struct SandboxWalker {
    walk: WalkSettings,
    /// Largest impulse, N·s, and velocity change, m/s, of one impulse.
    max_impulse: f64,
    max_delta_v: f64,
    /// Buttons of the previous input, for press edges.
    held: u8,
    /// No jump before this tick.
    jump_ready_at: u64,
}

impl SandboxWalker {
    /// The walker of `config` (its capsule, controller and caps).
    pub fn new(config: &PredictionConfig) -> Self {
        Self {
            walk: config.walk,
            max_impulse: config.max_impulse,
            max_delta_v: config.max_delta_v,
            held: 0,
            jump_ready_at: 0,
        }
    }
}

/// The server's clamp of movement: each axis to [−1, 1], the length to 1.
fn clamp_movement([x, z]: [f32; 2]) -> [f32; 2] {
    if !(x.is_finite() && z.is_finite()) {
        return [0.0, 0.0];
    }
    let (mut x, mut z) = (x.clamp(-1.0, 1.0), z.clamp(-1.0, 1.0));
    let len = (x * x + z * z).sqrt();
    if len > 1.0 {
        x /= len;
        z /= len;
    }
    [x, z]
}

impl AvatarController for SandboxWalker {
    fn body(&self, at: DVec3) -> Result<RigidBodyDesc, PredictionError> {
        Ok(self.walk.body_desc(at)?)
    }

    fn control(&mut self, step: ControlStep<'_>) {
        let ControlStep {
            world,
            avatar: h,
            input,
            tick: t,
            dt,
        } = step;
        // An input it cannot read walks nowhere.
        let input = SandboxInput::from_payload(input).unwrap_or_default();
        let movement = clamp_movement(input.movement);
        let pressed = input.buttons & !self.held;
        self.held = input.buttons;
        let Some(b) = world.body(h) else { return };
        let (v, com) = (b.linear_velocity(), b.center_of_mass());
        let walk = self.walk;
        let grounded = {
            let world = &*world;
            walk.grounded(com, |from, dir, reach| {
                world
                    .cast_ray(from, dir, reach, |other, body| {
                        other != h && !body.is_sensor()
                    })
                    .ok()
                    .flatten()
                    .is_some()
            })
        };
        let _ = world.set_body_control(h, walk.walk_force(movement, v, grounded), DVec3::ZERO);
        let jump_pressed = pressed & buttons::JUMP != 0;
        if let Some(j) = walk.jump(jump_pressed, grounded, t, self.jump_ready_at, v, dt) {
            let cap = self.max_impulse.min(walk.mass * self.max_delta_v);
            let len = j.impulse.length();
            let impulse = if len > cap {
                j.impulse * (cap / len)
            } else {
                j.impulse
            };
            if world.apply_body_impulse(h, impulse, com).is_ok() {
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
        match memory {
            [held, rest @ ..] if rest.len() == 8 => {
                self.held = *held;
                self.jump_ready_at = u64::from_le_bytes(rest.try_into().expect("8 bytes"));
            }
            _ => {
                self.held = 0;
                self.jump_ready_at = 0;
            }
        }
    }
}
