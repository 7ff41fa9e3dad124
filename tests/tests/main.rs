//! End-to-end tests: real servers and clients on loopback, through the
//! SDK, the viewer, WebTransport and the link conditioner.
//!
//! One test binary for the crate (each links the whole crate and its
//! dependencies, so one binary builds in a fraction of the time of one per
//! file): every file of this folder is a module here, and so are the
//! helpers they share. One file's tests:
//! `cargo test -p inertia-tests --test integration <file>::`.

mod e2e_admin;
mod e2e_connect;
mod e2e_record;
mod e2e_timeline;
mod e2e_world;
mod issue_11_abuse;
mod issue_11_supervision;
mod issue_12_silent_client;
mod issue_15_viewer;
mod issue_15_web_transport;
mod issue_16_point_sets;
mod issue_17_inputs_on_their_tick;
mod issue_17_lag_compensation;
mod issue_17_prediction;
mod issue_42_connections;
mod issue_43_football;
mod issue_43_game_input;
mod issue_43_messages;
mod issue_43_properties;
mod issue_44_replays;
