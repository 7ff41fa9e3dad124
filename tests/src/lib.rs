//! Helpers for Inertia's end-to-end tests: real servers and clients over
//! loopback, with a link conditioner between them.

pub mod admin;
pub mod conditioner;
pub mod fault;
pub mod raw;
pub mod server;

pub use conditioner::{BurstLoss, Conditioner, ConditionerStats, Impairment};
