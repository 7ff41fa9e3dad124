//! One file per suite.

pub mod bandwidth;
pub mod bots;
pub mod capacity;
pub mod integrators;
pub mod nbody;
pub mod particles;
pub mod physics;
pub mod properties;
pub mod replay;
pub mod replays;
pub mod soak;
pub mod soft;

use crate::report::Sink;
use crate::{BenchError, Opts};

/// The suites the binary runs, by command-line name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Suite {
    /// Order of convergence and energy drift of every integrator.
    Integrators,
    /// Particle, cloth and n-body stepping throughput against a memory copy.
    Particles,
    /// Exact and Barnes–Hut mutual gravity: time per step and force error.
    Nbody,
    /// Our rigid-body engine against rapier3d on the same scenes.
    Physics,
    /// Snapshot bandwidth and error of Fiedler's cube scene over a lossy link.
    Bandwidth,
    /// Clients one in-process server serves at 60 Hz, bots in processes of their own.
    Capacity,
    /// Recording size, seek time and offline verification of a recorded game.
    Replay,
    /// Players' kill-cams beside a loaded live match: their latency, what they cost the live clients, and that they show what was live.
    Replays,
    /// An hour of simulated time at fast-forward: memory and file handles bounded.
    Soak,
    /// Soft bodies and fluids on XPBD small steps: cloth, jelly, fluid.
    Soft,
}

impl Suite {
    /// Every suite.
    pub const ALL: [Suite; 10] = [
        Suite::Integrators,
        Suite::Particles,
        Suite::Nbody,
        Suite::Physics,
        Suite::Bandwidth,
        Suite::Capacity,
        Suite::Replay,
        Suite::Replays,
        Suite::Soak,
        Suite::Soft,
    ];

    /// The command-line name, also the `suite` field of every record.
    pub fn name(self) -> &'static str {
        match self {
            Suite::Integrators => "integrators",
            Suite::Particles => "particles",
            Suite::Nbody => "nbody",
            Suite::Physics => "physics",
            Suite::Bandwidth => "bandwidth",
            Suite::Capacity => "capacity",
            Suite::Replay => "replay",
            Suite::Replays => "replays",
            Suite::Soak => "soak",
            Suite::Soft => "soft",
        }
    }

    /// Runs the suite, sending one record per measured case to `sink`.
    pub fn run(self, opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
        match self {
            Suite::Integrators => integrators::run(opts, sink),
            Suite::Particles => particles::run(opts, sink),
            Suite::Nbody => nbody::run(opts, sink),
            Suite::Physics => physics::run(opts, sink),
            Suite::Bandwidth => {
                bandwidth::run(opts, sink)?;
                properties::run(opts, sink)
            }
            Suite::Capacity => capacity::run(opts, sink),
            Suite::Replay => replay::run(opts, sink),
            Suite::Replays => replays::run(opts, sink),
            Suite::Soak => soak::run(opts, sink),
            Suite::Soft => soft::run(opts, sink),
        }
    }
}
