//! The particle engine's force generators acting on rigid bodies.
//!
//! The same [`Force`] values that act on particles act on bodies, with the
//! body's shape standing in for a particle's area and volume:
//!
//! * **uniform gravity** — `m g` (times the body's gravity scale) at the
//!   centre of mass;
//! * **drag** — `-(b + c |v|) v` at the centre of mass with the body's own
//!   coefficients;
//! * **wind** — `½ ρ C s² A` along the wind, where `A` is the area the shape
//!   shows to the wind and the force acts at its centre of pressure, so a
//!   long body turns into the wind;
//! * **buoyancy** — `ρ g V_sub` up through the centre of the submerged
//!   volume (so a floating body rights itself), plus fluid drag scaled by the
//!   submerged fraction on the linear and angular velocity;
//! * **explosions** — the blast pressure on the area the shape shows to the
//!   blast centre, at the centre of mass, averaged over the step exactly as
//!   for particles.
//!
//! Mutual gravity between bodies is refused for now (typed error).

use glam::DVec3;

use crate::forces::wind::CompiledWind;
use crate::forces::{Buoyancy, Drag, Explosion, Force};
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::immersion::{projected_area, submerged, surface};

/// How far (m) above a fluid's surface a body's bounds must lie for the
/// body to count as wholly out of it without clipping its surface: far
/// more than the rounding between the world-frame bounds and the
/// body-frame clipping, so skipping never changes a result.
const ABOVE_SURFACE_MARGIN: f64 = 1e-9;

/// The lowest value of `up · x` over the box `b` (m).
fn lowest_along(b: &crate::rigid::aabb::Aabb, up: DVec3) -> f64 {
    let (c, e) = (b.center(), b.half_extents());
    up.dot(c) - up.abs().dot(e)
}

/// The body force generators of a world, compiled once per step.
#[derive(Debug, Default)]
pub(crate) struct BodyField {
    /// Extra uniform gravity from generators, m/s².
    pub(crate) gravity: DVec3,
    drag: Option<Drag>,
    winds: Vec<CompiledWind>,
    buoyancy: Vec<Buoyancy>,
    explosions: Vec<Explosion>,
    t: f64,
    dt: f64,
}

impl BodyField {
    pub(crate) fn compile<'a>(forces: impl Iterator<Item = &'a Force>, t: f64, dt: f64) -> Self {
        let mut f = BodyField {
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

    fn needs_surface(&self) -> bool {
        !(self.winds.is_empty() && self.buoyancy.is_empty() && self.explosions.is_empty())
    }

    /// Force (N, world) at the centre of mass and torque (N·m, world) about
    /// it on one dynamic body, from every generator but uniform gravity.
    pub(crate) fn force_and_torque(&self, b: &RigidBody) -> (DVec3, DVec3) {
        let (mut force, mut torque) = (DVec3::ZERO, DVec3::ZERO);
        if b.kind != BodyKind::Dynamic {
            return (force, torque);
        }
        if let Some(d) = &self.drag {
            force += d.force(b.linvel, b.drag_linear, b.drag_quadratic);
        }
        let Some(shape) = b.shape.as_ref().filter(|_| self.needs_surface()) else {
            return (force, torque);
        };
        // The triangulated surface, built only for a generator that reaches
        // the body (most bodies of a world with water never touch it).
        let surface_tris = std::cell::OnceCell::new();
        let tris = || surface_tris.get_or_init(|| surface(shape));
        let pose = b.pose();
        let to_local = pose.rotation.inverse();
        // Lever arm from the centre of mass to a point given in the body frame.
        let arm = |local_point: DVec3| pose.transform_point(local_point) - b.com;
        for w in &self.winds {
            if w.dir == DVec3::ZERO {
                continue;
            }
            let (area, centre) = projected_area(shape, tris(), to_local * w.dir);
            let f = w.force(b.linvel, area);
            force += f;
            torque += arm(centre).cross(f);
        }
        // The body's bounds, found only where there is a fluid to test.
        let bounds = std::cell::OnceCell::new();
        for fluid in &self.buoyancy {
            let bounds = bounds.get_or_init(|| shape.aabb(&pose));
            if lowest_along(bounds, fluid.up) > fluid.surface_height + ABOVE_SURFACE_MARGIN {
                // Wholly above the surface: nothing submerged.
                continue;
            }
            let n = to_local * fluid.up;
            let d = fluid.surface_height - fluid.up.dot(pose.translation);
            let (volume, centre) = submerged(shape, tris(), n, d);
            if volume <= 0.0 {
                continue;
            }
            let f = fluid.up * (fluid.fluid_density * volume * fluid.gravity);
            force += f;
            torque += arm(centre).cross(f);
            let fraction = shape.volume().map_or(1.0, |v| (volume / v).min(1.0));
            force -= (fluid.fluid_drag * fraction) * b.linvel;
            // Angular fluid drag: the same coefficient times a length² (V^(2/3)).
            torque -= (fluid.fluid_drag * fraction * volume.powf(2.0 / 3.0)) * b.angvel;
        }
        for e in &self.explosions {
            let away = b.com - e.center;
            if away.length_squared() == 0.0 {
                continue;
            }
            let (area, _) = projected_area(shape, tris(), to_local * -away.normalize());
            force += e.force(b.com, area, self.t, self.dt);
        }
        (force, torque)
    }
}
