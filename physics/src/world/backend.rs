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
                    self.on_gpu()?;
                    let on_gpu = self.gpu.as_mut().expect("created above");
                    let s = self
                        .systems
                        .get_mut(sys.index, sys.generation)
                        .expect("checked above");
                    let buffers = crate::gpu::upload(&on_gpu.ctx, s)?;
                    on_gpu.systems.insert((sys.index, sys.generation), buffers);
                    s.backend = Backend::Gpu;
                }
                Backend::Cpu => {
                    let on_gpu = self
                        .gpu
                        .as_mut()
                        .ok_or_else(|| PhysicsError::Gpu("no GPU context".into()))?;
                    let s = self
                        .systems
                        .get_mut(sys.index, sys.generation)
                        .expect("checked above");
                    if let Some(mut buffers) = on_gpu.systems.remove(&(sys.index, sys.generation)) {
                        crate::gpu::download(&on_gpu.ctx, s, &mut buffers)?;
                    }
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
        if let Some(on_gpu) = self.gpu.as_mut() {
            let ctx = &on_gpu.ctx;
            for (index, generation, s) in self.systems.iter_mut() {
                if let Some(buffers) = on_gpu.systems.get_mut(&(index, generation)) {
                    crate::gpu::download(ctx, s, buffers)?;
                }
            }
            for (index, generation, b) in self.soft_bodies.iter_mut() {
                if let Some(buffers) = on_gpu.soft_bodies.get(&(index, generation)) {
                    crate::gpu::soft::download(ctx, b, buffers)?;
                }
            }
            for (index, generation, f) in self.fluids.iter_mut() {
                if let Some(buffers) = on_gpu.fluids.get(&(index, generation)) {
                    crate::gpu::fluid::download(ctx, f, buffers)?;
                }
            }
        }
        Ok(())
    }

    /// The GPU context, created on first use.
    #[cfg(feature = "gpu")]
    pub fn gpu_context(&mut self) -> Result<&crate::gpu::GpuContext, PhysicsError> {
        Ok(&self.on_gpu()?.ctx)
    }

    /// The world's GPU side, created on first use.
    #[cfg(feature = "gpu")]
    pub(super) fn on_gpu(&mut self) -> Result<&mut crate::gpu::OnGpu, PhysicsError> {
        if self.gpu.is_none() {
            self.gpu = Some(crate::gpu::OnGpu::new()?);
        }
        Ok(self.gpu.as_mut().expect("just created"))
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
