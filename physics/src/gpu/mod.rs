//! GPU stepping of particle systems through wgpu compute (feature `gpu`).
//! Contract used by `World` (see world.rs); implementation in progress.

use crate::energy::Energy;
use crate::error::PhysicsError;
use crate::particle_system::ParticleSystem;

/// The wgpu device and compiled pipelines, shared by every GPU system.
#[derive(Debug)]
pub struct GpuContext {
    _private: (),
}

impl GpuContext {
    /// Opens an adapter and compiles the pipelines.
    pub fn new() -> Result<Self, PhysicsError> {
        Err(PhysicsError::Gpu("not built yet".into()))
    }
}

/// GPU buffers of one particle system.
#[derive(Debug, Clone)]
pub(crate) struct GpuSystem {}

/// Uploads `sys` to GPU buffers (stored in `sys.gpu`).
pub(crate) fn upload(_ctx: &GpuContext, _sys: &mut ParticleSystem) -> Result<(), PhysicsError> {
    Err(PhysicsError::Gpu("not built yet".into()))
}

/// Reads positions and velocities back into `sys`'s CPU arrays.
pub(crate) fn download(_ctx: &GpuContext, _sys: &mut ParticleSystem) -> Result<(), PhysicsError> {
    Err(PhysicsError::Gpu("not built yet".into()))
}

/// Steps one GPU system by `dt` from time `t`.
pub(crate) fn step_system(
    _ctx: &GpuContext,
    _sys: &mut ParticleSystem,
    _t: f64,
    _dt: f64,
    _readback: bool,
) -> Result<Energy, PhysicsError> {
    Err(PhysicsError::Gpu("not built yet".into()))
}
