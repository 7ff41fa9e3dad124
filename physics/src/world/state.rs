//! Whole-world state: the hash, save and restore.

use super::World;
use crate::error::PhysicsError;
use crate::hash::StateHasher;
use crate::particle_system::Backend;
use crate::snapshot::{encode_world, load_world, save_world, SnapshotError};
use crate::world::WorldConfig;

impl World {
    // ----- state -----

    /// 64-bit hash over the bit patterns of the whole state (what `save` writes).
    /// GPU systems are read from their CPU mirror: with
    /// [`WorldConfig::gpu_readback_every_step`] off, call [`World::sync_gpu`] first.
    pub fn state_hash(&self) -> u64 {
        let mut h = StateHasher::default();
        encode_world(&mut h, self.tick, self.time, &self.systems);
        h.finish()
    }

    /// The complete state as compact bytes (see [`crate::snapshot`]).
    /// GPU systems are saved from their CPU mirror: with
    /// [`WorldConfig::gpu_readback_every_step`] off, call [`World::sync_gpu`] first.
    pub fn save(&self) -> Vec<u8> {
        save_world(self.tick, self.time, &self.systems)
    }

    /// Replaces the whole state with a saved one. On error the world is untouched.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), SnapshotError> {
        let decoded = load_world(bytes)?;
        #[cfg(feature = "gpu")]
        let mut decoded = decoded;
        #[cfg(feature = "gpu")]
        if decoded
            .systems
            .iter()
            .any(|(_, _, s)| s.backend == Backend::Gpu)
        {
            let ctx = self
                .gpu_context()
                .map_err(|e| SnapshotError::Invalid(e.to_string()))?;
            for (_, _, s) in decoded.systems.iter_mut() {
                if s.backend == Backend::Gpu {
                    crate::gpu::upload(ctx, s)
                        .map_err(|e| SnapshotError::Invalid(e.to_string()))?;
                }
            }
        }
        #[cfg(not(feature = "gpu"))]
        if decoded
            .systems
            .iter()
            .any(|(_, _, s)| s.backend == Backend::Gpu)
        {
            return Err(SnapshotError::Invalid(
                "state has GPU systems but this build has no `gpu` feature".into(),
            ));
        }
        self.tick = decoded.tick;
        self.time = decoded.time;
        self.systems = decoded.systems;
        Ok(())
    }

    /// A new world from a saved state.
    pub fn from_saved(config: WorldConfig, bytes: &[u8]) -> Result<Self, PhysicsError> {
        let mut w = World::new(config)?;
        w.restore(bytes).map_err(|e| PhysicsError::Invalid {
            what: "saved state",
            why: e.to_string(),
        })?;
        Ok(w)
    }
}
