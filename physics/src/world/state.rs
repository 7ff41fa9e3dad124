//! Whole-world state: the hash, save and restore.

use super::World;
use crate::error::PhysicsError;
use crate::particle_system::Backend;
use crate::saved_state::hash::StateHasher;
use crate::saved_state::{encode_world, load_world, save_world, SavedStateError, StateRef};
use crate::world::WorldConfig;

impl World {
    fn state_ref(&self) -> StateRef<'_> {
        StateRef {
            tick: self.tick,
            time: self.time,
            systems: &self.systems,
            bodies: &self.bodies,
            gravity: self.gravity,
            body_forces: &self.body_forces,
            solver: &self.solver,
            contacts: &self.contacts.cache,
            touching: &self.contacts.touching,
            body_bounds: self.body_bounds,
            joints: &self.joints,
            attachments: &self.attachments,
            soft_bodies: &self.soft_bodies,
            fluids: &self.fluids,
        }
    }

    // ----- state -----

    /// 64-bit hash over the bit patterns of the whole state (what `save` writes).
    /// GPU systems are read from their CPU mirror: with
    /// [`WorldConfig::gpu_readback_every_step`] off, call [`World::sync_gpu`] first.
    pub fn state_hash(&self) -> u64 {
        let mut h = StateHasher::default();
        encode_world(&mut h, &self.state_ref());
        h.finish()
    }

    /// The complete state as compact bytes (see [`crate::saved_state`]).
    /// GPU systems are saved from their CPU mirror: with
    /// [`WorldConfig::gpu_readback_every_step`] off, call [`World::sync_gpu`] first.
    pub fn save(&self) -> Vec<u8> {
        save_world(&self.state_ref())
    }

    /// Replaces the whole state with a saved one. On error the world is untouched.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), SavedStateError> {
        let decoded = load_world(bytes)?;
        if decoded.bodies.len() > self.config.max_bodies {
            return Err(SavedStateError::Invalid(format!(
                "the state holds {} rigid bodies, more than this world's limit of {}",
                decoded.bodies.len(),
                self.config.max_bodies
            )));
        }
        #[cfg(feature = "gpu")]
        let mut decoded = decoded;
        #[cfg(feature = "gpu")]
        if decoded
            .systems
            .iter()
            .any(|(_, _, s)| s.backend == Backend::Gpu)
        {
            let on_gpu = self
                .on_gpu()
                .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
            let mut uploaded = std::collections::BTreeMap::new();
            for (index, generation, s) in decoded.systems.iter_mut() {
                if s.backend == Backend::Gpu {
                    let buffers = crate::gpu::upload(&on_gpu.ctx, s)
                        .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
                    uploaded.insert((index, generation), buffers);
                }
            }
            on_gpu.forget_all();
            on_gpu.systems = uploaded;
        } else if let Some(on_gpu) = self.gpu.as_mut() {
            on_gpu.forget_all();
        }
        #[cfg(not(feature = "gpu"))]
        if decoded
            .systems
            .iter()
            .any(|(_, _, s)| s.backend == Backend::Gpu)
        {
            return Err(SavedStateError::Invalid(
                "state has GPU systems but this build has no `gpu` feature".into(),
            ));
        }
        self.tick = decoded.tick;
        self.time = decoded.time;
        self.systems = decoded.systems;
        self.bodies = decoded.bodies;
        self.gravity = decoded.gravity;
        self.body_forces = decoded.body_forces;
        self.solver = decoded.solver;
        self.contacts.cache = decoded.contacts.into();
        self.contacts.touching = decoded.touching;
        self.body_bounds = decoded.body_bounds;
        self.joints = decoded.joints;
        self.attachments = decoded.attachments;
        self.soft_bodies = decoded.soft_bodies;
        self.fluids = decoded.fluids;
        self.contacts.reset_broad_phase();
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
