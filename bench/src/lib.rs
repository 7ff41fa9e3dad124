//! # inertia-bench
//!
//! Measures the figures Inertia claims, with their anchors, in one process.
//! The binary `inertia-bench <suite> [--json] [--quick]` runs one suite; see
//! `bench/README.md` for every suite, field and definition.

pub mod copy;
pub mod report;
pub mod suites;

/// Any failure of a suite (engine errors, missing particles, ...).
pub type BenchError = Box<dyn std::error::Error + Send + Sync>;

/// How a suite runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Opts {
    /// Shrink sizes and repetitions to a smoke test of a few seconds.
    pub quick: bool,
}
