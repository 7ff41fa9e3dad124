//! Soft bodies on XPBD small steps: ropes, cloth, volumetric solids and
//! inflated shells, made of particles and compliant constraints
//! (distance, dihedral bending, tetrahedral volume, long-range tethers,
//! pressure), with plasticity, tearing, attachments to rigid bodies and
//! contacts against every rigid shape.
//!
//! A soft body is described by a [`SoftBodyDesc`] (most easily made by
//! the builders: [`SoftRope`], [`SoftCloth`], [`SoftSolid`]) and added
//! with [`World::add_soft_body`](crate::World::add_soft_body).
//!
//! When to use which: the mass-spring systems of [`crate::soft_body`]
//! follow the lecture (forces, integrators, springs that must stay under
//! their stability bound: at 60 Hz a stiff cloth's springs are softened
//! to stay stable, so it sags like rubber). Soft bodies here take any
//! stiffness at any step, down to inextensible ropes, at the cost of
//! being position-based: their "forces" are what the constraints did.

mod build;
pub(crate) mod constraints;
mod lanes;
pub(crate) mod self_collision;
mod step;
mod tetra;

pub use build::{SoftBalloon, SoftCloth, SoftRope};
pub(crate) use step::step;
// A soft body on the GPU tears on the CPU between steps.
#[cfg(feature = "gpu")]
pub(crate) use step::tear;
pub use tetra::{SoftSolid, SolidShape};

use glam::{DVec3, Vec3};

use crate::error::{finite, finite3, non_negative, PhysicsError};
use crate::handle::BodyHandle;

use super::colouring::Coloured;
use constraints::{dihedral, tet_volume, Bend, Distance, Tet, Tether};

/// Most particles in one soft body.
pub const MAX_SOFT_PARTICLES: usize = 1 << 22;
/// Most substeps a step.
pub const MAX_SUBSTEPS: u32 = 64;

/// Plastic flow: past a yield strain, a constraint's rest length follows
/// its length, so the body keeps part of its deformation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plasticity {
    /// Strain (length over rest length, minus one) past which the rest
    /// length flows, > 0.
    pub yield_strain: f64,
    /// How fast the strain past the yield flows into the rest length,
    /// 1/s (the fraction a second; clamped to the whole excess a step).
    pub creep: f64,
    /// Largest permanent strain, relative to the length as built, > 0.
    pub max_strain: f64,
}

/// How a soft body moves as a whole.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftMaterial {
    /// Substeps a step, 1..=[`MAX_SUBSTEPS`] (Small Steps: 10 or more for
    /// stiff cloth and ropes).
    pub substeps: u32,
    /// Velocity damping, 1/s (the velocity loses `damping · h` of itself
    /// each substep of `h` seconds).
    pub damping: f64,
    /// Times the world's gravity.
    pub gravity_scale: f64,
    /// Radius of each particle against rigid shapes, m; 0: no contacts.
    pub collision_radius: f64,
    /// Coulomb friction against rigid shapes (the pair takes the larger of
    /// this and the body's).
    pub friction: f64,
    /// Particles keep `2 · collision_radius` apart from particles they
    /// are not joined to (cloth self-collision).
    pub self_collision: bool,
    /// Plastic flow of the distance constraints, if any.
    pub plasticity: Option<Plasticity>,
    /// A distance constraint stretched past this strain breaks, with the
    /// triangles, bending hinges and tetrahedra on its edge (tearing).
    /// At most [`MAX_TEARS_PER_STEP`] break a step, the most strained
    /// first, so a tear runs from where the strain is highest.
    pub tear_strain: Option<f64>,
}

/// Most constraints that tear in one step.
pub const MAX_TEARS_PER_STEP: usize = 8;

impl Default for SoftMaterial {
    fn default() -> Self {
        Self {
            substeps: 10,
            damping: 0.1,
            gravity_scale: 1.0,
            collision_radius: 0.0,
            friction: 0.3,
            self_collision: false,
            plasticity: None,
            tear_strain: None,
        }
    }
}

/// A distance constraint to be made; its rest length is the distance as
/// described.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeDesc {
    /// The two particles.
    pub particles: [u32; 2],
    /// m/N; 0 = inextensible.
    pub compliance: f64,
}

/// A bending hinge to be made: `particles = [e0, e1, o0, o1]`, the shared
/// edge and the vertex of each triangle opposite it. Its rest angle is
/// the angle as described.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HingeDesc {
    /// The hinge's four particles.
    pub particles: [u32; 4],
    /// rad/(N·m); 0 = rigid.
    pub compliance: f64,
}

/// A tetrahedral volume constraint to be made; its rest volume is the
/// volume as described (it must not be degenerate).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TetDesc {
    /// The four particles.
    pub particles: [u32; 4],
    /// 1/Pa; 0 = incompressible.
    pub compliance: f64,
}

/// A long-range attachment to be made: `particle` stays within its
/// distance as described from `anchor` (a pinned particle), times
/// `1 + slack`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TetherDesc {
    /// The particle held.
    pub particle: u32,
    /// The pinned particle it is held to.
    pub anchor: u32,
    /// Extra length allowed, as a fraction of the rest distance, >= 0.
    pub slack: f64,
}

/// An inflated shell: the volume the surface triangles enclose is kept at
/// `pressure` times its rest volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressureDesc {
    /// Target volume over rest volume, > 0 (1: keeps its volume; above 1:
    /// inflated).
    pub pressure: f64,
    /// 1/Pa; 0 = stiff.
    pub compliance: f64,
}

/// A soft body to be made: particles and the constraints between them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SoftBodyDesc {
    /// Particle positions, m.
    pub positions: Vec<DVec3>,
    /// Particle masses, kg; 0 pins the particle (it never moves unless
    /// set with [`World::set_soft_pin`](crate::World::set_soft_pin)).
    pub masses: Vec<f64>,
    /// Initial velocities, m/s; empty: at rest.
    pub velocities: Vec<DVec3>,
    /// Distance constraints.
    pub edges: Vec<EdgeDesc>,
    /// Bending hinges.
    pub hinges: Vec<HingeDesc>,
    /// Volume constraints.
    pub tetrahedra: Vec<TetDesc>,
    /// Long-range attachments.
    pub tethers: Vec<TetherDesc>,
    /// The surface, counter-clockwise seen from outside: drawn by clients
    /// and, with `pressure`, the shell whose volume is kept.
    pub triangles: Vec<[u32; 3]>,
    /// Keeps the volume the surface encloses.
    pub pressure: Option<PressureDesc>,
    /// How it moves as a whole.
    pub material: SoftMaterial,
}

/// A particle held to a point on a rigid body (two-way: the body is
/// pulled back).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SoftAttachment {
    pub(crate) particle: u32,
    pub(crate) body: BodyHandle,
    /// The point in the body's frame, m.
    pub(crate) local: DVec3,
    /// m/N.
    pub(crate) compliance: f32,
}

/// The pressure constraint as kept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pressure {
    /// The volume kept, m³ (pressure × rest volume).
    pub(crate) target: f32,
    pub(crate) compliance: f32,
}

/// A soft body in a world.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftBody {
    /// Positions, m.
    pub(crate) x: Vec<Vec3>,
    /// Velocities, m/s.
    pub(crate) v: Vec<Vec3>,
    /// Inverse masses, 1/kg (0: pinned).
    pub(crate) w: Vec<f32>,
    pub(crate) distance: Coloured<Distance>,
    pub(crate) bend: Coloured<Bend>,
    pub(crate) tets: Coloured<Tet>,
    pub(crate) tethers: Coloured<Tether>,
    pub(crate) pressure: Option<Pressure>,
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) attachments: Vec<SoftAttachment>,
    pub(crate) material: SoftMaterial,
    /// Positions at the start of the substep (scratch).
    pub(crate) prev: Vec<Vec3>,
    /// Self-collision's candidates (derived).
    pub(crate) self_collision: self_collision::SelfCollision,
    /// Where it steps (not saved: a restored body steps on the CPU).
    pub(crate) backend: crate::particle_system::Backend,
}

fn invalid(what: &'static str, why: impl Into<String>) -> PhysicsError {
    PhysicsError::Invalid {
        what,
        why: why.into(),
    }
}

fn index_ok(what: &'static str, i: u32, n: usize) -> Result<usize, PhysicsError> {
    if (i as usize) < n {
        Ok(i as usize)
    } else {
        Err(invalid(what, format!("particle {i} of {n}")))
    }
}

fn compliance(what: &'static str, c: f64) -> Result<f32, PhysicsError> {
    non_negative(what, c)?;
    if c > f64::from(f32::MAX) {
        return Err(invalid(what, "too large for single precision"));
    }
    Ok(c as f32)
}

impl SoftMaterial {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(invalid(
                "soft body substeps",
                format!("{} is not within 1..={MAX_SUBSTEPS}", self.substeps),
            ));
        }
        non_negative("soft body damping", self.damping)?;
        finite("soft body gravity scale", self.gravity_scale)?;
        non_negative("soft body collision radius", self.collision_radius)?;
        non_negative("soft body friction", self.friction)?;
        if let Some(p) = self.plasticity {
            crate::error::positive("plastic yield strain", p.yield_strain)?;
            non_negative("plastic creep", p.creep)?;
            crate::error::positive("plastic max strain", p.max_strain)?;
        }
        if let Some(t) = self.tear_strain {
            crate::error::positive("tear strain", t)?;
        }
        Ok(())
    }
}

/// The volume enclosed by counter-clockwise triangles, m³.
pub(crate) fn enclosed_volume(x: &[Vec3], triangles: &[[u32; 3]]) -> f32 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| x[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

impl SoftBody {
    /// A soft body from its description, every part checked; refused with
    /// a typed error naming what is wrong.
    pub fn new(desc: &SoftBodyDesc) -> Result<Self, PhysicsError> {
        let n = desc.positions.len();
        if n == 0 {
            return Err(invalid("soft body", "no particles"));
        }
        if n > MAX_SOFT_PARTICLES {
            return Err(invalid(
                "soft body",
                format!("{n} particles, more than {MAX_SOFT_PARTICLES}"),
            ));
        }
        if desc.masses.len() != n {
            return Err(invalid(
                "soft body masses",
                format!("{} masses for {n} particles", desc.masses.len()),
            ));
        }
        if !desc.velocities.is_empty() && desc.velocities.len() != n {
            return Err(invalid(
                "soft body velocities",
                format!("{} velocities for {n} particles", desc.velocities.len()),
            ));
        }
        desc.material.validate()?;
        let mut x = Vec::with_capacity(n);
        for p in &desc.positions {
            finite3("soft body position", *p)?;
            if p.abs().max_element() > crate::limits::MAX_COORDINATE {
                return Err(invalid("soft body position", format!("{p} is too far out")));
            }
            x.push(p.as_vec3());
        }
        let mut w = Vec::with_capacity(n);
        for &m in &desc.masses {
            non_negative("soft body particle mass", m)?;
            let inv = if m > 0.0 { (1.0 / m) as f32 } else { 0.0 };
            if !inv.is_finite() {
                return Err(PhysicsError::NonPositiveMass(m));
            }
            w.push(inv);
        }
        let mut v = vec![Vec3::ZERO; n];
        for (k, u) in desc.velocities.iter().enumerate() {
            finite3("soft body velocity", *u)?;
            v[k] = u.as_vec3();
        }
        let mut edges = Vec::with_capacity(desc.edges.len());
        for e in &desc.edges {
            let [a, b] = e.particles.map(|i| index_ok("soft body edge", i, n));
            let (a, b) = (a?, b?);
            let rest = (x[b] - x[a]).length();
            if a == b || rest < 1e-6 {
                return Err(PhysicsError::DegenerateSpring(
                    "a soft body edge has zero rest length",
                ));
            }
            edges.push(Distance {
                p: e.particles,
                rest,
                rest0: rest,
                compliance: compliance("edge compliance", e.compliance)?,
            });
        }
        let mut bends = Vec::with_capacity(desc.hinges.len());
        for h in &desc.hinges {
            for i in h.particles {
                index_ok("soft body hinge", i, n)?;
            }
            let Some((rest, _)) = dihedral(h.particles.map(|i| x[i as usize])) else {
                return Err(invalid(
                    "soft body hinge",
                    "a triangle of the hinge is degenerate",
                ));
            };
            bends.push(Bend {
                p: h.particles,
                rest,
                compliance: compliance("bending compliance", h.compliance)?,
            });
        }
        let mut tets = Vec::with_capacity(desc.tetrahedra.len());
        for t in &desc.tetrahedra {
            for i in t.particles {
                index_ok("soft body tetrahedron", i, n)?;
            }
            let rest = tet_volume(t.particles.map(|i| x[i as usize]));
            let scale = (x[t.particles[1] as usize] - x[t.particles[0] as usize]).length();
            if rest.is_nan() || rest <= 1e-6 * scale * scale * scale || rest < 1e-15 {
                return Err(invalid(
                    "soft body tetrahedron",
                    format!(
                        "{:?} is degenerate or inside out (volume {rest} m³)",
                        t.particles
                    ),
                ));
            }
            tets.push(Tet {
                p: t.particles,
                rest,
                compliance: compliance("volume compliance", t.compliance)?,
            });
        }
        let mut tethers = Vec::with_capacity(desc.tethers.len());
        for t in &desc.tethers {
            let a = index_ok("soft body tether", t.particle, n)?;
            let b = index_ok("soft body tether anchor", t.anchor, n)?;
            if w[b] != 0.0 {
                return Err(invalid(
                    "soft body tether",
                    "its anchor must be a pinned particle",
                ));
            }
            non_negative("tether slack", t.slack)?;
            tethers.push(Tether {
                p: [t.particle, t.anchor],
                max: (x[a] - x[b]).length() * (1.0 + t.slack as f32),
            });
        }
        for t in &desc.triangles {
            for i in t {
                index_ok("soft body triangle", *i, n)?;
            }
        }
        let pressure = match desc.pressure {
            None => None,
            Some(p) => {
                crate::error::positive("pressure", p.pressure)?;
                let rest = enclosed_volume(&x, &desc.triangles);
                if rest.is_nan() || rest <= 1e-9 {
                    return Err(invalid(
                        "soft body pressure",
                        format!("the surface encloses no volume ({rest} m³): it must be closed and face outwards"),
                    ));
                }
                Some(Pressure {
                    target: rest * p.pressure as f32,
                    compliance: compliance("pressure compliance", p.compliance)?,
                })
            }
        };
        Ok(Self {
            distance: Coloured::new(edges, &w),
            bend: Coloured::new(bends, &w),
            tets: Coloured::new(tets, &w),
            tethers: Coloured::new(tethers, &w),
            pressure,
            triangles: desc.triangles.clone(),
            attachments: Vec::new(),
            material: desc.material.clone(),
            self_collision: Default::default(),
            backend: crate::particle_system::Backend::Cpu,
            prev: x.clone(),
            x,
            v,
            w,
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether it has no particles (never, for a body in a world).
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Positions, m.
    pub fn positions(&self) -> &[Vec3] {
        &self.x
    }

    /// Velocities, m/s.
    pub fn velocities(&self) -> &[Vec3] {
        &self.v
    }

    /// Inverse masses, 1/kg (0: pinned).
    pub fn inverse_masses(&self) -> &[f32] {
        &self.w
    }

    /// The surface triangles left (tearing removes some).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// How it moves as a whole.
    pub fn material(&self) -> &SoftMaterial {
        &self.material
    }

    /// Where it steps.
    pub fn backend(&self) -> crate::particle_system::Backend {
        self.backend
    }

    /// Constraints by kind: distance, bending, volume, tether.
    pub fn constraint_counts(&self) -> [usize; 4] {
        [
            self.distance.items.len(),
            self.bend.items.len(),
            self.tets.items.len(),
            self.tethers.items.len(),
        ]
    }

    /// All constraints projected each substep (pressure counts one).
    pub fn constraints(&self) -> usize {
        self.constraint_counts().iter().sum::<usize>() + usize::from(self.pressure.is_some())
    }

    /// The largest strain of a distance constraint (length over its rest
    /// length as built, minus one).
    pub fn max_strain(&self) -> f32 {
        self.distance
            .items
            .iter()
            .map(|d| (self.x[d.p[1] as usize] - self.x[d.p[0] as usize]).length() / d.rest0 - 1.0)
            .fold(0.0, f32::max)
    }

    /// The distance constraints as `(particles, length now, rest length
    /// now, rest length as built)`, m.
    pub fn edges(&self) -> impl Iterator<Item = ([u32; 2], f32, f32, f32)> + '_ {
        self.distance.items.iter().map(|d| {
            (
                d.p,
                (self.x[d.p[1] as usize] - self.x[d.p[0] as usize]).length(),
                d.rest,
                d.rest0,
            )
        })
    }

    /// The volume of the tetrahedra now, m³.
    pub fn volume(&self) -> f32 {
        self.tets
            .items
            .iter()
            .map(|t| tet_volume(t.p.map(|i| self.x[i as usize])))
            .sum()
    }

    /// The volume of the tetrahedra at rest, m³.
    pub fn rest_volume(&self) -> f32 {
        self.tets.items.iter().map(|t| t.rest).sum()
    }

    /// The volume the surface encloses now, m³.
    pub fn enclosed_volume(&self) -> f32 {
        enclosed_volume(&self.x, &self.triangles)
    }

    /// The rigid bodies its attachments hold it to (arena index and
    /// generation), in attachment order.
    pub(crate) fn attached_bodies(&self) -> Vec<(u32, u32)> {
        self.attachments
            .iter()
            .map(|a| (a.body.index, a.body.generation))
            .collect()
    }

    /// How far a particle can go in a step of `dt` s under `gravity`
    /// (m/s², the world's): the fastest particle's speed and what gravity
    /// adds over the step, times `dt`, m.
    pub(crate) fn travel(&self, dt: f32, gravity: Vec3) -> f32 {
        let fastest = self
            .v
            .iter()
            .map(|v| v.length_squared())
            .fold(0.0f32, f32::max)
            .sqrt();
        let g = gravity.length() * self.material.gravity_scale.abs() as f32;
        (fastest + g * dt) * dt
    }

    /// Kinetic energy, J.
    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.w)
            .filter(|(_, w)| **w > 0.0)
            .map(|(v, w)| 0.5 * f64::from(v.length_squared()) / f64::from(*w))
            .sum()
    }

    /// The centre of the movable particles (by mass), m.
    pub fn centre_of_mass(&self) -> DVec3 {
        let mut sum = DVec3::ZERO;
        let mut mass = 0.0;
        for (x, w) in self.x.iter().zip(&self.w) {
            if *w > 0.0 {
                let m = 1.0 / f64::from(*w);
                sum += x.as_dvec3() * m;
                mass += m;
            }
        }
        if mass > 0.0 {
            sum / mass
        } else {
            DVec3::ZERO
        }
    }

    /// Moves a pinned particle (a scripted anchor) to `p`, m. A pinned
    /// particle has no velocity: the constraints see only where it is.
    pub(crate) fn set_pin(&mut self, i: usize, p: Vec3) {
        self.x[i] = p;
        self.prev[i] = p;
    }
}
