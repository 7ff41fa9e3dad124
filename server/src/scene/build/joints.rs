//! Joints, made once every body exists so they may name any.

use super::*;

impl Builder {
    pub(super) fn joint(&mut self, j: PendingJoint) -> Result<(), SceneError> {
        let a = self.body_named(&format!("{}.a", j.at), &j.a)?;
        let b = self.body_named(&format!("{}.b", j.at), &j.b)?;
        if a == b {
            return Err(invalid(&j.at, "a joint needs two different bodies"));
        }
        let pa = self.world.body(a).map_or(Pose::IDENTITY, |b| b.pose());
        let pb = self.world.body(b).map_or(Pose::IDENTITY, |b| b.pose());
        let (ia, ib) = (pa.rotation.inverse(), pb.rotation.inverse());
        let kind = match j.kind {
            JointKind::Hinge {
                axis_a,
                limits,
                motor,
                ..
            } => JointKind::Hinge {
                axis_a: ia * axis_a,
                axis_b: ib * axis_a,
                limits,
                motor,
            },
            JointKind::SwingTwist {
                axis_a,
                swing_limit,
                twist_limits,
                ..
            } => JointKind::SwingTwist {
                axis_a: ia * axis_a,
                axis_b: ib * axis_a,
                swing_limit,
                twist_limits,
            },
            JointKind::Prismatic {
                axis_a,
                limits,
                motor,
            } => JointKind::Prismatic {
                axis_a: ia * axis_a,
                limits,
                motor,
            },
            k => k,
        };
        self.world
            .add_joint(JointDesc {
                a,
                b,
                anchor_a: pa.inverse_transform_point(j.anchor),
                anchor_b: pb.inverse_transform_point(j.anchor),
                kind,
                break_force: j.break_force,
            })
            .map_err(physics(j.at))?;
        Ok(())
    }

    /// A file joint as a pending joint (axes and anchor in world terms).
    pub(super) fn joint_spec(&self, at: &str, j: &JointSpec) -> Result<PendingJoint, SceneError> {
        let a = self.body_named(&format!("{at}.a"), &j.a)?;
        let b = self.body_named(&format!("{at}.b"), &j.b)?;
        let anchor = match j.anchor {
            Some(p) => vec3(&format!("{at}.anchor"), p)?,
            None => {
                let pa = self
                    .world
                    .body(a)
                    .map_or(DVec3::ZERO, |b| b.pose().translation);
                let pb = self
                    .world
                    .body(b)
                    .map_or(DVec3::ZERO, |b| b.pose().translation);
                (pa + pb) * 0.5
            }
        };
        let k = format!("{at}.kind");
        let pair = |f: &str, p: (f64, f64)| -> Result<(f64, f64), SceneError> {
            let lo = finite(&format!("{k}.{f}[0]"), p.0)?;
            let hi = finite(&format!("{k}.{f}[1]"), p.1)?;
            if lo > hi {
                return Err(invalid(
                    format!("{k}.{f}"),
                    format!("lower {lo} is above upper {hi}"),
                ));
            }
            Ok((lo, hi))
        };
        let motor = |p: (f64, f64), scale: f64| -> Result<(f64, f64), SceneError> {
            Ok((
                finite(&format!("{k}.motor[0]"), p.0)? * scale,
                non_negative(&format!("{k}.motor[1]"), p.1)?,
            ))
        };
        let kind = match j.kind {
            JointKindSpec::Ball => JointKind::Ball,
            JointKindSpec::Fixed => JointKind::Fixed,
            JointKindSpec::Hinge {
                axis,
                limits_deg,
                motor: m,
            } => JointKind::Hinge {
                axis_a: unit(&format!("{k}.axis"), axis)?,
                axis_b: DVec3::ZERO,
                limits: limits_deg
                    .map(|l| pair("limits_deg", l))
                    .transpose()?
                    .map(|(lo, hi)| (lo.to_radians(), hi.to_radians())),
                motor: m.map(|m| motor(m, 1f64.to_radians())).transpose()?,
            },
            JointKindSpec::SwingTwist {
                axis,
                swing_deg,
                twist_deg,
            } => {
                let twist = non_negative(&format!("{k}.twist_deg"), twist_deg)?.to_radians();
                JointKind::SwingTwist {
                    axis_a: unit(&format!("{k}.axis"), axis)?,
                    axis_b: DVec3::ZERO,
                    swing_limit: non_negative(&format!("{k}.swing_deg"), swing_deg)?.to_radians(),
                    twist_limits: (-twist, twist),
                }
            }
            JointKindSpec::Prismatic {
                axis,
                limits,
                motor: m,
            } => JointKind::Prismatic {
                axis_a: unit(&format!("{k}.axis"), axis)?,
                limits: limits.map(|l| pair("limits", l)).transpose()?,
                motor: m.map(|m| motor(m, 1.0)).transpose()?,
            },
            JointKindSpec::Distance { min, max } => {
                let (min, max) = pair("min", (min, max))?;
                non_negative(&format!("{k}.min"), min)?;
                JointKind::Distance {
                    min,
                    max,
                    spring: None,
                }
            }
        };
        Ok(PendingJoint {
            at: at.to_string(),
            a: j.a.clone(),
            b: j.b.clone(),
            anchor,
            kind,
            break_force: match j.break_force {
                Some(f) => positive(&format!("{at}.break_force"), f)?,
                None => f64::MAX,
            },
        })
    }
}
