//! Position-based fluids (Macklin & Müller, "Position Based Fluids",
//! SIGGRAPH 2013) on small steps (Macklin et al., "Small Steps in Physics
//! Simulation", SCA 2019), on the CPU.
//!
//! A fluid is a set of particles, each standing for a cube of fluid of edge
//! `spacing` (its volume `V = spacing³`, its mass `ρ0 V`). Every particle
//! carries one constraint on the density its kernel finds,
//! `C_i = ρ_i / ρ0 − 1`, kept only where it is positive (the fluid resists
//! compression but never pulls, so the free surface does not clump). Walls
//! and floating bodies are the world's rigid bodies, seen through
//! the coupling (`xpbd::coupling`): they add to a particle's
//! density as solid fluid would (see `boundary`), keep the particles out of
//! them with friction, and a dynamic one shares each push with them.
//!
//! The stepping is in `step`; [`FluidDesc`] describes a fluid and
//! [`Fluid`] holds one.

pub(crate) mod boundary;
pub(crate) mod emitter;
pub(crate) mod kernels;
mod step;
#[cfg(test)]
mod tests;

use glam::{DVec3, Vec3};

use crate::error::{finite, finite3, non_negative, positive, PhysicsError};
use crate::limits;
use crate::rigid::aabb::Aabb;

use super::coupling::Push;
use super::grid::{Grid, Neighbours};
use boundary::WallTable;
use kernels::Kernels;

pub use emitter::{EmitterState, FluidEmitter, MAX_FLUID_EMITTERS, MAX_NOZZLE_PARTICLES};

/// Most particles one fluid may ever hold (its neighbour lists index them
/// with 32 bits and count their pairs in 32 bits).
pub const MAX_FLUID_PARTICLES: usize = 1 << 24;

/// Most substeps a step may be cut into.
pub const MAX_FLUID_SUBSTEPS: u32 = 64;

/// The cap on particles a [`FluidDesc`] starts with, unless it holds more.
pub const DEFAULT_MAX_FLUID_PARTICLES: usize = 1 << 18;

/// Particles per parallel work item of the fluid's passes: small enough
/// that ten thousand particles keep two threads evenly busy.
pub(crate) const CHUNK: usize = 1024;

/// A fluid to build: its particles, their size and the material.
#[derive(Debug, Clone, PartialEq)]
pub struct FluidDesc {
    /// Distance between neighbouring particles at rest, m. Each particle
    /// stands for `spacing³` of fluid and weighs `rest_density · spacing³`.
    pub spacing: f64,
    /// Kernel (smoothing) radius h, m, between `spacing` (exclusive) and
    /// `4 · spacing`; `None` takes `2 · spacing` (about 32 neighbours).
    pub kernel_radius: Option<f64>,
    /// Density of the fluid at rest, kg/m³ (water: 1000).
    pub rest_density: f64,
    /// Where the particles start, m.
    pub positions: Vec<DVec3>,
    /// Their starting velocities, m/s: one per position, or empty for a
    /// fluid at rest.
    pub velocities: Vec<DVec3>,
    /// Substeps per step, 1 to [`MAX_FLUID_SUBSTEPS`] (default 4): each
    /// predicts, projects the density constraints once and derives the
    /// velocities. More substeps compress less under gravity.
    pub substeps: u32,
    /// XSPH viscosity `c`, 0 to 1 (default 0.01): each step a particle's
    /// velocity moves by `c` towards the kernel-weighted mean of its
    /// neighbours'.
    pub viscosity: f64,
    /// Vorticity confinement `ε`, m/s (default 0, off): the acceleration
    /// `ε (N × ω)` that feeds back the swirl (`ω`, 1/s) damping loses.
    pub vorticity: f64,
    /// Tensile correction strength `k`, in units of `h²` of the constraint
    /// multiplier (the paper's `k = 0.1`): a short-range repulsion
    /// `k (W(r) / W(Δq))ⁿ` that keeps particles from pairing. Default 0,
    /// off: the density constraint here is one-sided and never pulls, so
    /// particles do not clump, and the term, a push applied every substep,
    /// lifts the free surface more the more substeps a step takes.
    pub tensile_k: f64,
    /// Tensile correction exponent `n`, 1 to 16 (default 4).
    pub tensile_n: u32,
    /// Tensile correction reference distance `Δq` as a fraction of the
    /// kernel radius, in (0, 1) (default 0.2).
    pub tensile_dq: f64,
    /// Constraint relaxation `ε` (the constraint force mixing term of the
    /// paper's `λ_i = −C_i / (Σ |∇C_i|² + ε)`), in units of `1/h²` (so the
    /// paper's 600 at `h = 0.1` would be 6), ≥ 0. Default 1.5: about
    /// `Σ |∇C_i|²` itself, which one Jacobi iteration a substep needs to
    /// stay stable (see the step's notes); larger values soften the fluid.
    pub relaxation: f64,
    /// Multiplies the world's gravity for the fluid (default 1).
    pub gravity_scale: f64,
    /// How far particles are kept from rigid surfaces, m, at most the
    /// kernel radius; `None` takes `spacing / 2`.
    pub collision_radius: Option<f64>,
    /// Coulomb friction of the particles on rigid surfaces, ≥ 0 (default
    /// 0; a pair takes the larger of this and the body's).
    pub friction: f64,
    /// Most particles the fluid may hold, emitters included: 1 to
    /// [`MAX_FLUID_PARTICLES`].
    pub max_particles: usize,
}

impl FluidDesc {
    /// A fluid of water-like defaults with no particles yet, `spacing` m
    /// apart.
    pub fn new(spacing: f64) -> Self {
        Self {
            spacing,
            kernel_radius: None,
            rest_density: 1000.0,
            positions: Vec::new(),
            velocities: Vec::new(),
            substeps: 4,
            viscosity: 0.01,
            vorticity: 0.0,
            tensile_k: 0.0,
            tensile_n: 4,
            tensile_dq: 0.2,
            relaxation: 1.5,
            gravity_scale: 1.0,
            collision_radius: None,
            friction: 0.0,
            max_particles: DEFAULT_MAX_FLUID_PARTICLES,
        }
    }

    /// A box from `min` to `max` (m) filled with particles at rest on a
    /// cubic lattice `spacing` m apart, the outer ones half a spacing in
    /// from the faces (so the particles' cubes tile the box). The cap is
    /// raised to the particle count if need be.
    pub fn block(min: DVec3, max: DVec3, spacing: f64) -> Result<Self, PhysicsError> {
        finite3("fluid block corner", min)?;
        finite3("fluid block corner", max)?;
        limits::position("fluid block corner (m)", min)?;
        limits::position("fluid block corner (m)", max)?;
        positive("fluid particle spacing", spacing)?;
        let size = max - min;
        let mut counts = [0usize; 3];
        let mut total = 1usize;
        for a in 0..3 {
            let n = (size[a] / spacing + 1e-6).floor();
            if n.is_nan() || n < 1.0 {
                return Err(PhysicsError::Invalid {
                    what: "fluid block",
                    why: format!(
                        "the box {min} to {max} holds no particle {spacing} m apart along axis {a}"
                    ),
                });
            }
            if n > MAX_FLUID_PARTICLES as f64 {
                total = usize::MAX;
                break;
            }
            counts[a] = n as usize;
            total = total.saturating_mul(counts[a]);
        }
        if total > MAX_FLUID_PARTICLES {
            return Err(PhysicsError::Invalid {
                what: "fluid block",
                why: format!(
                    "the box {min} to {max} at {spacing} m spacing holds more than {MAX_FLUID_PARTICLES} particles"
                ),
            });
        }
        let mut positions = Vec::with_capacity(total);
        for k in 0..counts[2] {
            for j in 0..counts[1] {
                for i in 0..counts[0] {
                    let at = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
                    positions.push(min + at * spacing);
                }
            }
        }
        let mut desc = Self::new(spacing);
        desc.max_particles = desc.max_particles.max(total);
        desc.positions = positions;
        Ok(desc)
    }

    /// The kernel radius h, m.
    pub fn kernel_radius(&self) -> f64 {
        self.kernel_radius.unwrap_or(2.0 * self.spacing)
    }

    /// The collision radius, m.
    pub fn collision_radius(&self) -> f64 {
        self.collision_radius.unwrap_or(0.5 * self.spacing)
    }

    /// Checks every field; the first problem found is returned.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        positive("fluid particle spacing", self.spacing)?;
        limits::length("fluid particle spacing (m)", self.spacing)?;
        let h = self.kernel_radius();
        positive("fluid kernel radius", h)?;
        if !(h > self.spacing && h <= 4.0 * self.spacing) {
            return Err(PhysicsError::Invalid {
                what: "fluid kernel radius",
                why: format!(
                    "must be above the spacing {} m and at most 4 times it, got {h} m",
                    self.spacing
                ),
            });
        }
        positive("fluid rest density", self.rest_density)?;
        limits::density(self.rest_density)?;
        if self.substeps == 0 {
            return Err(PhysicsError::NotPositive {
                what: "fluid substeps",
                value: 0.0,
            });
        }
        limits::in_range(
            "fluid substeps",
            f64::from(self.substeps),
            1.0,
            f64::from(MAX_FLUID_SUBSTEPS),
        )?;
        non_negative("fluid viscosity", self.viscosity)?;
        limits::in_range("fluid viscosity", self.viscosity, 0.0, 1.0)?;
        non_negative("fluid vorticity confinement", self.vorticity)?;
        non_negative("fluid tensile correction k", self.tensile_k)?;
        if self.tensile_n == 0 {
            return Err(PhysicsError::NotPositive {
                what: "fluid tensile correction exponent",
                value: 0.0,
            });
        }
        limits::in_range(
            "fluid tensile correction exponent",
            f64::from(self.tensile_n),
            1.0,
            16.0,
        )?;
        positive("fluid tensile correction distance", self.tensile_dq)?;
        if self.tensile_dq >= 1.0 {
            return Err(PhysicsError::Invalid {
                what: "fluid tensile correction distance",
                why: format!(
                    "a fraction of the kernel radius below 1, got {}",
                    self.tensile_dq
                ),
            });
        }
        non_negative("fluid relaxation", self.relaxation)?;
        finite("fluid gravity scale", self.gravity_scale)?;
        let radius = self.collision_radius();
        non_negative("fluid collision radius", radius)?;
        if radius > h {
            return Err(PhysicsError::Invalid {
                what: "fluid collision radius",
                why: format!("at most the kernel radius {h} m, got {radius} m"),
            });
        }
        non_negative("fluid friction", self.friction)?;
        if self.max_particles == 0 {
            return Err(PhysicsError::NotPositive {
                what: "fluid particle cap",
                value: 0.0,
            });
        }
        if self.max_particles > MAX_FLUID_PARTICLES {
            return Err(PhysicsError::OutOfRange {
                what: "fluid particle cap",
                value: self.max_particles as f64,
                min: 1.0,
                max: MAX_FLUID_PARTICLES as f64,
            });
        }
        check_particles(&self.positions, &self.velocities, 0, self.max_particles)
    }
}

/// Checks particles to add to a fluid of `held` particles capped at `max`.
fn check_particles(
    positions: &[DVec3],
    velocities: &[DVec3],
    held: usize,
    max: usize,
) -> Result<(), PhysicsError> {
    if held.saturating_add(positions.len()) > max {
        return Err(PhysicsError::Invalid {
            what: "fluid particles",
            why: format!(
                "{} more particles on {held} exceed the cap of {max}",
                positions.len()
            ),
        });
    }
    if !velocities.is_empty() && velocities.len() != positions.len() {
        return Err(PhysicsError::Invalid {
            what: "fluid particle velocities",
            why: format!(
                "one per position or none, got {} for {} positions",
                velocities.len(),
                positions.len()
            ),
        });
    }
    for &p in positions {
        finite3("fluid particle position", p)?;
        limits::position("fluid particle position (m)", p)?;
    }
    for &v in velocities {
        finite3("fluid particle velocity", v)?;
        limits::in_range(
            "fluid particle speed (m/s)",
            v.length(),
            0.0,
            limits::MAX_SPEED,
        )?;
    }
    Ok(())
}

/// One chunk's scratch: the walls its particles touched this substep and
/// what they gave the bodies this step.
#[derive(Debug, Default)]
pub(crate) struct ChunkScratch {
    /// Walls within a kernel radius of the chunk's particles, in particle
    /// order.
    contacts: Vec<WallContact>,
    /// Per coupling target: what the chunk's particles pushed it with in
    /// this substep.
    pushes: Vec<Push>,
    /// `dW_spiky/dr / r` of every pair in the chunk's neighbour lists, in
    /// their order, from the density pass for the correction pass, 1/m⁵.
    pair: Vec<f32>,
    /// Per particle of the chunk, a lower bound on its distance to every
    /// body (the kernel radius when no surface is nearer), m.
    gap: Vec<f32>,
    /// The surfaces near the chunk's particles over this step, in particle
    /// order.
    planes: Vec<WallPlane>,
}

/// The surface of a body near a particle over one step, as a plane: the
/// tangent plane at the surface point nearest the particle at the start of
/// the step, carried along with the body within the stage.
#[derive(Debug, Clone, Copy)]
struct WallPlane {
    particle: u32,
    /// Index into the coupling's targets.
    target: u32,
    /// A point of the plane, m, in the body's frame
    /// ([`Coupling::to_body`](crate::xpbd::coupling::Coupling::to_body)).
    point: DVec3,
    /// The plane's normal, out of the body, in the body's frame.
    normal: DVec3,
    /// Whether the whole body lies behind the plane (a convex body and a
    /// particle outside it), so that the particle's distance from the
    /// plane bounds its distance from the body.
    bounds: bool,
}

/// A wall within a kernel radius of a particle, over one substep.
#[derive(Debug, Clone, Copy)]
struct WallContact {
    particle: u32,
    /// Index into the coupling's targets.
    target: u32,
    /// The nearest surface point, m.
    point: DVec3,
    /// The outward unit normal.
    normal: Vec3,
    /// `Φ(d)`: the share of the kernel in the wall's half-space.
    phi: f32,
    /// `Ψ(d)`, 1/m: spiky's gradient along the normal over the half-space.
    psi: f32,
    /// The wall's part of the particle's constraint gradient, 1/m (see
    /// [`step`]'s union of walls).
    grad: Vec3,
}

/// A body of fluid: its particles and the scratch its steps reuse.
#[derive(Debug)]
pub struct Fluid {
    /// Positions, m, in the order the particles were made.
    pub(crate) x: Vec<Vec3>,
    /// Velocities, m/s.
    pub(crate) v: Vec<Vec3>,
    /// Positions at the start of the substep, m.
    pub(crate) prev: Vec<Vec3>,
    /// Scratch: predicted or corrected positions, new velocities.
    pub(crate) next: Vec<Vec3>,
    /// Constraint multipliers of the last substep, m².
    pub(crate) lambda: Vec<f32>,
    /// Densities found at the last substep, kg/m³.
    pub(crate) density: Vec<f32>,
    /// Vorticity, 1/s.
    pub(crate) omega: Vec<Vec3>,
    /// Every particle's inverse mass, 1/kg (for the coupling).
    pub(crate) inv_mass: Vec<f32>,
    pub(crate) grid: Grid,
    pub(crate) neighbours: Neighbours,
    pub(crate) chunks: Vec<ChunkScratch>,

    spacing: f32,
    rest_density: f32,
    mass: f32,
    /// The volume a neighbour weighs in kernel sums, m³: `spacing³`
    /// divided by the lattice sum, so a particle at rest in a cubic lattice
    /// `spacing` m apart reads exactly the rest density (the plain sum
    /// reads 1 % high at `h = 2 spacing`, and a block made at `spacing`
    /// would burst apart at its first step).
    volume: f32,
    kernels: Kernels,
    wall: WallTable,
    substeps: u32,
    viscosity: f32,
    vorticity: f32,
    tensile_k: f32,
    tensile_n: i32,
    /// `1 / W_poly6(Δq)`, m³.
    tensile_inv_w: f32,
    /// Relaxation in 1/m², `ε / h²`.
    relaxation: f32,
    gravity_scale: f32,
    collision_radius: f32,
    friction: f32,
    max_particles: usize,
    /// The description it was made from, without its particles (what a
    /// saved state keeps).
    params: FluidDesc,
    /// Its emitters, in the order they were added (each fires its shots
    /// in turn at the end of a step).
    pub(crate) emitters: Vec<EmitterState>,
    /// Where it steps: the CPU, or the GPU (`gpu/fluid.rs`) with these
    /// arrays as the mirror that readbacks fill.
    pub(crate) backend: crate::particle_system::Backend,
}

/// The numbers a step of a fluid uses, for the GPU path (`gpu/fluid.rs`),
/// which takes the same step.
#[cfg(feature = "gpu")]
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepConstants {
    pub(crate) kernels: Kernels,
    /// Particle spacing, m.
    pub(crate) spacing: f32,
    /// Rest density, kg/m³.
    pub(crate) rest_density: f32,
    /// A particle's mass, kg.
    pub(crate) mass: f32,
    /// The weight of a neighbour in kernel sums, m³.
    pub(crate) volume: f32,
    pub(crate) substeps: u32,
    /// XSPH `c`.
    pub(crate) viscosity: f32,
    /// Vorticity confinement `ε`, m/s.
    pub(crate) vorticity: f32,
    /// Tensile correction `k` (units of h²), exponent and `1 / W_poly6(Δq)` (m³).
    pub(crate) tensile_k: f32,
    pub(crate) tensile_n: u32,
    pub(crate) tensile_inv_w: f32,
    /// Relaxation `ε`, 1/m².
    pub(crate) relaxation: f32,
    pub(crate) gravity_scale: f32,
    /// Collision radius, m.
    pub(crate) collision_radius: f32,
    pub(crate) friction: f32,
    /// Largest correction a substep, in spacings.
    pub(crate) max_correction: f32,
}

impl Fluid {
    /// Builds the fluid `desc` describes, or says why not (and builds
    /// nothing).
    pub fn new(desc: FluidDesc) -> Result<Fluid, PhysicsError> {
        desc.validate()?;
        let h = desc.kernel_radius() as f32;
        let kernels = Kernels::new(h);
        let spacing = desc.spacing as f32;
        let cube = spacing * spacing * spacing;
        let rest_density = desc.rest_density as f32;
        let mass = rest_density * cube;
        let lattice = kernels.lattice_sum(spacing);
        let volume = if lattice > 0.0 {
            (f64::from(cube) / lattice) as f32
        } else {
            cube
        };
        let dq = desc.tensile_dq as f32 * h;
        let w_dq = kernels.poly6(dq * dq);
        let n = desc.positions.len();
        let mut wall = WallTable::new(h);
        wall.calibrate(&kernels, spacing, volume);
        let mut fluid = Fluid {
            x: Vec::with_capacity(n),
            v: Vec::with_capacity(n),
            prev: Vec::new(),
            next: Vec::new(),
            lambda: Vec::new(),
            density: Vec::new(),
            omega: Vec::new(),
            inv_mass: Vec::new(),
            grid: Grid::default(),
            neighbours: Neighbours::default(),
            chunks: Vec::new(),
            spacing,
            rest_density,
            mass,
            volume,
            kernels,
            wall,
            substeps: desc.substeps,
            viscosity: desc.viscosity as f32,
            vorticity: desc.vorticity as f32,
            tensile_k: desc.tensile_k as f32,
            tensile_n: desc.tensile_n as i32,
            tensile_inv_w: if w_dq > 0.0 { 1.0 / w_dq } else { 0.0 },
            relaxation: desc.relaxation as f32 / (h * h),
            gravity_scale: desc.gravity_scale as f32,
            collision_radius: desc.collision_radius() as f32,
            friction: desc.friction as f32,
            max_particles: desc.max_particles,
            params: FluidDesc {
                positions: Vec::new(),
                velocities: Vec::new(),
                ..desc.clone()
            },
            emitters: Vec::new(),
            backend: crate::particle_system::Backend::Cpu,
        };
        fluid.push(&desc.positions, &desc.velocities);
        Ok(fluid)
    }

    /// Appends checked particles.
    fn push(&mut self, positions: &[DVec3], velocities: &[DVec3]) {
        self.x.extend(positions.iter().map(|p| p.as_vec3()));
        if velocities.is_empty() {
            self.v.extend(positions.iter().map(|_| Vec3::ZERO));
        } else {
            self.v.extend(velocities.iter().map(|v| v.as_vec3()));
        }
        self.density.resize(self.x.len(), 0.0);
        self.inv_mass.resize(self.x.len(), 1.0 / self.mass);
    }

    /// Emits particles at `positions` (m) with `velocities` (m/s; one per
    /// position, or empty for at rest). All or nothing: refused, adding
    /// none, if any is bad or they would take the fluid past its cap.
    /// New particles report a density of 0 until the next step.
    pub fn add_particles(
        &mut self,
        positions: &[DVec3],
        velocities: &[DVec3],
    ) -> Result<(), PhysicsError> {
        check_particles(positions, velocities, self.x.len(), self.max_particles)?;
        self.push(positions, velocities);
        Ok(())
    }

    /// Adds an emitter that fires its first shot due at `now` (s, the
    /// world's time) or later: shots due before `now` are skipped, not
    /// fired at once. Returns its index in [`Fluid::emitters`]. Refused
    /// with a typed error for a bad description or past
    /// [`MAX_FLUID_EMITTERS`].
    pub fn add_emitter(&mut self, emitter: FluidEmitter, now: f64) -> Result<usize, PhysicsError> {
        if self.emitters.len() >= MAX_FLUID_EMITTERS {
            return Err(PhysicsError::Invalid {
                what: "fluid emitters",
                why: format!("a fluid has at most {MAX_FLUID_EMITTERS} emitters"),
            });
        }
        finite("world time", now)?;
        let mut state = EmitterState::new(emitter, self.params.spacing, 0, 0)?;
        state.shots = state.due_before(now);
        self.emitters.push(state);
        Ok(self.emitters.len() - 1)
    }

    /// Its emitters, in the order they were added.
    pub fn emitters(&self) -> &[EmitterState] {
        &self.emitters
    }

    /// Whether an emitter has a shot due by `now` (s): [`Fluid::emit`]
    /// would fire it.
    #[cfg(feature = "gpu")]
    pub(crate) fn shot_due(&self, now: f64) -> bool {
        self.emitters.iter().any(|e| e.due_by(now) > e.shots)
    }

    /// Where it steps (see [`World::set_fluid_backend`](crate::World::set_fluid_backend)).
    pub fn backend(&self) -> crate::particle_system::Backend {
        self.backend
    }

    /// The numbers a step uses (the GPU path takes the same step).
    #[cfg(feature = "gpu")]
    pub(crate) fn step_constants(&self) -> StepConstants {
        StepConstants {
            kernels: self.kernels,
            spacing: self.spacing,
            rest_density: self.rest_density,
            mass: self.mass,
            volume: self.volume,
            substeps: self.substeps,
            viscosity: self.viscosity,
            vorticity: self.vorticity,
            tensile_k: self.tensile_k,
            tensile_n: self.tensile_n.max(1) as u32,
            tensile_inv_w: self.tensile_inv_w,
            relaxation: self.relaxation,
            gravity_scale: self.gravity_scale,
            collision_radius: self.collision_radius,
            friction: self.friction,
            max_correction: step::MAX_CORRECTION,
        }
    }

    /// The wall table (`boundary`).
    #[cfg(feature = "gpu")]
    pub(crate) fn wall_table(&self) -> &WallTable {
        &self.wall
    }

    /// Fires every shot that has come due by `now` (s, the world's time at
    /// the end of the step), emitter by emitter (see [`emitter`]).
    pub(crate) fn emit(&mut self, now: f64) {
        let mut emitters = std::mem::take(&mut self.emitters);
        for e in &mut emitters {
            let due = e.due_by(now);
            while e.shots < due {
                let left_in_limit = e.desc.limit.map_or(u64::MAX, |l| l - e.emitted);
                let left_in_fluid = (self.max_particles - self.x.len()) as u64;
                let room = left_in_limit.min(left_in_fluid).min(e.nozzle.len() as u64) as usize;
                if room == 0 {
                    // Nothing fits: the shots due now are skipped.
                    e.shots = due;
                    break;
                }
                let late = now - e.due_time(e.shots);
                let centre = e.desc.position + e.desc.velocity * late;
                let positions: Vec<DVec3> = e.nozzle[..room].iter().map(|o| centre + *o).collect();
                let velocities = vec![e.desc.velocity; room];
                // A shot that would leave the world's range is skipped.
                if self.add_particles(&positions, &velocities).is_ok() {
                    e.emitted += room as u64;
                }
                e.shots += 1;
            }
        }
        self.emitters = emitters;
    }

    /// Puts back a saved emitter as it was (restore).
    pub(crate) fn restore_emitter(
        &mut self,
        emitter: FluidEmitter,
        shots: u64,
        emitted: u64,
    ) -> Result<(), PhysicsError> {
        if self.emitters.len() >= MAX_FLUID_EMITTERS {
            return Err(PhysicsError::Invalid {
                what: "fluid emitters",
                why: format!("a fluid has at most {MAX_FLUID_EMITTERS} emitters"),
            });
        }
        let state = EmitterState::new(emitter, self.params.spacing, shots, emitted)?;
        self.emitters.push(state);
        Ok(())
    }

    /// Removes the particles outside `bounds` (m); the others keep their
    /// order (and move down to fill the gaps). Returns how many went.
    pub fn remove_particles_outside(&mut self, bounds: Aabb) -> usize {
        let before = self.x.len();
        let mut kept = 0;
        for i in 0..before {
            if bounds.contains_point(self.x[i].as_dvec3()) {
                self.x[kept] = self.x[i];
                self.v[kept] = self.v[i];
                self.density[kept] = self.density[i];
                kept += 1;
            }
        }
        self.x.truncate(kept);
        self.v.truncate(kept);
        self.density.truncate(kept);
        self.inv_mass.truncate(kept);
        before - kept
    }

    /// Particle positions, m, in the order they were made.
    pub fn positions(&self) -> &[Vec3] {
        &self.x
    }

    /// Particle velocities, m/s.
    pub fn velocities(&self) -> &[Vec3] {
        &self.v
    }

    /// How many particles the fluid holds.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether the fluid holds no particle.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// The densities the particles found at the last substep, kg/m³.
    pub fn densities(&self) -> &[f32] {
        &self.density
    }

    /// Density at rest, kg/m³.
    pub fn rest_density(&self) -> f32 {
        self.rest_density
    }

    /// Mass of one particle, kg.
    pub fn particle_mass(&self) -> f32 {
        self.mass
    }

    /// Distance between neighbouring particles at rest, m.
    pub fn spacing(&self) -> f32 {
        self.spacing
    }

    /// Kernel radius h, m.
    pub fn kernel_radius(&self) -> f32 {
        self.kernels.h
    }

    /// Most particles the fluid may hold.
    pub fn max_particles(&self) -> usize {
        self.max_particles
    }

    /// The description it was made from, without its particles.
    pub fn params(&self) -> &FluidDesc {
        &self.params
    }

    /// Every particle's inverse mass, 1/kg (what the coupling asks for).
    pub(crate) fn inverse_masses(&self) -> &[f32] {
        &self.inv_mass
    }

    /// How far (m) from a particle's position at the start of a step of
    /// `dt` seconds a body can matter to it: a kernel radius, and as far
    /// as the fastest particle goes.
    pub(crate) fn reach(&self, dt: f32, gravity: Vec3) -> f32 {
        let mut vmax2 = 0.0f32;
        for v in &self.v {
            vmax2 = vmax2.max(v.length_squared());
        }
        let g = (gravity * self.gravity_scale).length();
        let reach = self.kernels.h.max(self.collision_radius)
            + vmax2.sqrt() * dt
            + g * dt * dt
            + self.spacing;
        if reach.is_finite() {
            reach
        } else {
            self.kernels.h + self.spacing
        }
    }
}
