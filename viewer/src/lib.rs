//! # inertia-viewer
//!
//! Watches an Inertia server as a game client would: it joins through the
//! SDK, draws the interpolated world with wgpu (every shape the server
//! describes, lit, with a metre grid on static scenery), shows a HUD of the connection
//! and the server's clock, and, with the admin credential, drives the clock
//! (pause, step, speed, reverse, seek) from a bottom panel.
//!
//! It runs in a window ([`window`]) or without one ([`headless`]), drawing
//! into an off-screen texture for screenshots and frame sequences.
//!
//! - [`mesh`]: triangle meshes for the shapes the server describes.
//! - [`scene`]: what was described, placed where the frame has it.
//! - [`camera`]: the orbit camera.
//! - [`render`]: the wgpu renderer (scene and HUD).
//! - [`hud`]: the HUD and the clock's controls (egui).
//! - [`admin`]: the admin link, on its own thread.
//! - [`controls`]: what the keys send and the HUD headlines, by game.
//! - [`view`]: one viewer's state, window or not.

pub mod admin;
pub mod camera;
pub mod controls;
pub mod headless;
pub mod hud;
pub mod mesh;
pub mod point_sets;
pub mod render;
pub mod scene;
pub mod view;
pub mod window;

/// Why the viewer stopped.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// The options make no sense.
    #[error("{0}")]
    Usage(String),
    /// The credentials file could not be used.
    #[error("credentials {0}")]
    Credentials(String),
    /// The server could not be joined, or the connection ended.
    #[error("connection {0}")]
    Connect(String),
    /// No adapter, device or surface could be had, or drawing failed.
    #[error("graphics: {0}")]
    Gpu(String),
    /// No window could be opened.
    #[error("window: {0}")]
    Window(String),
    /// A picture could not be written.
    #[error("picture {0}")]
    Image(String),
    /// What was waited for did not come.
    #[error("timed out: {0}")]
    Timeout(String),
}
