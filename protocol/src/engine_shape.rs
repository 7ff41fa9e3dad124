//! Entity shapes as the engine builds them (feature `physics`): the
//! inverse of the server's `scene::shape_desc`. The server builds the
//! bodies operators spawn from their descriptions with it, and the SDK's
//! prediction the bodies it collides with.

use glam::{DQuat, DVec3};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::{Shape, ShapeError};

use crate::entity::ShapeDesc;

/// Why a description does not make a body shape.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EngineShapeError {
    /// The engine refused the shape (a size, a mesh).
    #[error(transparent)]
    Shape(#[from] ShapeError),
    /// A description of something other than a body's shape.
    #[error("{0} is not a body shape")]
    NotABody(&'static str),
    /// A compound inside a compound.
    #[error("compounds do not nest")]
    NestedCompound,
    /// A compound part turned by something that is not a rotation.
    #[error("a compound part's rotation is not a rotation")]
    BadRotation,
}

fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]))
}

/// The engine shape of a body described by `desc`. The ground plane,
/// particles and point sets (soft bodies, fluids) are not body shapes.
pub fn body_shape(desc: &ShapeDesc) -> Result<Shape, EngineShapeError> {
    let shape = match desc {
        ShapeDesc::Sphere { radius } => Shape::sphere(f64::from(*radius))?,
        ShapeDesc::Cuboid { half_extents } => Shape::cuboid(v3(*half_extents))?,
        ShapeDesc::Capsule {
            half_height,
            radius,
        } => Shape::capsule(f64::from(*half_height), f64::from(*radius))?,
        ShapeDesc::Cylinder {
            half_height,
            radius,
        } => Shape::cylinder(f64::from(*half_height), f64::from(*radius))?,
        ShapeDesc::ConvexHull { points } => {
            Shape::convex_hull(&points.iter().map(|&p| v3(p)).collect::<Vec<_>>())?
        }
        ShapeDesc::TriMesh {
            vertices,
            triangles,
        } => Shape::trimesh(vertices.iter().map(|&p| v3(p)).collect(), triangles.clone())?,
        ShapeDesc::HeightField {
            rows,
            cols,
            size,
            heights,
        } => Shape::heightfield(
            heights.iter().map(|&h| f64::from(h)).collect(),
            *rows as usize,
            *cols as usize,
            DVec3::new(f64::from(size[0]), 1.0, f64::from(size[1])),
        )?,
        ShapeDesc::Compound { parts } => {
            let mut out = Vec::with_capacity(parts.len());
            for (offset, rotation, part) in parts {
                if matches!(part, ShapeDesc::Compound { .. }) {
                    return Err(EngineShapeError::NestedCompound);
                }
                let q = DQuat::from_array(rotation.map(f64::from));
                if !q.is_finite() || q.length() < 1e-6 {
                    return Err(EngineShapeError::BadRotation);
                }
                let pose = Pose {
                    translation: v3(*offset),
                    rotation: q.normalize(),
                };
                out.push((pose, body_shape(part)?));
            }
            Shape::compound(out)?
        }
        ShapeDesc::Ground => return Err(EngineShapeError::NotABody("a ground plane")),
        ShapeDesc::Particle { .. } => return Err(EngineShapeError::NotABody("a particle")),
        ShapeDesc::PointSet { .. } => {
            return Err(EngineShapeError::NotABody(
                "a point set (soft body or fluid)",
            ))
        }
    };
    Ok(shape)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_make_the_shapes_they_describe_and_refuse_the_rest() {
        let ball = body_shape(&ShapeDesc::Sphere { radius: 0.5 }).unwrap();
        assert!(
            matches!(ball, Shape::Sphere { radius } if radius == 0.5),
            "{ball:?}"
        );
        let part = ShapeDesc::Cuboid {
            half_extents: [0.1, 0.2, 0.3],
        };
        let compound = ShapeDesc::Compound {
            parts: vec![([1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], part.clone())],
        };
        assert!(body_shape(&compound).is_ok());
        let turned_by_nothing = ShapeDesc::Compound {
            parts: vec![([0.0; 3], [0.0; 4], part)],
        };
        assert_eq!(
            body_shape(&turned_by_nothing),
            Err(EngineShapeError::BadRotation)
        );
        assert_eq!(
            body_shape(&ShapeDesc::Ground),
            Err(EngineShapeError::NotABody("a ground plane"))
        );
        assert!(matches!(
            body_shape(&ShapeDesc::Sphere { radius: -1.0 }),
            Err(EngineShapeError::Shape(_))
        ));
    }
}
