//! Building the XPBD entries of a scene: `soft_bodies` and `fluids`.
//!
//! Each entry is checked field by field (errors name the field's path,
//! `soft_bodies[2].shape.segments`), turned into the physics crate's
//! builder (`SoftRope`, `SoftCloth`, `SoftSolid`, `SoftBalloon`,
//! `FluidDesc`, `FluidEmitter`) and added to the world. They make no
//! entities: their streaming is separate.

use inertia_physics::glam::DVec3;
use inertia_physics::{
    FluidDesc, FluidEmitter, Plasticity, SoftBalloon, SoftBodyDesc, SoftCloth, SoftMaterial,
    SoftRope, SoftSolid, SolidShape,
};
use inertia_protocol::ShapeDesc;

use super::{
    finite, invalid, non_negative, physics, positive, positive3, rotation, unit, vec3, Builder,
};
use crate::scene::schema::*;
use crate::scene::SceneError;

/// Most segments of a soft rope.
const MAX_ROPE_SEGMENTS: u32 = 10_000;
/// Most particles along a side of a soft cloth.
const MAX_CLOTH_SIDE: u32 = 256;
/// Most grid cubes a solid is sampled on (each holds six tetrahedra).
const MAX_SOLID_CELLS: f64 = 20_000.0;
/// Most subdivisions of a balloon (40 962 particles).
const MAX_BALLOON_SUBDIVISIONS: u32 = 6;
/// Most substeps a soft body or fluid takes a tick.
const MAX_SUBSTEPS: u32 = 64;
/// Most particles one fluid may hold.
const MAX_FLUID_PARTICLES: u64 = 1_000_000;

/// How a soft body's particles are laid out, for the entries that name
/// them (`Start`, `Grid(u, v)`, ...).
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// A rope: particles 0 (start) to `last` (end).
    Rope { last: usize },
    /// A cloth: particle `(u, v)` is `v × nu + u`.
    Cloth { nu: u32, nv: u32 },
    /// A solid or a balloon: particles in build order.
    Other,
}

/// Whether a shape is a solid (weighed by density).
fn is_solid(shape: &SoftShapeSpec) -> bool {
    matches!(
        shape,
        SoftShapeSpec::Box { .. } | SoftShapeSpec::Sphere { .. } | SoftShapeSpec::Mesh { .. }
    )
}

/// The material of `s`, every field checked.
fn material(at: &str, s: &SoftBodySpec) -> Result<SoftMaterial, SceneError> {
    let d = SoftMaterial::default();
    let substeps = s.substeps.unwrap_or(d.substeps);
    if !(1..=MAX_SUBSTEPS).contains(&substeps) {
        return Err(invalid(
            format!("{at}.substeps"),
            format!("must be in 1..={MAX_SUBSTEPS}, got {substeps}"),
        ));
    }
    let plasticity = match s.plasticity {
        None => None,
        Some(p) => {
            let pat = format!("{at}.plasticity");
            Some(Plasticity {
                yield_strain: positive(&format!("{pat}.yield_strain"), p.yield_strain)?,
                creep: non_negative(&format!("{pat}.creep"), p.creep)?,
                max_strain: positive(&format!("{pat}.max_strain"), p.max_strain)?,
            })
        }
    };
    Ok(SoftMaterial {
        substeps,
        damping: non_negative(&format!("{at}.damping"), s.damping.unwrap_or(d.damping))?,
        gravity_scale: finite(
            &format!("{at}.gravity_scale"),
            s.gravity_scale.unwrap_or(d.gravity_scale),
        )?,
        collision_radius: non_negative(
            &format!("{at}.collision_radius"),
            s.collision_radius.unwrap_or(d.collision_radius),
        )?,
        friction: non_negative(&format!("{at}.friction"), s.friction.unwrap_or(d.friction))?,
        self_collision: s.self_collision,
        plasticity,
        tear_strain: s
            .tear_strain
            .map(|t| positive(&format!("{at}.tear_strain"), t))
            .transpose()?,
    })
}

/// A compliance (m/N, rad/(N·m) or 1/Pa) at `at`, `default` if not given.
fn compliance(at: &str, c: Option<f64>, default: f64) -> Result<f64, SceneError> {
    non_negative(at, c.unwrap_or(default))
}

/// A solid (box, ball or mesh) with the edge and volume compliances of
/// the shape at `at` (defaults 1e-6 and 0), filled with tetrahedra.
fn build_solid(
    at: &str,
    mut solid: SoftSolid,
    edge_compliance: Option<f64>,
    volume_compliance: Option<f64>,
) -> Result<(SoftBodyDesc, Layout), SceneError> {
    solid.edge_compliance = compliance(&format!("{at}.edge_compliance"), edge_compliance, 1e-6)?;
    solid.volume_compliance =
        compliance(&format!("{at}.volume_compliance"), volume_compliance, 0.0)?;
    Ok((solid.build().map_err(physics(at))?, Layout::Other))
}

/// How many grid cubes of side `cell` cover a box of size `size` (m), as
/// the solid builder counts them.
fn cells(size: DVec3, cell: f64) -> f64 {
    (size / cell)
        .round()
        .max(DVec3::ONE)
        .to_array()
        .iter()
        .product()
}

/// Refuses a solid of more than [`MAX_SOLID_CELLS`] cubes.
fn check_cells(at: &str, size: DVec3, cell: f64) -> Result<(), SceneError> {
    let n = cells(size, cell);
    if n > MAX_SOLID_CELLS {
        return Err(invalid(
            format!("{at}.cell"),
            format!("{n} cubes of {cell} m is more than {MAX_SOLID_CELLS}: use larger cells"),
        ));
    }
    Ok(())
}

/// The indices of the particles `p` names, at `positions` (m).
fn select(
    at: &str,
    p: &ParticleSpec,
    layout: Layout,
    positions: &[DVec3],
) -> Result<Vec<usize>, SceneError> {
    let n = positions.len();
    match (*p, layout) {
        (ParticleSpec::Index(i), _) => {
            if (i as usize) < n {
                Ok(vec![i as usize])
            } else {
                Err(invalid(at, format!("particle {i} of {n} (0..{n})")))
            }
        }
        (ParticleSpec::Start, Layout::Rope { .. }) => Ok(vec![0]),
        (ParticleSpec::End, Layout::Rope { last }) => Ok(vec![last]),
        (ParticleSpec::Start | ParticleSpec::End, _) => {
            Err(invalid(at, "`Start` and `End` name the ends of a rope"))
        }
        (ParticleSpec::Grid(u, v), Layout::Cloth { nu, nv }) => {
            if u < nu && v < nv {
                Ok(vec![(v * nu + u) as usize])
            } else {
                Err(invalid(
                    at,
                    format!("({u}, {v}) is outside the {nu}x{nv} grid"),
                ))
            }
        }
        (ParticleSpec::Grid(..), _) => Err(invalid(at, "`Grid` names a particle of a cloth")),
        (ParticleSpec::InBox { min, max }, _) => {
            let lo = vec3(&format!("{at}.min"), min)?;
            let hi = vec3(&format!("{at}.max"), max)?;
            if lo.cmpgt(hi).any() {
                return Err(invalid(at, "min must not exceed max"));
            }
            let inside: Vec<usize> = positions
                .iter()
                .enumerate()
                .filter(|(_, q)| q.cmpge(lo).all() && q.cmple(hi).all())
                .map(|(i, _)| i)
                .collect();
            if inside.is_empty() {
                return Err(invalid(at, "no particle lies in the box"));
            }
            Ok(inside)
        }
    }
}

/// The particles of a closed mesh, checked: counts, finite vertices,
/// indices in range, and some enclosed volume.
fn mesh(
    at: &str,
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
) -> Result<(Vec<DVec3>, DVec3), SceneError> {
    let max = ShapeDesc::MAX_POINTS;
    if !(4..=max).contains(&vertices.len()) {
        return Err(invalid(
            format!("{at}.vertices"),
            format!("need 4..={max} vertices, got {}", vertices.len()),
        ));
    }
    if !(4..=max).contains(&triangles.len()) {
        return Err(invalid(
            format!("{at}.triangles"),
            format!(
                "a closed mesh needs 4..={max} triangles, got {}",
                triangles.len()
            ),
        ));
    }
    let v = vertices
        .iter()
        .enumerate()
        .map(|(i, p)| vec3(&format!("{at}.vertices[{i}]"), *p))
        .collect::<Result<Vec<_>, _>>()?;
    for (k, t) in triangles.iter().enumerate() {
        for &i in t {
            if i as usize >= v.len() {
                return Err(invalid(
                    format!("{at}.triangles[{k}]"),
                    format!("vertex {i} of {} (0..{})", v.len(), v.len()),
                ));
            }
        }
    }
    let (mut lo, mut hi) = (v[0], v[0]);
    for p in &v {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let size = hi - lo;
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize] - lo);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    let scale = size.max_element();
    if volume.is_nan() || volume.abs() <= 1e-9 * scale * scale * scale {
        return Err(invalid(
            at,
            format!("the mesh encloses no volume ({volume} m³): it must be closed and not flat"),
        ));
    }
    Ok((v, size))
}

impl Builder {
    /// Checks an XPBD entry's name: not empty, not taken by another soft
    /// body or fluid.
    fn xpbd_name(&self, at: &str, name: &str) -> Result<(), SceneError> {
        if name.is_empty() {
            return Err(invalid(at, "a name must not be empty"));
        }
        if self.soft_bodies.contains_key(name) || self.fluids.contains_key(name) {
            return Err(invalid(
                at,
                format!("duplicate soft body or fluid name `{name}`"),
            ));
        }
        Ok(())
    }

    /// The description of a soft body's shape (masses from `mass`, or from
    /// density for solids) and how its particles are laid out.
    fn soft_shape(
        &self,
        at: &str,
        shape: &SoftShapeSpec,
        mass: f64,
        density: f64,
        material: SoftMaterial,
    ) -> Result<(SoftBodyDesc, Layout), SceneError> {
        let f = |field: &str| format!("{at}.{field}");
        match shape {
            SoftShapeSpec::Rope {
                start,
                end,
                segments,
                sag,
                compliance: c,
                pin_start,
                pin_end,
                tethers,
            } => {
                if !(1..=MAX_ROPE_SEGMENTS).contains(segments) {
                    return Err(invalid(
                        f("segments"),
                        format!("must be in 1..={MAX_ROPE_SEGMENTS}, got {segments}"),
                    ));
                }
                let start = vec3(&f("start"), *start)?;
                let end = vec3(&f("end"), *end)?;
                if start == end {
                    return Err(invalid(f("end"), "the ends must differ"));
                }
                let sag = finite(&f("sag"), *sag)?;
                let rope = SoftRope {
                    start,
                    end,
                    segments: *segments,
                    mass,
                    compliance: compliance(&f("compliance"), *c, 0.0)?,
                    pin_start: *pin_start,
                    pin_end: *pin_end,
                    tethers: *tethers,
                    material,
                };
                let mut desc = rope.build().map_err(physics(at))?;
                // Hang the middle `sag` below the line (a parabola): the
                // constraints take their rest lengths from these places.
                let up = -self.gravity.try_normalize().unwrap_or(DVec3::NEG_Y);
                for (k, p) in desc.positions.iter_mut().enumerate() {
                    let t = k as f64 / f64::from(*segments);
                    *p -= up * (4.0 * sag * t * (1.0 - t));
                }
                let last = *segments as usize;
                Ok((desc, Layout::Rope { last }))
            }
            SoftShapeSpec::Cloth {
                origin,
                u_axis,
                v_axis,
                width,
                height,
                nu,
                nv,
                pinned,
                tethers,
                stretch_compliance,
                shear_compliance,
                bend_compliance,
            } => {
                for (field, n) in [("nu", nu), ("nv", nv)] {
                    if !(2..=MAX_CLOTH_SIDE).contains(n) {
                        return Err(invalid(
                            f(field),
                            format!("must be in 2..={MAX_CLOTH_SIDE}, got {n}"),
                        ));
                    }
                }
                for (i, &(u, v)) in pinned.iter().enumerate() {
                    if u >= *nu || v >= *nv {
                        return Err(invalid(
                            format!("{at}.pinned[{i}]"),
                            format!("({u}, {v}) is outside the {nu}x{nv} grid"),
                        ));
                    }
                }
                let u = unit(&f("u_axis"), u_axis.unwrap_or([1.0, 0.0, 0.0]))?;
                let v = unit(&f("v_axis"), v_axis.unwrap_or([0.0, -1.0, 0.0]))?;
                if u.cross(v).length() < 1e-6 {
                    return Err(invalid(
                        f("v_axis"),
                        "must not be parallel to u_axis: the axes span the sheet",
                    ));
                }
                let cloth = SoftCloth {
                    corner: vec3(&f("origin"), *origin)?,
                    across: u * positive(&f("width"), *width)?,
                    down: v * positive(&f("height"), *height)?,
                    rows: *nv,
                    cols: *nu,
                    mass,
                    stretch_compliance: compliance(
                        &f("stretch_compliance"),
                        *stretch_compliance,
                        0.0,
                    )?,
                    shear_compliance: compliance(&f("shear_compliance"), *shear_compliance, 1e-6)?,
                    bend_compliance: compliance(&f("bend_compliance"), *bend_compliance, 1.0)?,
                    pinned: pinned.iter().map(|&(u, v)| [v, u]).collect(),
                    tethers: *tethers,
                    material,
                };
                let desc = cloth.build().map_err(physics(at))?;
                Ok((desc, Layout::Cloth { nu: *nu, nv: *nv }))
            }
            SoftShapeSpec::Box {
                center,
                half_extents,
                rotation: rot,
                cell,
                edge_compliance,
                volume_compliance,
            } => {
                let half = positive3(&f("half_extents"), *half_extents)?;
                let cell = positive(&f("cell"), *cell)?;
                check_cells(at, half * 2.0, cell)?;
                let solid = SoftSolid {
                    shape: SolidShape::Box { half_extents: half },
                    position: vec3(&f("center"), *center)?,
                    rotation: rotation(&f("rotation"), rot.as_ref())?,
                    cell,
                    density,
                    material,
                    ..SoftSolid::default()
                };
                build_solid(at, solid, *edge_compliance, *volume_compliance)
            }
            SoftShapeSpec::Sphere {
                center,
                radius,
                cell,
                edge_compliance,
                volume_compliance,
            } => {
                let radius = positive(&f("radius"), *radius)?;
                let cell = positive(&f("cell"), *cell)?;
                check_cells(at, DVec3::splat(2.0 * radius), cell)?;
                let solid = SoftSolid {
                    shape: SolidShape::Sphere { radius },
                    position: vec3(&f("center"), *center)?,
                    cell,
                    density,
                    material,
                    ..SoftSolid::default()
                };
                build_solid(at, solid, *edge_compliance, *volume_compliance)
            }
            SoftShapeSpec::Mesh {
                position,
                rotation: rot,
                vertices,
                triangles,
                cell,
                edge_compliance,
                volume_compliance,
            } => {
                let (vertices, size) = mesh(at, vertices, triangles)?;
                let cell = positive(&f("cell"), *cell)?;
                check_cells(at, size, cell)?;
                let solid = SoftSolid {
                    shape: SolidShape::Mesh {
                        vertices,
                        triangles: triangles.clone(),
                    },
                    position: vec3(&f("position"), *position)?,
                    rotation: rotation(&f("rotation"), rot.as_ref())?,
                    cell,
                    density,
                    material,
                    ..SoftSolid::default()
                };
                build_solid(at, solid, *edge_compliance, *volume_compliance)
            }
            SoftShapeSpec::Balloon {
                center,
                radius,
                subdivisions,
                stretch_compliance,
                bend_compliance,
                pressure,
                pressure_compliance,
            } => {
                let subdivisions = subdivisions.unwrap_or(3);
                if subdivisions > MAX_BALLOON_SUBDIVISIONS {
                    return Err(invalid(
                        f("subdivisions"),
                        format!("must be in 0..={MAX_BALLOON_SUBDIVISIONS}, got {subdivisions}"),
                    ));
                }
                let balloon = SoftBalloon {
                    centre: vec3(&f("center"), *center)?,
                    radius: positive(&f("radius"), *radius)?,
                    subdivisions,
                    mass,
                    stretch_compliance: compliance(
                        &f("stretch_compliance"),
                        *stretch_compliance,
                        1e-4,
                    )?,
                    bend_compliance: compliance(&f("bend_compliance"), *bend_compliance, 10.0)?,
                    pressure: positive(&f("pressure"), pressure.unwrap_or(1.0))?,
                    pressure_compliance: compliance(
                        &f("pressure_compliance"),
                        *pressure_compliance,
                        0.0,
                    )?,
                    material,
                };
                Ok((balloon.build().map_err(physics(at))?, Layout::Other))
            }
        }
    }

    /// Adds one soft body, its pins and its attachments.
    pub(super) fn soft_body(&mut self, at: &str, s: &SoftBodySpec) -> Result<(), SceneError> {
        self.xpbd_name(&format!("{at}.name"), &s.name)?;
        let material = material(at, s)?;
        let solid = is_solid(&s.shape);
        // Ropes, cloth and balloons are weighed by mass; solids by density
        // (or scaled to `mass` once built).
        let (mass, density) = match (s.mass, s.density) {
            (Some(_), Some(_)) => return Err(invalid(at, "give density or mass, not both")),
            (None, Some(_)) if !solid => {
                return Err(invalid(
                    format!("{at}.density"),
                    "density is for solids (Box, Sphere, Mesh): give `mass`",
                ))
            }
            (Some(m), None) => (positive(&format!("{at}.mass"), m)?, 1000.0),
            (None, Some(d)) => (1.0, positive(&format!("{at}.density"), d)?),
            (None, None) => (1.0, 1000.0),
        };
        let (mut desc, layout) =
            self.soft_shape(&format!("{at}.shape"), &s.shape, mass, density, material)?;
        if solid && s.mass.is_some() {
            let built: f64 = desc.masses.iter().sum();
            if built > 0.0 {
                desc.masses.iter_mut().for_each(|m| *m *= mass / built);
            }
        }
        let velocity = vec3(&format!("{at}.velocity"), s.velocity)?;
        if velocity != DVec3::ZERO {
            desc.velocities = vec![velocity; desc.positions.len()];
        }
        for (k, p) in s.pinned.iter().enumerate() {
            for i in select(&format!("{at}.pinned[{k}]"), p, layout, &desc.positions)? {
                desc.masses[i] = 0.0;
            }
        }
        // Attachments are checked before the body is added, so a bad one
        // leaves nothing behind.
        let mut holds = Vec::new();
        for (k, a) in s.attach.iter().enumerate() {
            let aat = format!("{at}.attach[{k}]");
            let body = self.body_named(&format!("{aat}.body"), &a.body)?;
            let particles = select(
                &format!("{aat}.particles"),
                &a.particles,
                layout,
                &desc.positions,
            )?;
            let point = a
                .point
                .map(|p| vec3(&format!("{aat}.point"), p))
                .transpose()?;
            if point.is_some() && particles.len() > 1 {
                return Err(invalid(
                    format!("{aat}.point"),
                    format!(
                        "a point holds one particle, and `particles` names {}",
                        particles.len()
                    ),
                ));
            }
            let c = compliance(&format!("{aat}.compliance"), a.compliance, 0.0)?;
            for i in particles {
                let at_point = point.unwrap_or(desc.positions[i]);
                holds.push((aat.clone(), i as u32, body, at_point, c));
            }
        }
        let h = self.world.add_soft_body(&desc).map_err(physics(at))?;
        for (aat, particle, body, point, c) in holds {
            self.world
                .attach_soft_to_body(h, particle, body, point, c)
                .map_err(physics(aat))?;
        }
        let color = s.color.unwrap_or([220, 90, 60, 255]);
        self.entities
            .insert_soft_body(&self.world, h, s.name.clone(), color);
        self.soft_bodies.insert(s.name.clone(), h);
        Ok(())
    }

    /// Adds one fluid and its emitters.
    pub(super) fn fluid(&mut self, at: &str, f: &FluidSpec) -> Result<(), SceneError> {
        self.xpbd_name(&format!("{at}.name"), &f.name)?;
        let field = |name: &str| format!("{at}.{name}");
        let spacing = positive(&field("spacing"), f.spacing)?;
        if f.blocks.is_empty() && f.emitters.is_empty() {
            return Err(invalid(at, "give at least one block or emitter"));
        }
        let mut positions = Vec::new();
        let mut boxes: Vec<(DVec3, DVec3)> = Vec::new();
        for (k, b) in f.blocks.iter().enumerate() {
            let bat = format!("{at}.blocks[{k}]");
            let min = vec3(&format!("{bat}.min"), b.min)?;
            let max = vec3(&format!("{bat}.max"), b.max)?;
            // Counted as `FluidDesc::block` counts, before anything is made.
            let counts = ((max - min) / spacing + DVec3::splat(1e-6)).floor();
            if counts.min_element() < 1.0 {
                return Err(invalid(
                    format!("{bat}.max"),
                    format!("the box holds no particle {spacing} m apart: make it at least one spacing deep on every axis"),
                ));
            }
            let total = positions.len() as f64 + counts.x * counts.y * counts.z;
            if total > MAX_FLUID_PARTICLES as f64 {
                return Err(invalid(
                    bat,
                    format!("the blocks hold more than {MAX_FLUID_PARTICLES} particles"),
                ));
            }
            for (j, (lo, hi)) in boxes.iter().enumerate() {
                if min.cmplt(*hi).all() && lo.cmplt(max).all() {
                    return Err(invalid(
                        bat,
                        format!("overlaps {at}.blocks[{j}]: their particles would overlap"),
                    ));
                }
            }
            boxes.push((min, max));
            let block = FluidDesc::block(min, max, spacing).map_err(physics(bat))?;
            positions.extend(block.positions);
        }
        let mut desc = FluidDesc::new(spacing);
        desc.positions = positions;
        if let Some(d) = f.rest_density {
            desc.rest_density = positive(&field("rest_density"), d)?;
        }
        if let Some(h) = f.kernel_radius {
            let h = positive(&field("kernel_radius"), h)?;
            if !(h > spacing && h <= 4.0 * spacing) {
                return Err(invalid(
                    field("kernel_radius"),
                    format!(
                        "must be above the spacing {spacing} m and at most 4 times it, got {h} m"
                    ),
                ));
            }
            desc.kernel_radius = Some(h);
        }
        if let Some(v) = f.viscosity {
            let v = non_negative(&field("viscosity"), v)?;
            if v > 1.0 {
                return Err(invalid(
                    field("viscosity"),
                    format!("must be at most 1, got {v}"),
                ));
            }
            desc.viscosity = v;
        }
        if let Some(v) = f.vorticity {
            desc.vorticity = non_negative(&field("vorticity"), v)?;
        }
        if let Some(n) = f.substeps {
            if !(1..=MAX_SUBSTEPS).contains(&n) {
                return Err(invalid(
                    field("substeps"),
                    format!("must be in 1..={MAX_SUBSTEPS}, got {n}"),
                ));
            }
            desc.substeps = n;
        }
        if let Some(c) = f.friction {
            desc.friction = non_negative(&field("friction"), c)?;
        }
        if let Some(r) = f.collision_radius {
            let r = non_negative(&field("collision_radius"), r)?;
            if r > desc.kernel_radius() {
                return Err(invalid(
                    field("collision_radius"),
                    format!(
                        "must be at most the kernel radius {} m, got {r} m",
                        desc.kernel_radius()
                    ),
                ));
            }
            desc.collision_radius = Some(r);
        }
        if let Some(g) = f.gravity_scale {
            desc.gravity_scale = finite(&field("gravity_scale"), g)?;
        }
        let mut emitters = Vec::with_capacity(f.emitters.len());
        // The particles the emitters may add in all, if each has a limit.
        let mut limits = Some(0u64);
        for (k, e) in f.emitters.iter().enumerate() {
            let eat = format!("{at}.emitters[{k}]");
            emitters.push((eat.clone(), emitter(&eat, e, spacing)?));
            limits = limits.and_then(|sum| e.limit.map(|l| sum + u64::from(l)));
        }
        let initial = desc.positions.len() as u64;
        let cap = match (f.max_particles, limits) {
            (Some(m), _) => {
                let m = u64::from(m);
                if m == 0 || m < initial {
                    return Err(invalid(
                        field("max_particles"),
                        format!("must be at least the blocks' {initial} particles and 1, got {m}"),
                    ));
                }
                m
            }
            (None, Some(sum)) => initial + sum,
            (None, None) => {
                return Err(invalid(
                    field("max_particles"),
                    "an emitter without a `limit` needs the fluid's `max_particles`",
                ))
            }
        };
        if cap > MAX_FLUID_PARTICLES {
            return Err(invalid(
                field("max_particles"),
                format!("at most {MAX_FLUID_PARTICLES} particles, got {cap}"),
            ));
        }
        desc.max_particles = cap as usize;
        let h = self.world.add_fluid(desc).map_err(physics(at))?;
        for (eat, e) in emitters {
            self.world.add_fluid_emitter(h, e).map_err(physics(eat))?;
        }
        let color = f.color.unwrap_or([60, 130, 220, 200]);
        self.entities
            .insert_fluid(&self.world, h, f.name.clone(), color);
        self.fluids.insert(f.name.clone(), h);
        Ok(())
    }
}

/// The emitter `e` describes, every field checked, for a fluid `spacing`
/// m apart.
fn emitter(at: &str, e: &FluidEmitterSpec, spacing: f64) -> Result<FluidEmitter, SceneError> {
    let field = |name: &str| format!("{at}.{name}");
    let velocity = vec3(&field("velocity"), e.velocity)?;
    if velocity == DVec3::ZERO {
        return Err(invalid(
            field("velocity"),
            "must not be zero: it is also the nozzle's axis",
        ));
    }
    let start = non_negative(&field("start"), e.start.unwrap_or(0.0))?;
    let stop = e.stop.map(|s| finite(&field("stop"), s)).transpose()?;
    if let Some(stop) = stop {
        if stop < start {
            return Err(invalid(
                field("stop"),
                format!("{stop} s is before the start, {start} s"),
            ));
        }
    }
    if e.limit == Some(0) {
        return Err(invalid(field("limit"), "must be > 0, got 0"));
    }
    let emitter = FluidEmitter {
        position: vec3(&field("position"), e.position)?,
        velocity,
        radius: non_negative(&field("radius"), e.radius.unwrap_or(0.0))?,
        interval: e
            .interval
            .map(|i| positive(&field("interval"), i))
            .transpose()?,
        start,
        stop,
        limit: e.limit.map(u64::from),
    };
    // The rest (shots that would overlap, a nozzle too wide) as the
    // engine checks it.
    emitter.validate(spacing).map_err(physics(at))?;
    Ok(emitter)
}
