//! The Inertia server: owns one physics world, steps it on its own thread at a
//! fixed rate, and streams snapshots to clients over QUIC.

pub mod admin;
pub mod clock;
pub mod config;
pub mod credentials;
pub mod health;
pub mod http;
pub mod metrics;
pub mod net;
pub mod orchestrator;
pub mod play;
pub mod pose_history;
pub mod priority;
pub mod process;
pub mod properties;
pub mod record;
pub mod replay;
pub mod rules;
pub mod scene;
pub mod secrets;
pub mod server;
pub mod sim;
