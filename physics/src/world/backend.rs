//! Moving particle systems between the CPU and the GPU.

use super::World;
use crate::error::PhysicsError;
use crate::handle::SystemHandle;
use crate::particle_system::Backend;

impl World {
    // ----- backends -----

    /// Moves a system to another backend, carrying its state across.
    pub fn set_backend(&mut self, sys: SystemHandle, backend: Backend) -> Result<(), PhysicsError> {
        let current = self
            .system(sys)
            .ok_or(PhysicsError::UnknownSystem(sys))?
            .backend;
        if current == backend {
            return Ok(());
        }
        #[cfg(feature = "gpu")]
        {
            match backend {
                Backend::Gpu => {
                    self.gpu_context()?;
                    let ctx = self.gpu.as_ref().expect("context created above");
                    let s = self
                        .systems
                        .get_mut(sys.index, sys.generation)
                        .expect("checked above");
                    crate::gpu::upload(ctx, s)?;
                    s.backend = Backend::Gpu;
                }
                Backend::Cpu => {
                    let ctx = self
                        .gpu
                        .as_ref()
                        .ok_or_else(|| PhysicsError::Gpu("no GPU context".into()))?;
                    let s = self
                        .systems
                        .get_mut(sys.index, sys.generation)
                        .expect("checked above");
                    crate::gpu::download(ctx, s)?;
                    s.gpu = None;
                    s.backend = Backend::Cpu;
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

    /// Copies every GPU system's, soft body's and fluid's state back into its
    /// CPU mirror.
    pub fn sync_gpu(&mut self) -> Result<(), PhysicsError> {
        #[cfg(feature = "gpu")]
        if let Some(ctx) = self.gpu.as_ref() {
            for (_, _, s) in self.systems.iter_mut() {
                if s.backend == Backend::Gpu {
                    crate::gpu::download(ctx, s)?;
                }
            }
            for (_, _, b) in self.soft_bodies.iter_mut() {
                if let Some(gpu) = b.gpu.0.clone() {
                    crate::gpu::soft::download(ctx, b, &gpu)?;
                }
            }
            for (_, _, f) in self.fluids.iter_mut() {
                if let Some(gpu) = f.gpu.0.clone() {
                    crate::gpu::fluid::download(ctx, f, &gpu)?;
                }
            }
        }
        Ok(())
    }

    /// The GPU context, created on first use.
    #[cfg(feature = "gpu")]
    pub fn gpu_context(&mut self) -> Result<&crate::gpu::GpuContext, PhysicsError> {
        if self.gpu.is_none() {
            self.gpu = Some(crate::gpu::GpuContext::new()?);
        }
        Ok(self.gpu.as_ref().expect("just created"))
    }

    /// Structural edits (particles, springs) go through the CPU state, so they
    /// are refused while a system lives on the GPU.
    pub(super) fn gpu_guard(&self, sys: SystemHandle) -> Result<(), PhysicsError> {
        match self.system(sys) {
            Some(s) if s.backend == Backend::Gpu => Err(PhysicsError::Gpu(
                "move the system back to the CPU backend before editing it".into(),
            )),
            _ => Ok(()),
        }
    }
}
