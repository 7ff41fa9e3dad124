//! Volumetric soft bodies: a box, a sphere or a closed triangle mesh
//! filled with tetrahedra.
//!
//! The shape is sampled on a grid of cubes of side `cell`: every cube
//! whose centre lies inside becomes six tetrahedra around its main
//! diagonal (the Kuhn split, the same in every cube, so neighbouring
//! cubes share their faces' triangles and the mesh is conforming). Every
//! edge of a tetrahedron is a distance constraint and every tetrahedron a
//! volume constraint (as in Müller et al.'s tetrahedral XPBD soft bodies);
//! the faces that belong to one tetrahedron only are the surface. A
//! sphere's surface vertices are then moved onto the sphere where that
//! leaves every tetrahedron right side out.

use std::collections::BTreeMap;

use glam::{DQuat, DVec3};

use crate::error::{finite3, non_negative, positive, PhysicsError};

use super::{constraints::tet_volume, EdgeDesc, SoftBodyDesc, SoftMaterial, TetDesc};

/// What a volumetric soft body fills.
#[derive(Debug, Clone, PartialEq)]
pub enum SolidShape {
    /// A box of these half extents, m.
    Box {
        /// Half extents, m.
        half_extents: DVec3,
    },
    /// A ball of this radius, m.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// The inside of a closed triangle mesh (vertices in m, in the body's
    /// frame).
    Mesh {
        /// Vertices, m.
        vertices: Vec<DVec3>,
        /// Triangles (any winding; inside is found by ray parity).
        triangles: Vec<[u32; 3]>,
    },
}

/// A volumetric soft body: a jelly, a rubber bar.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftSolid {
    /// What it fills.
    pub shape: SolidShape,
    /// Where its frame's origin stands, m.
    pub position: DVec3,
    /// Its frame's orientation.
    pub rotation: DQuat,
    /// The side of the grid's cubes, m.
    pub cell: f64,
    /// Density, kg/m³.
    pub density: f64,
    /// Compliance of the edges, m/N.
    pub edge_compliance: f64,
    /// Compliance of the volumes, 1/Pa; 0 = incompressible.
    pub volume_compliance: f64,
    /// How it moves as a whole.
    pub material: SoftMaterial,
}

impl Default for SoftSolid {
    fn default() -> Self {
        Self {
            shape: SolidShape::Box {
                half_extents: DVec3::splat(0.5),
            },
            position: DVec3::ZERO,
            rotation: DQuat::IDENTITY,
            cell: 0.1,
            density: 1000.0,
            edge_compliance: 1e-6,
            volume_compliance: 0.0,
            material: SoftMaterial::default(),
        }
    }
}

/// Most grid cells a solid is sampled on.
const MAX_CELLS: usize = 1 << 21;

/// The Kuhn split of a cube into six tetrahedra around the diagonal from
/// corner 0 to corner 7 (corner `k` is at `(k & 1, k >> 1 & 1, k >> 2 & 1)`).
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

impl SoftSolid {
    /// The solid's description.
    pub fn build(&self) -> Result<SoftBodyDesc, PhysicsError> {
        finite3("solid position", self.position)?;
        positive("solid cell", self.cell)?;
        positive("solid density", self.density)?;
        non_negative("solid edge compliance", self.edge_compliance)?;
        non_negative("solid volume compliance", self.volume_compliance)?;
        let rotation = crate::rigid::body::checked_rotation(self.rotation)?;
        let (lo, hi, inside): (DVec3, DVec3, Box<dyn Fn(DVec3) -> bool>) = match &self.shape {
            SolidShape::Box { half_extents } => {
                finite3("solid half extents", *half_extents)?;
                if half_extents.min_element() <= 0.0 {
                    return Err(PhysicsError::Invalid {
                        what: "solid box",
                        why: format!("half extents {half_extents} must be > 0"),
                    });
                }
                let h = *half_extents;
                (-h, h, Box::new(move |p: DVec3| p.abs().cmple(h).all()))
            }
            SolidShape::Sphere { radius } => {
                positive("solid sphere radius", *radius)?;
                let r = *radius;
                (
                    DVec3::splat(-r),
                    DVec3::splat(r),
                    Box::new(move |p: DVec3| p.length() <= r),
                )
            }
            SolidShape::Mesh {
                vertices,
                triangles,
            } => {
                let (lo, hi) = mesh_bounds(vertices, triangles)?;
                let (v, t) = (vertices.clone(), triangles.clone());
                (lo, hi, Box::new(move |p: DVec3| inside_mesh(&v, &t, p)))
            }
        };
        let cell = self.cell;
        let dims = ((hi - lo) / cell).round().max(DVec3::ONE);
        let (nx, ny, nz) = (dims.x as usize, dims.y as usize, dims.z as usize);
        if nx.saturating_mul(ny).saturating_mul(nz) > MAX_CELLS {
            return Err(PhysicsError::Invalid {
                what: "solid cell",
                why: format!("{nx} × {ny} × {nz} cells is more than {MAX_CELLS}: use larger cells"),
            });
        }
        // The cubes fill the bounds exactly.
        let step = (hi - lo) / DVec3::new(nx as f64, ny as f64, nz as f64);
        let corner =
            |i: usize, j: usize, k: usize| lo + DVec3::new(i as f64, j as f64, k as f64) * step;
        let mut vertex_of: BTreeMap<(usize, usize, usize), u32> = BTreeMap::new();
        let mut local = Vec::new();
        let mut tets = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let centre = corner(i, j, k) + step * 0.5;
                    if !inside(centre) {
                        continue;
                    }
                    let ids: Vec<u32> = (0..8)
                        .map(|c| {
                            let key = (i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1));
                            *vertex_of.entry(key).or_insert_with(|| {
                                local.push(corner(key.0, key.1, key.2));
                                (local.len() - 1) as u32
                            })
                        })
                        .collect();
                    for t in KUHN {
                        tets.push(t.map(|c| ids[c]));
                    }
                }
            }
        }
        if tets.is_empty() {
            return Err(PhysicsError::Invalid {
                what: "solid",
                why: format!("no cell of {cell} m lies inside the shape: use smaller cells"),
            });
        }
        // Right side out (the split's orientation is the same in every cube).
        let positions32: Vec<glam::Vec3> = local.iter().map(|p| p.as_vec3()).collect();
        for t in &mut tets {
            if tet_volume(t.map(|i| positions32[i as usize])) < 0.0 {
                t.swap(2, 3);
            }
        }
        let surface = surface_of(&tets);
        if let SolidShape::Sphere { radius } = self.shape {
            snap_to_sphere(&mut local, &tets, &surface, radius);
        }
        let mut masses = vec![0.0; local.len()];
        for t in &tets {
            let v = tet_volume(t.map(|i| local[i as usize].as_vec3())) as f64;
            for i in t {
                masses[*i as usize] += self.density * v / 4.0;
            }
        }
        let mut edges = Vec::new();
        let mut seen = std::collections::BTreeSet::new();
        for t in &tets {
            for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                let (p, q) = (t[a].min(t[b]), t[a].max(t[b]));
                if seen.insert((p, q)) {
                    edges.push(EdgeDesc {
                        particles: [p, q],
                        compliance: self.edge_compliance,
                    });
                }
            }
        }
        let positions = local
            .iter()
            .map(|p| self.position + rotation * *p)
            .collect();
        Ok(SoftBodyDesc {
            positions,
            masses,
            edges,
            tetrahedra: tets
                .into_iter()
                .map(|particles| TetDesc {
                    particles,
                    compliance: self.volume_compliance,
                })
                .collect(),
            triangles: surface,
            material: self.material.clone(),
            ..SoftBodyDesc::default()
        })
    }
}

/// The faces of `tets` that belong to one tetrahedron only, each
/// counter-clockwise seen from outside.
fn surface_of(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut faces: BTreeMap<[u32; 3], (usize, [u32; 3])> = BTreeMap::new();
    for t in tets {
        // The faces of a right-handed tetrahedron, each wound so that its
        // normal points away from the vertex it does not hold.
        for f in [
            [t[1], t[2], t[3]],
            [t[0], t[3], t[2]],
            [t[0], t[1], t[3]],
            [t[0], t[2], t[1]],
        ] {
            let mut key = f;
            key.sort_unstable();
            faces.entry(key).or_insert((0, f)).0 += 1;
        }
    }
    faces
        .into_values()
        .filter(|(count, _)| *count == 1)
        .map(|(_, f)| f)
        .collect()
}

/// Moves the surface vertices radially onto the sphere, keeping each move
/// only if every tetrahedron stays right side out.
fn snap_to_sphere(local: &mut [DVec3], tets: &[[u32; 4]], surface: &[[u32; 3]], radius: f64) {
    let mut on_surface: Vec<u32> = surface.iter().flatten().copied().collect();
    on_surface.sort_unstable();
    on_surface.dedup();
    let before = local.to_vec();
    for &i in &on_surface {
        let p = local[i as usize];
        if p.length() > 1e-9 {
            local[i as usize] = p * (radius / p.length());
        }
    }
    let ok = tets.iter().all(|t| {
        let v = tet_volume(t.map(|i| local[i as usize].as_vec3()));
        let v0 = tet_volume(t.map(|i| before[i as usize].as_vec3()));
        v > 0.1 * v0
    });
    if !ok {
        local.copy_from_slice(&before);
    }
}

fn mesh_bounds(vertices: &[DVec3], triangles: &[[u32; 3]]) -> Result<(DVec3, DVec3), PhysicsError> {
    if vertices.is_empty() || triangles.len() < 4 {
        return Err(PhysicsError::Invalid {
            what: "solid mesh",
            why: "a closed mesh needs at least four triangles".into(),
        });
    }
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for v in vertices {
        finite3("solid mesh vertex", *v)?;
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    for t in triangles {
        if t.iter().any(|&i| i as usize >= vertices.len()) {
            return Err(PhysicsError::Invalid {
                what: "solid mesh",
                why: format!("triangle {t:?} names a vertex past {}", vertices.len()),
            });
        }
    }
    if (hi - lo).min_element() <= 0.0 {
        return Err(PhysicsError::Invalid {
            what: "solid mesh",
            why: "the mesh is flat: it encloses no volume".into(),
        });
    }
    Ok((lo, hi))
}

/// Whether `p` lies inside the closed mesh: the parity of the crossings
/// of a ray from `p` (in a fixed, slightly skewed direction, so it does
/// not graze edges of axis-aligned meshes).
fn inside_mesh(vertices: &[DVec3], triangles: &[[u32; 3]], p: DVec3) -> bool {
    let dir = DVec3::new(1.0, 0.000_123_7, 0.000_071_3).normalize();
    let mut crossings = 0;
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        // Möller–Trumbore.
        let e1 = b - a;
        let e2 = c - a;
        let q = dir.cross(e2);
        let det = e1.dot(q);
        if det.abs() < 1e-14 {
            continue;
        }
        let s = p - a;
        let u = s.dot(q) / det;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let r = s.cross(e1);
        let v = dir.dot(r) / det;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        if e2.dot(r) / det > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}
