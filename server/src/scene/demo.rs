//! The built-in demo scene: ground, a box pyramid, ragdolls, a rope bridge
//! between two posts, a cloth flag on a pole in the wind, a pool of water
//! with floating crates, and bouncing balls; and on XPBD small steps, a
//! rope bridge of two inextensible ropes carrying ten deck boards, a
//! 20 × 12 banner on tethers, a jelly cube (5³ cells) dropped so it
//! squashes and springs back, a plastic bar that a falling weight bends
//! for good, and a tank of fluid (800 particles, and 80 more from a spout)
//! with a crate of half its density floating in it.
//!
//! It is `server/scenes/demo.ron`, embedded at compile time, so the file
//! and the built-in scene cannot drift apart. About 150 bodies, 100
//! mass-spring particles, five soft bodies (about 600 particles) and 880
//! fluid particles: a tick takes about 2.5 ms on two cores.

use super::{Scene, SceneError, SceneFormat};

/// The demo scene's text (RON).
pub const DEMO_RON: &str = include_str!("../../scenes/demo.ron");

/// The demo scene, parsed and checked.
pub fn demo_scene() -> Result<Scene, SceneError> {
    Scene::parse(DEMO_RON, SceneFormat::Ron)
}
