//! The particle-system half of the `World` API: systems, particles,
//! springs and force generators. Every method validates before it changes
//! anything.

use glam::DVec3;

use super::World;
use crate::error::{finite3, PhysicsError};
use crate::forces::{Force, ForceEntry};
use crate::handle::{ForceHandle, ParticleHandle, SpringHandle, SystemHandle};
use crate::integrator::Integrator;
use crate::particle_system::{
    ParticleDesc, ParticleState, ParticleSystem, SystemDesc, FLAG_PINNED, FLAG_QUARANTINED,
    MAX_GROUPS,
};
use crate::spring::{Spring, SpringParams};

impl World {
    // ----- systems -----

    /// Adds an empty particle system.
    pub fn add_system(&mut self, desc: SystemDesc) -> SystemHandle {
        let (index, generation) = self.systems.insert(ParticleSystem::new(
            SystemHandle {
                index: 0,
                generation: 0,
            },
            desc,
        ));
        let h = SystemHandle { index, generation };
        self.systems
            .get_mut(index, generation)
            .expect("just inserted")
            .handle = h;
        h
    }

    /// Removes a system with all its particles, springs and forces.
    pub fn remove_system(&mut self, h: SystemHandle) -> Result<(), PhysicsError> {
        #[cfg(feature = "gpu")]
        if let Some(on_gpu) = self.gpu.as_mut() {
            on_gpu.systems.remove(&(h.index, h.generation));
        }
        self.systems
            .remove(h.index, h.generation)
            .map(|_| ())
            .ok_or(PhysicsError::UnknownSystem(h))
    }

    /// A system, or `None` for a stale handle.
    pub fn system(&self, h: SystemHandle) -> Option<&ParticleSystem> {
        self.systems.get(h.index, h.generation)
    }

    /// All systems in handle order.
    pub fn systems(&self) -> impl Iterator<Item = &ParticleSystem> {
        self.systems.iter().map(|(_, _, s)| s)
    }

    /// How many substeps a world step of `dt` seconds takes for system `h`
    /// (see [`SystemDesc::max_substeps`]); 0 for a stale handle.
    pub fn substeps_for(&mut self, h: SystemHandle, dt: f64) -> u32 {
        self.systems
            .get_mut(h.index, h.generation)
            .map_or(0, |s| s.substeps_for(dt))
    }

    pub(super) fn sys_mut(&mut self, h: SystemHandle) -> Result<&mut ParticleSystem, PhysicsError> {
        self.systems
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownSystem(h))
    }

    /// Changes a system's integrator. Switching to Verlet primes its history
    /// from the current velocities on the next step.
    pub fn set_integrator(
        &mut self,
        h: SystemHandle,
        integrator: Integrator,
    ) -> Result<(), PhysicsError> {
        let s = self.sys_mut(h)?;
        if s.integrator != integrator {
            s.integrator = integrator;
            s.prev_position.clear();
            s.verlet_dt = 0.0;
        }
        Ok(())
    }

    // ----- particles -----

    /// Adds a particle; refuses non-finite values, non-positive mass, negative
    /// coefficients and out-of-range groups.
    pub fn add_particle(
        &mut self,
        sys: SystemHandle,
        desc: ParticleDesc,
    ) -> Result<ParticleHandle, PhysicsError> {
        let inv = desc.validate()?;
        self.gpu_guard(sys)?;
        Ok(self.sys_mut(sys)?.push(&desc, inv))
    }

    /// Adds many particles; all or nothing.
    pub fn add_particles(
        &mut self,
        sys: SystemHandle,
        descs: &[ParticleDesc],
    ) -> Result<Vec<ParticleHandle>, PhysicsError> {
        let invs = descs
            .iter()
            .map(ParticleDesc::validate)
            .collect::<Result<Vec<_>, _>>()?;
        self.gpu_guard(sys)?;
        let s = self.sys_mut(sys)?;
        Ok(descs
            .iter()
            .zip(invs)
            .map(|(d, inv)| s.push(d, inv))
            .collect())
    }

    /// Removes a particle and every spring attached to it.
    pub fn remove_particle(&mut self, h: ParticleHandle) -> Result<(), PhysicsError> {
        self.gpu_guard(h.system)?;
        let s = self.sys_mut(h.system)?;
        let i = s.dense_index(h).ok_or(PhysicsError::UnknownParticle(h))?;
        s.springs.retain(|sp| sp.a != h.slot && sp.b != h.slot);
        s.swap_remove(i);
        Ok(())
    }

    /// A particle's state, or `None` for a stale handle.
    pub fn particle(&self, h: ParticleHandle) -> Option<ParticleState> {
        self.system(h.system)?.particle(h)
    }

    pub(super) fn particle_mut(
        &mut self,
        h: ParticleHandle,
    ) -> Result<(&mut ParticleSystem, usize), PhysicsError> {
        self.gpu_guard(h.system)?;
        let s = self.sys_mut(h.system)?;
        let i = s.dense_index(h).ok_or(PhysicsError::UnknownParticle(h))?;
        Ok((s, i))
    }

    /// Teleports a particle, m.
    pub fn set_position(&mut self, h: ParticleHandle, position: DVec3) -> Result<(), PhysicsError> {
        finite3("particle position", position)?;
        let (s, i) = self.particle_mut(h)?;
        s.position[i] = position;
        if !s.prev_position.is_empty() {
            s.prev_position[i] = position - s.velocity[i] * s.verlet_dt;
        }
        Ok(())
    }

    /// Sets a particle's velocity, m/s (ignored for pinned particles, which stay at rest).
    pub fn set_velocity(&mut self, h: ParticleHandle, velocity: DVec3) -> Result<(), PhysicsError> {
        finite3("particle velocity", velocity)?;
        let (s, i) = self.particle_mut(h)?;
        if s.flags[i] & FLAG_PINNED == 0 {
            s.velocity[i] = velocity;
            if !s.prev_position.is_empty() {
                s.prev_position[i] = s.position[i] - velocity * s.verlet_dt;
            }
        }
        Ok(())
    }

    /// Pins (or releases) a particle: a pinned particle never moves but still
    /// anchors springs and attracts others.
    pub fn set_pinned(&mut self, h: ParticleHandle, pinned: bool) -> Result<(), PhysicsError> {
        let (s, i) = self.particle_mut(h)?;
        s.topology.dirty = true;
        if pinned {
            s.flags[i] |= FLAG_PINNED;
            s.velocity[i] = DVec3::ZERO;
            if !s.prev_position.is_empty() {
                s.prev_position[i] = s.position[i];
            }
        } else {
            s.flags[i] &= !FLAG_PINNED;
        }
        Ok(())
    }

    /// Sets the scripted control force on one particle, N (stays until changed).
    pub fn set_control_force(
        &mut self,
        h: ParticleHandle,
        force: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("control force", force)?;
        let (s, i) = self.particle_mut(h)?;
        s.ensure_control();
        s.control[i] = force;
        Ok(())
    }

    /// Sets the scripted control force on every particle of `group`, N.
    pub fn set_group_control(
        &mut self,
        sys: SystemHandle,
        group: u32,
        force: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("group control force", force)?;
        if group >= MAX_GROUPS {
            return Err(PhysicsError::GroupOutOfRange(group));
        }
        self.gpu_guard(sys)?;
        let s = self.sys_mut(sys)?;
        if s.group_control.len() <= group as usize {
            s.group_control.resize(group as usize + 1, DVec3::ZERO);
        }
        s.group_control[group as usize] = force;
        Ok(())
    }

    /// Releases a quarantined particle at a new, finite state.
    pub fn release_quarantine(
        &mut self,
        h: ParticleHandle,
        position: DVec3,
        velocity: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("particle position", position)?;
        finite3("particle velocity", velocity)?;
        let (s, i) = self.particle_mut(h)?;
        s.flags[i] &= !FLAG_QUARANTINED;
        s.position[i] = position;
        s.velocity[i] = velocity;
        if !s.prev_position.is_empty() {
            s.prev_position[i] = position - velocity * s.verlet_dt;
        }
        Ok(())
    }

    // ----- springs -----

    /// Joins two particles of one system with a damped Hooke spring.
    pub fn add_spring(
        &mut self,
        a: ParticleHandle,
        b: ParticleHandle,
        params: SpringParams,
    ) -> Result<SpringHandle, PhysicsError> {
        params.validate()?;
        if a.system != b.system {
            return Err(PhysicsError::DifferentSystems(a, b));
        }
        if a == b {
            return Err(PhysicsError::DegenerateSpring(
                "both ends are the same particle",
            ));
        }
        self.gpu_guard(a.system)?;
        let s = self.sys_mut(a.system)?;
        s.dense_index(a).ok_or(PhysicsError::UnknownParticle(a))?;
        s.dense_index(b).ok_or(PhysicsError::UnknownParticle(b))?;
        let (index, generation) = s.springs.insert(Spring {
            a: a.slot,
            b: b.slot,
            params,
        });
        s.topology.dirty = true;
        Ok(SpringHandle {
            system: a.system,
            index,
            generation,
        })
    }

    /// Removes a spring.
    pub fn remove_spring(&mut self, h: SpringHandle) -> Result<(), PhysicsError> {
        self.gpu_guard(h.system)?;
        let s = self.sys_mut(h.system)?;
        s.springs
            .remove(h.index, h.generation)
            .ok_or(PhysicsError::UnknownSpring(h))?;
        s.topology.dirty = true;
        Ok(())
    }

    /// A spring's parameters and endpoints, or `None` for a stale handle.
    pub fn spring(
        &self,
        h: SpringHandle,
    ) -> Option<(ParticleHandle, ParticleHandle, SpringParams)> {
        let s = self.system(h.system)?;
        let sp = s.springs.get(h.index, h.generation)?;
        let ph = |slot: u32| ParticleHandle {
            system: h.system,
            slot,
            generation: s.slots[slot as usize].generation,
        };
        Some((ph(sp.a), ph(sp.b), sp.params))
    }

    // ----- forces -----

    /// Attaches a force generator to a system.
    pub fn add_force(
        &mut self,
        sys: SystemHandle,
        force: impl Into<Force>,
    ) -> Result<ForceHandle, PhysicsError> {
        let force = force.into();
        force.validate()?;
        let s = self.sys_mut(sys)?;
        let (index, generation) = s.forces.insert(ForceEntry { force });
        Ok(ForceHandle {
            system: sys,
            index,
            generation,
        })
    }

    /// Replaces a force generator's parameters (e.g. a changing wind).
    pub fn set_force(
        &mut self,
        h: ForceHandle,
        force: impl Into<Force>,
    ) -> Result<(), PhysicsError> {
        let force = force.into();
        force.validate()?;
        let s = self.sys_mut(h.system)?;
        let e = s
            .forces
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownForce(h))?;
        e.force = force;
        Ok(())
    }

    /// Detaches a force generator.
    pub fn remove_force(&mut self, h: ForceHandle) -> Result<(), PhysicsError> {
        let s = self.sys_mut(h.system)?;
        s.forces
            .remove(h.index, h.generation)
            .map(|_| ())
            .ok_or(PhysicsError::UnknownForce(h))
    }

    /// A force generator, or `None` for a stale handle.
    pub fn force(&self, h: ForceHandle) -> Option<Force> {
        Some(
            self.system(h.system)?
                .forces
                .get(h.index, h.generation)?
                .force,
        )
    }
}
