//! The protocol's integration tests: sessions, codecs and the golden
//! vectors the other clients test against.
//!
//! One test binary for the crate (each links the whole crate and its
//! dependencies, so one binary builds in a fraction of the time of one per
//! file): every file of this folder is a module here, and so are the
//! helpers they share. One file's tests:
//! `cargo test -p inertia-protocol --test integration <file>::`.

mod common;
mod support;

mod admin;
mod connection;
mod control;
mod control_vectors;
mod input_vectors;
mod properties;
mod session;
mod snapshot;
mod vectors;
