//! Triangle meshes for the shapes a server describes ([`ShapeDesc`]), in the
//! entity's own frame, m. Flat faces get one normal per face (their corners
//! are not shared); round surfaces get smooth normals.

use glam::{DVec3, Quat, Vec3};
use inertia_physics::rigid::shape::hull::ConvexHull;
use inertia_protocol::ShapeDesc;

/// One corner of a triangle, as the scene shader reads it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Position in the entity's frame, m.
    pub position: [f32; 3],
    /// Unit normal in the entity's frame.
    pub normal: [f32; 3],
}

/// An indexed triangle list, counter-clockwise seen from outside.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// The corners.
    pub vertices: Vec<Vertex>,
    /// Three indices into `vertices` per triangle.
    pub indices: Vec<u32>,
}

/// Segments around a ball or a cylinder.
const ROUND_SEGMENTS: u32 = 24;
/// Rings from pole to pole of a ball.
const BALL_RINGS: u32 = 14;
/// Segments and rings of a particle (many are drawn: kept coarse).
const PARTICLE_SEGMENTS: u32 = 8;
const PARTICLE_RINGS: u32 = 6;
/// Half the side of the square drawn for the infinite ground, m.
pub const GROUND_HALF_SIDE: f32 = 500.0;

impl Mesh {
    /// Triangles in the mesh.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    fn push(&mut self, position: Vec3, normal: Vec3) -> u32 {
        let i = self.vertices.len() as u32;
        self.vertices.push(Vertex {
            position: position.to_array(),
            normal: normal.normalize_or(Vec3::Y).to_array(),
        });
        i
    }

    /// A flat triangle with its own three corners.
    fn push_flat_triangle(&mut self, a: Vec3, b: Vec3, c: Vec3) {
        let n = (b - a).cross(c - a);
        // Degenerate (or not finite): nothing to draw.
        if n.length_squared().is_nan() || n.length_squared() <= 0.0 {
            return;
        }
        let i = self.push(a, n);
        self.push(b, n);
        self.push(c, n);
        self.indices.extend([i, i + 1, i + 2]);
    }

    /// Appends `other` moved by `offset` and turned by `rotation`.
    fn append(&mut self, other: &Mesh, offset: Vec3, rotation: Quat) {
        let base = self.vertices.len() as u32;
        self.vertices.extend(other.vertices.iter().map(|v| Vertex {
            position: (rotation * Vec3::from(v.position) + offset).to_array(),
            normal: (rotation * Vec3::from(v.normal)).to_array(),
        }));
        self.indices.extend(other.indices.iter().map(|i| base + i));
    }
}

/// The mesh that draws `shape`.
pub fn mesh_of(shape: &ShapeDesc) -> Mesh {
    match shape {
        ShapeDesc::Sphere { radius } => ball(*radius, 0.0, ROUND_SEGMENTS, BALL_RINGS),
        ShapeDesc::Particle { radius } => ball(*radius, 0.0, PARTICLE_SEGMENTS, PARTICLE_RINGS),
        ShapeDesc::Capsule {
            half_height,
            radius,
        } => ball(*radius, *half_height, ROUND_SEGMENTS, BALL_RINGS),
        ShapeDesc::Cuboid { half_extents } => cuboid(Vec3::from(*half_extents)),
        ShapeDesc::Cylinder {
            half_height,
            radius,
        } => cylinder(*half_height, *radius),
        ShapeDesc::ConvexHull { points } => hull(points),
        ShapeDesc::TriMesh {
            vertices,
            triangles,
        } => tri_mesh(vertices, triangles),
        ShapeDesc::Compound { parts } => {
            let mut out = Mesh::default();
            for (offset, rotation, part) in parts {
                let rotation = Quat::from_array(*rotation).normalize();
                let rotation = if rotation.is_finite() {
                    rotation
                } else {
                    Quat::IDENTITY
                };
                out.append(&mesh_of(part), Vec3::from(*offset), rotation);
            }
            out
        }
        ShapeDesc::Ground => ground(),
        ShapeDesc::HeightField {
            rows,
            cols,
            size,
            heights,
        } => height_field(*rows as usize, *cols as usize, *size, heights),
        // Drawn from its points each frame (`crate::point_sets`).
        ShapeDesc::PointSet { .. } => Mesh::default(),
    }
}

/// Terrain: one corner per sample, smooth normals from the neighbouring
/// samples, two triangles per cell. A field whose heights do not match its
/// rows and columns draws nothing.
fn height_field(rows: usize, cols: usize, size: [f32; 2], heights: &[f32]) -> Mesh {
    let mut mesh = Mesh::default();
    if rows < 2 || cols < 2 || heights.len() != rows * cols {
        return mesh;
    }
    let (dx, dz) = (size[0] / (cols - 1) as f32, size[1] / (rows - 1) as f32);
    let at = |r: usize, c: usize| {
        Vec3::new(
            c as f32 * dx - size[0] * 0.5,
            heights[r * cols + c],
            r as f32 * dz - size[1] * 0.5,
        )
    };
    for r in 0..rows {
        for c in 0..cols {
            // Central differences (one-sided at the edges).
            let (c0, c1) = (c.saturating_sub(1), (c + 1).min(cols - 1));
            let (r0, r1) = (r.saturating_sub(1), (r + 1).min(rows - 1));
            let along_x = at(r, c1) - at(r, c0);
            let along_z = at(r1, c) - at(r0, c);
            mesh.push(at(r, c), along_z.cross(along_x));
        }
    }
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let a = (r * cols + c) as u32;
            let (b, d, e) = (a + 1, a + cols as u32, a + cols as u32 + 1);
            mesh.indices.extend([a, d, b, b, d, e]);
        }
    }
    mesh
}

/// A ball of `radius`, or a capsule when `half_height` > 0 (the two
/// half-balls pulled apart along Y, joined by a tube).
fn ball(radius: f32, half_height: f32, segments: u32, rings: u32) -> Mesh {
    let radius = radius.max(1e-4);
    let mut mesh = Mesh::default();
    // Rings from the top pole down; a capsule repeats the equator ring so
    // the tube between the halves has its own (horizontal) normals.
    let mut ring_rows = Vec::new();
    for r in 0..=rings {
        let polar = std::f32::consts::PI * r as f32 / rings as f32;
        let lift = if r * 2 <= rings {
            half_height
        } else {
            -half_height
        };
        ring_rows.push((polar, lift));
        if half_height > 0.0 && r * 2 == rings {
            ring_rows.push((polar, -half_height));
        }
    }
    for &(polar, lift) in &ring_rows {
        for s in 0..=segments {
            let azimuth = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(
                polar.sin() * azimuth.cos(),
                polar.cos(),
                polar.sin() * azimuth.sin(),
            );
            mesh.push(n * radius + Vec3::Y * lift, n);
        }
    }
    let row = segments + 1;
    for r in 0..ring_rows.len() as u32 - 1 {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            mesh.indices.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    mesh
}

fn cuboid(h: Vec3) -> Mesh {
    let h = h.max(Vec3::splat(1e-4));
    let mut mesh = Mesh::default();
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // Two directions along the face, u × v = n.
            let u = Vec3::from_array(std::array::from_fn(|k| {
                if k == (axis + 1) % 3 {
                    1.0
                } else {
                    0.0
                }
            }));
            let v = n.cross(u);
            let centre = n * h;
            let corner = |a: f32, b: f32| centre + u * h * a + v * h * b;
            let i = mesh.push(corner(-1.0, -1.0), n);
            mesh.push(corner(1.0, -1.0), n);
            mesh.push(corner(1.0, 1.0), n);
            mesh.push(corner(-1.0, 1.0), n);
            mesh.indices.extend([i, i + 1, i + 2, i, i + 2, i + 3]);
        }
    }
    mesh
}

fn cylinder(half_height: f32, radius: f32) -> Mesh {
    let (h, r) = (half_height.max(1e-4), radius.max(1e-4));
    let mut mesh = Mesh::default();
    let around = |s: u32| {
        let a = std::f32::consts::TAU * s as f32 / ROUND_SEGMENTS as f32;
        Vec3::new(a.cos(), 0.0, a.sin())
    };
    // The side: a strip with outward normals.
    for s in 0..=ROUND_SEGMENTS {
        let n = around(s);
        mesh.push(n * r + Vec3::Y * h, n);
        mesh.push(n * r - Vec3::Y * h, n);
    }
    for s in 0..ROUND_SEGMENTS {
        let (top, bottom) = (2 * s, 2 * s + 1);
        mesh.indices
            .extend([top, top + 2, bottom, top + 2, bottom + 2, bottom]);
    }
    // The caps: fans about their centres.
    for sign in [1.0f32, -1.0] {
        let n = Vec3::Y * sign;
        let centre = mesh.push(n * h, n);
        for s in 0..ROUND_SEGMENTS {
            let a = mesh.push(around(s) * r + n * h, n);
            let b = mesh.push(around(s + 1) * r + n * h, n);
            if sign > 0.0 {
                mesh.indices.extend([centre, b, a]);
            } else {
                mesh.indices.extend([centre, a, b]);
            }
        }
    }
    mesh
}

/// The convex hull of `points`, flat shaded; a point cloud the hull
/// builder refuses (too few points, all in a plane) is drawn as its
/// bounding box.
fn hull(points: &[[f32; 3]]) -> Mesh {
    let as_f64: Vec<DVec3> = points.iter().map(|p| Vec3::from(*p).as_dvec3()).collect();
    match ConvexHull::from_points(&as_f64) {
        Ok(hull) => {
            let v = hull.vertices();
            let mut mesh = Mesh::default();
            for [a, b, c] in hull.triangles() {
                mesh.push_flat_triangle(
                    v[a as usize].as_vec3(),
                    v[b as usize].as_vec3(),
                    v[c as usize].as_vec3(),
                );
            }
            mesh
        }
        Err(_) => {
            let (lo, hi) = points.iter().fold(
                (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
                |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
            );
            if lo.x > hi.x {
                return Mesh::default();
            }
            let mut mesh = Mesh::default();
            mesh.append(&cuboid((hi - lo) * 0.5), (hi + lo) * 0.5, Quat::IDENTITY);
            mesh
        }
    }
}

/// A triangle mesh, flat shaded (drawn from both sides: scenery meshes are
/// often open). Triangles with an index out of range are skipped.
fn tri_mesh(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Mesh {
    let mut mesh = Mesh::default();
    for t in triangles {
        let [Some(a), Some(b), Some(c)] = t.map(|i| vertices.get(i as usize)) else {
            continue;
        };
        mesh.push_flat_triangle(Vec3::from(*a), Vec3::from(*b), Vec3::from(*c));
    }
    mesh
}

/// The ground plane, drawn as a large square about the origin.
fn ground() -> Mesh {
    let s = GROUND_HALF_SIDE;
    let mut mesh = Mesh::default();
    for (x, z) in [(-s, -s), (-s, s), (s, s), (s, -s)] {
        mesh.push(Vec3::new(x, 0.0, z), Vec3::Y);
    }
    mesh.indices.extend([0, 1, 2, 0, 2, 3]);
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle faces away from the shape's centre (the shapes here
    /// are convex and centred), and every normal is a unit vector.
    fn assert_outward(mesh: &Mesh) {
        assert!(!mesh.indices.is_empty());
        for v in &mesh.vertices {
            let n = Vec3::from(v.normal);
            assert!((n.length() - 1.0).abs() < 1e-4, "normal {n}");
        }
        for t in mesh.indices.chunks(3) {
            let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(mesh.vertices[t[k] as usize].position));
            let n = (b - a).cross(c - a);
            if n.length() < 1e-6 {
                continue; // a pole's degenerate corner
            }
            let centroid = (a + b + c) / 3.0;
            assert!(n.dot(centroid) > 0.0, "triangle {a} {b} {c} faces inwards");
        }
    }

    #[test]
    fn a_box_has_six_flat_faces_at_its_half_extents() {
        let mesh = mesh_of(&ShapeDesc::Cuboid {
            half_extents: [1.0, 2.0, 3.0],
        });
        assert_eq!(mesh.vertices.len(), 24);
        assert_eq!(mesh.triangle_count(), 12);
        for v in &mesh.vertices {
            let p = Vec3::from(v.position);
            assert_eq!(p.abs(), Vec3::new(1.0, 2.0, 3.0));
        }
        assert_outward(&mesh);
    }

    #[test]
    fn a_ball_lies_on_its_radius() {
        let mesh = mesh_of(&ShapeDesc::Sphere { radius: 0.5 });
        for v in &mesh.vertices {
            assert!((Vec3::from(v.position).length() - 0.5).abs() < 1e-5);
        }
        assert_outward(&mesh);
    }

    #[test]
    fn a_capsule_spans_its_segment_plus_its_radius() {
        let mesh = mesh_of(&ShapeDesc::Capsule {
            half_height: 1.0,
            radius: 0.25,
        });
        let top = mesh
            .vertices
            .iter()
            .map(|v| v.position[1])
            .fold(f32::MIN, f32::max);
        let widest = mesh
            .vertices
            .iter()
            .map(|v| Vec3::new(v.position[0], 0.0, v.position[2]).length())
            .fold(0.0, f32::max);
        assert!((top - 1.25).abs() < 1e-5, "top {top}");
        assert!((widest - 0.25).abs() < 1e-5, "widest {widest}");
        assert_outward(&mesh);
    }

    #[test]
    fn a_cylinder_is_closed_and_faces_out() {
        let mesh = mesh_of(&ShapeDesc::Cylinder {
            half_height: 0.5,
            radius: 1.0,
        });
        assert_outward(&mesh);
        // Side strip plus two capped fans.
        assert_eq!(mesh.triangle_count() as u32, 4 * ROUND_SEGMENTS);
    }

    #[test]
    fn a_hull_of_a_cube_s_corners_draws_a_cube() {
        let points: Vec<[f32; 3]> = (0..8)
            .map(|i| [0, 1, 2].map(|k| if i >> k & 1 == 1 { 1.0 } else { -1.0 }))
            .collect();
        let mesh = mesh_of(&ShapeDesc::ConvexHull { points });
        assert_eq!(mesh.triangle_count(), 12);
        assert_outward(&mesh);
    }

    #[test]
    fn a_flat_point_cloud_is_drawn_as_its_bounds_not_refused() {
        let points = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let mesh = mesh_of(&ShapeDesc::ConvexHull { points });
        assert_eq!(mesh.triangle_count(), 12);
    }

    #[test]
    fn a_tri_mesh_skips_triangles_that_point_past_its_vertices() {
        let mesh = mesh_of(&ShapeDesc::TriMesh {
            vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            triangles: vec![[0, 2, 1], [0, 1, 7]],
        });
        assert_eq!(mesh.triangle_count(), 1);
        assert_eq!(mesh.vertices[0].normal, [0.0, 1.0, 0.0]);
    }

    #[test]
    fn a_heightfield_spans_its_size_with_its_heights_and_faces_up() {
        let mesh = mesh_of(&ShapeDesc::HeightField {
            rows: 3,
            cols: 4,
            size: [6.0, 2.0],
            heights: vec![0.0, 0.5, 1.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.5, 1.0, 2.0],
        });
        assert_eq!(mesh.vertices.len(), 12);
        assert_eq!(mesh.triangle_count(), 2 * 2 * 3);
        assert_eq!(mesh.vertices[0].position, [-3.0, 0.0, -1.0]);
        assert_eq!(mesh.vertices[11].position, [3.0, 2.0, 1.0]);
        for v in &mesh.vertices {
            assert!(v.normal[1] > 0.0, "{:?} faces down", v.normal);
        }
        for t in mesh.indices.chunks(3) {
            let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(mesh.vertices[t[k] as usize].position));
            assert!((b - a).cross(c - a).y > 0.0, "a triangle faces down");
        }
        let bad = mesh_of(&ShapeDesc::HeightField {
            rows: 3,
            cols: 3,
            size: [1.0, 1.0],
            heights: vec![0.0; 4],
        });
        assert!(bad.indices.is_empty());
    }

    #[test]
    fn a_compound_places_its_parts() {
        let part = ShapeDesc::Sphere { radius: 0.1 };
        let mesh = mesh_of(&ShapeDesc::Compound {
            parts: vec![
                ([2.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], part.clone()),
                ([-2.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], part),
            ],
        });
        let xs: Vec<f32> = mesh.vertices.iter().map(|v| v.position[0]).collect();
        assert!(xs.iter().any(|&x| x > 1.8) && xs.iter().any(|&x| x < -1.8));
        assert!(mesh.vertices.iter().all(|v| v.position[0].is_finite()));
    }
}
