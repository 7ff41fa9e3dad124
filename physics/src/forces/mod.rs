//! Force generators. Each is a small value type with its formula and units in
//! its own file; a particle system holds any number of them, and they add up.
//!
//! Two kinds, evaluated differently:
//! * **Field forces** depend only on one particle's own state and the time
//!   (uniform gravity, drag, wind, buoyancy, explosions, scripted control).
//!   They are evaluated inside the integration pass, particle by particle, so
//!   a step streams through memory once.
//! * **Interaction forces** couple particles (springs, mutual gravity). They
//!   are accumulated into a force buffer before the integration pass.

pub mod barnes_hut;
pub mod buoyancy;
pub mod drag;
pub mod explosion;
pub mod mutual_gravity;
pub mod uniform_gravity;
pub mod wind;

use glam::DVec3;

pub use buoyancy::Buoyancy;
pub use drag::Drag;
pub use explosion::Explosion;
pub use mutual_gravity::{GravityMethod, MutualGravity};
pub use uniform_gravity::UniformGravity;
pub use wind::Wind;

use crate::error::PhysicsError;
use wind::CompiledWind;

/// A force generator attached to a particle system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Force {
    /// Constant acceleration near a planet.
    UniformGravity(UniformGravity),
    /// Newtonian gravity between the system's particles.
    MutualGravity(MutualGravity),
    /// Linear and quadratic drag with each particle's coefficients.
    Drag(Drag),
    /// Wind pressure on exposed area.
    Wind(Wind),
    /// Buoyancy and drag in a fluid below a surface.
    Buoyancy(Buoyancy),
    /// A radial shock front.
    Explosion(Explosion),
}

impl Force {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        match self {
            Force::UniformGravity(f) => f.validate(),
            Force::MutualGravity(f) => f.validate(),
            Force::Drag(f) => f.validate(),
            Force::Wind(f) => f.validate(),
            Force::Buoyancy(f) => f.validate(),
            Force::Explosion(f) => f.validate(),
        }
    }
}

impl From<UniformGravity> for Force {
    fn from(f: UniformGravity) -> Self {
        Force::UniformGravity(f)
    }
}
impl From<MutualGravity> for Force {
    fn from(f: MutualGravity) -> Self {
        Force::MutualGravity(f)
    }
}
impl From<Drag> for Force {
    fn from(f: Drag) -> Self {
        Force::Drag(f)
    }
}
impl From<Wind> for Force {
    fn from(f: Wind) -> Self {
        Force::Wind(f)
    }
}
impl From<Buoyancy> for Force {
    fn from(f: Buoyancy) -> Self {
        Force::Buoyancy(f)
    }
}
impl From<Explosion> for Force {
    fn from(f: Explosion) -> Self {
        Force::Explosion(f)
    }
}

/// A force as stored in a system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ForceEntry {
    pub(crate) force: Force,
}

/// The field forces of one system, compiled once per step: sums and
/// invariants hoisted out of the per-particle loop.
#[derive(Debug, Clone, Default)]
pub(crate) struct FieldForces {
    /// The world's gravity (times the system's gravity scale) plus the
    /// system's own uniform gravities, m/s².
    pub(crate) gravity: DVec3,
    pub(crate) drag: Option<Drag>,
    pub(crate) winds: Vec<CompiledWind>,
    pub(crate) buoyancy: Vec<Buoyancy>,
    pub(crate) explosions: Vec<Explosion>,
    /// Step interval `[t, t + dt]` the explosions are averaged over, s.
    pub(crate) t: f64,
    pub(crate) dt: f64,
}

impl FieldForces {
    /// `forces` over the step `[t, t + dt]` (s), under the uniform
    /// `gravity` (m/s², the world's scaled by the system's gravity scale).
    pub(crate) fn compile<'a>(
        forces: impl IntoIterator<Item = &'a Force>,
        gravity: DVec3,
        t: f64,
        dt: f64,
    ) -> Self {
        let mut f = FieldForces {
            gravity,
            t,
            dt,
            ..Default::default()
        };
        for force in forces {
            match *force {
                Force::UniformGravity(g) => f.gravity += g.acceleration(),
                Force::Drag(d) => f.drag = Some(f.drag.map_or(d, |prev| prev.combined(&d))),
                Force::Wind(w) => f.winds.push(w.compiled()),
                Force::Buoyancy(b) => f.buoyancy.push(b.compiled()),
                Force::Explosion(e) => f.explosions.push(e),
                Force::MutualGravity(_) => {}
            }
        }
        f
    }

    /// Sum of the non-gravity field forces on dense particle `i` of `sys`, N,
    /// at position `x` and velocity `v` (which may be an integrator's stage
    /// values rather than the stored ones).
    #[inline(always)]
    pub(crate) fn force(&self, sys: &PerParticle<'_>, i: usize, x: DVec3, v: DVec3) -> DVec3 {
        let mut f = DVec3::ZERO;
        if let Some(d) = &self.drag {
            f += d.force(v, sys.drag_linear[i], sys.drag_quadratic[i]);
        }
        for w in &self.winds {
            f += w.force(v, sys.area[i]);
        }
        for b in &self.buoyancy {
            f += b.force(x, v, sys.volume[i]);
        }
        for e in &self.explosions {
            f += e.force(x, sys.area[i], self.t, self.dt);
        }
        if let Some(c) = sys.control {
            f += c[i];
        }
        if let Some(g) = sys.group_control {
            if let Some(gf) = g.get(sys.group[i] as usize) {
                f += *gf;
            }
        }
        f
    }

    /// Potential energy of uniform gravity for a particle of inverse mass
    /// `inv_mass` at `x`, J: `-m (g · x)`.
    #[inline(always)]
    pub(crate) fn gravity_potential(&self, x: DVec3, inv_mass: f64) -> f64 {
        -self.gravity.dot(x) / inv_mass
    }
}

impl<'a> PerParticle<'a> {
    /// The same properties for dense particles `base..base + n`, indexed from 0.
    /// (`group_control` is indexed by group id and stays whole.)
    #[inline]
    pub(crate) fn chunk(&self, base: usize, n: usize) -> PerParticle<'a> {
        let r = base..base + n;
        PerParticle {
            inv_mass: &self.inv_mass[r.clone()],
            drag_linear: &self.drag_linear[r.clone()],
            drag_quadratic: &self.drag_quadratic[r.clone()],
            area: &self.area[r.clone()],
            volume: &self.volume[r.clone()],
            group: &self.group[r.clone()],
            control: self.control.map(|c| &c[r]),
            group_control: self.group_control,
        }
    }
}

/// Borrowed read-only per-particle properties that field forces read.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PerParticle<'a> {
    pub(crate) inv_mass: &'a [f64],
    pub(crate) drag_linear: &'a [f64],
    pub(crate) drag_quadratic: &'a [f64],
    pub(crate) area: &'a [f64],
    pub(crate) volume: &'a [f64],
    pub(crate) group: &'a [u32],
    pub(crate) control: Option<&'a [DVec3]>,
    pub(crate) group_control: Option<&'a [DVec3]>,
}
