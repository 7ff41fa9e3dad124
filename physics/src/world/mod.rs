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
//! 3. **bodies** — rigid bodies move (gravity, damping, scripted forces,
//!    rotation); particles and bodies that went non-finite are reported.
//! 4. **soft** — soft bodies and fluids take their small steps against
//!    the bodies' new poses, and give the bodies their impulses back.
//! 5. **energy** — spring and mutual-gravity potential (kinetic and uniform
//!    gravity come free from the integrate pass).
//!
//! Every mutating call validates its input first and changes nothing when it
//! returns an error.

mod backend;
mod fluid;
mod joints;
mod particles;
mod pinning;
mod query;
mod query_index;
mod rigid;
mod soft;
mod state;

pub use pinning::ThreadPinning;
pub use query_index::QueryIndex;

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::arena::Arena;
use crate::energy::Energy;
use crate::error::{positive, PhysicsError};
use crate::forces::barnes_hut::Octree;
use crate::forces::mutual_gravity::exact_potential;
use crate::forces::{Force, GravityMethod};
use glam::DVec3;

use crate::handle::{BodyHandle, ForceHandle, ParticleHandle};
use crate::particle_system::step::{fill_masses, step_system, ChunkOut, FLAG_NEW_QUARANTINE};
use crate::particle_system::{Backend, ParticleSystem, FLAG_QUARANTINED};
use crate::profile::{ProfileTotals, StepProfile};
use crate::rigid::body::RigidBody;
use crate::rigid::forces::BodyField;
use crate::rigid::pipeline::{self, ContactEvent, ContactForceEvent, Contacts};
use crate::rigid::solver::SolverConfig;

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
    /// Most rigid bodies the world holds at once. Adding one more is
    /// refused ([`PhysicsError::TooManyBodies`]), and so is restoring a
    /// saved state that holds more. [`usize::MAX`] (the default): no limit.
    pub max_bodies: usize,
    /// Whether the world's own worker threads (`threads` ≥ 2) are pinned
    /// one to a core ([`ThreadPinning`]; by default where the process owns
    /// its cores).
    pub pin_threads: ThreadPinning,
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self {
            threads: 0,
            energy_accounting: true,
            gpu_readback_every_step: true,
            max_bodies: usize::MAX,
            pin_threads: ThreadPinning::Auto,
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
    /// Rigid bodies that became non-finite during the step and were quarantined.
    pub quarantined_bodies: Vec<BodyHandle>,
    /// Pairs of bodies that began or stopped touching (sensors: overlapping).
    pub contact_events: Vec<ContactEvent>,
    /// Pairs pressed together harder than a body's contact force threshold.
    pub contact_forces: Vec<ContactForceEvent>,
    /// Bodies that left the world bounds and were removed (their handles are now stale).
    pub removed_bodies: Vec<BodyHandle>,
    /// Joints that broke (force above their threshold) and were removed.
    pub broken_joints: Vec<crate::handle::JointHandle>,
    /// Explosions whose front passed their max radius and were removed.
    pub expired_forces: Vec<ForceHandle>,
    /// World energy after the step.
    pub energy: Energy,
    /// How the step's contact manifolds were found.
    pub manifolds: crate::rigid::contact::ManifoldCount,
    /// Fluids the GPU could not step against the bodies near them (a shape
    /// it does not handle, too many bodies), with why: each went back to
    /// the CPU and took this step there.
    pub fluids_to_cpu: Vec<(crate::handle::FluidHandle, PhysicsError)>,
    /// Soft bodies the GPU could not step against the bodies near them,
    /// with why: each went back to the CPU and took this step there.
    pub soft_bodies_to_cpu: Vec<(crate::handle::SoftBodyHandle, PhysicsError)>,
}

/// A physics world: particle systems and rigid bodies.
pub struct World {
    config: WorldConfig,
    pool: Option<Arc<rayon::ThreadPool>>,
    /// The core each worker of `pool` is pinned to, if pinned.
    pinned: Option<Vec<usize>>,
    tick: u64,
    time: f64,
    systems: Arena<ParticleSystem>,
    bodies: Arena<RigidBody>,
    /// Uniform gravity on everything: rigid bodies and particles (each
    /// scaled by its gravity scale), m/s².
    gravity: DVec3,
    /// Force generators acting on every rigid body.
    body_forces: Arena<crate::forces::ForceEntry>,
    /// Bodies whose centre leaves this box are removed and reported.
    body_bounds: Option<crate::rigid::aabb::Aabb>,
    /// Joints between bodies.
    joints: Arena<crate::rigid::joint::Joint>,
    /// Springs from particles to bodies.
    attachments: Arena<crate::rigid::attachment::Attachment>,
    /// Forces and torques on bodies from attachments this step (derived).
    attachment_loads: std::collections::BTreeMap<BodyHandle, (DVec3, DVec3)>,
    /// Soft bodies (XPBD).
    soft_bodies: Arena<crate::xpbd::soft::SoftBody>,
    /// Fluids (position-based fluids).
    fluids: Arena<crate::xpbd::fluid::Fluid>,
    /// Where the bodies stood as this step began, for the soft stage
    /// (derived, per step).
    step_start: crate::xpbd::coupling::StepStart,
    /// Contact solver settings (state: they change the motion).
    solver: SolverConfig,
    /// Warm-start cache and broad phase.
    contacts: Contacts,
    energy: Energy,
    /// The bodies' kinetic and uniform-gravity energy, J, with the bodies'
    /// revision and the gravity they were worked out for (derived: a world
    /// at rest reuses them instead of visiting every body).
    body_energy: Option<(crate::arena::Revision, DVec3, (f64, f64))>,
    profile: StepProfile,
    totals: ProfileTotals,
    /// What of the world lives on the GPU (created on first use).
    #[cfg(feature = "gpu")]
    gpu: Option<crate::gpu::OnGpu>,
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
        let (pool, pinned) = if config.threads <= 1 {
            (None, None)
        } else {
            let pinned = pinning::plan(
                config.pin_threads,
                config.threads,
                pinning::allowed_cores().as_deref(),
            );
            let cores = pinned.clone();
            let p = rayon::ThreadPoolBuilder::new()
                .num_threads(config.threads)
                .start_handler(move |k| {
                    if let Some(core) = cores.as_ref().and_then(|c| c.get(k)) {
                        // A core the OS refuses leaves the thread where it
                        // may run: placement, never results.
                        pinning::pin_current_thread(*core);
                    }
                })
                .build()
                .map_err(|e| PhysicsError::ThreadPool(e.to_string()))?;
            (Some(Arc::new(p)), pinned)
        };
        Ok(Self {
            config,
            pool,
            pinned,
            tick: 0,
            time: 0.0,
            systems: Arena::default(),
            bodies: Arena::default(),
            gravity: DVec3::ZERO,
            body_forces: Arena::default(),
            body_bounds: None,
            joints: Arena::default(),
            attachments: Arena::default(),
            attachment_loads: Default::default(),
            soft_bodies: Arena::default(),
            fluids: Arena::default(),
            step_start: Default::default(),
            solver: SolverConfig::default(),
            contacts: Contacts::default(),
            body_energy: None,
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

    /// The core each of the world's worker threads was pinned to
    /// ([`WorldConfig::pin_threads`]), in worker order; `None` if they were
    /// not pinned. A core the OS refused is listed all the same.
    pub fn pinned_cores(&self) -> Option<&[usize]> {
        self.pinned.as_deref()
    }

    /// Sets [`WorldConfig::max_bodies`]; refused
    /// ([`PhysicsError::TooManyBodies`], nothing changed) when the world
    /// already holds more rigid bodies than `max`.
    pub fn set_max_bodies(&mut self, max: usize) -> Result<(), PhysicsError> {
        if self.bodies.len() > max {
            return Err(PhysicsError::TooManyBodies { max });
        }
        self.config.max_bodies = max;
        Ok(())
    }

    /// Ticks stepped so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Simulation time, s (the sum of every step's `dt`).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Sets the world's uniform gravity, m/s², once for everything in it:
    /// every rigid body (times its [gravity scale](crate::rigid::body::RigidBodyDesc::gravity_scale))
    /// and every particle of every system, ropes and cloth included (times
    /// the system's [`SystemDesc::gravity_scale`](crate::SystemDesc::gravity_scale)).
    /// A system's own [`UniformGravity`](crate::forces::UniformGravity)
    /// forces add to it. Zero until set; refused if not finite.
    ///
    /// ```
    /// use inertia_physics::glam::DVec3;
    /// use inertia_physics::{World, WorldConfig};
    ///
    /// let mut world = World::new(WorldConfig::default())?;
    /// world.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
    /// assert_eq!(world.gravity().y, -9.81);
    /// assert!(world.set_gravity(DVec3::new(f64::NAN, 0.0, 0.0)).is_err());
    /// assert_eq!(world.gravity().y, -9.81, "a refused value changes nothing");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn set_gravity(&mut self, gravity: DVec3) -> Result<(), PhysicsError> {
        self.gravity = crate::error::finite3("gravity", gravity)?;
        Ok(())
    }

    /// The world's uniform gravity, m/s².
    pub fn gravity(&self) -> DVec3 {
        self.gravity
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

        self.stage_attachments();
        let mut energy = self.stage_systems(dt, &mut profile, &mut report)?;

        let t0 = Instant::now();
        if self.soft_bodies.len() + self.fluids.len() > 0 {
            self.step_start.record(&self.bodies, dt);
        }
        profile.rigid = self.stage_bodies(dt, &mut energy, &mut report);
        // Particles that collide with bodies are kept out of them.
        let t1 = Instant::now();
        for (_, _, s) in self.systems.iter_mut() {
            if s.backend == Backend::Cpu {
                crate::particle_contact::resolve(s, &mut self.bodies);
            }
        }
        profile.rigid.particle_contacts = t1.elapsed();
        profile.bodies = t0.elapsed();

        let t0 = Instant::now();
        self.stage_soft(dt, &mut energy, &mut report)?;
        profile.soft = t0.elapsed();

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
        #[cfg_attr(not(feature = "gpu"), allow(unused_variables))]
        for (index, generation, s) in self.systems.iter_mut() {
            match s.backend {
                Backend::Cpu => {
                    let (kinetic, gravity, quarantined) =
                        step_cpu_system(s, self.gravity, t, dt, profile);
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
                        let on_gpu = self
                            .gpu
                            .as_mut()
                            .ok_or_else(|| PhysicsError::Gpu("no GPU context".into()))?;
                        let buffers =
                            on_gpu
                                .systems
                                .get_mut(&(index, generation))
                                .ok_or_else(|| {
                                    PhysicsError::Gpu(
                                        "the system was never uploaded to the GPU".into(),
                                    )
                                })?;
                        let readback = self.config.gpu_readback_every_step;
                        let e = crate::gpu::step_system(
                            &on_gpu.ctx,
                            s,
                            buffers,
                            self.gravity,
                            t,
                            dt,
                            readback,
                        )?;
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

    /// Stage 3: rigid bodies: contacts found and solved in substeps with
    /// gravity, force generators, damping and gyroscopic rotation (see
    /// [`crate::rigid::pipeline`]). A body whose new state would not be
    /// finite is quarantined: left where it was, at rest, and reported.
    fn stage_bodies(
        &mut self,
        dt: f64,
        energy: &mut Energy,
        report: &mut StepReport,
    ) -> crate::profile::RigidProfile {
        let field = BodyField::compile(
            self.body_forces.iter().map(|(_, _, e)| &e.force),
            self.time,
            dt,
        );
        let g = self.gravity + field.gravity;
        let inputs = pipeline::StepInputs {
            field: &field,
            gravity: g,
            cfg: &self.solver,
            extra: &self.attachment_loads,
            dt,
        };
        let out = pipeline::step(
            &mut self.bodies,
            &mut self.joints,
            &mut self.contacts,
            inputs,
        );
        report.broken_joints = out.broken_joints.clone();
        report.quarantined_bodies = out.quarantined;
        report.contact_events = out.events;
        report.contact_forces = out.forces;
        report.manifolds = out.manifolds;
        if let Some(bounds) = self.body_bounds {
            let gone: Vec<BodyHandle> = self
                .bodies
                .iter()
                .filter(|(_, _, b)| {
                    b.kind != crate::rigid::body::BodyKind::Static && !bounds.contains_point(b.com)
                })
                .map(|(index, generation, _)| BodyHandle { index, generation })
                .collect();
            for h in &gone {
                self.bodies.remove(h.index, h.generation);
                self.contacts.forget(*h);
                self.joints.retain(|j| j.desc.a != *h && j.desc.b != *h);
            }
            report.removed_bodies = gone;
        }
        let revision = self.bodies.revision();
        let (kinetic, potential) = match self.body_energy {
            Some((r, g0, e)) if r == revision && g0 == g => e,
            _ => {
                let mut e = (0.0, 0.0);
                for (_, _, b) in self.bodies.iter() {
                    e.0 += b.kinetic_energy();
                    if b.inv_mass > 0.0 {
                        e.1 -= (g * b.gravity_scale).dot(b.com) / b.inv_mass;
                    }
                }
                self.body_energy = Some((revision, g, e));
                e
            }
        };
        energy.kinetic += kinetic;
        energy.gravity_uniform += potential;
        out.profile
    }

    /// Before the systems step: the force of every particle–body spring,
    /// from both states now, for the particle (its system's interaction
    /// forces) and the opposite load on the body (the rigid step). Springs
    /// whose particle or body is gone are dropped.
    fn stage_attachments(&mut self) {
        for (_, _, s) in self.systems.iter_mut() {
            s.coupling.clear();
        }
        self.attachment_loads.clear();
        if self.attachments.len() == 0 {
            return;
        }
        let mut dead = Vec::new();
        for (index, generation, a) in self.attachments.iter() {
            let body = self.bodies.get(a.body.index, a.body.generation);
            let sys = self
                .systems
                .get_mut(a.particle.system.index, a.particle.system.generation);
            let (Some(body), Some(sys)) = (body, sys) else {
                dead.push((index, generation));
                continue;
            };
            let Some(i) = sys.dense_index(a.particle) else {
                dead.push((index, generation));
                continue;
            };
            if sys.backend != Backend::Cpu {
                continue;
            }
            let anchor = body.pose().transform_point(a.anchor);
            let f = a.force(
                sys.position[i],
                sys.velocity[i],
                anchor,
                body.velocity_at(anchor),
            );
            if !f.is_finite() {
                continue;
            }
            sys.coupling.push((i as u32, f));
            let load = self.attachment_loads.entry(a.body).or_default();
            load.0 -= f;
            load.1 -= (anchor - body.com).cross(f);
        }
        for (index, generation) in dead {
            self.attachments.remove(index, generation);
        }
        // A body on a spring to particles is kept awake: the particles can
        // move it at any time.
        for h in self.attachment_loads.keys() {
            if let Some(b) = self.bodies.get_mut(h.index, h.generation) {
                b.wake();
            }
        }
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
            let field = s.field_forces(self.gravity, self.time, 1.0);
            for i in 0..s.len() {
                e.kinetic += 0.5 * s.velocity[i].length_squared() / s.inv_mass[i];
                e.gravity_uniform += field.gravity_potential(s.position[i], s.inv_mass[i]);
            }
            total = total.add(&e);
        }
        total
    }
}

/// Steps one CPU system by `dt` from `t` in its planned substeps, under the
/// world's `gravity` (m/s²). Returns kinetic and uniform-gravity energy of
/// the final state and whether any particle was quarantined.
fn step_cpu_system(
    s: &mut ParticleSystem,
    gravity: DVec3,
    t: f64,
    dt: f64,
    profile: &mut StepProfile,
) -> (f64, f64, bool) {
    let n = s.substeps_for(dt);
    let h = dt / f64::from(n);
    let mut scratch = std::mem::take(&mut s.scratch);
    let (mut last, mut quarantined) = (ChunkOut::default(), 0);
    for k in 0..n {
        let (out, times) = step_system(s, &mut scratch, gravity, t + f64::from(k) * h, h);
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
