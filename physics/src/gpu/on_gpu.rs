//! What of a world lives on the GPU: the context, the soft-body and fluid
//! pipelines compiled on it, and the buffers of every particle system,
//! soft body and fluid that steps there.
//!
//! The world holds one (`World::gpu`, created on first use); the systems,
//! soft bodies and fluids themselves know nothing of the GPU beyond their
//! `backend`. Their buffers are found here by the arena slot (index,
//! generation) of their handle, so a removed one's buffers go with it and a
//! slot reused by another never finds them.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::error::PhysicsError;

use super::buffers::GpuSystem;
use super::context::GpuContext;
use super::fluid::{FluidPipelines, GpuFluid};
use super::soft::{GpuSoftBody, SoftPipelines};

/// An arena slot: a handle's index and generation.
type HandleSlot = (u32, u32);

/// A world's GPU side.
pub(crate) struct OnGpu {
    pub(crate) ctx: GpuContext,
    /// Soft bodies' pipelines (`gpu/soft.rs`); `None` on an adapter that
    /// binds too few storage buffers per shader.
    pub(crate) soft_pipelines: Option<SoftPipelines>,
    /// Fluids' pipelines (`gpu/fluid.rs`); `None` on an adapter that binds
    /// too few storage buffers per shader.
    pub(crate) fluid_pipelines: Option<FluidPipelines>,
    /// The particle systems on the GPU, by slot.
    pub(crate) systems: BTreeMap<HandleSlot, GpuSystem>,
    /// The soft bodies on the GPU, by slot (shared with a step in flight
    /// that uploads a body again).
    pub(crate) soft_bodies: BTreeMap<HandleSlot, Arc<GpuSoftBody>>,
    /// The fluids on the GPU, by slot.
    pub(crate) fluids: BTreeMap<HandleSlot, Arc<GpuFluid>>,
}

impl std::fmt::Debug for OnGpu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnGpu")
            .field("ctx", &self.ctx)
            .field("systems", &self.systems.len())
            .field("soft_bodies", &self.soft_bodies.len())
            .field("fluids", &self.fluids.len())
            .finish_non_exhaustive()
    }
}

impl OnGpu {
    /// Opens an adapter ([`GpuContext::new`]) and compiles the soft-body
    /// and fluid pipelines on it.
    pub(crate) fn new() -> Result<Self, PhysicsError> {
        let ctx = GpuContext::new()?;
        let (soft_pipelines, fluid_pipelines) =
            ctx.scoped("compiling the soft-body and fluid shaders", || {
                Ok((
                    SoftPipelines::new(&ctx.device),
                    FluidPipelines::new(&ctx.device),
                ))
            })?;
        Ok(Self {
            ctx,
            soft_pipelines,
            fluid_pipelines,
            systems: BTreeMap::new(),
            soft_bodies: BTreeMap::new(),
            fluids: BTreeMap::new(),
        })
    }

    /// Forgets every soft body's and fluid's buffers (a restored state
    /// steps them on the CPU) and every particle system's (a restored state
    /// uploads its GPU systems again).
    pub(crate) fn forget_all(&mut self) {
        self.systems.clear();
        self.soft_bodies.clear();
        self.fluids.clear();
    }
}
