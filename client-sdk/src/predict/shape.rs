//! Entity descriptions back into engine shapes, for the local world.

use glam::DVec3;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_protocol::engine_shape::{body_shape, EngineShapeError};
use inertia_protocol::ShapeDesc;

/// Half the size of the box that stands in for an infinite ground plane,
/// m: far beyond any neighbourhood prediction looks at.
const GROUND_HALF_SIZE: f64 = 10_000.0;
/// Half the ground box's thickness, m.
const GROUND_HALF_THICKNESS: f64 = 1.0;

/// The engine shape a description stands for, with the pose of that shape
/// in the entity's frame (not the identity only for the ground, a box
/// whose top is the plane). `Ok(None)` for what does not collide: points
/// of soft bodies and fluids.
pub fn shape_of(desc: &ShapeDesc) -> Result<Option<(Shape, Pose)>, EngineShapeError> {
    match desc {
        ShapeDesc::Ground => {
            let half = DVec3::new(GROUND_HALF_SIZE, GROUND_HALF_THICKNESS, GROUND_HALF_SIZE);
            Ok(Some((
                Shape::cuboid(half)?,
                Pose::from_translation(DVec3::NEG_Y * GROUND_HALF_THICKNESS),
            )))
        }
        ShapeDesc::Particle { .. } | ShapeDesc::PointSet { .. } => Ok(None),
        body => Ok(Some((body_shape(body)?, Pose::IDENTITY))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ground_is_a_box_whose_top_is_the_plane() {
        let (shape, pose) = shape_of(&ShapeDesc::Ground).unwrap().unwrap();
        let b = shape.aabb(&pose);
        assert!(b.max.y.abs() < 1e-12 && b.min.y < 0.0);
        assert!(shape_of(&ShapeDesc::Particle { radius: 0.1 })
            .unwrap()
            .is_none());
        assert!(matches!(
            shape_of(&ShapeDesc::Capsule {
                half_height: 0.5,
                radius: 0.3
            }),
            Ok(Some((Shape::Capsule { .. }, _)))
        ));
    }
}
