//! # inertia-bench
//!
//! Measures the figures Inertia claims, with their anchors, in one process.
//! The binary `inertia-bench <suite> [--json] [--quick]` runs one suite; see
//! `bench/README.md` for every suite, field and definition.

pub mod copy;
pub mod plot;
pub mod report;
pub mod suites;
pub mod usage;

/// Any failure of a suite (engine errors, missing particles, ...).
pub type BenchError = Box<dyn std::error::Error + Send + Sync>;

/// How a suite runs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Opts {
    /// Shrink sizes and repetitions to a smoke test of a few seconds.
    pub quick: bool,
    /// Run only the cases whose name contains this (case, integrator or
    /// method name); `None` runs everything.
    pub only: Option<String>,
    /// Seconds to run for suites that stream over time (`bandwidth`);
    /// `None` takes the suite's default.
    pub seconds: Option<u32>,
    /// Client counts to step through (`capacity`); `None` takes the
    /// suite's default.
    pub clients: Option<Vec<u32>>,
    /// Minutes of play to record (`replay`); `None` takes the default.
    pub minutes: Option<f64>,
    /// Keyframe intervals to record with, ticks, one recording each
    /// (`replay`); `None` takes the default.
    pub keyframe_ticks: Option<Vec<u64>>,
    /// Seeks to time per recording (`replay`).
    pub seeks: Option<u32>,
    /// Dynamic bodies in the scene (`replay`).
    pub bodies: Option<u32>,
    /// Clients playing (`replay`).
    pub bots: Option<u32>,
    /// Run the GPU cases sized for a real GPU (`soft`: `fluid_1m`) on a
    /// CPU adapter too (minutes on Mesa lavapipe).
    pub gpu_large: bool,
    /// Whether the worlds of more than one thread pin their workers one to
    /// a core (`soft`, `particles`; the default: where the process owns
    /// its cores).
    pub pin_threads: inertia_physics::ThreadPinning,
}

impl Opts {
    /// Whether the case called `name` is selected.
    pub fn wants(&self, name: &str) -> bool {
        self.only.as_deref().is_none_or(|f| name.contains(f))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_selects_by_substring() {
        let all = Opts::default();
        assert!(all.wants("particles_1e6"));
        let some = Opts {
            only: Some("1e6".into()),
            ..Opts::default()
        };
        assert!(some.wants("particles_1e6") && !some.wants("cloth_256"));
    }
}
