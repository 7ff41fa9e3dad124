//! A humanoid ragdoll: eleven bodies (pelvis, torso, head, upper and lower
//! arms and legs) joined by swing-twist joints at the spine, neck,
//! shoulders and hips and limited hinges at the elbows and knees.
//!
//! Proportions are those of a 1.8 m adult, scaled to the requested height;
//! the mass is spread by volume. The limits keep the pose anatomically
//! plausible (knees and elbows bend one way, heads do not spin), which is
//! what keeps a falling ragdoll from folding into itself.

use glam::{DQuat, DVec3};

use crate::error::{positive, PhysicsError};
use crate::handle::{BodyHandle, JointHandle};
use crate::rigid::body::RigidBodyDesc;
use crate::rigid::joint::{JointDesc, JointKind};
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;
use crate::world::World;

/// How to build a ragdoll.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RagdollDesc {
    /// Where the ragdoll stands: its feet at the origin of this pose, facing +Z.
    pub pose: Pose,
    /// Standing height, m.
    pub height: f64,
    /// Total mass, kg.
    pub mass: f64,
}

impl Default for RagdollDesc {
    fn default() -> Self {
        Self {
            pose: Pose::IDENTITY,
            height: 1.8,
            mass: 75.0,
        }
    }
}

/// The bodies and joints of a built ragdoll.
#[derive(Debug, Clone, PartialEq)]
pub struct Ragdoll {
    /// Bodies by part name, from the pelvis out.
    pub bodies: Vec<(&'static str, BodyHandle)>,
    /// The ten joints.
    pub joints: Vec<JointHandle>,
}

struct Part {
    name: &'static str,
    shape: Shape,
    center: DVec3,
    rotation: DQuat,
}

/// Builds a ragdoll.
pub fn build_ragdoll(world: &mut World, desc: &RagdollDesc) -> Result<Ragdoll, PhysicsError> {
    positive("ragdoll height", desc.height)?;
    positive("ragdoll mass", desc.mass)?;
    let s = desc.height / 1.8;
    let shape_err = |e: crate::rigid::shape::ShapeError| PhysicsError::Invalid {
        what: "ragdoll",
        why: e.to_string(),
    };
    let along_x = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) * s;
    let capsule = |hh: f64, r: f64| Shape::capsule(hh * s, r * s).map_err(shape_err);
    let mut parts = vec![
        Part {
            name: "pelvis",
            shape: Shape::cuboid(v(0.15, 0.09, 0.1)).map_err(shape_err)?,
            center: v(0.0, 1.0, 0.0),
            rotation: DQuat::IDENTITY,
        },
        Part {
            name: "torso",
            shape: Shape::cuboid(v(0.17, 0.19, 0.1)).map_err(shape_err)?,
            center: v(0.0, 1.31, 0.0),
            rotation: DQuat::IDENTITY,
        },
        Part {
            name: "head",
            shape: Shape::sphere(0.11 * s).map_err(shape_err)?,
            center: v(0.0, 1.66, 0.0),
            rotation: DQuat::IDENTITY,
        },
    ];
    let names = [
        (
            "upper_arm_left",
            "lower_arm_left",
            "upper_leg_left",
            "lower_leg_left",
            1.0,
        ),
        (
            "upper_arm_right",
            "lower_arm_right",
            "upper_leg_right",
            "lower_leg_right",
            -1.0,
        ),
    ];
    for (ua, la, ul, ll, x) in names {
        parts.push(Part {
            name: ua,
            shape: capsule(0.12, 0.05)?,
            center: v(x * 0.34, 1.44, 0.0),
            rotation: along_x,
        });
        parts.push(Part {
            name: la,
            shape: capsule(0.12, 0.045)?,
            center: v(x * 0.62, 1.44, 0.0),
            rotation: along_x,
        });
        parts.push(Part {
            name: ul,
            shape: capsule(0.17, 0.07)?,
            center: v(x * 0.1, 0.7, 0.0),
            rotation: DQuat::IDENTITY,
        });
        parts.push(Part {
            name: ll,
            shape: capsule(0.17, 0.055)?,
            center: v(x * 0.1, 0.27, 0.0),
            rotation: DQuat::IDENTITY,
        });
    }
    let volume: f64 = parts.iter().filter_map(|p| p.shape.volume()).sum();
    let density = desc.mass / volume;
    let mut bodies = Vec::with_capacity(parts.len());
    for p in &parts {
        let pose = desc.pose.mul(&Pose::new(p.center, p.rotation));
        let mut d = RigidBodyDesc::dynamic(p.shape.clone(), density, pose)?;
        d.angular_damping = 0.5;
        bodies.push(world.add_body(&d)?);
    }
    let index = |name: &str| parts.iter().position(|p| p.name == name).unwrap_or(0);
    let mut joints = Vec::new();
    let mut join = |world: &mut World,
                    a: &str,
                    b: &str,
                    at: DVec3,
                    kind: JointKind|
     -> Result<(), PhysicsError> {
        let (ha, hb) = (bodies[index(a)], bodies[index(b)]);
        let at = desc.pose.transform_point(at);
        let pa = world.body(ha).ok_or(PhysicsError::UnknownBody(ha))?.pose();
        let pb = world.body(hb).ok_or(PhysicsError::UnknownBody(hb))?.pose();
        // Axes are given in the standing frame; express them in each body's frame.
        let to_bodies = |axis: DVec3| {
            let w = desc.pose.rotation * axis;
            (pa.rotation.inverse() * w, pb.rotation.inverse() * w)
        };
        let kind = match kind {
            JointKind::Hinge {
                axis_a,
                limits,
                motor,
                ..
            } => {
                let (axis_a, axis_b) = to_bodies(axis_a);
                JointKind::Hinge {
                    axis_a,
                    axis_b,
                    limits,
                    motor,
                }
            }
            JointKind::SwingTwist {
                axis_a,
                swing_limit,
                twist_limits,
                ..
            } => {
                let (axis_a, axis_b) = to_bodies(axis_a);
                JointKind::SwingTwist {
                    axis_a,
                    axis_b,
                    swing_limit,
                    twist_limits,
                }
            }
            k => k,
        };
        joints.push(world.add_joint(JointDesc {
            a: ha,
            b: hb,
            anchor_a: pa.inverse_transform_point(at),
            anchor_b: pb.inverse_transform_point(at),
            kind,
            break_force: f64::MAX,
        })?);
        Ok(())
    };
    let st = |axis: DVec3, swing: f64, twist: f64| JointKind::SwingTwist {
        axis_a: axis,
        axis_b: axis,
        swing_limit: swing,
        twist_limits: (-twist, twist),
    };
    let hinge = |axis: DVec3, lo: f64, hi: f64| JointKind::Hinge {
        axis_a: axis,
        axis_b: axis,
        limits: Some((lo, hi)),
        motor: None,
    };
    join(
        world,
        "pelvis",
        "torso",
        v(0.0, 1.1, 0.0),
        st(DVec3::Y, 0.5, 0.4),
    )?;
    join(
        world,
        "torso",
        "head",
        v(0.0, 1.53, 0.0),
        st(DVec3::Y, 0.6, 0.9),
    )?;
    for (ua, la, ul, ll, x) in names {
        join(
            world,
            "torso",
            ua,
            v(x * 0.2, 1.44, 0.0),
            st(DVec3::X * x, 1.4, 0.8),
        )?;
        join(
            world,
            ua,
            la,
            v(x * 0.48, 1.44, 0.0),
            hinge(DVec3::Y * x, 0.0, 2.5),
        )?;
        join(
            world,
            "pelvis",
            ul,
            v(x * 0.1, 0.89, 0.0),
            st(DVec3::NEG_Y, 1.2, 0.5),
        )?;
        join(
            world,
            ul,
            ll,
            v(x * 0.1, 0.5, 0.0),
            hinge(DVec3::X, -2.5, 0.0),
        )?;
    }
    Ok(Ragdoll {
        bodies: parts
            .iter()
            .map(|p| p.name)
            .zip(bodies.iter().copied())
            .collect(),
        joints,
    })
}
