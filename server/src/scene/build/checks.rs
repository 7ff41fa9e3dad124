//! The checks every value of a scene file passes, each error naming the
//! path of the entry it refuses.

use super::*;

pub(super) fn invalid(at: impl Into<String>, why: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        at: at.into(),
        why: why.into(),
    }
}

pub(super) fn physics(at: impl Into<String>) -> impl FnOnce(PhysicsError) -> SceneError {
    let at = at.into();
    move |source| SceneError::Physics { at, source }
}

pub(super) fn finite(at: &str, v: f64) -> Result<f64, SceneError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(invalid(at, format!("must be a finite number, got {v}")))
    }
}

pub(super) fn positive(at: &str, v: f64) -> Result<f64, SceneError> {
    finite(at, v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(at, format!("must be > 0, got {v}")))
    }
}

pub(super) fn non_negative(at: &str, v: f64) -> Result<f64, SceneError> {
    finite(at, v)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(invalid(at, format!("must be >= 0, got {v}")))
    }
}

pub(super) fn vec3(at: &str, v: Vec3) -> Result<DVec3, SceneError> {
    for (i, c) in v.iter().enumerate() {
        if !c.is_finite() {
            return Err(invalid(
                format!("{at}[{i}]"),
                format!("must be a finite number, got {c}"),
            ));
        }
    }
    Ok(DVec3::from_array(v))
}

pub(super) fn positive3(at: &str, v: Vec3) -> Result<DVec3, SceneError> {
    for (i, &c) in v.iter().enumerate() {
        positive(&format!("{at}[{i}]"), c)?;
    }
    Ok(DVec3::from_array(v))
}

pub(super) fn unit(at: &str, v: Vec3) -> Result<DVec3, SceneError> {
    let v = vec3(at, v)?;
    let len = v.length();
    if len > 1e-12 {
        Ok(v / len)
    } else {
        Err(invalid(at, "must not be the zero vector"))
    }
}

/// The quaternion a rotation spec stands for.
pub(crate) fn rotation(at: &str, r: Option<&Rotation>) -> Result<DQuat, SceneError> {
    let Some(r) = r else {
        return Ok(DQuat::IDENTITY);
    };
    match *r {
        Rotation::Quat(q) => {
            for (i, c) in q.iter().enumerate() {
                finite(&format!("{at}[{i}]"), *c)?;
            }
            let q = DQuat::from_array(q);
            let len = q.length();
            if (len - 1.0).abs() > 1e-6 {
                return Err(invalid(
                    at,
                    format!("a rotation quaternion must have length 1, got {len}"),
                ));
            }
            Ok(q / len)
        }
        Rotation::Euler(deg) => {
            let d = vec3(at, deg)?;
            Ok(DQuat::from_rotation_z(d.z.to_radians())
                * DQuat::from_rotation_y(d.y.to_radians())
                * DQuat::from_rotation_x(d.x.to_radians()))
        }
        Rotation::AxisAngle { axis, deg } => {
            let axis = unit(&format!("{at}.axis"), axis)?;
            let deg = finite(&format!("{at}.deg"), deg)?;
            Ok(DQuat::from_axis_angle(axis, deg.to_radians()))
        }
    }
}
