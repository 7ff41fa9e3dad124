//! Soft bodies and fluids, drawn from their points each frame: a set's
//! triangles (cloth, a solid's surface) become one mesh in world
//! coordinates with smooth normals, its lines (a rope's segments) thin
//! square tubes in the same mesh, and a set with neither (a fluid) is drawn
//! as one small ball per point by the instanced path ([`crate::scene`]).

use glam::Vec3;
use inertia_client::point_sets::PointSetSample;

use crate::mesh::{Mesh, Vertex};

/// The mesh of a set's drawn triangles and lines, world coordinates, m.
/// Both faces of a cloth are lit alike (the scene pipeline does not cull,
/// and the shader lights the face towards the eye).
pub fn surface_of(set: &PointSetSample<'_>) -> Mesh {
    let mut mesh = Mesh::default();
    let normals = set.normals();
    // Only the points a drawn triangle uses become vertices.
    let mut slot = vec![u32::MAX; set.positions.len()];
    for t in set.drawn_triangles() {
        for i in t {
            let i = i as usize;
            if slot[i] == u32::MAX {
                slot[i] = mesh.vertices.len() as u32;
                mesh.vertices.push(Vertex {
                    position: set.positions[i].to_array(),
                    normal: normals[i].normalize_or(Vec3::Y).to_array(),
                });
            }
            mesh.indices.push(slot[i]);
        }
    }
    let radius = set.radius().max(0.005);
    for [a, b] in set.drawn_lines() {
        tube(
            &mut mesh,
            set.positions[a as usize],
            set.positions[b as usize],
            radius,
        );
    }
    mesh
}

/// A square tube of half-width `r` from `a` to `b` (four flat sides, open
/// ends: neighbouring segments meet).
fn tube(mesh: &mut Mesh, a: Vec3, b: Vec3, r: f32) {
    let axis = b - a;
    if !axis.is_finite() || axis.length_squared() < 1e-12 {
        return;
    }
    let (u, v) = axis.normalize().any_orthonormal_pair();
    let sides = [(u, v), (v, -u), (-u, -v), (-v, u)];
    for (normal, across) in sides {
        let base = mesh.vertices.len() as u32;
        for corner in [
            a + (normal - across) * r,
            a + (normal + across) * r,
            b + (normal + across) * r,
            b + (normal - across) * r,
        ] {
            mesh.vertices.push(Vertex {
                position: corner.to_array(),
                normal: normal.to_array(),
            });
        }
        mesh.indices
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_protocol::{EntityDesc, EntityKind, ShapeDesc};

    fn set_desc(triangles: Vec<[u32; 3]>, lines: Vec<[u32; 2]>) -> EntityDesc {
        EntityDesc {
            id: 1,
            kind: EntityKind::SoftBody,
            shape: ShapeDesc::PointSet {
                points: 4,
                radius: 0.02,
                triangles,
                lines,
            },
            color: [255; 4],
            owner: None,
            name: String::new(),
            position: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }

    fn frame_of(desc: &EntityDesc, present: [bool; 4]) -> PointSetSample<'_> {
        PointSetSample {
            id: 1,
            desc,
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(1.0, 0.0, 1.0)],
            present: present.to_vec(),
        }
    }

    #[test]
    fn a_cloth_becomes_its_known_triangles_with_shared_smooth_corners() {
        let desc = set_desc(vec![[0, 2, 1], [1, 2, 3]], vec![]);
        let mesh = surface_of(&frame_of(&desc, [true; 4]));
        assert_eq!(mesh.triangle_count(), 2);
        assert_eq!(mesh.vertices.len(), 4, "corners shared");
        for v in &mesh.vertices {
            assert!((Vec3::from(v.normal) - Vec3::Y).length() < 1e-6);
        }
        // A point not known takes its triangles with it.
        let mesh = surface_of(&frame_of(&desc, [true, true, true, false]));
        assert_eq!(mesh.triangle_count(), 1);
        assert_eq!(mesh.vertices.len(), 3);
    }

    #[test]
    fn a_rope_becomes_tubes_along_its_lines() {
        let desc = set_desc(vec![], vec![[0, 1], [1, 3], [3, 3]]);
        let mesh = surface_of(&frame_of(&desc, [true; 4]));
        // Two segments of four sides, two triangles a side; the segment
        // of no length draws nothing.
        assert_eq!(mesh.triangle_count(), 16);
        for v in &mesh.vertices {
            assert!(Vec3::from(v.position).is_finite());
            assert!((Vec3::from(v.normal).length() - 1.0).abs() < 1e-5);
        }
    }
}
