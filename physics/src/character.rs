//! A walking character: an upright capsule pushed by a capped force towards
//! the velocity the player asks for, with a jump that leaves the ground at
//! a fixed speed.
//!
//! This is the pure part of a walking controller, shared by whoever runs
//! one: a server's game rules move the authoritative avatar with it, and a
//! client predicting its own avatar runs the very same rules on a local
//! copy of the world, so that the two agree tick for tick and the client
//! corrects only for what it could not know (other players, lost inputs).
//! It reads nothing but what it is given: a body's velocity, whether a ray
//! cast hits, the tick. The caller owns the state between ticks (the held
//! buttons, when the next jump is allowed).
//!
//! Per tick, in this order: [`WalkSettings::grounded`] (rays down from the
//! centre), [`WalkSettings::walk_force`] (set as the body's control force
//! for the step), [`WalkSettings::jump`] (an impulse at the centre of mass,
//! if one is due), then the world steps.

use glam::{DMat3, DVec3};

use crate::error::PhysicsError;
use crate::rigid::body::{CombineRule, RigidBodyDesc};
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;

/// How a walking character is built and moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WalkSettings {
    /// Capsule radius, m.
    pub radius: f64,
    /// Half the straight part of the capsule, m (total height is
    /// `2 (half_height + radius)`).
    pub half_height: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Fastest walking speed, m/s.
    pub max_speed: f64,
    /// How quickly the velocity follows the stick, 1/s (force = mass ×
    /// gain × velocity error).
    pub acceleration_gain: f64,
    /// Largest walking force on the ground, N.
    pub max_force: f64,
    /// Fraction of the walking force available in the air.
    pub air_control: f64,
    /// Upward speed a jump leaves the ground with, m/s.
    pub jump_speed: f64,
    /// Least time between jumps, s.
    pub jump_cooldown: f64,
}

impl Default for WalkSettings {
    /// A person-sized capsule (1.8 m tall, 70 kg) walking at up to 6 m/s
    /// and jumping about 1.5 m high.
    fn default() -> Self {
        Self {
            radius: 0.35,
            half_height: 0.55,
            mass: 70.0,
            max_speed: 6.0,
            acceleration_gain: 10.0,
            max_force: 2_000.0,
            air_control: 0.3,
            jump_speed: 5.5,
            jump_cooldown: 0.3,
        }
    }
}

/// A jump the controller decided on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jump {
    /// The impulse to apply at the centre of mass, N·s (world).
    pub impulse: DVec3,
    /// The first tick at which the next jump may start.
    pub ready_at: u64,
}

impl WalkSettings {
    /// The character's body at `at` (m, the capsule's centre): dynamic, of
    /// the set mass, with an inertia so large that contacts cannot tip it
    /// over (it stays upright), frictionless (friction would fight the
    /// walking force, which brakes instead), never asleep, and with CCD.
    pub fn body_desc(&self, at: DVec3) -> Result<RigidBodyDesc, PhysicsError> {
        let shape =
            Shape::capsule(self.half_height, self.radius).map_err(|e| PhysicsError::Invalid {
                what: "character capsule",
                why: e.to_string(),
            })?;
        let mut d = RigidBodyDesc::dynamic(shape, 1000.0, Pose::from_translation(at))?;
        d.mass_properties.mass = self.mass;
        d.mass_properties.inertia = DMat3::from_diagonal(DVec3::splat(self.mass * 1e6));
        d.friction_static = 0.0;
        d.friction_dynamic = 0.0;
        d.friction_combine = CombineRule::Min;
        d.can_sleep = false;
        d.ccd = true;
        Ok(d)
    }

    /// Where the ground probes start, relative to the centre of mass, m:
    /// the centre and four points around it, so that standing on an edge
    /// still counts.
    pub fn probe_offsets(&self) -> [DVec3; 5] {
        let r = self.radius * 0.7;
        [
            DVec3::ZERO,
            DVec3::X * r,
            DVec3::NEG_X * r,
            DVec3::Z * r,
            DVec3::NEG_Z * r,
        ]
    }

    /// How far down the ground probes reach from the centre, m: to 10 cm
    /// below the feet.
    pub fn probe_reach(&self) -> f64 {
        self.half_height + self.radius + 0.1
    }

    /// Whether a character centred at `com` (m) stands on something:
    /// `hits(origin, direction, max_t)` casts one probe (a unit direction,
    /// `max_t` in m) against solid bodies other than the character.
    pub fn grounded(&self, com: DVec3, mut hits: impl FnMut(DVec3, DVec3, f64) -> bool) -> bool {
        let reach = self.probe_reach();
        self.probe_offsets()
            .iter()
            .any(|&off| hits(com + off, DVec3::NEG_Y, reach))
    }

    /// The walking force for one tick, N (world, horizontal): towards the
    /// desired velocity `movement × max_speed` (x, z; a length ≤ 1 is
    /// expected) from the current `velocity` (m/s), capped at
    /// [`Self::max_force`] on the ground and a fraction of it in the air.
    pub fn walk_force(&self, movement: [f32; 2], velocity: DVec3, grounded: bool) -> DVec3 {
        let [mx, mz] = movement;
        let desired = DVec3::new(f64::from(mx), 0.0, f64::from(mz)) * self.max_speed;
        let error = desired - DVec3::new(velocity.x, 0.0, velocity.z);
        let cap = if grounded {
            self.max_force
        } else {
            self.max_force * self.air_control
        };
        let force = error * (self.mass * self.acceleration_gain);
        let len = force.length();
        if len > cap && len > 0.0 {
            force * (cap / len)
        } else {
            force
        }
    }

    /// The jump for this tick, if one starts: the button was `pressed`
    /// since the last tick, the character stands on something, `tick` is
    /// at or after `ready_at`, and it is not already rising fast (vertical
    /// `velocity` below half the jump speed). Whatever the vertical speed
    /// (landing included), it leaves at exactly the jump speed, so every
    /// jump rises the same height. `dt` is the tick's length, s.
    pub fn jump(
        &self,
        pressed: bool,
        grounded: bool,
        tick: u64,
        ready_at: u64,
        velocity: DVec3,
        dt: f64,
    ) -> Option<Jump> {
        if !(pressed && grounded && tick >= ready_at && velocity.y < self.jump_speed * 0.5) {
            return None;
        }
        Some(Jump {
            impulse: DVec3::Y * (self.mass * (self.jump_speed - velocity.y)),
            ready_at: tick + ticks(self.jump_cooldown, dt),
        })
    }
}

/// Whole ticks of `dt` s that cover `secs` s (rounded up).
pub fn ticks(secs: f64, dt: f64) -> u64 {
    (secs / dt).ceil() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walk_force_is_capped_and_weaker_in_the_air() {
        let s = WalkSettings::default();
        let ground = s.walk_force([1.0, 0.0], DVec3::ZERO, true);
        assert!((ground.length() - s.max_force).abs() < 1e-9, "{ground}");
        assert!(ground.x > 0.0 && ground.y == 0.0);
        let air = s.walk_force([1.0, 0.0], DVec3::ZERO, false);
        assert!((air.length() - s.max_force * s.air_control).abs() < 1e-9);
        // Close to the desired speed the force is proportional.
        let near = s.walk_force([1.0, 0.0], DVec3::new(5.9, -3.0, 0.0), true);
        assert!((near.x - 0.1 * s.mass * s.acceleration_gain).abs() < 1e-9);
    }

    #[test]
    fn a_jump_needs_ground_a_press_and_the_cooldown() {
        let s = WalkSettings::default();
        let dt = 1.0 / 60.0;
        let j = s.jump(true, true, 10, 10, DVec3::NEG_Y, dt).expect("jumps");
        assert!((j.impulse.y - s.mass * (s.jump_speed + 1.0)).abs() < 1e-9);
        assert_eq!(j.ready_at, 10 + 18);
        assert!(s.jump(false, true, 10, 0, DVec3::ZERO, dt).is_none());
        assert!(s.jump(true, false, 10, 0, DVec3::ZERO, dt).is_none());
        assert!(s.jump(true, true, 9, 10, DVec3::ZERO, dt).is_none());
        assert!(s.jump(true, true, 10, 0, DVec3::Y * 3.0, dt).is_none());
    }

    #[test]
    fn probes_reach_below_the_feet() {
        let s = WalkSettings::default();
        let mut casts = Vec::new();
        assert!(!s.grounded(DVec3::ZERO, |o, d, t| {
            casts.push((o, d, t));
            false
        }));
        assert_eq!(casts.len(), 5);
        assert!(casts
            .iter()
            .all(|&(_, d, t)| d == DVec3::NEG_Y && (t - 1.0).abs() < 1e-12));
    }
}
