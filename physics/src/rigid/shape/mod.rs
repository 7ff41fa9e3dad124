//! Collision shapes: what a rigid body is made of.
//!
//! Primitive shapes are centred on their local origin; capsules and
//! cylinders stand along +Y. Large or shared data (hulls, meshes,
//! heightfields, compounds) sits behind an `Arc`, so cloning a shape for
//! many bodies is cheap. Every constructor validates its input and returns
//! a typed [`ShapeError`]; nothing here panics on bad input.
//!
//! Mass properties use closed forms for the primitives (Hibbeler,
//! *Engineering Mechanics: Dynamics*, table of mass moments of inertia) and
//! polyhedral integration for hulls (the [mass module](super::mass) says
//! how). Triangle meshes and heightfields are surfaces, not solids: they
//! have no volume or mass and are meant for static geometry.

use std::sync::Arc;

use glam::{DMat3, DVec3};

use super::aabb::Aabb;
pub mod hull;

use super::mass::{self, MassProperties};
use super::pose::Pose;
use hull::ConvexHull;

/// Why a shape could not be built or measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    /// A number that must be finite was NaN or infinite.
    #[error("{what} must be finite, got {value}")]
    NonFinite {
        /// Which input was bad, e.g. "sphere radius".
        what: &'static str,
        /// The offending value (one component for vectors).
        value: f64,
    },
    /// A size or density that must be strictly positive was not.
    #[error("{what} must be > 0, got {value}")]
    NotPositive {
        /// Which input was bad.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// Too few points (or vertices) to make the shape.
    #[error("{what}: need at least {need}, got {got}")]
    TooFewPoints {
        /// Which input.
        what: &'static str,
        /// How many were given.
        got: usize,
        /// The minimum.
        need: usize,
    },
    /// More items than 32-bit indices can address.
    #[error("{what}: at most {max}, got {got}")]
    TooMany {
        /// Which input.
        what: &'static str,
        /// How many were given.
        got: usize,
        /// The maximum.
        max: usize,
    },
    /// A size or coordinate outside what the engine keeps finite (see
    /// [`crate::limits`]).
    #[error("{what} must be within {min}..={max}, got {value}")]
    OutOfRange {
        /// Which input was bad.
        what: &'static str,
        /// The offending value.
        value: f64,
        /// The least allowed.
        min: f64,
        /// The greatest allowed.
        max: f64,
    },
    /// A list that must not be empty was.
    #[error("{0} must not be empty")]
    Empty(&'static str),
    /// Every hull point is the same point (to the hull tolerance).
    #[error("convex hull points all coincide: a hull needs volume")]
    CoincidentPoints,
    /// The hull points lie on one line (to the hull tolerance).
    #[error("convex hull points are collinear: a hull needs volume")]
    CollinearPoints,
    /// The hull points lie in one plane (to the hull tolerance); for a flat
    /// piece, use a thin cuboid or a triangle mesh.
    #[error("convex hull points are coplanar: a hull needs volume")]
    CoplanarPoints,
    /// The hull construction could not produce a valid closed mesh. Should
    /// not happen; report the input if it does.
    #[error("convex hull construction failed on this input (internal consistency check)")]
    HullFailed,
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} uses vertex {index}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Index of the triangle in the input list.
        triangle: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices given.
        vertex_count: usize,
    },
    /// A triangle repeats a vertex or has zero area (to rounding); remove it.
    #[error("triangle {triangle} is degenerate (repeated vertex or zero area)")]
    DegenerateTriangle {
        /// Index of the triangle in the input list.
        triangle: usize,
    },
    /// The heightfield grid is too small (needs 2×2) or does not match the
    /// number of heights.
    #[error("heightfield needs rows >= 2, cols >= 2 and rows * cols heights; got {rows} x {cols} with {len} heights")]
    HeightFieldSize {
        /// Rows requested (along Z).
        rows: usize,
        /// Columns requested (along X).
        cols: usize,
        /// Number of heights given.
        len: usize,
    },
    /// A compound part's rotation is not a unit quaternion (to 1e-6).
    #[error("compound part {part}: rotation must be a unit quaternion, |q| = {length}")]
    NotUnitRotation {
        /// Index of the part.
        part: usize,
        /// Length of its quaternion.
        length: f64,
    },
    /// Triangle meshes and heightfields are surfaces: they have no volume,
    /// so no mass. Use them for static bodies, or a hull or compound.
    #[error("triangle meshes and heightfields are not solid and have no mass properties")]
    NotSolid,
}

fn finite(what: &'static str, v: f64) -> Result<f64, ShapeError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ShapeError::NonFinite { what, value: v })
    }
}

/// Checks a size against [`crate::limits`] (radius, half extent, half
/// height), m.
fn length(what: &'static str, v: f64) -> Result<f64, ShapeError> {
    positive(what, v)?;
    within(
        what,
        v,
        crate::limits::MIN_LENGTH,
        crate::limits::MAX_LENGTH,
    )
}

/// Checks a capsule's half height: above zero (a capsule of almost no
/// length is a ball, which is fine) and at most [`crate::limits::MAX_LENGTH`].
fn half_length(what: &'static str, v: f64) -> Result<f64, ShapeError> {
    positive(what, v)?;
    within(what, v, 0.0, crate::limits::MAX_LENGTH)
}

/// Checks every coordinate of `points` against [`crate::limits`], m.
fn coordinates(what: &'static str, points: &[DVec3]) -> Result<(), ShapeError> {
    let max = crate::limits::MAX_COORDINATE;
    for c in points.iter().flat_map(|p| p.to_array()) {
        finite(what, c)?;
        within(what, c, -max, max)?;
    }
    Ok(())
}

/// Checks that `v` lies within `min..=max`.
fn within(what: &'static str, v: f64, min: f64, max: f64) -> Result<f64, ShapeError> {
    if (min..=max).contains(&v) {
        Ok(v)
    } else {
        Err(ShapeError::OutOfRange {
            what,
            value: v,
            min,
            max,
        })
    }
}

fn positive(what: &'static str, v: f64) -> Result<f64, ShapeError> {
    finite(what, v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(ShapeError::NotPositive { what, value: v })
    }
}

fn finite3(what: &'static str, v: DVec3) -> Result<DVec3, ShapeError> {
    for c in v.to_array() {
        finite(what, c)?;
    }
    Ok(v)
}

/// A triangle soup or mesh: a surface for static level geometry.
///
/// Triangles are counter-clockwise seen from the front (outside).
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    local_aabb: Aabb,
}

impl TriMesh {
    /// A mesh from vertices (m) and triangles (indices into `vertices`).
    ///
    /// # Errors
    /// Fewer than 3 vertices, more than `u32::MAX` of them, a non-finite
    /// vertex, no triangles, an index out of range, or a triangle with a
    /// repeated vertex or zero area.
    pub fn new(vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<TriMesh, ShapeError> {
        if vertices.len() < 3 {
            return Err(ShapeError::TooFewPoints {
                what: "triangle mesh vertices",
                got: vertices.len(),
                need: 3,
            });
        }
        if vertices.len() > u32::MAX as usize {
            return Err(ShapeError::TooMany {
                what: "triangle mesh vertices",
                got: vertices.len(),
                max: u32::MAX as usize,
            });
        }
        for &v in &vertices {
            finite3("triangle mesh vertex", v)?;
        }
        if triangles.is_empty() {
            return Err(ShapeError::Empty("triangle mesh triangles"));
        }
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
                return Err(ShapeError::IndexOutOfRange {
                    triangle: t,
                    index,
                    vertex_count: vertices.len(),
                });
            }
            let [a, b, c] = tri.map(|i| vertices[i as usize]);
            let (e1, e2) = (b - a, c - a);
            let area2 = e1.cross(e2).length();
            if tri[0] == tri[1]
                || tri[1] == tri[2]
                || tri[2] == tri[0]
                || area2 <= f64::EPSILON * e1.length() * e2.length()
                || !area2.is_finite()
            {
                return Err(ShapeError::DegenerateTriangle { triangle: t });
            }
        }
        let local_aabb = Aabb::from_points(&vertices).ok_or(ShapeError::TooFewPoints {
            what: "triangle mesh vertices",
            got: 0,
            need: 3,
        })?;
        Ok(TriMesh {
            vertices,
            triangles,
            local_aabb,
        })
    }

    /// The vertices, m.
    #[inline]
    pub fn vertices(&self) -> &[DVec3] {
        &self.vertices
    }

    /// The triangles as vertex index triples, counter-clockwise from the front.
    #[inline]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Bounds of the vertices in the mesh's frame, m.
    #[inline]
    pub fn local_aabb(&self) -> Aabb {
        self.local_aabb
    }
}

/// A regular grid of heights: terrain.
///
/// `rows × cols` samples, row-major (`heights[r * cols + c]`). Columns run
/// along X and rows along Z; the grid spans `scale.x` by `scale.z` metres,
/// centred on the origin, and sample `(r, c)` sits at
/// `x = (c / (cols − 1) − ½) scale.x`, `z = (r / (rows − 1) − ½) scale.z`,
/// `y = heights[r * cols + c] · scale.y`.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightField {
    heights: Vec<f64>,
    rows: usize,
    cols: usize,
    scale: DVec3,
    min_height: f64,
    max_height: f64,
}

impl HeightField {
    /// A heightfield from `rows × cols` heights (scaled by `scale.y` to m)
    /// and the total size `scale` (m along X and Z, a factor along Y).
    ///
    /// # Errors
    /// Fewer than 2 rows or columns, a length other than `rows * cols`, a
    /// non-finite height, or a scale component that is not finite and > 0.
    pub fn new(
        heights: Vec<f64>,
        rows: usize,
        cols: usize,
        scale: DVec3,
    ) -> Result<HeightField, ShapeError> {
        if rows < 2 || cols < 2 || rows.checked_mul(cols) != Some(heights.len()) {
            return Err(ShapeError::HeightFieldSize {
                rows,
                cols,
                len: heights.len(),
            });
        }
        for c in scale.to_array() {
            positive("heightfield scale", c)?;
        }
        let mut min_height = f64::INFINITY;
        let mut max_height = f64::NEG_INFINITY;
        for &h in &heights {
            finite("heightfield height", h)?;
            min_height = min_height.min(h);
            max_height = max_height.max(h);
        }
        Ok(HeightField {
            heights,
            rows,
            cols,
            scale,
            min_height,
            max_height,
        })
    }

    /// The raw heights, row-major, before scaling by `scale.y`.
    #[inline]
    pub fn heights(&self) -> &[f64] {
        &self.heights
    }

    /// Number of rows (samples along Z).
    #[inline]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns (samples along X).
    #[inline]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Total size along X and Z (m) and the height factor along Y.
    #[inline]
    pub fn scale(&self) -> DVec3 {
        self.scale
    }

    /// The sample at row `r`, column `c` as a point in the field's frame
    /// (m), or `None` outside the grid.
    pub fn vertex(&self, r: usize, c: usize) -> Option<DVec3> {
        if r >= self.rows || c >= self.cols {
            return None;
        }
        let h = self.heights[r * self.cols + c];
        Some(DVec3::new(
            (c as f64 / (self.cols - 1) as f64 - 0.5) * self.scale.x,
            h * self.scale.y,
            (r as f64 / (self.rows - 1) as f64 - 0.5) * self.scale.z,
        ))
    }

    /// Bounds of the field in its own frame, m.
    pub fn local_aabb(&self) -> Aabb {
        let half = 0.5 * self.scale;
        Aabb::new(
            DVec3::new(-half.x, self.min_height * self.scale.y, -half.z),
            DVec3::new(half.x, self.max_height * self.scale.y, half.z),
        )
    }
}

/// A collision shape in its own frame (centred on the origin for the
/// primitives; capsules and cylinders along +Y).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A ball.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// A box.
    Cuboid {
        /// Half the size along each axis, m.
        half_extents: DVec3,
    },
    /// A segment from `(0, −half_height, 0)` to `(0, half_height, 0)`
    /// swept by a ball: a cylinder with hemispherical caps.
    Capsule {
        /// Half the length of the inner segment, m (total height is
        /// `2 (half_height + radius)`).
        half_height: f64,
        /// Radius, m.
        radius: f64,
    },
    /// A solid circular cylinder along Y.
    Cylinder {
        /// Half the height, m.
        half_height: f64,
        /// Radius, m.
        radius: f64,
    },
    /// A convex polyhedron.
    ConvexHull(Arc<ConvexHull>),
    /// A triangle surface (not solid).
    TriMesh(Arc<TriMesh>),
    /// A terrain grid (not solid).
    HeightField(Arc<HeightField>),
    /// Shapes placed in a common frame. Parts should not overlap, or the
    /// overlap counts twice in volume and mass.
    Compound(Arc<Vec<(Pose, Shape)>>),
}

impl Shape {
    /// The kind of shape in words ("sphere", "convex hull", ...), for
    /// error messages.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Shape::Sphere { .. } => "sphere",
            Shape::Cuboid { .. } => "cuboid",
            Shape::Capsule { .. } => "capsule",
            Shape::Cylinder { .. } => "cylinder",
            Shape::ConvexHull(_) => "convex hull",
            Shape::TriMesh(_) => "triangle mesh",
            Shape::HeightField(_) => "heightfield",
            Shape::Compound(_) => "compound",
        }
    }

    /// A ball of `radius` m (> 0).
    pub fn sphere(radius: f64) -> Result<Shape, ShapeError> {
        Ok(Shape::Sphere {
            radius: length("sphere radius", radius)?,
        })
    }

    /// A box with `half_extents` m (each > 0).
    pub fn cuboid(half_extents: DVec3) -> Result<Shape, ShapeError> {
        for c in half_extents.to_array() {
            length("cuboid half extent", c)?;
        }
        Ok(Shape::Cuboid { half_extents })
    }

    /// A capsule along Y: inner segment half length `half_height` m and
    /// `radius` m (both > 0; for zero length use a sphere).
    pub fn capsule(half_height: f64, radius: f64) -> Result<Shape, ShapeError> {
        Ok(Shape::Capsule {
            half_height: half_length("capsule half height", half_height)?,
            radius: length("capsule radius", radius)?,
        })
    }

    /// A cylinder along Y of half height `half_height` m and `radius` m
    /// (both > 0).
    pub fn cylinder(half_height: f64, radius: f64) -> Result<Shape, ShapeError> {
        Ok(Shape::Cylinder {
            half_height: length("cylinder half height", half_height)?,
            radius: length("cylinder radius", radius)?,
        })
    }

    /// The convex hull of `points` (m); see [`ConvexHull::from_points`].
    pub fn convex_hull(points: &[DVec3]) -> Result<Shape, ShapeError> {
        coordinates("convex hull point", points)?;
        Ok(Shape::ConvexHull(Arc::new(ConvexHull::from_points(
            points,
        )?)))
    }

    /// A triangle mesh; see [`TriMesh::new`].
    pub fn trimesh(vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Shape, ShapeError> {
        coordinates("triangle mesh vertex", &vertices)?;
        Ok(Shape::TriMesh(Arc::new(TriMesh::new(vertices, triangles)?)))
    }

    /// A heightfield of `rows × cols` heights; see [`HeightField::new`].
    pub fn heightfield(
        heights: Vec<f64>,
        rows: usize,
        cols: usize,
        scale: DVec3,
    ) -> Result<Shape, ShapeError> {
        Ok(Shape::HeightField(Arc::new(HeightField::new(
            heights, rows, cols, scale,
        )?)))
    }

    /// Shapes placed by poses in a common frame.
    ///
    /// # Errors
    /// No parts, a non-finite translation, or a rotation that is not a unit
    /// quaternion to within 1e-6 in length (those within are renormalised).
    pub fn compound(parts: Vec<(Pose, Shape)>) -> Result<Shape, ShapeError> {
        if parts.is_empty() {
            return Err(ShapeError::Empty("compound parts"));
        }
        let mut parts = parts;
        for (i, (pose, _)) in parts.iter_mut().enumerate() {
            finite3("compound part translation", pose.translation)?;
            let length = pose.rotation.length();
            if !length.is_finite() || (length - 1.0).abs() > 1e-6 {
                return Err(ShapeError::NotUnitRotation { part: i, length });
            }
            pose.rotation /= length;
        }
        Ok(Shape::Compound(Arc::new(parts)))
    }

    /// True for the shapes whose [`support`](Self::support) is defined:
    /// sphere, cuboid, capsule, cylinder and convex hull.
    pub fn is_convex(&self) -> bool {
        matches!(
            self,
            Shape::Sphere { .. }
                | Shape::Cuboid { .. }
                | Shape::Capsule { .. }
                | Shape::Cylinder { .. }
                | Shape::ConvexHull(_)
        )
    }

    /// Enclosed volume, m³; `None` for surfaces (triangle mesh,
    /// heightfield) and for compounds that contain one.
    pub fn volume(&self) -> Option<f64> {
        use std::f64::consts::PI;
        match self {
            Shape::Sphere { radius: r } => Some(4.0 / 3.0 * PI * r * r * r),
            Shape::Cuboid { half_extents: h } => Some(8.0 * h.x * h.y * h.z),
            Shape::Capsule {
                half_height,
                radius: r,
            } => Some(PI * r * r * (2.0 * half_height + 4.0 / 3.0 * r)),
            Shape::Cylinder {
                half_height,
                radius: r,
            } => Some(PI * r * r * 2.0 * half_height),
            Shape::ConvexHull(hull) => Some(hull.volume()),
            Shape::TriMesh(_) | Shape::HeightField(_) => None,
            Shape::Compound(parts) => parts.iter().map(|(_, s)| s.volume()).sum(),
        }
    }

    /// Mass, centre of mass (m, shape frame) and inertia about the centre
    /// (kg·m², shape frame) of the shape filled at `density` kg/m³.
    ///
    /// # Errors
    /// [`ShapeError::NotPositive`] / [`ShapeError::NonFinite`] for a bad
    /// density, [`ShapeError::NotSolid`] for a triangle mesh, a heightfield
    /// or a compound containing one.
    pub fn mass_properties(&self, density: f64) -> Result<MassProperties, ShapeError> {
        use std::f64::consts::PI;
        let rho = positive("density", density)?;
        let diag = |x: f64, y: f64, z: f64| DMat3::from_diagonal(DVec3::new(x, y, z));
        Ok(match self {
            Shape::Sphere { radius: r } => {
                let m = rho * 4.0 / 3.0 * PI * r * r * r;
                let i = 0.4 * m * r * r;
                MassProperties::new(m, DVec3::ZERO, diag(i, i, i))
            }
            Shape::Cuboid { half_extents: h } => {
                // m/12 (b² + c²) with full sizes b = 2 h_y, c = 2 h_z.
                let m = rho * 8.0 * h.x * h.y * h.z;
                let s = h * h;
                MassProperties::new(
                    m,
                    DVec3::ZERO,
                    diag(
                        m / 3.0 * (s.y + s.z),
                        m / 3.0 * (s.z + s.x),
                        m / 3.0 * (s.x + s.y),
                    ),
                )
            }
            Shape::Cylinder {
                half_height: hh,
                radius: r,
            } => {
                let m = rho * PI * r * r * 2.0 * hh;
                // m/12 (3 r² + h²) with h = 2 hh; m r² / 2 about the axis.
                let radial = m / 12.0 * (3.0 * r * r + 4.0 * hh * hh);
                MassProperties::new(m, DVec3::ZERO, diag(radial, 0.5 * m * r * r, radial))
            }
            Shape::Capsule {
                half_height: hh,
                radius: r,
            } => {
                let (hh, r) = (*hh, *r);
                let m_cyl = rho * PI * r * r * 2.0 * hh;
                let m_hemi = rho * 2.0 / 3.0 * PI * r * r * r;
                // A hemisphere's centre of mass is 3r/8 from its flat face,
                // and about a diameter of that face its moment is 2/5 m r²
                // (half a ball's). Moving to its centre of mass and then to
                // the capsule's centre (distance hh + 3r/8):
                // 2/5 m r² − m (3r/8)² + m (hh + 3r/8)²
                //   = m (2/5 r² + hh² + 3/4 hh r).
                let radial = m_cyl / 12.0 * (3.0 * r * r + 4.0 * hh * hh)
                    + 2.0 * m_hemi * (0.4 * r * r + hh * hh + 0.75 * hh * r);
                let axial = 0.5 * m_cyl * r * r + 2.0 * 0.4 * m_hemi * r * r;
                MassProperties::new(
                    m_cyl + 2.0 * m_hemi,
                    DVec3::ZERO,
                    diag(radial, axial, radial),
                )
            }
            Shape::ConvexHull(hull) => {
                let tris = hull.triangles().map(|t| t.map(|i| i as usize));
                let (volume, center, inertia) = mass::polyhedron(hull.vertices(), tris);
                MassProperties::new(rho * volume, center, inertia * rho)
            }
            Shape::TriMesh(_) | Shape::HeightField(_) => return Err(ShapeError::NotSolid),
            Shape::Compound(parts) => {
                let mut props = Vec::with_capacity(parts.len());
                for (pose, shape) in parts.iter() {
                    props.push(shape.mass_properties(rho)?.transformed(pose));
                }
                MassProperties::combine(&props)
            }
        })
    }

    /// The bounding box (m) of the shape placed at `pose` in the parent
    /// frame. Exact (touching the shape) for spheres, cuboids, capsules,
    /// cylinders, hulls, meshes and compounds of them; for a heightfield,
    /// the box of its local bounds, exact when its rotation is axis-aligned.
    pub fn aabb(&self, pose: &Pose) -> Aabb {
        let rot = DMat3::from_quat(pose.rotation);
        let c = pose.translation;
        match self {
            Shape::Sphere { radius } => Aabb::from_center_half_extents(c, DVec3::splat(*radius)),
            Shape::Cuboid { half_extents } => {
                Aabb::from_center_half_extents(c, rot.abs() * *half_extents)
            }
            Shape::Capsule {
                half_height,
                radius,
            } => {
                let axis = rot.y_axis * *half_height;
                Aabb::from_center_half_extents(c, axis.abs() + DVec3::splat(*radius))
            }
            Shape::Cylinder {
                half_height,
                radius,
            } => {
                // The rim circle of radius r in the plane ⟂ a reaches
                // r √(1 − a_i²) along axis i; the caps add hh |a_i|.
                let a = rot.y_axis;
                let rim = (DVec3::ONE - a * a).max(DVec3::ZERO);
                let rim = DVec3::new(rim.x.sqrt(), rim.y.sqrt(), rim.z.sqrt());
                Aabb::from_center_half_extents(c, a.abs() * *half_height + rim * *radius)
            }
            Shape::ConvexHull(hull) => transformed_bounds(hull.vertices(), pose),
            Shape::TriMesh(mesh) => transformed_bounds(mesh.vertices(), pose),
            Shape::HeightField(field) => {
                let local = field.local_aabb();
                Aabb::from_center_half_extents(
                    pose.transform_point(local.center()),
                    rot.abs() * local.half_extents(),
                )
            }
            Shape::Compound(parts) => {
                let mut iter = parts.iter().map(|(p, s)| s.aabb(&pose.mul(p)));
                let first = iter.next().unwrap_or(Aabb::new(c, c));
                iter.fold(first, |a, b| a.union(&b))
            }
        }
    }

    /// Bounds of the shape in its own frame, m.
    pub fn local_aabb(&self) -> Aabb {
        self.aabb(&Pose::IDENTITY)
    }

    /// The point of the shape farthest along `dir` (m, shape frame), for
    /// GJK and friends. `dir` need not be normalised. `None` for shapes that
    /// are not convex (triangle mesh, heightfield, compound). A zero `dir`
    /// gives some point on the surface.
    pub fn support(&self, dir: DVec3) -> Option<DVec3> {
        Some(match self {
            Shape::Sphere { radius } => dir.normalize_or(DVec3::X) * *radius,
            Shape::Cuboid { half_extents: h } => DVec3::select(dir.cmpge(DVec3::ZERO), *h, -*h),
            Shape::Capsule {
                half_height,
                radius,
            } => {
                let end = if dir.y >= 0.0 {
                    *half_height
                } else {
                    -*half_height
                };
                DVec3::new(0.0, end, 0.0) + dir.normalize_or(DVec3::Y) * *radius
            }
            Shape::Cylinder {
                half_height,
                radius,
            } => {
                let y = if dir.y >= 0.0 {
                    *half_height
                } else {
                    -*half_height
                };
                let radial = DVec3::new(dir.x, 0.0, dir.z).normalize_or_zero() * *radius;
                radial + DVec3::new(0.0, y, 0.0)
            }
            Shape::ConvexHull(hull) => hull.support(dir),
            Shape::TriMesh(_) | Shape::HeightField(_) | Shape::Compound(_) => return None,
        })
    }
}

/// Bounds of `points` (m) mapped by `pose`.
fn transformed_bounds(points: &[DVec3], pose: &Pose) -> Aabb {
    let mut iter = points.iter().map(|&p| pose.transform_point(p));
    let first = iter.next().unwrap_or(pose.translation);
    iter.fold(Aabb::new(first, first), |b, p| {
        Aabb::new(b.min.min(p), b.max.max(p))
    })
}
