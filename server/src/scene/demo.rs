//! The built-in demo scene: ground, a box pyramid, ragdolls, a rope bridge
//! between two posts, a cloth flag on a pole in the wind, a pool of water
//! with floating crates, and bouncing balls.
//!
//! It is `server/scenes/demo.ron`, embedded at compile time, so the file
//! and the built-in scene cannot drift apart. About 150 bodies and 80
//! particles: a tick takes a few milliseconds on one core.

use super::{Scene, SceneError, SceneFormat};

/// The demo scene's text (RON).
pub const DEMO_RON: &str = include_str!("../../scenes/demo.ron");

/// The demo scene, parsed and checked.
pub fn demo_scene() -> Result<Scene, SceneError> {
    Scene::parse(DEMO_RON, SceneFormat::Ron)
}
