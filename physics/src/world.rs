//! The world: particle systems, their forces and springs, the clock, and the
//! step.
//!
//! [`World::step`] reads top to bottom as named stages, each timed into a
//! [`StepProfile`]:
//!
//! 1. **prepare** — expire spent explosions, rebuild derived data.
//! 2. **systems** — per system, in handle order: interaction forces
//!    (**forces**), then the **integrate** pass (CPU), or the **gpu**
//!    dispatches.
//! 3. **quarantine** — report particles that went non-finite.
//! 4. **energy** — spring and mutual-gravity potential (kinetic and uniform
//!    gravity come free from the integrate pass).
//!
//! Every mutating call validates its input first and changes nothing when it
//! returns an error.

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;

use crate::arena::Arena;
use crate::energy::Energy;
use crate::error::{finite3, positive, PhysicsError};
use crate::forces::barnes_hut::Octree;
use crate::forces::mutual_gravity::exact_potential;
use crate::forces::{Force, ForceEntry, GravityMethod};
use crate::handle::{ForceHandle, ParticleHandle, SpringHandle, SystemHandle};
use crate::hash::StateHasher;
use crate::integrator::Integrator;
use crate::particle_system::{
    Backend, ParticleDesc, ParticleState, ParticleSystem, SystemDesc, FLAG_PINNED,
    FLAG_QUARANTINED, MAX_GROUPS,
};
use crate::profile::{ProfileTotals, StepProfile};
use crate::snapshot::{encode_world, load_world, save_world, SnapshotError};
use crate::spring::{Spring, SpringParams};
use crate::step::{fill_masses, step_system, ChunkOut, FLAG_NEW_QUARANTINE};

/// How a world runs. None of this is simulation state: a world saved with
/// one configuration restores and steps identically under another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WorldConfig {
    /// Worker threads for the step; 0 = rayon's global pool (one per core).
    /// Results are bit-identical for every count.
    pub threads: usize,
    /// Compute spring and mutual-gravity potential energy after every step
    /// (kinetic and uniform-gravity energy are always computed, for free).
    pub energy_accounting: bool,
    /// Read GPU systems back to the CPU mirror after every step (feature
    /// `gpu`); without it, call [`World::sync_gpu`] before reading them.
    pub gpu_readback_every_step: bool,
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self {
            threads: 0,
            energy_accounting: true,
            gpu_readback_every_step: true,
        }
    }
}

/// What one step did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepReport {
    /// The tick just completed (the world's tick count after the step).
    pub tick: u64,
    /// Simulation time after the step, s.
    pub time: f64,
    /// Particles that became non-finite during the step and were quarantined.
    pub quarantined: Vec<ParticleHandle>,
    /// Explosions whose front passed their max radius and were removed.
    pub expired_forces: Vec<ForceHandle>,
    /// World energy after the step.
    pub energy: Energy,
}

/// A physics world of particle systems.
pub struct World {
    config: WorldConfig,
    pool: Option<Arc<rayon::ThreadPool>>,
    tick: u64,
    time: f64,
    systems: Arena<ParticleSystem>,
    energy: Energy,
    profile: StepProfile,
    totals: ProfileTotals,
    #[cfg(feature = "gpu")]
    gpu: Option<crate::gpu::GpuContext>,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("config", &self.config)
            .field("tick", &self.tick)
            .field("time", &self.time)
            .field("systems", &self.systems.len())
            .finish()
    }
}

impl World {
    /// An empty world.
    pub fn new(config: WorldConfig) -> Result<Self, PhysicsError> {
        // One thread: run on the caller, no pool and no hand-off per step.
        let pool = if config.threads <= 1 {
            None
        } else {
            let p = rayon::ThreadPoolBuilder::new()
                .num_threads(config.threads)
                .build()
                .map_err(|e| PhysicsError::ThreadPool(e.to_string()))?;
            Some(Arc::new(p))
        };
        Ok(Self {
            config,
            pool,
            tick: 0,
            time: 0.0,
            systems: Arena::default(),
            energy: Energy::default(),
            profile: StepProfile::default(),
            totals: ProfileTotals::default(),
            #[cfg(feature = "gpu")]
            gpu: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// Ticks stepped so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Simulation time, s (the sum of every step's `dt`).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Stage timings of the last step.
    pub fn profile(&self) -> &StepProfile {
        &self.profile
    }

    /// Stage timings summed over every step so far.
    pub fn profile_totals(&self) -> &ProfileTotals {
        &self.totals
    }

    /// World energy after the last step (see [`WorldConfig::energy_accounting`]).
    pub fn energy(&self) -> Energy {
        self.energy
    }

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

    fn sys_mut(&mut self, h: SystemHandle) -> Result<&mut ParticleSystem, PhysicsError> {
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

    fn particle_mut(
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

    // ----- stepping -----

    /// Advances the world by `dt` seconds of simulation time.
    pub fn step(&mut self, dt: f64) -> Result<StepReport, PhysicsError> {
        positive("time step dt", dt)?;
        match self.pool.clone() {
            Some(pool) => pool.install(|| self.step_inner(dt)),
            None if self.config.threads == 1 => crate::parallel::sequential(|| self.step_inner(dt)),
            None => self.step_inner(dt),
        }
    }

    /// The step as named stages; each adds its wall time to the profile.
    fn step_inner(&mut self, dt: f64) -> Result<StepReport, PhysicsError> {
        let start = Instant::now();
        let mut profile = StepProfile::default();
        let mut report = StepReport::default();

        let t0 = Instant::now();
        self.stage_prepare(&mut report);
        profile.prepare = t0.elapsed();

        let mut energy = self.stage_systems(dt, &mut profile, &mut report)?;

        if self.config.energy_accounting {
            let t0 = Instant::now();
            self.stage_energy(&mut energy);
            profile.energy = t0.elapsed();
        }

        self.tick += 1;
        self.time += dt;
        self.energy = energy;
        profile.total = start.elapsed();
        self.profile = profile;
        self.totals.add(&profile);
        report.tick = self.tick;
        report.time = self.time;
        report.energy = energy;
        Ok(report)
    }

    /// Stage 1: explosions whose front has passed their max radius expire.
    /// (Spring adjacency and substep plans are refreshed per system in stage 2.)
    fn stage_prepare(&mut self, report: &mut StepReport) {
        let t = self.time;
        for (_, _, s) in self.systems.iter_mut() {
            let spent: Vec<(u32, u32)> = s
                .forces
                .iter()
                .filter(|(_, _, e)| matches!(e.force, Force::Explosion(x) if x.is_spent(t)))
                .map(|(i, g, _)| (i, g))
                .collect();
            for (index, generation) in spent {
                s.forces.remove(index, generation);
                report.expired_forces.push(ForceHandle {
                    system: s.handle,
                    index,
                    generation,
                });
            }
        }
    }

    /// Stage 2: every system, in handle order, on its backend. Returns the
    /// kinetic and uniform-gravity energy of the new state.
    fn stage_systems(
        &mut self,
        dt: f64,
        profile: &mut StepProfile,
        report: &mut StepReport,
    ) -> Result<Energy, PhysicsError> {
        let t = self.time;
        let mut energy = Energy::default();
        for (_, _, s) in self.systems.iter_mut() {
            match s.backend {
                Backend::Cpu => {
                    let (kinetic, gravity, quarantined) = step_cpu_system(s, t, dt, profile);
                    energy.kinetic += kinetic;
                    energy.gravity_uniform += gravity;
                    if quarantined {
                        let t0 = Instant::now();
                        collect_quarantined(s, &mut report.quarantined);
                        profile.quarantine += t0.elapsed();
                    }
                }
                Backend::Gpu => {
                    let t0 = Instant::now();
                    #[cfg(feature = "gpu")]
                    {
                        let ctx = self
                            .gpu
                            .as_ref()
                            .ok_or_else(|| PhysicsError::Gpu("no GPU context".into()))?;
                        let readback = self.config.gpu_readback_every_step;
                        let e = crate::gpu::step_system(ctx, s, t, dt, readback)?;
                        energy.kinetic += e.kinetic;
                        energy.gravity_uniform += e.gravity_uniform;
                        // Flags are only current after a readback.
                        if readback {
                            collect_quarantined(s, &mut report.quarantined);
                        }
                    }
                    profile.gpu += t0.elapsed();
                }
            }
        }
        Ok(energy)
    }

    /// Stage 4: spring and mutual-gravity potential energy.
    fn stage_energy(&mut self, energy: &mut Energy) {
        for (_, _, s) in self.systems.iter_mut() {
            let e = potential_energy(s);
            energy.spring += e.spring;
            energy.gravity_mutual += e.gravity_mutual;
        }
    }

    /// Computes the world's energy now (all terms, whatever the config).
    pub fn compute_energy(&mut self) -> Energy {
        let mut total = Energy::default();
        for (_, _, s) in self.systems.iter_mut() {
            let mut e = potential_energy(s);
            let field = crate::forces::FieldForces::compile(s, self.time, 1.0);
            for i in 0..s.len() {
                e.kinetic += 0.5 * s.velocity[i].length_squared() / s.inv_mass[i];
                e.gravity_uniform += field.gravity_potential(s.position[i], s.inv_mass[i]);
            }
            total = total.add(&e);
        }
        total
    }

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

    /// Copies every GPU system's state back into its CPU mirror.
    pub fn sync_gpu(&mut self) -> Result<(), PhysicsError> {
        #[cfg(feature = "gpu")]
        if let Some(ctx) = self.gpu.as_ref() {
            for (_, _, s) in self.systems.iter_mut() {
                if s.backend == Backend::Gpu {
                    crate::gpu::download(ctx, s)?;
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
    fn gpu_guard(&self, sys: SystemHandle) -> Result<(), PhysicsError> {
        match self.system(sys) {
            Some(s) if s.backend == Backend::Gpu => Err(PhysicsError::Gpu(
                "move the system back to the CPU backend before editing it".into(),
            )),
            _ => Ok(()),
        }
    }
}

/// Steps one CPU system by `dt` from `t` in its planned substeps. Returns
/// kinetic and uniform-gravity energy of the final state and whether any
/// particle was quarantined.
fn step_cpu_system(
    s: &mut ParticleSystem,
    t: f64,
    dt: f64,
    profile: &mut StepProfile,
) -> (f64, f64, bool) {
    let n = s.substeps_for(dt);
    let h = dt / f64::from(n);
    let mut scratch = std::mem::take(&mut s.scratch);
    let (mut last, mut quarantined) = (ChunkOut::default(), 0);
    for k in 0..n {
        let (out, times) = step_system(s, &mut scratch, t + f64::from(k) * h, h);
        profile.forces += Duration::from_secs_f64(times.forces);
        profile.integrate += Duration::from_secs_f64(times.integrate);
        quarantined += out.quarantined;
        last = out;
    }
    s.scratch = scratch;
    (last.kinetic, last.gravity, quarantined > 0)
}

/// Stage 3: reports (and clears the transient mark of) particles
/// quarantined during this step.
fn collect_quarantined(s: &mut ParticleSystem, out: &mut Vec<ParticleHandle>) {
    for (i, f) in s.flags.iter_mut().enumerate() {
        if *f & FLAG_NEW_QUARANTINE != 0 {
            *f &= !FLAG_NEW_QUARANTINE;
            let slot = s.dense_to_slot[i];
            out.push(ParticleHandle {
                system: s.handle,
                slot,
                generation: s.slots[slot as usize].generation,
            });
        }
    }
}

/// Spring and mutual-gravity potential of one system, J.
fn potential_energy(s: &mut ParticleSystem) -> Energy {
    let mut e = Energy::default();
    if s.springs.len() > 0 {
        s.refresh_topology();
        e.spring = s
            .topology
            .potential(&s.position, &s.flags, FLAG_QUARANTINED);
    }
    let gravities: Vec<_> = s
        .forces
        .iter()
        .filter_map(|(_, _, f)| match f.force {
            Force::MutualGravity(g) => Some(g),
            _ => None,
        })
        .collect();
    if !gravities.is_empty() {
        let mut mass = Vec::new();
        fill_masses(&s.inv_mass, &s.flags, &mut mass);
        for g in gravities {
            let eps2 = g.softening * g.softening;
            e.gravity_mutual +=
                match g.method {
                    GravityMethod::Exact => exact_potential(&s.position, &mass, g.g_constant, eps2),
                    GravityMethod::BarnesHut { theta } => Octree::build(&s.position, &mass)
                        .potential(&s.position, &mass, g.g_constant, eps2, theta),
                };
        }
    }
    e
}
