//! Shape specs into physics shapes.

use super::*;

/// The physics shape of a shape spec; `solid` refuses surfaces (meshes).
pub(super) fn shape(at: &str, s: &ShapeSpec, nested: bool) -> Result<Shape, SceneError> {
    let shape_err = |e: inertia_physics::rigid::shape::ShapeError| invalid(at, e.to_string());
    match s {
        ShapeSpec::Sphere { radius } => {
            Shape::sphere(positive(&format!("{at}.radius"), *radius)?).map_err(shape_err)
        }
        ShapeSpec::Cuboid { half_extents } => {
            Shape::cuboid(positive3(&format!("{at}.half_extents"), *half_extents)?)
                .map_err(shape_err)
        }
        ShapeSpec::Capsule {
            half_height,
            radius,
        } => Shape::capsule(
            positive(&format!("{at}.half_height"), *half_height)?,
            positive(&format!("{at}.radius"), *radius)?,
        )
        .map_err(shape_err),
        ShapeSpec::Cylinder {
            half_height,
            radius,
        } => Shape::cylinder(
            positive(&format!("{at}.half_height"), *half_height)?,
            positive(&format!("{at}.radius"), *radius)?,
        )
        .map_err(shape_err),
        ShapeSpec::ConvexHull { points } => {
            if points.len() < 4 {
                return Err(invalid(
                    format!("{at}.points"),
                    format!("a hull needs at least 4 points, got {}", points.len()),
                ));
            }
            if points.len() > ShapeDesc::MAX_POINTS {
                return Err(invalid(
                    format!("{at}.points"),
                    format!("at most {} points", ShapeDesc::MAX_POINTS),
                ));
            }
            let pts = points
                .iter()
                .enumerate()
                .map(|(i, p)| vec3(&format!("{at}.points[{i}]"), *p))
                .collect::<Result<Vec<_>, _>>()?;
            Shape::convex_hull(&pts).map_err(|e| invalid(format!("{at}.points"), e.to_string()))
        }
        ShapeSpec::Compound { parts } => {
            if nested {
                return Err(invalid(at, "compounds cannot be nested"));
            }
            if parts.is_empty() || parts.len() > ShapeDesc::MAX_PARTS {
                return Err(invalid(
                    format!("{at}.parts"),
                    format!(
                        "need 1..={} parts, got {}",
                        ShapeDesc::MAX_PARTS,
                        parts.len()
                    ),
                ));
            }
            let mut out = Vec::with_capacity(parts.len());
            for (i, p) in parts.iter().enumerate() {
                let pat = format!("{at}.parts[{i}]");
                let pos = vec3(&format!("{pat}.position"), p.position)?;
                let rot = rotation(&format!("{pat}.rotation"), p.rotation.as_ref())?;
                let part = shape(&format!("{pat}.shape"), &p.shape, true)?;
                if matches!(part, Shape::TriMesh(_)) {
                    return Err(invalid(
                        format!("{pat}.shape"),
                        "a compound part must be solid (no meshes)",
                    ));
                }
                out.push((Pose::new(pos, rot), part));
            }
            Shape::compound(out).map_err(shape_err)
        }
        ShapeSpec::TriMesh {
            vertices,
            triangles,
        } => {
            if nested {
                return Err(invalid(at, "a compound part must be solid (no meshes)"));
            }
            if vertices.len() > ShapeDesc::MAX_POINTS || triangles.len() > ShapeDesc::MAX_POINTS {
                return Err(invalid(
                    at,
                    format!("at most {} vertices and triangles", ShapeDesc::MAX_POINTS),
                ));
            }
            let v = vertices
                .iter()
                .enumerate()
                .map(|(i, p)| vec3(&format!("{at}.vertices[{i}]"), *p))
                .collect::<Result<Vec<_>, _>>()?;
            Shape::trimesh(v, triangles.clone()).map_err(shape_err)
        }
    }
}
