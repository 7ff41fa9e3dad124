//! How the client predicts its own ball: the same roll the rules give it
//! ([`crate::rules::OrbsRules`]'s `before_tick`), run on the client at
//! once, corrected by the server's snapshots (`inertia_client::predict`).

use inertia_client::predict::{AvatarController, ControlStep, PredictionError};
use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_protocol::input::GameInput;

use crate::rules::{roll_force, BALL_DENSITY, BALL_RADIUS};
use crate::Drive;

/// A player's ball, as the client rolls it.
#[derive(Debug, Clone, Copy, Default)]
pub struct Roller;

impl AvatarController for Roller {
    fn body(&self, at: DVec3) -> Result<RigidBodyDesc, PredictionError> {
        let shape = Shape::sphere(BALL_RADIUS)?;
        Ok(RigidBodyDesc::dynamic(
            shape,
            BALL_DENSITY,
            Pose::from_translation(at),
        )?)
    }

    fn control(&mut self, step: ControlStep<'_>) {
        // An input the game does not define rolls nowhere, as on the server.
        let drive = Drive::from_payload(step.input).unwrap_or_default();
        let _ = step
            .world
            .set_body_control(step.avatar, roll_force(&drive), DVec3::ZERO);
    }

    fn memory(&self) -> Vec<u8> {
        Vec::new()
    }

    fn recall(&mut self, _memory: &[u8]) {}
}
