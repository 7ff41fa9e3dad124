//! Per-step timings of the world's stages, for the caller to read.
//! Wall-clock readings are for profiling only: nothing in the simulation
//! reads them, so they cannot make a run non-deterministic.

use std::time::Duration;

/// Wall time of each stage of the last [`World::step`](crate::World::step).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepProfile {
    /// Rebuilding derived data (spring adjacency), compiling force fields, expiring explosions.
    pub prepare: Duration,
    /// Interaction and (for multi-stage integrators) acceleration evaluation.
    pub forces: Duration,
    /// The integration passes (fused with field forces for the Euler methods).
    pub integrate: Duration,
    /// GPU dispatches (feature `gpu`), including any readback.
    pub gpu: Duration,
    /// Rigid-body motion.
    pub bodies: Duration,
    /// Collecting and reporting quarantined particles.
    pub quarantine: Duration,
    /// Spring and mutual-gravity potential energy.
    pub energy: Duration,
    /// The whole step.
    pub total: Duration,
}

/// Totals over many steps, with the step count.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ProfileTotals {
    /// Number of steps summed.
    pub steps: u64,
    /// Sum of the per-stage times.
    pub sum: StepProfile,
}

impl ProfileTotals {
    pub(crate) fn add(&mut self, p: &StepProfile) {
        self.steps += 1;
        let s = &mut self.sum;
        s.prepare += p.prepare;
        s.forces += p.forces;
        s.integrate += p.integrate;
        s.gpu += p.gpu;
        s.bodies += p.bodies;
        s.quarantine += p.quarantine;
        s.energy += p.energy;
        s.total += p.total;
    }
}
