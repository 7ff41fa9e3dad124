//! How a client draws a body: its entity kind and its shape's
//! description, within the protocol's limits.

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::BodyKind;
use inertia_physics::rigid::shape::{HeightField, Shape};
use inertia_protocol::{EntityKind, ShapeDesc};

/// The entity kind a body of `kind` is drawn as.
pub fn entity_kind(kind: BodyKind) -> EntityKind {
    match kind {
        BodyKind::Dynamic => EntityKind::Dynamic,
        BodyKind::Kinematic => EntityKind::Kinematic,
        BodyKind::Static => EntityKind::Static,
    }
}

/// How a client draws `shape`. Shapes beyond the protocol's limits (too
/// many points or parts, nested compounds) are drawn as their bounding
/// box; a heightfield of more samples than a description holds is thinned
/// ([`height_field_desc`]).
pub fn shape_desc(shape: &Shape) -> ShapeDesc {
    exact_shape_desc(shape, true).unwrap_or_else(|| bounding_box(shape))
}

fn f3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

fn exact_shape_desc(shape: &Shape, top: bool) -> Option<ShapeDesc> {
    Some(match shape {
        Shape::Sphere { radius } => ShapeDesc::Sphere {
            radius: *radius as f32,
        },
        Shape::Cuboid { half_extents } => ShapeDesc::Cuboid {
            half_extents: f3(*half_extents),
        },
        Shape::Capsule {
            half_height,
            radius,
        } => ShapeDesc::Capsule {
            half_height: *half_height as f32,
            radius: *radius as f32,
        },
        Shape::Cylinder {
            half_height,
            radius,
        } => ShapeDesc::Cylinder {
            half_height: *half_height as f32,
            radius: *radius as f32,
        },
        Shape::ConvexHull(hull) => {
            let v = hull.vertices();
            if v.len() > ShapeDesc::MAX_POINTS {
                return None;
            }
            ShapeDesc::ConvexHull {
                points: v.iter().map(|&p| f3(p)).collect(),
            }
        }
        Shape::TriMesh(mesh) => {
            if mesh.vertices().len() > ShapeDesc::MAX_POINTS
                || mesh.triangles().len() > ShapeDesc::MAX_POINTS
            {
                return None;
            }
            ShapeDesc::TriMesh {
                vertices: mesh.vertices().iter().map(|&p| f3(p)).collect(),
                triangles: mesh.triangles().to_vec(),
            }
        }
        Shape::HeightField(field) => height_field_desc(field),
        Shape::Compound(parts) => {
            if !top || parts.len() > ShapeDesc::MAX_PARTS {
                return None;
            }
            let mut out = Vec::with_capacity(parts.len());
            for (pose, part) in parts.iter() {
                let part = exact_shape_desc(part, false)?;
                out.push((
                    f3(pose.translation),
                    pose.rotation.as_quat().to_array(),
                    part,
                ));
            }
            ShapeDesc::Compound { parts: out }
        }
    })
}

/// A heightfield's description: every sample when they fit in
/// [`ShapeDesc::MAX_POINTS`], else every `step`-th row and column (the last
/// ones always kept, so the field keeps its size), the smallest step that
/// fits.
pub fn height_field_desc(field: &HeightField) -> ShapeDesc {
    let (rows, cols) = (field.rows(), field.cols());
    let picks = |n: usize, step: usize| -> Vec<usize> {
        let mut v: Vec<usize> = (0..n).step_by(step).collect();
        if v.last() != Some(&(n - 1)) {
            v.push(n - 1);
        }
        v
    };
    let mut step = 1;
    let (rs, cs) = loop {
        let (rs, cs) = (picks(rows, step), picks(cols, step));
        if rs.len() * cs.len() <= ShapeDesc::MAX_POINTS {
            break (rs, cs);
        }
        step += 1;
    };
    let scale = field.scale();
    let heights = rs
        .iter()
        .flat_map(|&r| cs.iter().map(move |&c| (r, c)))
        .map(|(r, c)| (field.heights()[r * cols + c] * scale.y) as f32)
        .collect();
    ShapeDesc::HeightField {
        rows: rs.len() as u32,
        cols: cs.len() as u32,
        size: [scale.x as f32, scale.z as f32],
        heights,
    }
}

fn bounding_box(shape: &Shape) -> ShapeDesc {
    let b = shape.local_aabb();
    let center = (b.min + b.max) * 0.5;
    let cuboid = ShapeDesc::Cuboid {
        half_extents: f3(((b.max - b.min) * 0.5).max(DVec3::splat(1e-3))),
    };
    if center.length() < 1e-9 {
        cuboid
    } else {
        ShapeDesc::Compound {
            parts: vec![(f3(center), [0.0, 0.0, 0.0, 1.0], cuboid)],
        }
    }
}
