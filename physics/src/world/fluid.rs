//! Fluids (position-based fluids) in the world: adding, emitting,
//! reading. They step in the soft stage (`world/soft.rs`).

use glam::DVec3;

use super::World;
use crate::error::PhysicsError;
use crate::handle::FluidHandle;
use crate::xpbd::fluid::{Fluid, FluidDesc, FluidEmitter};

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
        #[cfg(feature = "gpu")]
        if let Some(on_gpu) = self.gpu.as_mut() {
            on_gpu.fluids.remove(&(h.index, h.generation));
        }
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
        #[cfg(feature = "gpu")]
        if let Some(on_gpu) = self.gpu.as_mut() {
            let slot = (h.index, h.generation);
            if let Some(buffers) = on_gpu.fluids.get(&slot) {
                // On the GPU: back to the host, the particles added, up
                // again.
                let fluid = self
                    .fluids
                    .get_mut(h.index, h.generation)
                    .ok_or(PhysicsError::UnknownFluid(h))?;
                crate::gpu::fluid::download(&on_gpu.ctx, fluid, buffers)?;
                fluid.add_particles(positions, velocities)?;
                let buffers =
                    crate::gpu::fluid::upload(&on_gpu.ctx, on_gpu.fluid_pipelines.as_ref(), fluid)?;
                on_gpu.fluids.insert(slot, buffers);
                return Ok(());
            }
        }
        self.fluids
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownFluid(h))?
            .add_particles(positions, velocities)
    }

    /// Moves fluid `h` to `backend`, carrying its particles across. On the
    /// GPU (feature `gpu`) it takes the same steps in `f32` (`gpu/fluid.rs`),
    /// against the bodies near it, pushing the dynamic ones back as on the
    /// CPU (`gpu/bodies.rs`). Refused with [`PhysicsError::Gpu`]
    /// naming what, while a body near the fluid has a shape other than a
    /// cuboid, sphere or capsule, or more than
    /// [`MAX_GPU_BODIES`](crate::gpu::MAX_GPU_BODIES) bodies
    /// are near it. A step that finds such bodies near it later moves the
    /// fluid back to the CPU and says so in
    /// [`StepReport::fluids_to_cpu`](crate::StepReport). Emitters and [`World::add_fluid_particles`] work on the host
    /// between steps (the fluid is read back and uploaded again). A saved
    /// state does not keep the backend: a restored fluid steps on the CPU
    /// until moved again. With
    /// [`WorldConfig::gpu_readback_every_step`](crate::WorldConfig) off,
    /// call [`World::sync_gpu`] before reading or saving it.
    pub fn set_fluid_backend(
        &mut self,
        h: FluidHandle,
        backend: crate::particle_system::Backend,
    ) -> Result<(), PhysicsError> {
        #[cfg(feature = "gpu")]
        use crate::particle_system::Backend;
        let current = self
            .fluid(h)
            .ok_or(PhysicsError::UnknownFluid(h))?
            .backend();
        if current == backend {
            return Ok(());
        }
        #[cfg(feature = "gpu")]
        {
            match backend {
                Backend::Gpu => {
                    let fluid = self.fluid(h).expect("checked above");
                    let reach = fluid.reach(0.0, self.gravity.as_vec3());
                    let near = crate::gpu::bodies::near_box(&fluid.x, reach);
                    crate::gpu::bodies::gather(
                        &self.bodies,
                        &self.step_start,
                        near.as_ref(),
                        &[],
                        true,
                    )?;
                    self.on_gpu()?;
                    let on_gpu = self.gpu.as_mut().expect("created above");
                    let fluid = self
                        .fluids
                        .get_mut(h.index, h.generation)
                        .expect("checked above");
                    let buffers = crate::gpu::fluid::upload(
                        &on_gpu.ctx,
                        on_gpu.fluid_pipelines.as_ref(),
                        fluid,
                    )?;
                    on_gpu.fluids.insert((h.index, h.generation), buffers);
                    fluid.backend = Backend::Gpu;
                }
                Backend::Cpu => {
                    let on_gpu = self
                        .gpu
                        .as_mut()
                        .ok_or_else(|| PhysicsError::Gpu("no GPU context".into()))?;
                    let fluid = self
                        .fluids
                        .get_mut(h.index, h.generation)
                        .expect("checked above");
                    if let Some(buffers) = on_gpu.fluids.remove(&(h.index, h.generation)) {
                        crate::gpu::fluid::download(&on_gpu.ctx, fluid, &buffers)?;
                    }
                    fluid.backend = Backend::Cpu;
                }
            }
            Ok(())
        }
        #[cfg(not(feature = "gpu"))]
        {
            let _ = backend;
            Err(PhysicsError::Gpu("this build has no `gpu` feature".into()))
        }
    }

    /// Adds an emitter to fluid `h`: from the next step on, it adds
    /// particles at the end of every step that a shot of it comes due in
    /// (see [`FluidEmitter`]); shots due before now are skipped. Returns its
    /// index in [`Fluid::emitters`]. Refused with a typed error for a bad
    /// description (a zero velocity, shots closer than the spacing, a
    /// negative radius or start, a stop before the start, a zero limit,
    /// ...) or a stale handle.
    pub fn add_fluid_emitter(
        &mut self,
        h: FluidHandle,
        emitter: FluidEmitter,
    ) -> Result<usize, PhysicsError> {
        let now = self.time;
        self.fluids
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownFluid(h))?
            .add_emitter(emitter, now)
    }
}
