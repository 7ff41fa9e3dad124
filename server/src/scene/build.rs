//! Building a scene file into a world and its entity table.
//!
//! Order (it fixes the entity ids): `bodies`, `generators`, `ragdolls`,
//! `ropes`, `cloths`, then the water regions of `forces`; joints after
//! every body exists, so they may name bodies from any section. The XPBD
//! `soft_bodies` and `fluids` (see [`soft`]) come after the cloths and make
//! no entities. Every check reports the path of the entry it refuses.

mod soft;

use std::collections::BTreeMap;

use inertia_physics::glam::{DMat3, DQuat, DVec3};
use inertia_physics::rigid::aabb::Aabb;
use inertia_physics::rigid::body::{BodyKind, RigidBodyDesc};
use inertia_physics::rigid::joint::{JointDesc, JointKind};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::ragdoll::{build_ragdoll, RagdollDesc};
use inertia_physics::rigid::shape::Shape;
use inertia_physics::rigid::solver::SolverConfig;
use inertia_physics::{
    build_cloth, build_rope, BodyHandle, Buoyancy, ClothDesc, Drag, Explosion, FluidHandle, Force,
    ParticleHandle, PhysicsError, RopeDesc, SoftBodyHandle, SpringParams, SpringStiffness,
    SystemDesc, SystemHandle, Wind, World, WorldConfig,
};
use inertia_protocol::{EntityDesc, EntityKind, ShapeDesc};

use super::entities::{entity_kind, shape_desc, EntitySource, EntityTable};
use super::schema::*;
use super::{BuiltScene, SceneError};

/// Slowest tick rate at which rope-to-body attachments stay stable, Hz.
const ATTACH_HZ: f64 = 60.0;

/// Most bodies one generator may make.
const MAX_GENERATED: u64 = 100_000;

fn invalid(at: impl Into<String>, why: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        at: at.into(),
        why: why.into(),
    }
}

fn physics(at: impl Into<String>) -> impl FnOnce(PhysicsError) -> SceneError {
    let at = at.into();
    move |source| SceneError::Physics { at, source }
}

fn finite(at: &str, v: f64) -> Result<f64, SceneError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(invalid(at, format!("must be a finite number, got {v}")))
    }
}

fn positive(at: &str, v: f64) -> Result<f64, SceneError> {
    finite(at, v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(at, format!("must be > 0, got {v}")))
    }
}

fn non_negative(at: &str, v: f64) -> Result<f64, SceneError> {
    finite(at, v)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(invalid(at, format!("must be >= 0, got {v}")))
    }
}

fn vec3(at: &str, v: Vec3) -> Result<DVec3, SceneError> {
    for (i, c) in v.iter().enumerate() {
        if !c.is_finite() {
            return Err(invalid(
                format!("{at}[{i}]"),
                format!("must be a finite number, got {c}"),
            ));
        }
    }
    Ok(DVec3::from_array(v))
}

fn positive3(at: &str, v: Vec3) -> Result<DVec3, SceneError> {
    for (i, &c) in v.iter().enumerate() {
        positive(&format!("{at}[{i}]"), c)?;
    }
    Ok(DVec3::from_array(v))
}

fn unit(at: &str, v: Vec3) -> Result<DVec3, SceneError> {
    let v = vec3(at, v)?;
    let len = v.length();
    if len > 1e-12 {
        Ok(v / len)
    } else {
        Err(invalid(at, "must not be the zero vector"))
    }
}

/// The quaternion a rotation spec stands for.
pub(crate) fn rotation(at: &str, r: Option<&Rotation>) -> Result<DQuat, SceneError> {
    let Some(r) = r else {
        return Ok(DQuat::IDENTITY);
    };
    match *r {
        Rotation::Quat(q) => {
            for (i, c) in q.iter().enumerate() {
                finite(&format!("{at}[{i}]"), *c)?;
            }
            let q = DQuat::from_array(q);
            let len = q.length();
            if (len - 1.0).abs() > 1e-6 {
                return Err(invalid(
                    at,
                    format!("a rotation quaternion must have length 1, got {len}"),
                ));
            }
            Ok(q / len)
        }
        Rotation::Euler(deg) => {
            let d = vec3(at, deg)?;
            Ok(DQuat::from_rotation_z(d.z.to_radians())
                * DQuat::from_rotation_y(d.y.to_radians())
                * DQuat::from_rotation_x(d.x.to_radians()))
        }
        Rotation::AxisAngle { axis, deg } => {
            let axis = unit(&format!("{at}.axis"), axis)?;
            let deg = finite(&format!("{at}.deg"), deg)?;
            Ok(DQuat::from_axis_angle(axis, deg.to_radians()))
        }
    }
}

/// The physics shape of a shape spec; `solid` refuses surfaces (meshes).
fn shape(at: &str, s: &ShapeSpec, nested: bool) -> Result<Shape, SceneError> {
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

fn default_color(kind: BodyKind, index: usize) -> [u8; 4] {
    const PALETTE: [[u8; 4]; 6] = [
        [214, 96, 77, 255],
        [67, 147, 195, 255],
        [244, 165, 130, 255],
        [146, 197, 222, 255],
        [178, 171, 210, 255],
        [253, 219, 120, 255],
    ];
    match kind {
        BodyKind::Static => [140, 140, 135, 255],
        BodyKind::Kinematic => [120, 180, 120, 255],
        BodyKind::Dynamic => PALETTE[index % PALETTE.len()],
    }
}

/// Everything the build has made so far.
struct Builder {
    world: World,
    entities: EntityTable,
    names: BTreeMap<String, BodyHandle>,
    /// Where each name was defined, for duplicate reports.
    systems: Vec<SystemHandle>,
    gravity: DVec3,
    /// Joints of generators, made once every body exists: (path, a, b,
    /// world anchor, kind with world axes).
    pending_joints: Vec<PendingJoint>,
    unnamed: usize,
    /// XPBD soft bodies by name.
    soft_bodies: BTreeMap<String, SoftBodyHandle>,
    /// Fluids by name.
    fluids: BTreeMap<String, FluidHandle>,
}

struct PendingJoint {
    at: String,
    a: String,
    b: String,
    anchor: DVec3,
    kind: JointKind,
    break_force: f64,
}

impl Builder {
    fn add_entity(
        &mut self,
        source: EntitySource,
        kind: EntityKind,
        shape: ShapeDesc,
        color: [u8; 4],
        name: String,
        pose: Pose,
    ) {
        self.entities.insert(
            source,
            EntityDesc {
                id: 0,
                kind,
                shape,
                color,
                owner: None,
                name,
                position: pose.translation.to_array(),
                rotation: pose.rotation.to_array(),
            },
        );
    }

    fn name(&mut self, at: &str, name: Option<&str>, h: BodyHandle) -> Result<String, SceneError> {
        let name = match name {
            Some(n) => {
                if n.is_empty() {
                    return Err(invalid(at, "a name must not be empty"));
                }
                n.to_string()
            }
            None => {
                self.unnamed += 1;
                format!("body#{}", self.unnamed)
            }
        };
        if self.names.insert(name.clone(), h).is_some() {
            return Err(invalid(at, format!("duplicate body name `{name}`")));
        }
        Ok(name)
    }

    /// Adds one body (at `offset` plus its own position) and its entity.
    fn body(
        &mut self,
        at: &str,
        spec: &BodySpec,
        name: Option<&str>,
        offset: DVec3,
    ) -> Result<BodyHandle, SceneError> {
        let s = shape(&format!("{at}.shape"), &spec.shape, false)?;
        let position = offset + vec3(&format!("{at}.position"), spec.position)?;
        let rot = rotation(&format!("{at}.rotation"), spec.rotation.as_ref())?;
        let pose = Pose::new(position, rot);
        let kind = match spec.kind {
            BodyKindSpec::Dynamic => BodyKind::Dynamic,
            BodyKindSpec::Static => BodyKind::Static,
            BodyKindSpec::Kinematic => BodyKind::Kinematic,
        };
        let mut desc = match kind {
            BodyKind::Dynamic => {
                if matches!(s, Shape::TriMesh(_)) {
                    return Err(invalid(
                        format!("{at}.shape"),
                        "a triangle mesh has no volume: make the body Static",
                    ));
                }
                let density = match (spec.density, spec.mass) {
                    (Some(_), Some(_)) => {
                        return Err(invalid(at, "give density or mass, not both"))
                    }
                    (Some(d), None) => positive(&format!("{at}.density"), d)?,
                    (None, Some(m)) => {
                        positive(&format!("{at}.mass"), m)?;
                        1.0
                    }
                    (None, None) => 1000.0,
                };
                let mut d = RigidBodyDesc::dynamic(s.clone(), density, pose)
                    .map_err(physics(format!("{at}.shape")))?;
                if let Some(m) = spec.mass {
                    let k = m / d.mass_properties.mass;
                    d.mass_properties.mass = m;
                    d.mass_properties.inertia *= k;
                }
                d
            }
            BodyKind::Static => RigidBodyDesc::fixed(s.clone(), pose),
            BodyKind::Kinematic => RigidBodyDesc::kinematic(s.clone(), pose),
        };
        desc.linear_velocity = vec3(&format!("{at}.velocity"), spec.velocity)?;
        desc.angular_velocity = vec3(&format!("{at}.angular_velocity"), spec.angular_velocity)?;
        if let Some(f) = spec.friction {
            let f = non_negative(&format!("{at}.friction"), f)?;
            desc.friction_static = f;
            desc.friction_dynamic = f;
        }
        if let Some(r) = spec.restitution {
            let r = non_negative(&format!("{at}.restitution"), r)?;
            if r > 1.0 {
                return Err(invalid(
                    format!("{at}.restitution"),
                    format!("must be at most 1, got {r}"),
                ));
            }
            desc.restitution = r;
        }
        if let Some(d) = spec.linear_damping {
            desc.linear_damping = non_negative(&format!("{at}.linear_damping"), d)?;
        }
        if let Some(d) = spec.angular_damping {
            desc.angular_damping = non_negative(&format!("{at}.angular_damping"), d)?;
        }
        if let Some(g) = spec.gravity_scale {
            desc.gravity_scale = finite(&format!("{at}.gravity_scale"), g)?;
        }
        desc.ccd = spec.ccd;
        desc.sensor = spec.sensor;
        let h = self.world.add_body(&desc).map_err(physics(at))?;
        let name = self.name(at, name.or(spec.name.as_deref()), h)?;
        let index = self.entities.len();
        self.add_entity(
            EntitySource::Body(h),
            entity_kind(kind),
            shape_desc(&s),
            spec.color.unwrap_or(default_color(kind, index)),
            name,
            pose,
        );
        Ok(h)
    }

    fn generator(&mut self, at: &str, g: &Generator) -> Result<(), SceneError> {
        match g {
            Generator::Pyramid {
                name,
                rows,
                origin,
                gap,
                body,
            } => {
                if !(1..=100).contains(rows) {
                    return Err(invalid(
                        format!("{at}.rows"),
                        format!("must be in 1..=100, got {rows}"),
                    ));
                }
                let origin = vec3(&format!("{at}.origin"), *origin)?;
                let gap = non_negative(&format!("{at}.gap"), *gap)?;
                let size = shape(&format!("{at}.body.shape"), &body.shape, false)?.local_aabb();
                let (w, h) = (size.max.x - size.min.x, size.max.y - size.min.y);
                let mut i = 0;
                for r in 0..*rows {
                    let n = rows - r;
                    for k in 0..n {
                        let x = (k as f64 - (n - 1) as f64 * 0.5) * (w + gap);
                        let y = -size.min.y + r as f64 * h;
                        let name = format!("{name}[{i}]");
                        self.body(
                            &format!("{at}.body"),
                            body,
                            Some(&name),
                            origin + DVec3::new(x, y, 0.0),
                        )?;
                        i += 1;
                    }
                }
                Ok(())
            }
            Generator::Grid {
                name,
                counts,
                spacing,
                origin,
                body,
            } => {
                let total: u64 = counts.iter().map(|&c| u64::from(c)).product();
                if total == 0 || total > MAX_GENERATED {
                    return Err(invalid(
                        format!("{at}.counts"),
                        format!("must make 1..={MAX_GENERATED} bodies, makes {total}"),
                    ));
                }
                let spacing = vec3(&format!("{at}.spacing"), *spacing)?;
                let origin = vec3(&format!("{at}.origin"), *origin)?;
                let mut i = 0;
                for y in 0..counts[1] {
                    for z in 0..counts[2] {
                        for x in 0..counts[0] {
                            let p = origin
                                + spacing * DVec3::new(f64::from(x), f64::from(y), f64::from(z));
                            let name = format!("{name}[{i}]");
                            self.body(&format!("{at}.body"), body, Some(&name), p)?;
                            i += 1;
                        }
                    }
                }
                Ok(())
            }
            Generator::Bridge {
                name,
                start,
                end,
                planks,
                width,
                thickness,
                gap,
                sag,
                density,
                start_body,
                end_body,
                color,
            } => self.bridge(
                at,
                &BridgeArgs {
                    name,
                    start: vec3(&format!("{at}.start"), *start)?,
                    end: vec3(&format!("{at}.end"), *end)?,
                    planks: *planks,
                    width: positive(&format!("{at}.width"), *width)?,
                    thickness: positive(&format!("{at}.thickness"), *thickness)?,
                    gap: non_negative(&format!("{at}.gap"), *gap)?,
                    sag: finite(&format!("{at}.sag"), *sag)?,
                    density: positive(&format!("{at}.density"), density.unwrap_or(600.0))?,
                    start_body: start_body.as_deref(),
                    end_body: end_body.as_deref(),
                    color: *color,
                },
            ),
        }
    }

    fn bridge(&mut self, at: &str, b: &BridgeArgs<'_>) -> Result<(), SceneError> {
        if !(1..=1000).contains(&b.planks) {
            return Err(invalid(
                format!("{at}.planks"),
                format!("must be in 1..=1000, got {}", b.planks),
            ));
        }
        let span = b.end - b.start;
        let up = -self.gravity.try_normalize().unwrap_or(DVec3::NEG_Y);
        let side = span.cross(up).try_normalize().ok_or_else(|| {
            invalid(
                format!("{at}.end"),
                "the bridge must span some horizontal distance",
            )
        })?;
        let n = b.planks as usize;
        let points: Vec<DVec3> = (0..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                b.start + span * t - up * (4.0 * b.sag * t * (1.0 - t))
            })
            .collect();
        let mut names = Vec::with_capacity(n);
        for i in 0..n {
            let (p, q) = (points[i], points[i + 1]);
            let len = (q - p).length() - b.gap;
            if len <= 0.0 {
                return Err(invalid(
                    format!("{at}.gap"),
                    "the gap leaves no room for the planks",
                ));
            }
            let dir = (q - p).normalize();
            let y = side.cross(dir);
            let rot = DQuat::from_mat3(&DMat3::from_cols(dir, y, side)).normalize();
            let spec = BodySpec {
                name: Some(format!("{}[{i}]", b.name)),
                kind: BodyKindSpec::Dynamic,
                shape: ShapeSpec::Cuboid {
                    half_extents: [len * 0.5, b.thickness * 0.5, b.width * 0.5],
                },
                position: ((p + q) * 0.5).to_array(),
                rotation: Some(Rotation::Quat(rot.to_array())),
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
                density: Some(b.density),
                mass: None,
                friction: Some(0.8),
                restitution: None,
                linear_damping: Some(0.1),
                angular_damping: Some(0.5),
                gravity_scale: None,
                ccd: false,
                sensor: false,
                color: Some(b.color.unwrap_or([150, 111, 51, 255])),
            };
            self.body(at, &spec, None, DVec3::ZERO)?;
            names.push(format!("{}[{i}]", b.name));
        }
        let hinge = JointKind::Hinge {
            axis_a: side,
            axis_b: side,
            limits: None,
            motor: None,
        };
        let mut link = |a: &str, b: &str, anchor: DVec3, at: String| {
            self.pending_joints.push(PendingJoint {
                at,
                a: a.into(),
                b: b.into(),
                anchor,
                kind: hinge,
                break_force: f64::MAX,
            })
        };
        if let Some(s) = b.start_body {
            link(s, &names[0], points[0], format!("{at}.start_body"));
        }
        for i in 1..n {
            link(&names[i - 1], &names[i], points[i], at.to_string());
        }
        if let Some(e) = b.end_body {
            link(&names[n - 1], e, points[n], format!("{at}.end_body"));
        }
        Ok(())
    }

    fn ragdoll(&mut self, at: &str, r: &RagdollSpec) -> Result<(), SceneError> {
        let position = vec3(&format!("{at}.position"), r.position)?;
        let rot = rotation(&format!("{at}.rotation"), r.rotation.as_ref())?;
        let desc = RagdollDesc {
            pose: Pose::new(position, rot),
            height: positive(&format!("{at}.height"), r.height.unwrap_or(1.8))?,
            mass: positive(&format!("{at}.mass"), r.mass.unwrap_or(75.0))?,
        };
        if r.name.is_empty() {
            return Err(invalid(format!("{at}.name"), "a name must not be empty"));
        }
        let doll = build_ragdoll(&mut self.world, &desc).map_err(physics(at))?;
        let color = r.color.unwrap_or([230, 190, 150, 255]);
        for (part, h) in doll.bodies {
            let name = format!("{}.{part}", r.name);
            let name = self.name(&format!("{at}.name"), Some(&name), h)?;
            let body = self
                .world
                .body(h)
                .ok_or_else(|| invalid(at, "part vanished"))?;
            let (shape, pose) = (body.shape().map(shape_desc), body.pose());
            let shape = shape.unwrap_or(ShapeDesc::Sphere { radius: 0.1 });
            self.add_entity(
                EntitySource::Body(h),
                EntityKind::Dynamic,
                shape,
                color,
                name,
                pose,
            );
        }
        Ok(())
    }

    fn particle_system(&mut self, radius: f64) -> SystemHandle {
        // The world's gravity reaches the particles as it does the bodies.
        let sys = self.world.add_system(SystemDesc {
            collision_radius: radius,
            ..SystemDesc::default()
        });
        self.systems.push(sys);
        sys
    }

    fn particle_entities(
        &mut self,
        name: &str,
        particles: &[ParticleHandle],
        radius: f64,
        color: [u8; 4],
    ) {
        for (i, &p) in particles.iter().enumerate() {
            let pos = self.world.particle(p).map_or(DVec3::ZERO, |s| s.position);
            self.add_entity(
                EntitySource::Particle(p),
                EntityKind::Dynamic,
                ShapeDesc::Particle {
                    radius: radius.max(0.01) as f32,
                },
                color,
                format!("{name}[{i}]"),
                Pose::from_translation(pos),
            );
        }
    }

    fn body_named(&self, at: &str, name: &str) -> Result<BodyHandle, SceneError> {
        self.names
            .get(name)
            .copied()
            .ok_or_else(|| invalid(at, format!("no body is named `{name}`")))
    }

    fn rope(&mut self, at: &str, r: &RopeSpec) -> Result<(), SceneError> {
        if !(1..=1000).contains(&r.segments) {
            return Err(invalid(
                format!("{at}.segments"),
                format!("must be in 1..=1000, got {}", r.segments),
            ));
        }
        let radius = non_negative(&format!("{at}.radius"), r.radius.unwrap_or(0.05))?;
        let start_body = r
            .attach_start
            .as_deref()
            .map(|n| self.body_named(&format!("{at}.attach_start"), n))
            .transpose()?;
        let end_body = r
            .attach_end
            .as_deref()
            .map(|n| self.body_named(&format!("{at}.attach_end"), n))
            .transpose()?;
        let desc = RopeDesc {
            start: vec3(&format!("{at}.start"), r.start)?,
            end: vec3(&format!("{at}.end"), r.end)?,
            segments: r.segments as usize,
            mass: positive(&format!("{at}.mass"), r.mass.unwrap_or(1.0))?,
            stiffness: non_negative(&format!("{at}.stiffness"), r.stiffness.unwrap_or(2000.0))?,
            damping: non_negative(&format!("{at}.damping"), r.damping.unwrap_or(2.0))?,
            drag_linear: 0.01,
            pin_start: r.pin_start && start_body.is_none(),
            pin_end: r.pin_end && end_body.is_none(),
        };
        if desc.start == desc.end {
            return Err(invalid(format!("{at}.end"), "the ends must differ"));
        }
        let sys = self.particle_system(radius);
        let rope = build_rope(&mut self.world, sys, &desc).map_err(physics(at))?;
        // The particle-body spring is evaluated once per tick (not in the
        // rope's substeps), so it must be stable at the tick rate on its own:
        // `ω dt ≤ 0.7` for the end particle at 60 Hz or faster.
        let m_end = desc.mass / (desc.segments + 1) as f64;
        let spring = SpringParams {
            rest_length: 1e-3,
            stiffness: desc.stiffness.min(0.5 * m_end * ATTACH_HZ * ATTACH_HZ),
            damping: desc.damping.min(0.2 * m_end * ATTACH_HZ),
        };
        for (body, particle, field) in [
            (start_body, rope.particles.first(), "attach_start"),
            (end_body, rope.particles.last(), "attach_end"),
        ] {
            if let (Some(b), Some(&p)) = (body, particle) {
                let pos = self.world.particle(p).map_or(DVec3::ZERO, |s| s.position);
                let pose = self.world.body(b).map_or(Pose::IDENTITY, |b| b.pose());
                self.world
                    .attach_particle(p, b, pose.inverse_transform_point(pos), spring)
                    .map_err(physics(format!("{at}.{field}")))?;
            }
        }
        self.particle_entities(
            &r.name,
            &rope.particles,
            radius,
            r.color.unwrap_or([200, 170, 110, 255]),
        );
        Ok(())
    }

    fn cloth(&mut self, at: &str, c: &ClothSpec) -> Result<(), SceneError> {
        for (field, n) in [("nu", c.nu), ("nv", c.nv)] {
            if !(2..=128).contains(&n) {
                return Err(invalid(
                    format!("{at}.{field}"),
                    format!("must be in 2..=128, got {n}"),
                ));
            }
        }
        for (i, &(u, v)) in c.pinned.iter().enumerate() {
            if u >= c.nu || v >= c.nv {
                return Err(invalid(
                    format!("{at}.pinned[{i}]"),
                    format!("({u}, {v}) is outside the {}x{} grid", c.nu, c.nv),
                ));
            }
        }
        let radius = non_negative(&format!("{at}.radius"), c.radius.unwrap_or(0.04))?;
        let k = positive(&format!("{at}.stiffness"), c.stiffness.unwrap_or(300.0))?;
        let family = |s: f64| SpringStiffness {
            stiffness: s,
            damping: s * 2e-4,
        };
        let desc = ClothDesc {
            origin: vec3(&format!("{at}.origin"), c.origin)?,
            u_axis: unit(&format!("{at}.u_axis"), c.u_axis.unwrap_or([1.0, 0.0, 0.0]))?,
            v_axis: unit(
                &format!("{at}.v_axis"),
                c.v_axis.unwrap_or([0.0, -1.0, 0.0]),
            )?,
            width: positive(&format!("{at}.width"), c.width)?,
            height: positive(&format!("{at}.height"), c.height)?,
            nu: c.nu as usize,
            nv: c.nv as usize,
            mass: positive(&format!("{at}.mass"), c.mass.unwrap_or(1.0))?,
            structural: family(k),
            shear: family(0.4 * k),
            bend: family(0.1 * k),
            drag_linear: non_negative(&format!("{at}.drag"), c.drag.unwrap_or(0.002))?,
            pinned: c
                .pinned
                .iter()
                .map(|&(u, v)| (u as usize, v as usize))
                .collect(),
        };
        let sys = self.particle_system(radius);
        let cloth = build_cloth(&mut self.world, sys, &desc).map_err(physics(at))?;
        self.particle_entities(
            &c.name,
            &cloth.particles,
            radius,
            c.color.unwrap_or([200, 40, 40, 255]),
        );
        Ok(())
    }

    fn force(&mut self, at: &str, f: &ForceSpec) -> Result<(), SceneError> {
        let (force, target): (Force, Target) = match f {
            ForceSpec::Wind {
                velocity,
                air_density,
                pressure_coefficient,
                applies_to,
            } => (
                Wind {
                    velocity: vec3(&format!("{at}.velocity"), *velocity)?,
                    air_density: non_negative(
                        &format!("{at}.air_density"),
                        air_density.unwrap_or(1.225),
                    )?,
                    pressure_coefficient: non_negative(
                        &format!("{at}.pressure_coefficient"),
                        pressure_coefficient.unwrap_or(1.0),
                    )?,
                }
                .into(),
                *applies_to,
            ),
            ForceSpec::Drag {
                linear_scale,
                quadratic_scale,
                applies_to,
            } => (
                Drag {
                    linear_scale: non_negative(
                        &format!("{at}.linear_scale"),
                        linear_scale.unwrap_or(1.0),
                    )?,
                    quadratic_scale: non_negative(
                        &format!("{at}.quadratic_scale"),
                        quadratic_scale.unwrap_or(1.0),
                    )?,
                }
                .into(),
                *applies_to,
            ),
            ForceSpec::Water {
                surface_height,
                density,
                drag,
                region,
                applies_to,
            } => {
                let surface = finite(&format!("{at}.surface_height"), *surface_height)?;
                if let Some(r) = region {
                    self.water_region(&format!("{at}.region"), r)?;
                }
                let g = self.gravity.length();
                (
                    Buoyancy {
                        surface_height: surface,
                        up: -self.gravity.try_normalize().unwrap_or(DVec3::NEG_Y),
                        fluid_density: non_negative(
                            &format!("{at}.density"),
                            density.unwrap_or(1000.0),
                        )?,
                        gravity: g,
                        fluid_drag: non_negative(&format!("{at}.drag"), drag.unwrap_or(500.0))?,
                    }
                    .into(),
                    *applies_to,
                )
            }
            ForceSpec::Explosion {
                center,
                at: time,
                peak_pressure,
                max_radius,
                applies_to,
            } => (
                Explosion {
                    center: vec3(&format!("{at}.center"), *center)?,
                    start_time: non_negative(&format!("{at}.at"), *time)?,
                    peak_pressure: non_negative(
                        &format!("{at}.peak_pressure"),
                        peak_pressure.unwrap_or(20_000.0),
                    )?,
                    max_radius: positive(&format!("{at}.max_radius"), max_radius.unwrap_or(10.0))?,
                    front_speed: 340.0,
                    front_thickness: 1.0,
                    reference_radius: 1.0,
                }
                .into(),
                *applies_to,
            ),
        };
        if matches!(target, Target::All | Target::Bodies) {
            self.world.add_body_force(force).map_err(physics(at))?;
        }
        if matches!(target, Target::All | Target::Particles) {
            for &sys in &self.systems {
                self.world.add_force(sys, force).map_err(physics(at))?;
            }
        }
        Ok(())
    }

    fn water_region(&mut self, at: &str, r: &RegionSpec) -> Result<(), SceneError> {
        let center = vec3(&format!("{at}.center"), r.center)?;
        let half = positive3(&format!("{at}.half_extents"), r.half_extents)?;
        let s = Shape::cuboid(half).map_err(|e| invalid(at, e.to_string()))?;
        let pose = Pose::from_translation(center);
        let mut desc = RigidBodyDesc::fixed(s.clone(), pose);
        desc.sensor = true;
        let h = self.world.add_body(&desc).map_err(physics(at))?;
        self.add_entity(
            EntitySource::Body(h),
            EntityKind::Water,
            shape_desc(&s),
            [40, 110, 200, 140],
            "water".into(),
            pose,
        );
        Ok(())
    }

    fn joint(&mut self, j: PendingJoint) -> Result<(), SceneError> {
        let a = self.body_named(&format!("{}.a", j.at), &j.a)?;
        let b = self.body_named(&format!("{}.b", j.at), &j.b)?;
        if a == b {
            return Err(invalid(&j.at, "a joint needs two different bodies"));
        }
        let pa = self.world.body(a).map_or(Pose::IDENTITY, |b| b.pose());
        let pb = self.world.body(b).map_or(Pose::IDENTITY, |b| b.pose());
        let (ia, ib) = (pa.rotation.inverse(), pb.rotation.inverse());
        let kind = match j.kind {
            JointKind::Hinge {
                axis_a,
                limits,
                motor,
                ..
            } => JointKind::Hinge {
                axis_a: ia * axis_a,
                axis_b: ib * axis_a,
                limits,
                motor,
            },
            JointKind::SwingTwist {
                axis_a,
                swing_limit,
                twist_limits,
                ..
            } => JointKind::SwingTwist {
                axis_a: ia * axis_a,
                axis_b: ib * axis_a,
                swing_limit,
                twist_limits,
            },
            JointKind::Prismatic {
                axis_a,
                limits,
                motor,
            } => JointKind::Prismatic {
                axis_a: ia * axis_a,
                limits,
                motor,
            },
            k => k,
        };
        self.world
            .add_joint(JointDesc {
                a,
                b,
                anchor_a: pa.inverse_transform_point(j.anchor),
                anchor_b: pb.inverse_transform_point(j.anchor),
                kind,
                break_force: j.break_force,
            })
            .map_err(physics(j.at))?;
        Ok(())
    }

    /// A file joint as a pending joint (axes and anchor in world terms).
    fn joint_spec(&self, at: &str, j: &JointSpec) -> Result<PendingJoint, SceneError> {
        let a = self.body_named(&format!("{at}.a"), &j.a)?;
        let b = self.body_named(&format!("{at}.b"), &j.b)?;
        let anchor = match j.anchor {
            Some(p) => vec3(&format!("{at}.anchor"), p)?,
            None => {
                let pa = self
                    .world
                    .body(a)
                    .map_or(DVec3::ZERO, |b| b.pose().translation);
                let pb = self
                    .world
                    .body(b)
                    .map_or(DVec3::ZERO, |b| b.pose().translation);
                (pa + pb) * 0.5
            }
        };
        let k = format!("{at}.kind");
        let pair = |f: &str, p: (f64, f64)| -> Result<(f64, f64), SceneError> {
            let lo = finite(&format!("{k}.{f}[0]"), p.0)?;
            let hi = finite(&format!("{k}.{f}[1]"), p.1)?;
            if lo > hi {
                return Err(invalid(
                    format!("{k}.{f}"),
                    format!("lower {lo} is above upper {hi}"),
                ));
            }
            Ok((lo, hi))
        };
        let motor = |p: (f64, f64), scale: f64| -> Result<(f64, f64), SceneError> {
            Ok((
                finite(&format!("{k}.motor[0]"), p.0)? * scale,
                non_negative(&format!("{k}.motor[1]"), p.1)?,
            ))
        };
        let kind = match j.kind {
            JointKindSpec::Ball => JointKind::Ball,
            JointKindSpec::Fixed => JointKind::Fixed,
            JointKindSpec::Hinge {
                axis,
                limits_deg,
                motor: m,
            } => JointKind::Hinge {
                axis_a: unit(&format!("{k}.axis"), axis)?,
                axis_b: DVec3::ZERO,
                limits: limits_deg
                    .map(|l| pair("limits_deg", l))
                    .transpose()?
                    .map(|(lo, hi)| (lo.to_radians(), hi.to_radians())),
                motor: m.map(|m| motor(m, 1f64.to_radians())).transpose()?,
            },
            JointKindSpec::SwingTwist {
                axis,
                swing_deg,
                twist_deg,
            } => {
                let twist = non_negative(&format!("{k}.twist_deg"), twist_deg)?.to_radians();
                JointKind::SwingTwist {
                    axis_a: unit(&format!("{k}.axis"), axis)?,
                    axis_b: DVec3::ZERO,
                    swing_limit: non_negative(&format!("{k}.swing_deg"), swing_deg)?.to_radians(),
                    twist_limits: (-twist, twist),
                }
            }
            JointKindSpec::Prismatic {
                axis,
                limits,
                motor: m,
            } => JointKind::Prismatic {
                axis_a: unit(&format!("{k}.axis"), axis)?,
                limits: limits.map(|l| pair("limits", l)).transpose()?,
                motor: m.map(|m| motor(m, 1.0)).transpose()?,
            },
            JointKindSpec::Distance { min, max } => {
                let (min, max) = pair("min", (min, max))?;
                non_negative(&format!("{k}.min"), min)?;
                JointKind::Distance {
                    min,
                    max,
                    spring: None,
                }
            }
        };
        Ok(PendingJoint {
            at: at.to_string(),
            a: j.a.clone(),
            b: j.b.clone(),
            anchor,
            kind,
            break_force: match j.break_force {
                Some(f) => positive(&format!("{at}.break_force"), f)?,
                None => f64::MAX,
            },
        })
    }
}

struct BridgeArgs<'a> {
    name: &'a str,
    start: DVec3,
    end: DVec3,
    planks: u32,
    width: f64,
    thickness: f64,
    gap: f64,
    sag: f64,
    density: f64,
    start_body: Option<&'a str>,
    end_body: Option<&'a str>,
    color: Option<[u8; 4]>,
}

/// Builds `file` into a world configured by `config`.
pub(crate) fn build(file: &SceneFile, config: WorldConfig) -> Result<BuiltScene, SceneError> {
    let mut world = World::new(config).map_err(physics("."))?;
    let gravity = vec3("world.gravity", file.world.gravity)?;
    world
        .set_gravity(gravity)
        .map_err(physics("world.gravity"))?;
    let substeps = file.world.solver_substeps;
    if !(1..=64).contains(&substeps) {
        return Err(invalid(
            "world.solver_substeps",
            format!("must be in 1..=64, got {substeps}"),
        ));
    }
    let mut solver = SolverConfig {
        substeps,
        ..SolverConfig::default()
    };
    solver.sleep.enabled = file.world.sleep;
    world
        .set_solver_config(solver)
        .map_err(physics("world.solver_substeps"))?;
    if let Some(b) = &file.world.bounds {
        let min = vec3("world.bounds.min", b.min)?;
        let max = vec3("world.bounds.max", b.max)?;
        if min.cmpgt(max).any() {
            return Err(invalid("world.bounds", "min must not exceed max"));
        }
        world
            .set_body_bounds(Some(Aabb::new(min, max)))
            .map_err(physics("world.bounds"))?;
    }
    let spawn_points = file
        .spawn_points
        .iter()
        .enumerate()
        .map(|(i, p)| vec3(&format!("spawn_points[{i}]"), *p))
        .collect::<Result<Vec<_>, _>>()?;
    if spawn_points.is_empty() {
        return Err(invalid("spawn_points", "give at least one spawn point"));
    }
    let mut b = Builder {
        world,
        entities: EntityTable::new(),
        names: BTreeMap::new(),
        systems: Vec::new(),
        gravity,
        pending_joints: Vec::new(),
        unnamed: 0,
        soft_bodies: BTreeMap::new(),
        fluids: BTreeMap::new(),
    };
    for (i, spec) in file.bodies.iter().enumerate() {
        b.body(&format!("bodies[{i}]"), spec, None, DVec3::ZERO)?;
    }
    for (i, g) in file.generators.iter().enumerate() {
        b.generator(&format!("generators[{i}]"), g)?;
    }
    for (i, r) in file.ragdolls.iter().enumerate() {
        b.ragdoll(&format!("ragdolls[{i}]"), r)?;
    }
    let generated = std::mem::take(&mut b.pending_joints);
    for j in generated {
        b.joint(j)?;
    }
    for (i, j) in file.joints.iter().enumerate() {
        let at = format!("joints[{i}]");
        let pending = b.joint_spec(&at, j)?;
        b.joint(pending)?;
    }
    for (i, r) in file.ropes.iter().enumerate() {
        b.rope(&format!("ropes[{i}]"), r)?;
    }
    for (i, c) in file.cloths.iter().enumerate() {
        b.cloth(&format!("cloths[{i}]"), c)?;
    }
    for (i, s) in file.soft_bodies.iter().enumerate() {
        b.soft_body(&format!("soft_bodies[{i}]"), s)?;
    }
    for (i, f) in file.fluids.iter().enumerate() {
        b.fluid(&format!("fluids[{i}]"), f)?;
    }
    for (i, f) in file.forces.iter().enumerate() {
        b.force(&format!("forces[{i}]"), f)?;
    }
    Ok(BuiltScene {
        world: b.world,
        entities: b.entities,
        bodies_by_name: b.names,
        soft_bodies_by_name: b.soft_bodies,
        fluids_by_name: b.fluids,
        spawn_points,
        name: file.name.clone(),
    })
}
