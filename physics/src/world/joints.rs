//! Joints in the `World` API. Every method validates before it changes
//! anything.

use glam::DVec3;

use super::World;
use crate::error::{finite3, non_negative, positive, PhysicsError};
use crate::handle::JointHandle;
use crate::rigid::joint::{Joint, JointDesc, JointKind};

fn invalid(why: impl Into<String>) -> PhysicsError {
    PhysicsError::Invalid {
        what: "joint",
        why: why.into(),
    }
}

fn unit(what: &'static str, v: DVec3) -> Result<DVec3, PhysicsError> {
    crate::error::direction(what, v)
}

impl World {
    /// Joins two bodies. The joint holds them as they are now (fixed and
    /// prismatic joints keep the present relative rotation; hinge angles
    /// count from it).
    pub fn add_joint(&mut self, desc: JointDesc) -> Result<JointHandle, PhysicsError> {
        let mut desc = desc;
        finite3("joint anchor", desc.anchor_a)?;
        finite3("joint anchor", desc.anchor_b)?;
        non_negative("joint break force", desc.break_force)?;
        if desc.a == desc.b {
            return Err(invalid("both ends are the same body"));
        }
        let ra = self
            .body(desc.a)
            .ok_or(PhysicsError::UnknownBody(desc.a))?
            .pose()
            .rotation;
        let rb = self
            .body(desc.b)
            .ok_or(PhysicsError::UnknownBody(desc.b))?
            .pose()
            .rotation;
        match &mut desc.kind {
            JointKind::Ball | JointKind::Fixed => {}
            JointKind::SwingTwist {
                axis_a,
                axis_b,
                swing_limit,
                twist_limits,
            } => {
                *axis_a = unit("twist axis", *axis_a)?;
                *axis_b = unit("twist axis", *axis_b)?;
                non_negative("swing limit", *swing_limit)?;
                crate::error::finite("twist limit", twist_limits.0)?;
                crate::error::finite("twist limit", twist_limits.1)?;
                if twist_limits.0 > twist_limits.1 {
                    return Err(invalid(format!(
                        "twist limits {} > {}",
                        twist_limits.0, twist_limits.1
                    )));
                }
            }
            JointKind::Hinge {
                axis_a,
                axis_b,
                limits,
                motor,
            } => {
                *axis_a = unit("hinge axis", *axis_a)?;
                *axis_b = unit("hinge axis", *axis_b)?;
                if let Some((lo, hi)) = limits {
                    crate::error::finite("hinge limit", *lo)?;
                    crate::error::finite("hinge limit", *hi)?;
                    if lo > hi {
                        return Err(invalid(format!("hinge limits {lo} > {hi}")));
                    }
                }
                if let Some((speed, torque)) = motor {
                    crate::error::finite("motor speed", *speed)?;
                    non_negative("motor torque", *torque)?;
                }
            }
            JointKind::Prismatic {
                axis_a,
                limits,
                motor,
            } => {
                *axis_a = unit("prismatic axis", *axis_a)?;
                if let Some((lo, hi)) = limits {
                    crate::error::finite("prismatic limit", *lo)?;
                    crate::error::finite("prismatic limit", *hi)?;
                    if lo > hi {
                        return Err(invalid(format!("prismatic limits {lo} > {hi}")));
                    }
                }
                if let Some((speed, force)) = motor {
                    crate::error::finite("motor speed", *speed)?;
                    non_negative("motor force", *force)?;
                }
            }
            JointKind::Distance { min, max, spring } => {
                non_negative("distance min", *min)?;
                crate::error::finite("distance max", *max)?;
                if min > max {
                    return Err(invalid(format!("distance limits {min} > {max}")));
                }
                if let Some((rest, hz, zeta)) = spring {
                    non_negative("spring rest length", *rest)?;
                    positive("spring frequency", *hz)?;
                    non_negative("spring damping ratio", *zeta)?;
                }
            }
        }
        let (index, generation) = self.joints.insert(Joint::new(desc, ra, rb));
        self.wake_body(desc.a);
        self.wake_body(desc.b);
        Ok(JointHandle { index, generation })
    }

    /// Removes a joint.
    pub fn remove_joint(&mut self, h: JointHandle) -> Result<(), PhysicsError> {
        let j = self
            .joints
            .remove(h.index, h.generation)
            .ok_or(PhysicsError::UnknownJoint(h))?;
        self.wake_body(j.desc.a);
        self.wake_body(j.desc.b);
        Ok(())
    }

    /// A joint, or `None` for a stale handle.
    pub fn joint(&self, h: JointHandle) -> Option<&Joint> {
        self.joints.get(h.index, h.generation)
    }

    fn wake_body(&mut self, h: crate::handle::BodyHandle) {
        if let Some(b) = self.bodies.get_mut(h.index, h.generation) {
            b.wake();
        }
    }
}

impl World {
    /// Hangs a particle from a point on a body (`anchor`, body frame, m) by
    /// a damped spring: the particle is pulled by the body and the body by
    /// the particle. Dropped automatically when either end is removed. (A
    /// particle system stepped on the GPU is not coupled while it is there.)
    pub fn attach_particle(
        &mut self,
        particle: crate::handle::ParticleHandle,
        body: crate::handle::BodyHandle,
        anchor: DVec3,
        params: crate::spring::SpringParams,
    ) -> Result<crate::handle::AttachmentHandle, PhysicsError> {
        finite3("attachment anchor", anchor)?;
        params.validate()?;
        self.particle(particle)
            .ok_or(PhysicsError::UnknownParticle(particle))?;
        self.body(body).ok_or(PhysicsError::UnknownBody(body))?;
        let (index, generation) = self
            .attachments
            .insert(crate::rigid::attachment::Attachment {
                particle,
                body,
                anchor,
                params,
            });
        self.wake_body(body);
        Ok(crate::handle::AttachmentHandle { index, generation })
    }

    /// Removes a particle–body spring.
    pub fn detach_particle(
        &mut self,
        h: crate::handle::AttachmentHandle,
    ) -> Result<(), PhysicsError> {
        self.attachments
            .remove(h.index, h.generation)
            .map(|_| ())
            .ok_or(PhysicsError::UnknownAttachment(h))
    }
}
