//! Builders of soft bodies made of lines and sheets: ropes and cloth.

use std::collections::BTreeMap;

use glam::DVec3;

use crate::error::{finite3, non_negative, positive, PhysicsError};

use super::{EdgeDesc, HingeDesc, SoftBodyDesc, SoftMaterial, TetherDesc};

/// A rope: a chain of particles joined by distance constraints.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftRope {
    /// First end, m.
    pub start: DVec3,
    /// Other end, m.
    pub end: DVec3,
    /// Segments (particles = segments + 1), >= 1.
    pub segments: u32,
    /// Total mass, kg.
    pub mass: f64,
    /// Compliance of each segment, m/N; 0 = inextensible.
    pub compliance: f64,
    /// Pin the first particle.
    pub pin_start: bool,
    /// Pin the last particle.
    pub pin_end: bool,
    /// Every particle tethered to the pinned end(s) at its distance along
    /// the rope (long-range attachments): however heavy the load, the
    /// rope does not stretch away from its pins.
    pub tethers: bool,
    /// How it moves as a whole.
    pub material: SoftMaterial,
}

impl Default for SoftRope {
    fn default() -> Self {
        Self {
            start: DVec3::ZERO,
            end: DVec3::X,
            segments: 10,
            mass: 1.0,
            compliance: 0.0,
            pin_start: true,
            pin_end: false,
            tethers: true,
            material: SoftMaterial::default(),
        }
    }
}

impl SoftRope {
    /// The rope's description (particle `k` is the `k`-th from `start`).
    pub fn build(&self) -> Result<SoftBodyDesc, PhysicsError> {
        finite3("rope start", self.start)?;
        finite3("rope end", self.end)?;
        positive("rope mass", self.mass)?;
        non_negative("rope compliance", self.compliance)?;
        if self.segments == 0 || self.segments as usize >= super::MAX_SOFT_PARTICLES {
            return Err(PhysicsError::Invalid {
                what: "rope segments",
                why: format!(
                    "{} is not within 1..{}",
                    self.segments,
                    super::MAX_SOFT_PARTICLES
                ),
            });
        }
        let n = self.segments as usize + 1;
        let m = self.mass / n as f64;
        let positions: Vec<DVec3> = (0..n)
            .map(|k| self.start.lerp(self.end, k as f64 / self.segments as f64))
            .collect();
        let mut masses = vec![m; n];
        if self.pin_start {
            masses[0] = 0.0;
        }
        if self.pin_end {
            masses[n - 1] = 0.0;
        }
        let edges = (0..self.segments)
            .map(|k| EdgeDesc {
                particles: [k, k + 1],
                compliance: self.compliance,
            })
            .collect();
        let mut tethers = Vec::new();
        if self.tethers {
            for k in 1..n - 1 {
                for (pinned, anchor) in [(self.pin_start, 0), (self.pin_end, n - 1)] {
                    if pinned {
                        tethers.push(TetherDesc {
                            particle: k as u32,
                            anchor: anchor as u32,
                            slack: 0.0,
                        });
                    }
                }
            }
            if self.pin_start && !self.pin_end {
                tethers.push(TetherDesc {
                    particle: (n - 1) as u32,
                    anchor: 0,
                    slack: 0.0,
                });
            }
            if self.pin_end && !self.pin_start {
                tethers.push(TetherDesc {
                    particle: 0,
                    anchor: (n - 1) as u32,
                    slack: 0.0,
                });
            }
        }
        Ok(SoftBodyDesc {
            positions,
            masses,
            edges,
            tethers,
            material: self.material.clone(),
            ..SoftBodyDesc::default()
        })
    }
}

/// A sheet of cloth: a grid of particles, triangulated, with distance
/// constraints along the grid lines (stretch) and the diagonals (shear),
/// dihedral bending across every inner edge, and optionally long-range
/// tethers to its pinned particles.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftCloth {
    /// The corner of particle (row 0, column 0), m.
    pub corner: DVec3,
    /// From column 0 to the last column, m.
    pub across: DVec3,
    /// From row 0 to the last row, m.
    pub down: DVec3,
    /// Particles along `down`, >= 2.
    pub rows: u32,
    /// Particles along `across`, >= 2.
    pub cols: u32,
    /// Total mass, kg.
    pub mass: f64,
    /// Compliance of the grid lines, m/N; 0 = inextensible.
    pub stretch_compliance: f64,
    /// Compliance of the diagonals, m/N.
    pub shear_compliance: f64,
    /// Compliance of the bending hinges, rad/(N·m).
    pub bend_compliance: f64,
    /// Pinned particles, as `[row, column]`.
    pub pinned: Vec<[u32; 2]>,
    /// Every free particle tethered to its nearest pinned particle (long
    /// range attachments), so the sheet cannot stretch away from its pins.
    pub tethers: bool,
    /// How it moves as a whole.
    pub material: SoftMaterial,
}

impl Default for SoftCloth {
    fn default() -> Self {
        Self {
            corner: DVec3::ZERO,
            across: DVec3::X,
            down: DVec3::NEG_Z,
            rows: 16,
            cols: 16,
            mass: 1.0,
            stretch_compliance: 0.0,
            shear_compliance: 1e-6,
            bend_compliance: 1.0,
            pinned: Vec::new(),
            tethers: false,
            material: SoftMaterial::default(),
        }
    }
}

impl SoftCloth {
    /// The index of the particle at `row`, `col`.
    pub fn index(&self, row: u32, col: u32) -> u32 {
        row * self.cols + col
    }

    /// The cloth's description (particles row after row).
    pub fn build(&self) -> Result<SoftBodyDesc, PhysicsError> {
        finite3("cloth corner", self.corner)?;
        finite3("cloth across", self.across)?;
        finite3("cloth down", self.down)?;
        positive("cloth mass", self.mass)?;
        non_negative("cloth stretch compliance", self.stretch_compliance)?;
        non_negative("cloth shear compliance", self.shear_compliance)?;
        non_negative("cloth bend compliance", self.bend_compliance)?;
        let (rows, cols) = (self.rows as usize, self.cols as usize);
        if rows < 2 || cols < 2 || rows.saturating_mul(cols) > super::MAX_SOFT_PARTICLES {
            return Err(PhysicsError::Invalid {
                what: "cloth size",
                why: format!(
                    "{rows} × {cols}: at least 2 × 2 and at most {} particles",
                    super::MAX_SOFT_PARTICLES
                ),
            });
        }
        if self.across.cross(self.down).length() < 1e-9 {
            return Err(PhysicsError::Invalid {
                what: "cloth",
                why: "`across` and `down` must span a sheet".into(),
            });
        }
        let n = rows * cols;
        let mut positions = Vec::with_capacity(n);
        for r in 0..rows {
            for c in 0..cols {
                positions.push(
                    self.corner
                        + self.across * (c as f64 / (cols - 1) as f64)
                        + self.down * (r as f64 / (rows - 1) as f64),
                );
            }
        }
        let mut masses = vec![self.mass / n as f64; n];
        let mut pins = Vec::new();
        for &[r, c] in &self.pinned {
            if r as usize >= rows || c as usize >= cols {
                return Err(PhysicsError::Invalid {
                    what: "cloth pin",
                    why: format!("[{r}, {c}] is outside the {rows} × {cols} grid"),
                });
            }
            let i = self.index(r, c);
            masses[i as usize] = 0.0;
            pins.push(i);
        }
        let at = |r: usize, c: usize| (r * cols + c) as u32;
        // Two triangles a quad, split along the (r, c)–(r+1, c+1) diagonal,
        // counter-clockwise seen from the side `across × down` points to.
        let mut triangles = Vec::with_capacity(2 * (rows - 1) * (cols - 1));
        for r in 0..rows - 1 {
            for c in 0..cols - 1 {
                triangles.push([at(r, c), at(r + 1, c + 1), at(r, c + 1)]);
                triangles.push([at(r, c), at(r + 1, c), at(r + 1, c + 1)]);
            }
        }
        let (edges, hinges) = edges_and_hinges(&triangles);
        let edges = edges
            .into_iter()
            .map(|[a, b]| {
                let (ra, ca) = (a as usize / cols, a as usize % cols);
                let (rb, cb) = (b as usize / cols, b as usize % cols);
                let diagonal = ra != rb && ca != cb;
                EdgeDesc {
                    particles: [a, b],
                    compliance: if diagonal {
                        self.shear_compliance
                    } else {
                        self.stretch_compliance
                    },
                }
            })
            .collect();
        let hinges = hinges
            .into_iter()
            .map(|particles| HingeDesc {
                particles,
                compliance: self.bend_compliance,
            })
            .collect();
        let mut tethers = Vec::new();
        if self.tethers && !pins.is_empty() {
            for i in 0..n {
                if masses[i] == 0.0 {
                    continue;
                }
                let nearest = pins
                    .iter()
                    .copied()
                    .min_by(|&a, &b| {
                        let da = positions[a as usize].distance_squared(positions[i]);
                        let db = positions[b as usize].distance_squared(positions[i]);
                        da.total_cmp(&db).then(a.cmp(&b))
                    })
                    .expect("pins is not empty");
                tethers.push(TetherDesc {
                    particle: i as u32,
                    anchor: nearest,
                    slack: 0.0,
                });
            }
        }
        Ok(SoftBodyDesc {
            positions,
            masses,
            edges,
            hinges,
            tethers,
            triangles,
            material: self.material.clone(),
            ..SoftBodyDesc::default()
        })
    }
}

/// The unique edges of `triangles` (each as `[low, high]`, in the order
/// first met) and a bending hinge for every edge two triangles share
/// (`[e0, e1, o0, o1]`).
pub(crate) fn edges_and_hinges(triangles: &[[u32; 3]]) -> (Vec<[u32; 2]>, Vec<[u32; 4]>) {
    // Edge → (first met, the opposite vertices, the edge as the first
    // triangle runs it).
    let mut seen: BTreeMap<[u32; 2], (usize, Vec<u32>, [u32; 2])> = BTreeMap::new();
    let mut order = 0;
    for t in triangles {
        for k in 0..3 {
            let (a, b, o) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let key = [a.min(b), a.max(b)];
            let e = seen.entry(key).or_insert_with(|| {
                order += 1;
                (order, Vec::new(), [a, b])
            });
            e.1.push(o);
        }
    }
    let mut edges: Vec<(usize, [u32; 2])> = seen.iter().map(|(k, v)| (v.0, *k)).collect();
    edges.sort_unstable();
    let mut hinges: Vec<(usize, [u32; 4])> = seen
        .values()
        .filter(|v| v.1.len() == 2)
        .map(|v| (v.0, [v.2[0], v.2[1], v.1[0], v.1[1]]))
        .collect();
    hinges.sort_unstable();
    (
        edges.into_iter().map(|(_, e)| e).collect(),
        hinges.into_iter().map(|(_, h)| h).collect(),
    )
}

/// An inflated shell: a sphere's surface (an icosahedron subdivided
/// `subdivisions` times and pushed out onto the sphere), with stretch and
/// bending constraints along its triangles and a pressure constraint that
/// keeps the volume it encloses at `pressure` times its rest volume.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftBalloon {
    /// Centre, m.
    pub centre: DVec3,
    /// Radius, m.
    pub radius: f64,
    /// Times each triangle of the icosahedron is cut in four, 0..=6
    /// (12, 42, 162, 642, 2562, 10242, 40962 particles).
    pub subdivisions: u32,
    /// Total mass, kg.
    pub mass: f64,
    /// Compliance of the edges, m/N.
    pub stretch_compliance: f64,
    /// Compliance of the bending hinges, rad/(N·m).
    pub bend_compliance: f64,
    /// Volume kept over rest volume (1: as built; above 1: inflated).
    pub pressure: f64,
    /// Compliance of the volume, 1/Pa.
    pub pressure_compliance: f64,
    /// How it moves as a whole.
    pub material: SoftMaterial,
}

impl Default for SoftBalloon {
    fn default() -> Self {
        Self {
            centre: DVec3::ZERO,
            radius: 0.5,
            subdivisions: 3,
            mass: 1.0,
            stretch_compliance: 1e-4,
            bend_compliance: 10.0,
            pressure: 1.0,
            pressure_compliance: 0.0,
            material: SoftMaterial::default(),
        }
    }
}

impl SoftBalloon {
    /// The balloon's description.
    pub fn build(&self) -> Result<SoftBodyDesc, PhysicsError> {
        finite3("balloon centre", self.centre)?;
        positive("balloon radius", self.radius)?;
        positive("balloon mass", self.mass)?;
        non_negative("balloon stretch compliance", self.stretch_compliance)?;
        non_negative("balloon bend compliance", self.bend_compliance)?;
        positive("balloon pressure", self.pressure)?;
        non_negative("balloon pressure compliance", self.pressure_compliance)?;
        if self.subdivisions > 6 {
            return Err(PhysicsError::Invalid {
                what: "balloon subdivisions",
                why: format!("{} is more than 6", self.subdivisions),
            });
        }
        let (unit, triangles) = icosphere(self.subdivisions);
        let positions: Vec<DVec3> = unit
            .iter()
            .map(|p| self.centre + *p * self.radius)
            .collect();
        let masses = vec![self.mass / positions.len() as f64; positions.len()];
        let (edges, hinges) = edges_and_hinges(&triangles);
        Ok(SoftBodyDesc {
            positions,
            masses,
            edges: edges
                .into_iter()
                .map(|particles| EdgeDesc {
                    particles,
                    compliance: self.stretch_compliance,
                })
                .collect(),
            hinges: hinges
                .into_iter()
                .map(|particles| HingeDesc {
                    particles,
                    compliance: self.bend_compliance,
                })
                .collect(),
            triangles,
            pressure: Some(super::PressureDesc {
                pressure: self.pressure,
                compliance: self.pressure_compliance,
            }),
            material: self.material.clone(),
            ..SoftBodyDesc::default()
        })
    }
}

/// A unit sphere's surface: an icosahedron, each triangle cut in four
/// `subdivisions` times, the new vertices pushed out onto the sphere;
/// triangles counter-clockwise seen from outside.
fn icosphere(subdivisions: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut middle: BTreeMap<[u32; 2], u32> = BTreeMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<DVec3>| {
            *middle.entry([a.min(b), a.max(b)]).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                (v.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let ab = mid(a, b, &mut v);
            let bc = mid(b, c, &mut v);
            let ca = mid(c, a, &mut v);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}
