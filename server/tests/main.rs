//! The server's integration tests: its binaries, recordings, resume,
//! matches, the admin CLI, Agones and the simulation thread.
//!
//! One test binary for the crate (each links the whole crate and its
//! dependencies, so one binary builds in a fraction of the time of one per
//! file): every file of this folder is a module here, and so are the
//! helpers they share. One file's tests:
//! `cargo test -p inertia-server --test integration <file>::`.

mod common;
mod fake_agones;

mod admin_cli;
mod agones;
mod issue_11_admin_tokens;
mod issue_11_checkpoints;
mod issue_11_max_bodies;
mod issue_11_physical_bounds;
mod issue_11_resume;
mod issue_11_saved_state_bounds;
mod issue_11_seek_memory;
mod issue_17_inputs_on_their_tick;
mod issue_43_command_line;
mod match_end;
mod matches;
mod record_store;
mod recording;
mod replay_file;
mod resume;
mod rules;
mod scenes;
mod secrets_reload;
mod sigterm;
mod sim_thread;
mod timeline;
