//! Structure-of-arrays storage for one particle system.
//!
//! Each attribute is its own dense array indexed by a *dense index*; the
//! integration pass streams through them in order, which is what lets a
//! million-particle step run at memory bandwidth. Particles are addressed from
//! outside through a slot table (`slot -> dense index`) with generations, so
//! removing a particle (a swap-remove in every array) never invalidates the
//! handles of the others, and a stale handle is detected.

use glam::DVec3;

use crate::arena::Arena;
use crate::error::{finite3, non_negative, PhysicsError};
use crate::forces::{FieldForces, ForceEntry};
use crate::handle::{ParticleHandle, SystemHandle};
use crate::integrator::Integrator;
use crate::spring::{Spring, SpringTopology};

pub(crate) mod step;

/// Per-particle flag: the particle never moves (infinite effective mass).
pub const FLAG_PINNED: u32 = 1;
/// Per-particle flag: the particle became non-finite during a step and is
/// frozen, excluded from every force, until released.
pub const FLAG_QUARANTINED: u32 = 2;

/// The highest group id plus one that [`ParticleDesc::group`] accepts.
pub const MAX_GROUPS: u32 = 4096;

/// Where a particle system is stepped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// On the CPU, in `f64`, in parallel with rayon.
    #[default]
    Cpu,
    /// On the GPU through wgpu compute, in `f32` (feature `gpu`).
    Gpu,
}

/// Everything needed to create one particle. Units are SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleDesc {
    /// Position, m.
    pub position: DVec3,
    /// Velocity, m/s.
    pub velocity: DVec3,
    /// Mass, kg. Must be finite and > 0.
    pub mass: f64,
    /// Linear drag coefficient `b`, kg/s: force `-b v`.
    pub drag_linear: f64,
    /// Quadratic drag coefficient `c`, kg/m: force `-c |v| v`.
    pub drag_quadratic: f64,
    /// Area exposed to wind and blast pressure, m².
    pub area: f64,
    /// Volume, m³, for buoyancy (the particle is treated as a sphere of this volume).
    pub volume: f64,
    /// Group id for group control forces, `0..MAX_GROUPS`.
    pub group: u32,
    /// Whether the particle is pinned in place.
    pub pinned: bool,
}

impl Default for ParticleDesc {
    fn default() -> Self {
        Self {
            position: DVec3::ZERO,
            velocity: DVec3::ZERO,
            mass: 1.0,
            drag_linear: 0.0,
            drag_quadratic: 0.0,
            area: 0.0,
            volume: 0.0,
            group: 0,
            pinned: false,
        }
    }
}

impl ParticleDesc {
    /// A particle of `mass` kg at `position` m, at rest.
    pub fn at(position: DVec3, mass: f64) -> Self {
        Self {
            position,
            mass,
            ..Self::default()
        }
    }

    /// Sets the initial velocity, m/s.
    pub fn with_velocity(mut self, velocity: DVec3) -> Self {
        self.velocity = velocity;
        self
    }

    /// Checks every field; returns the inverse mass.
    pub(crate) fn validate(&self) -> Result<f64, PhysicsError> {
        finite3("particle position", self.position)?;
        finite3("particle velocity", self.velocity)?;
        if !(self.mass.is_finite() && self.mass > 0.0) {
            return Err(PhysicsError::NonPositiveMass(self.mass));
        }
        let inv = 1.0 / self.mass;
        if !inv.is_finite() {
            return Err(PhysicsError::NonPositiveMass(self.mass));
        }
        non_negative("linear drag coefficient", self.drag_linear)?;
        non_negative("quadratic drag coefficient", self.drag_quadratic)?;
        non_negative("particle area", self.area)?;
        non_negative("particle volume", self.volume)?;
        if self.group >= MAX_GROUPS {
            return Err(PhysicsError::GroupOutOfRange(self.group));
        }
        Ok(inv)
    }
}

/// How a new particle system is set up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SystemDesc {
    /// The integration method.
    pub integrator: Integrator,
    /// Most substeps one world step may be cut into to keep stiff springs
    /// stable (1 = never substep). An explicit step of a spring network is
    /// stable while `ω dt < 2` (symplectic methods); the system splits `dt`
    /// so that `ω_max h <= 1`, a margin of two, where `ω_max` is bounded from
    /// the springs' stiffness and the particles' masses. If even this many
    /// substeps are not enough, the springs are softened for the step just
    /// enough to stay stable (see `ParticleSystem::spring_stiffness_scale`).
    /// Default 16.
    pub max_substeps: u32,
    /// Radius with which the particles collide with rigid bodies, m; 0 = they
    /// pass through bodies (see `particle_contact`).
    pub collision_radius: f64,
    /// Friction coefficient of particles sliding on bodies.
    pub collision_friction: f64,
    /// Multiplies the world's gravity ([`crate::World::set_gravity`]) on
    /// this system's particles: 1 (the default) for particles that fall
    /// like everything else, 0 for those that feel only the system's own
    /// forces, negative for smoke that rises. A value that is not finite is
    /// taken as 1.
    pub gravity_scale: f64,
}

impl Default for SystemDesc {
    fn default() -> Self {
        Self {
            integrator: Integrator::default(),
            max_substeps: 16,
            collision_radius: 0.0,
            collision_friction: 0.3,
            gravity_scale: 1.0,
        }
    }
}

impl SystemDesc {
    /// Default settings with the given integrator.
    pub fn with_integrator(integrator: Integrator) -> Self {
        Self {
            integrator,
            ..Self::default()
        }
    }
}

/// Maps a handle's slot to a dense index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Slot {
    pub(crate) generation: u32,
    /// Dense index, or `u32::MAX` when the slot is free.
    pub(crate) dense: u32,
}

pub(crate) const FREE: u32 = u32::MAX;

/// One particle system: its particles (SoA), springs, forces and integrator.
#[derive(Debug, Clone)]
pub struct ParticleSystem {
    pub(crate) handle: SystemHandle,
    pub(crate) integrator: Integrator,
    pub(crate) backend: Backend,
    pub(crate) max_substeps: u32,
    /// Collision radius against rigid bodies, m (0 = off), and friction.
    pub(crate) collision_radius: f64,
    pub(crate) collision_friction: f64,
    /// Multiplies the world's gravity on these particles.
    pub(crate) gravity_scale: f64,

    // --- hot data, one entry per particle, dense ---
    /// Positions, m.
    pub(crate) position: Vec<DVec3>,
    /// Velocities, m/s.
    pub(crate) velocity: Vec<DVec3>,
    /// Previous positions, m; only kept (same length as `position`) under Verlet.
    pub(crate) prev_position: Vec<DVec3>,
    /// Inverse masses, 1/kg.
    pub(crate) inv_mass: Vec<f64>,
    /// Linear drag coefficients, kg/s.
    pub(crate) drag_linear: Vec<f64>,
    /// Quadratic drag coefficients, kg/m.
    pub(crate) drag_quadratic: Vec<f64>,
    /// Exposed areas, m².
    pub(crate) area: Vec<f64>,
    /// Volumes, m³.
    pub(crate) volume: Vec<f64>,
    /// `FLAG_*` bits.
    pub(crate) flags: Vec<u32>,
    /// Group ids.
    pub(crate) group: Vec<u32>,
    /// Per-particle scripted control force, N; kept only once `control_active`.
    pub(crate) control: Vec<DVec3>,
    /// Whether any per-particle control force has been set.
    pub(crate) control_active: bool,

    // --- bookkeeping ---
    pub(crate) slots: Vec<Slot>,
    pub(crate) dense_to_slot: Vec<u32>,
    pub(crate) free_slots: Vec<u32>,
    /// Scripted control force per group, N; index = group id; empty until first set.
    pub(crate) group_control: Vec<DVec3>,
    pub(crate) springs: Arena<Spring>,
    pub(crate) forces: Arena<ForceEntry>,
    /// The time step the Verlet history was built for, s; 0 = history not primed.
    pub(crate) verlet_dt: f64,

    // --- derived, rebuilt on demand, not part of the state ---
    pub(crate) topology: SpringTopology,
    pub(crate) scratch: step::Scratch,
    /// Forces from attachments to rigid bodies for this step: (dense index,
    /// force in N). Derived at the start of each step, not state.
    pub(crate) coupling: Vec<(u32, DVec3)>,
}

/// A read-only copy of one particle's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleState {
    /// Position, m.
    pub position: DVec3,
    /// Velocity, m/s.
    pub velocity: DVec3,
    /// Mass, kg.
    pub mass: f64,
    /// Whether pinned.
    pub pinned: bool,
    /// Whether quarantined after becoming non-finite.
    pub quarantined: bool,
    /// Group id.
    pub group: u32,
}

impl ParticleSystem {
    /// The field forces on this system over the step `[t, t + dt]` (s):
    /// its own forces, and the world's uniform `gravity` (m/s²) scaled by
    /// its gravity scale.
    pub(crate) fn field_forces(&self, gravity: DVec3, t: f64, dt: f64) -> FieldForces {
        FieldForces::compile(
            self.forces.iter().map(|(_, _, e)| &e.force),
            gravity * self.gravity_scale,
            t,
            dt,
        )
    }

    pub(crate) fn new(handle: SystemHandle, desc: SystemDesc) -> Self {
        Self {
            handle,
            integrator: desc.integrator,
            backend: Backend::Cpu,
            max_substeps: desc.max_substeps.max(1),
            collision_radius: if desc.collision_radius.is_finite() {
                desc.collision_radius.max(0.0)
            } else {
                0.0
            },
            collision_friction: if desc.collision_friction.is_finite() {
                desc.collision_friction.max(0.0)
            } else {
                0.0
            },
            gravity_scale: if desc.gravity_scale.is_finite() {
                desc.gravity_scale
            } else {
                1.0
            },
            position: Vec::new(),
            velocity: Vec::new(),
            prev_position: Vec::new(),
            inv_mass: Vec::new(),
            drag_linear: Vec::new(),
            drag_quadratic: Vec::new(),
            area: Vec::new(),
            volume: Vec::new(),
            flags: Vec::new(),
            group: Vec::new(),
            control: Vec::new(),
            control_active: false,
            slots: Vec::new(),
            dense_to_slot: Vec::new(),
            free_slots: Vec::new(),
            group_control: Vec::new(),
            springs: Arena::default(),
            forces: Arena::default(),
            verlet_dt: 0.0,
            topology: SpringTopology::default(),
            scratch: Default::default(),
            coupling: Vec::new(),
        }
    }

    /// This system's handle.
    pub fn handle(&self) -> SystemHandle {
        self.handle
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// Whether the system has no particles.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// The integration method.
    pub fn integrator(&self) -> Integrator {
        self.integrator
    }

    /// Where this system is stepped.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Positions in dense order, m. For a GPU system: as of the last sync.
    pub fn positions(&self) -> &[DVec3] {
        &self.position
    }

    /// Velocities in dense order, m/s. For a GPU system: as of the last sync.
    pub fn velocities(&self) -> &[DVec3] {
        &self.velocity
    }

    /// Inverse masses in dense order, 1/kg.
    pub fn inverse_masses(&self) -> &[f64] {
        &self.inv_mass
    }

    /// Flags (`FLAG_*`) in dense order.
    pub fn flags(&self) -> &[u32] {
        &self.flags
    }

    /// Number of springs.
    pub fn spring_count(&self) -> usize {
        self.springs.len()
    }

    /// Handles of all particles, in dense order.
    pub fn particle_handles(&self) -> impl Iterator<Item = ParticleHandle> + '_ {
        self.dense_to_slot.iter().map(move |&slot| ParticleHandle {
            system: self.handle,
            slot,
            generation: self.slots[slot as usize].generation,
        })
    }

    /// Dense index of a live particle, or `None` for a stale handle.
    pub fn dense_index(&self, h: ParticleHandle) -> Option<usize> {
        if h.system != self.handle {
            return None;
        }
        let slot = self.slots.get(h.slot as usize)?;
        (slot.generation == h.generation && slot.dense != FREE).then_some(slot.dense as usize)
    }

    /// The state of one particle, or `None` for a stale handle.
    pub fn particle(&self, h: ParticleHandle) -> Option<ParticleState> {
        let i = self.dense_index(h)?;
        Some(ParticleState {
            position: self.position[i],
            velocity: self.velocity[i],
            mass: 1.0 / self.inv_mass[i],
            pinned: self.flags[i] & FLAG_PINNED != 0,
            quarantined: self.flags[i] & FLAG_QUARANTINED != 0,
            group: self.group[i],
        })
    }

    /// Appends a validated particle; returns its handle.
    pub(crate) fn push(&mut self, desc: &ParticleDesc, inv_mass: f64) -> ParticleHandle {
        let dense = self.position.len() as u32;
        let slot = match self.free_slots.pop() {
            Some(s) => {
                self.slots[s as usize].dense = dense;
                s
            }
            None => {
                self.slots.push(Slot {
                    generation: 0,
                    dense,
                });
                (self.slots.len() - 1) as u32
            }
        };
        let velocity = if desc.pinned {
            DVec3::ZERO
        } else {
            desc.velocity
        };
        self.position.push(desc.position);
        self.velocity.push(velocity);
        if self.integrator == Integrator::Verlet {
            self.prev_position
                .push(desc.position - velocity * self.verlet_dt);
        }
        self.inv_mass.push(inv_mass);
        self.drag_linear.push(desc.drag_linear);
        self.drag_quadratic.push(desc.drag_quadratic);
        self.area.push(desc.area);
        self.volume.push(desc.volume);
        self.flags.push(if desc.pinned { FLAG_PINNED } else { 0 });
        self.group.push(desc.group);
        if self.control_active {
            self.control.push(DVec3::ZERO);
        }
        self.dense_to_slot.push(slot);
        self.topology.dirty = true;
        ParticleHandle {
            system: self.handle,
            slot,
            generation: self.slots[slot as usize].generation,
        }
    }

    /// Swap-removes the particle at dense index `i` from every array.
    pub(crate) fn swap_remove(&mut self, i: usize) {
        let slot = self.dense_to_slot[i];
        self.position.swap_remove(i);
        self.velocity.swap_remove(i);
        if !self.prev_position.is_empty() {
            self.prev_position.swap_remove(i);
        }
        self.inv_mass.swap_remove(i);
        self.drag_linear.swap_remove(i);
        self.drag_quadratic.swap_remove(i);
        self.area.swap_remove(i);
        self.volume.swap_remove(i);
        self.flags.swap_remove(i);
        self.group.swap_remove(i);
        if self.control_active {
            self.control.swap_remove(i);
        }
        self.dense_to_slot.swap_remove(i);
        if i < self.dense_to_slot.len() {
            let moved = self.dense_to_slot[i];
            self.slots[moved as usize].dense = i as u32;
        }
        let s = &mut self.slots[slot as usize];
        s.dense = FREE;
        s.generation = s.generation.wrapping_add(1);
        self.free_slots.push(slot);
        self.topology.dirty = true;
    }

    /// Makes sure the per-particle control array exists.
    pub(crate) fn ensure_control(&mut self) {
        if !self.control_active {
            self.control = vec![DVec3::ZERO; self.len()];
            self.control_active = true;
        }
    }

    /// Rebuilds the spring adjacency and stability bound if anything changed.
    pub(crate) fn refresh_topology(&mut self) {
        if self.topology.dirty {
            let (slots, flags) = (&self.slots, &self.flags);
            self.topology.rebuild(
                self.springs.iter().map(|(_, _, s)| s),
                |slot| slots[slot as usize].dense,
                &self.inv_mass,
                |i| flags[i] & (FLAG_PINNED | FLAG_QUARANTINED) == 0,
            );
        }
    }

    /// Substeps a world step of `dt` seconds is cut into for this system.
    pub fn substeps_for(&mut self, dt: f64) -> u32 {
        self.refresh_topology();
        if self.topology.is_empty() {
            1
        } else {
            self.topology.plan(dt, self.max_substeps)
        }
    }

    /// The factor applied to spring stiffness in the last planned step: 1
    /// unless the springs were too stiff for `max_substeps` and were softened
    /// to stay stable.
    pub fn spring_stiffness_scale(&self) -> f64 {
        if self.topology.is_empty() {
            1.0
        } else {
            self.topology.stiffness_scale
        }
    }

    /// Most substeps per world step (see [`SystemDesc::max_substeps`]).
    pub fn max_substeps(&self) -> u32 {
        self.max_substeps
    }

    /// Number of particles flagged quarantined.
    pub fn quarantined_count(&self) -> usize {
        self.flags
            .iter()
            .filter(|&&f| f & FLAG_QUARANTINED != 0)
            .count()
    }
}
