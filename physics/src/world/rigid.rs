//! The rigid-body half of the `World` API. Every method validates before it
//! changes anything.

use glam::DVec3;

use super::World;
use crate::error::{finite3, PhysicsError};
use crate::forces::{Force, ForceEntry};
use crate::handle::{BodyForceHandle, BodyHandle};
use crate::rigid::body::{checked_rotation, BodyKind, RigidBody, RigidBodyDesc};
use crate::rigid::pose::Pose;
use crate::rigid::solver::SolverConfig;
use crate::rigid::PairContact;

impl World {
    /// Adds a rigid body.
    pub fn add_body(&mut self, desc: &RigidBodyDesc) -> Result<BodyHandle, PhysicsError> {
        if self.bodies.len() >= self.config.max_bodies {
            return Err(PhysicsError::TooManyBodies {
                max: self.config.max_bodies,
            });
        }
        let body = desc.build()?;
        let (index, generation) = self.bodies.insert(body);
        Ok(BodyHandle { index, generation })
    }

    /// Removes a rigid body.
    pub fn remove_body(&mut self, h: BodyHandle) -> Result<(), PhysicsError> {
        self.bodies
            .remove(h.index, h.generation)
            .ok_or(PhysicsError::UnknownBody(h))?;
        self.contacts.forget(h);
        self.joints.retain(|j| j.desc.a != h && j.desc.b != h);
        Ok(())
    }

    /// A body, or `None` for a stale handle.
    pub fn body(&self, h: BodyHandle) -> Option<&RigidBody> {
        self.bodies.get(h.index, h.generation)
    }

    /// All bodies with their handles, in handle order.
    pub fn bodies(&self) -> impl Iterator<Item = (BodyHandle, &RigidBody)> {
        self.bodies
            .iter()
            .map(|(index, generation, b)| (BodyHandle { index, generation }, b))
    }

    fn body_mut(&mut self, h: BodyHandle) -> Result<&mut RigidBody, PhysicsError> {
        self.bodies
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownBody(h))
    }

    /// Sets a body's velocities, m/s and rad/s (world). Wakes it. Refused for
    /// static bodies.
    pub fn set_body_velocity(
        &mut self,
        h: BodyHandle,
        linear: DVec3,
        angular: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("body linear velocity", linear)?;
        finite3("body angular velocity", angular)?;
        let b = self.body_mut(h)?;
        if b.kind == BodyKind::Static {
            return Err(PhysicsError::Invalid {
                what: "body velocity",
                why: "static bodies do not move".into(),
            });
        }
        b.linvel = linear;
        b.angvel = angular;
        b.wake();
        Ok(())
    }

    /// Teleports a body: its frame goes to `pose`. Wakes it.
    pub fn set_body_pose(&mut self, h: BodyHandle, pose: Pose) -> Result<(), PhysicsError> {
        finite3("body position", pose.translation)?;
        let rotation = checked_rotation(pose.rotation)?;
        let b = self.body_mut(h)?;
        b.rotation = rotation;
        b.com = pose.translation + rotation * b.local_com;
        b.wake();
        if b.kind == crate::rigid::body::BodyKind::Static {
            // The broad phase never updates a static body's box on its own.
            self.contacts.reset_broad_phase();
        }
        Ok(())
    }

    /// Sets the scripted force (N, at the centre of mass) and torque (N·m)
    /// that act on a dynamic body every step until changed. Wakes it.
    pub fn set_body_control(
        &mut self,
        h: BodyHandle,
        force: DVec3,
        torque: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("body control force", force)?;
        finite3("body control torque", torque)?;
        let b = self.body_mut(h)?;
        b.control_force = force;
        b.control_torque = torque;
        b.wake();
        Ok(())
    }

    /// Applies an impulse (N·s) at a world point to a dynamic body: its
    /// momentum changes at once. Wakes it. The point must lie within the
    /// world's coordinates and the body's speeds stay within
    /// [`limits`](crate::limits) after it; otherwise it is refused and
    /// nothing changes (a small impulse far off spins a body past any
    /// bound: at 10²⁰⁰ m it was a body quarantined and removed a tick
    /// later).
    pub fn apply_body_impulse(
        &mut self,
        h: BodyHandle,
        impulse: DVec3,
        point: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("impulse", impulse)?;
        crate::limits::position("impulse point (m)", point)?;
        let b = self.body_mut(h)?;
        if b.kind != BodyKind::Dynamic {
            return Ok(());
        }
        let dv = impulse * b.inv_mass;
        let dw = b.inverse_inertia_world() * (point - b.com).cross(impulse);
        if !(dv.is_finite() && dw.is_finite()) {
            return Err(PhysicsError::NonFinite {
                what: "velocity after impulse",
                value: f64::INFINITY,
            });
        }
        let linvel = crate::limits::velocity(b.linvel + dv)?;
        let angvel = crate::limits::angular_velocity(b.angvel + dw)?;
        b.linvel = linvel;
        b.angvel = angvel;
        b.wake();
        Ok(())
    }

    /// Releases a quarantined body at a new, finite state.
    pub fn release_body_quarantine(
        &mut self,
        h: BodyHandle,
        pose: Pose,
        linear: DVec3,
        angular: DVec3,
    ) -> Result<(), PhysicsError> {
        finite3("body linear velocity", linear)?;
        finite3("body angular velocity", angular)?;
        self.set_body_pose(h, pose)?;
        let b = self.body_mut(h)?;
        b.quarantined = false;
        b.linvel = linear;
        b.angvel = angular;
        Ok(())
    }

    /// Contact solver settings.
    pub fn solver_config(&self) -> &SolverConfig {
        &self.solver
    }

    /// Changes the contact solver settings (substeps 1..=64, positive
    /// stiffness and push-out, non-negative limits).
    pub fn set_solver_config(&mut self, cfg: SolverConfig) -> Result<(), PhysicsError> {
        if cfg.substeps == 0 || cfg.substeps > 64 {
            return Err(PhysicsError::Invalid {
                what: "solver substeps",
                why: format!("must be 1..=64, got {}", cfg.substeps),
            });
        }
        crate::error::positive("contact hertz", cfg.contact_hertz)?;
        crate::error::non_negative("contact damping ratio", cfg.contact_damping_ratio)?;
        crate::error::positive("push-out speed", cfg.push_out)?;
        crate::error::non_negative("restitution threshold", cfg.restitution_threshold)?;
        crate::error::non_negative("stick speed", cfg.stick_speed)?;
        crate::error::non_negative("linear sleep tolerance", cfg.sleep.linear_tolerance)?;
        crate::error::non_negative("angular sleep tolerance", cfg.sleep.angular_tolerance)?;
        crate::error::non_negative("time to sleep", cfg.sleep.time_to_sleep)?;
        self.solver = cfg;
        Ok(())
    }

    /// Removes (and reports) every non-static body whose centre of mass
    /// leaves `bounds` from now on; `None` switches this off.
    pub fn set_body_bounds(
        &mut self,
        bounds: Option<crate::rigid::aabb::Aabb>,
    ) -> Result<(), PhysicsError> {
        if let Some(b) = bounds {
            finite3("bounds min", b.min)?;
            finite3("bounds max", b.max)?;
            if b.min.cmpgt(b.max).any() {
                return Err(PhysicsError::Invalid {
                    what: "world bounds",
                    why: "min exceeds max".into(),
                });
            }
        }
        self.body_bounds = bounds;
        Ok(())
    }

    /// Number of touching manifolds after the last step.
    pub fn contact_count(&self) -> usize {
        self.contacts.manifold_count()
    }

    /// The bodies in contact with `h` at the last step, each seen from `h`:
    /// [`PairContact::a`] is `h`, [`PairContact::b`] the other body, and the
    /// normal points from `h` to it (a box resting on the ground has a
    /// normal of about `-Y`). Empty for a stale handle. Pairs of bodies
    /// that both stayed put (asleep or fixed) report what the step that
    /// last solved them found.
    ///
    /// What this reports is part of the saved state, so rules that branch
    /// on it replay bit for bit across a save and a restore.
    ///
    /// ```
    /// use inertia_physics::glam::DVec3;
    /// use inertia_physics::rigid::body::RigidBodyDesc;
    /// use inertia_physics::rigid::pose::Pose;
    /// use inertia_physics::rigid::shape::Shape;
    /// use inertia_physics::{World, WorldConfig};
    ///
    /// let mut world = World::new(WorldConfig::default())?;
    /// world.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
    /// let ground = world.add_body(&RigidBodyDesc::fixed(
    ///     Shape::cuboid(DVec3::new(10.0, 0.5, 10.0))?,
    ///     Pose::from_translation(DVec3::NEG_Y * 0.5),
    /// ))?;
    /// let ball = world.add_body(&RigidBodyDesc::dynamic(
    ///     Shape::sphere(0.5)?,
    ///     100.0,
    ///     Pose::from_translation(DVec3::Y * 0.5),
    /// )?)?;
    /// world.step(1.0 / 60.0)?;
    /// let below = world.contacts_of(ball).next().expect("on the ground");
    /// assert_eq!((below.a, below.b), (ball, ground));
    /// assert!(below.normal.y < -0.99, "the ground is below it");
    /// assert!(below.impulse > 0.0, "and holds it up");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn contacts_of(&self, h: BodyHandle) -> impl Iterator<Item = PairContact> + '_ {
        let id = (h.index, h.generation);
        let of_h = self
            .contacts
            .cache
            .iter()
            .filter(move |(k, _)| k.a == id || k.b == id);
        crate::rigid::pipeline::pair_contacts(of_h, &self.bodies).map(move |p| {
            if p.a == h {
                p
            } else {
                PairContact {
                    a: p.b,
                    b: p.a,
                    normal: -p.normal,
                    ..p
                }
            }
        })
    }

    /// The contact between `a` and `b` at the last step, seen from `a`
    /// (see [`Self::contacts_of`]), if they touched or nearly did.
    pub fn contact_between(&self, a: BodyHandle, b: BodyHandle) -> Option<PairContact> {
        self.contacts_of(a).find(|p| p.b == b)
    }

    /// The deepest overlap between two bodies that the last step's narrow
    /// phase found (before solving), m; 0 when nothing overlapped. Pairs
    /// that stayed asleep are not re-measured.
    pub fn deepest_penetration(&self) -> f64 {
        self.contacts.deepest_penetration
    }

    /// Attaches a force generator that acts on every rigid body: drag, wind
    /// on the area shown, buoyancy of the submerged volume, blasts. Mutual gravity between bodies is refused.
    pub fn add_body_force(
        &mut self,
        force: impl Into<Force>,
    ) -> Result<BodyForceHandle, PhysicsError> {
        let force = checked_body_force(force.into())?;
        let (index, generation) = self.body_forces.insert(ForceEntry { force });
        Ok(BodyForceHandle { index, generation })
    }

    /// Replaces a body force generator's parameters.
    pub fn set_body_force(
        &mut self,
        h: BodyForceHandle,
        force: impl Into<Force>,
    ) -> Result<(), PhysicsError> {
        let force = checked_body_force(force.into())?;
        let e = self
            .body_forces
            .get_mut(h.index, h.generation)
            .ok_or(PhysicsError::UnknownBodyForce(h))?;
        e.force = force;
        Ok(())
    }

    /// Detaches a body force generator.
    pub fn remove_body_force(&mut self, h: BodyForceHandle) -> Result<(), PhysicsError> {
        self.body_forces
            .remove(h.index, h.generation)
            .map(|_| ())
            .ok_or(PhysicsError::UnknownBodyForce(h))
    }

    /// A body force generator, or `None` for a stale handle.
    pub fn body_force(&self, h: BodyForceHandle) -> Option<Force> {
        Some(self.body_forces.get(h.index, h.generation)?.force)
    }
}

fn checked_body_force(force: Force) -> Result<Force, PhysicsError> {
    force.validate()?;
    if matches!(force, Force::MutualGravity(_)) {
        return Err(PhysicsError::Invalid {
            what: "body force",
            why: "mutual gravity acts between particles; between rigid bodies it is not supported"
                .into(),
        });
    }
    Ok(force)
}
