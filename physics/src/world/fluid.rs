//! Fluids (position-based fluids) in the world: adding, emitting,
//! reading. They step in the soft stage (`world/soft.rs`).

use glam::DVec3;

use super::World;
use crate::error::PhysicsError;
use crate::handle::FluidHandle;
use crate::xpbd::fluid::{Fluid, FluidDesc};

impl World {
    /// Adds a fluid; refused with a typed error (nothing added) when the
    /// description is bad: non-positive spacing or density, a kernel
    /// smaller than the spacing, non-finite particles, more particles
    /// than its cap, ...
    pub fn add_fluid(&mut self, desc: FluidDesc) -> Result<FluidHandle, PhysicsError> {
        let fluid = Fluid::new(desc)?;
        let (index, generation) = self.fluids.insert(fluid);
        Ok(FluidHandle { index, generation })
    }

    /// Removes a fluid.
    pub fn remove_fluid(&mut self, h: FluidHandle) -> Result<(), PhysicsError> {
        self.fluids
            .remove(h.index, h.generation)
            .map(|_| ())
            .ok_or(PhysicsError::UnknownFluid(h))
    }

    /// A fluid, or `None` for a stale handle.
    pub fn fluid(&self, h: FluidHandle) -> Option<&Fluid> {
        self.fluids.get(h.index, h.generation)
    }

    /// Every fluid, in handle order.
    pub fn fluids(&self) -> impl Iterator<Item = (FluidHandle, &Fluid)> {
        self.fluids
            .iter()
            .map(|(index, generation, f)| (FluidHandle { index, generation }, f))
    }

    /// Emits particles into fluid `h` at `positions` (m) with `velocities`
    /// (m/s; one per position, or empty: at rest): an emitter's spout.
    /// All or nothing: refused past the fluid's cap or for a bad value.
    pub fn add_fluid_particles(
        &mut self,
        h: FluidHandle,
        positions: &[DVec3],
        velocities: &[DVec3],
    ) -> Result<(), PhysicsError> {
        self.fluids
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownFluid(h))?
            .add_particles(positions, velocities)
    }
}
