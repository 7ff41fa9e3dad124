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
    /// Rigid-body motion (all of it; its parts in [`Self::rigid`]).
    pub bodies: Duration,
    /// The parts of [`Self::bodies`].
    pub rigid: RigidProfile,
    /// Soft bodies and fluids (XPBD small steps), their contacts with
    /// rigid bodies included.
    pub soft: Duration,
    /// Collecting and reporting quarantined particles.
    pub quarantine: Duration,
    /// Spring and mutual-gravity potential energy.
    pub energy: Duration,
    /// The whole step.
    pub total: Duration,
}

/// Wall time of each stage of the rigid-body step (forces, broad phase,
/// narrow phase, colouring, solve, finish, islands; see ARCHITECTURE.md).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RigidProfile {
    /// Force generators evaluated on every body, and waking.
    pub forces: Duration,
    /// Updating the AABB tree and finding the overlapping pairs.
    pub broad_phase: Duration,
    /// Contact manifolds of the pairs, and the constraints built from them.
    pub narrow_phase: Duration,
    /// Colouring the constraint graph for parallel solving.
    pub colouring: Duration,
    /// The substeps: integration, warm starting, solving, relaxing, restitution.
    pub solve: Duration,
    /// Joint breaking, contact and force events, the contact cache, writing
    /// velocities back.
    pub finish: Duration,
    /// Islands and sleeping.
    pub islands: Duration,
    /// Particles kept out of rigid shapes.
    pub particle_contacts: Duration,
}

impl RigidProfile {
    fn add(&mut self, p: &RigidProfile) {
        self.forces += p.forces;
        self.broad_phase += p.broad_phase;
        self.narrow_phase += p.narrow_phase;
        self.colouring += p.colouring;
        self.solve += p.solve;
        self.finish += p.finish;
        self.islands += p.islands;
        self.particle_contacts += p.particle_contacts;
    }
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
        s.rigid.add(&p.rigid);
        s.soft += p.soft;
        s.quarantine += p.quarantine;
        s.energy += p.energy;
        s.total += p.total;
    }
}
