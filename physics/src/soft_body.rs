//! Mass-spring soft bodies built from particles and springs: ropes (chains)
//! and cloth (a grid with structural, shear and bend springs).
//!
//! Cloth springs follow Provot ("Deformation constraints in a mass-spring
//! model to describe rigid cloth behavior", Graphics Interface 1995):
//! *structural* springs join grid neighbours, *shear* springs the diagonals,
//! *bend* springs every second particle along rows and columns, so the sheet
//! resists stretching, shearing and folding with separate stiffnesses.

use glam::DVec3;

use crate::error::{finite3, positive, PhysicsError};
use crate::handle::{ParticleHandle, SpringHandle, SystemHandle};
use crate::particle_system::ParticleDesc;
use crate::spring::SpringParams;
use crate::world::World;

/// A rope: a chain of particles joined by springs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RopeDesc {
    /// First end, m.
    pub start: DVec3,
    /// Other end, m.
    pub end: DVec3,
    /// Number of segments (particles = segments + 1), >= 1.
    pub segments: usize,
    /// Total mass, kg.
    pub mass: f64,
    /// Stiffness of each segment, N/m.
    pub stiffness: f64,
    /// Damping of each segment, N·s/m.
    pub damping: f64,
    /// Linear drag per particle, kg/s.
    pub drag_linear: f64,
    /// Pin the first particle.
    pub pin_start: bool,
    /// Pin the last particle.
    pub pin_end: bool,
}

impl Default for RopeDesc {
    fn default() -> Self {
        Self {
            start: DVec3::ZERO,
            end: DVec3::new(1.0, 0.0, 0.0),
            segments: 10,
            mass: 1.0,
            stiffness: 1000.0,
            damping: 1.0,
            drag_linear: 0.0,
            pin_start: true,
            pin_end: false,
        }
    }
}

/// Handles of a built rope.
#[derive(Debug, Clone, PartialEq)]
pub struct Rope {
    /// Particles from start to end.
    pub particles: Vec<ParticleHandle>,
    /// Segment springs, in order.
    pub springs: Vec<SpringHandle>,
}

/// Builds a rope in `sys`. All or nothing: on error nothing is added.
pub fn build_rope(
    world: &mut World,
    sys: SystemHandle,
    d: &RopeDesc,
) -> Result<Rope, PhysicsError> {
    finite3("rope start", d.start)?;
    finite3("rope end", d.end)?;
    if d.segments == 0 {
        return Err(PhysicsError::Invalid {
            what: "rope segments",
            why: "must be at least 1".into(),
        });
    }
    positive("rope mass", d.mass)?;
    let rest = (d.end - d.start).length() / d.segments as f64;
    let params = SpringParams {
        rest_length: rest,
        stiffness: d.stiffness,
        damping: d.damping,
    };
    params.validate()?;
    let m = d.mass / (d.segments + 1) as f64;
    let descs: Vec<ParticleDesc> = (0..=d.segments)
        .map(|k| ParticleDesc {
            position: d.start.lerp(d.end, k as f64 / d.segments as f64),
            mass: m,
            drag_linear: d.drag_linear,
            pinned: (k == 0 && d.pin_start) || (k == d.segments && d.pin_end),
            ..ParticleDesc::default()
        })
        .collect();
    for desc in &descs {
        desc.validate()?;
    }
    world.system(sys).ok_or(PhysicsError::UnknownSystem(sys))?;
    let particles = world.add_particles(sys, &descs)?;
    let springs = particles
        .windows(2)
        .map(|w| world.add_spring(w[0], w[1], params))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Rope { particles, springs })
}

/// A rectangular cloth.
#[derive(Debug, Clone, PartialEq)]
pub struct ClothDesc {
    /// Corner of particle (0, 0), m.
    pub origin: DVec3,
    /// Direction of the rows (need not be normalised).
    pub u_axis: DVec3,
    /// Direction of the columns.
    pub v_axis: DVec3,
    /// Extent along `u_axis`, m.
    pub width: f64,
    /// Extent along `v_axis`, m.
    pub height: f64,
    /// Particles along `u`, >= 2.
    pub nu: usize,
    /// Particles along `v`, >= 2.
    pub nv: usize,
    /// Total mass, kg.
    pub mass: f64,
    /// Structural springs (grid edges).
    pub structural: SpringStiffness,
    /// Shear springs (diagonals).
    pub shear: SpringStiffness,
    /// Bend springs (every second particle).
    pub bend: SpringStiffness,
    /// Linear drag per particle, kg/s.
    pub drag_linear: f64,
    /// Grid coordinates `(iu, iv)` to pin.
    pub pinned: Vec<(usize, usize)>,
}

/// Stiffness and damping of one spring family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringStiffness {
    /// N/m.
    pub stiffness: f64,
    /// N·s/m.
    pub damping: f64,
}

impl Default for ClothDesc {
    fn default() -> Self {
        Self {
            origin: DVec3::ZERO,
            u_axis: DVec3::X,
            v_axis: DVec3::NEG_Z,
            width: 1.0,
            height: 1.0,
            nu: 16,
            nv: 16,
            mass: 1.0,
            structural: SpringStiffness {
                stiffness: 500.0,
                damping: 0.5,
            },
            shear: SpringStiffness {
                stiffness: 200.0,
                damping: 0.2,
            },
            bend: SpringStiffness {
                stiffness: 50.0,
                damping: 0.05,
            },
            drag_linear: 0.0,
            pinned: Vec::new(),
        }
    }
}

/// Handles of a built cloth.
#[derive(Debug, Clone, PartialEq)]
pub struct Cloth {
    /// Particles, row-major: index `iv * nu + iu`.
    pub particles: Vec<ParticleHandle>,
    /// Number of structural, shear and bend springs.
    pub spring_counts: [usize; 3],
    /// Particles along u and v.
    pub nu: usize,
    /// Particles along v.
    pub nv: usize,
}

/// Builds a cloth in `sys`. All or nothing: on error nothing is added.
pub fn build_cloth(
    world: &mut World,
    sys: SystemHandle,
    d: &ClothDesc,
) -> Result<Cloth, PhysicsError> {
    finite3("cloth origin", d.origin)?;
    let u = crate::error::direction("cloth u axis", d.u_axis)?;
    let v = crate::error::direction("cloth v axis", d.v_axis)?;
    positive("cloth width", d.width)?;
    positive("cloth height", d.height)?;
    positive("cloth mass", d.mass)?;
    if d.nu < 2 || d.nv < 2 {
        return Err(PhysicsError::Invalid {
            what: "cloth resolution",
            why: format!("{}x{} (need at least 2x2)", d.nu, d.nv),
        });
    }
    if let Some(&(iu, iv)) = d.pinned.iter().find(|&&(iu, iv)| iu >= d.nu || iv >= d.nv) {
        return Err(PhysicsError::Invalid {
            what: "cloth pin",
            why: format!("({iu}, {iv}) is outside the grid"),
        });
    }
    let (du, dv) = (d.width / (d.nu - 1) as f64, d.height / (d.nv - 1) as f64);
    let diag = (du * du + dv * dv).sqrt();
    let families = [
        (d.structural, du, dv),
        (d.shear, diag, diag),
        (d.bend, 2.0 * du, 2.0 * dv),
    ];
    for (f, lu, lv) in families {
        SpringParams {
            rest_length: lu,
            stiffness: f.stiffness,
            damping: f.damping,
        }
        .validate()?;
        SpringParams {
            rest_length: lv,
            stiffness: f.stiffness,
            damping: f.damping,
        }
        .validate()?;
    }
    world.system(sys).ok_or(PhysicsError::UnknownSystem(sys))?;
    let m = d.mass / (d.nu * d.nv) as f64;
    let cell_area = du * dv;
    let mut descs = Vec::with_capacity(d.nu * d.nv);
    for iv in 0..d.nv {
        for iu in 0..d.nu {
            descs.push(ParticleDesc {
                position: d.origin + u * (iu as f64 * du) + v * (iv as f64 * dv),
                mass: m,
                area: cell_area,
                drag_linear: d.drag_linear,
                pinned: d.pinned.contains(&(iu, iv)),
                ..ParticleDesc::default()
            });
        }
    }
    let particles = world.add_particles(sys, &descs)?;
    let at = |iu: usize, iv: usize| particles[iv * d.nu + iu];
    let mut counts = [0usize; 3];
    let mut spring = |w: &mut World,
                      a,
                      b,
                      f: SpringStiffness,
                      len: f64,
                      family: usize|
     -> Result<(), PhysicsError> {
        w.add_spring(
            a,
            b,
            SpringParams {
                rest_length: len,
                stiffness: f.stiffness,
                damping: f.damping,
            },
        )?;
        counts[family] += 1;
        Ok(())
    };
    for iv in 0..d.nv {
        for iu in 0..d.nu {
            if iu + 1 < d.nu {
                spring(world, at(iu, iv), at(iu + 1, iv), d.structural, du, 0)?;
            }
            if iv + 1 < d.nv {
                spring(world, at(iu, iv), at(iu, iv + 1), d.structural, dv, 0)?;
            }
            if iu + 1 < d.nu && iv + 1 < d.nv {
                spring(world, at(iu, iv), at(iu + 1, iv + 1), d.shear, diag, 1)?;
                spring(world, at(iu + 1, iv), at(iu, iv + 1), d.shear, diag, 1)?;
            }
            if iu + 2 < d.nu {
                spring(world, at(iu, iv), at(iu + 2, iv), d.bend, 2.0 * du, 2)?;
            }
            if iv + 2 < d.nv {
                spring(world, at(iu, iv), at(iu, iv + 2), d.bend, 2.0 * dv, 2)?;
            }
        }
    }
    Ok(Cloth {
        particles,
        spring_counts: counts,
        nu: d.nu,
        nv: d.nv,
    })
}
