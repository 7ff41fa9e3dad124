//! Rigid bodies and their shapes in the saved state.
//!
//! Shapes are written as the inputs that built them (a hull as its
//! vertices, a mesh as vertices and triangles) and rebuilt through the same
//! validating constructors on restore; a compound nests at most
//! [`MAX_COMPOUND_DEPTH`] levels so hostile bytes cannot recurse without
//! bound.

use std::collections::{BTreeMap, BTreeSet};

use glam::{DQuat, DVec3, Quat, Vec3};

use super::{invalid, Reader, SavedStateError, StateSink};
use crate::handle::BodyHandle;
use crate::rigid::aabb::Aabb;
use crate::rigid::attachment::Attachment;
use crate::rigid::body::{BodyKind, CombineRule, RigidBody};
use crate::rigid::joint::{Joint, JointDesc, JointKind};
use crate::rigid::pipeline::{CachedManifold, CachedPoint, ContactCache, ContactKey, Reference};
use crate::rigid::pose::Pose;
use crate::rigid::shape::Shape;
use crate::rigid::solver::SolverConfig;

/// Deepest nesting of compound shapes a saved state may hold.
pub const MAX_COMPOUND_DEPTH: u32 = 8;

fn quat<S: StateSink>(s: &mut S, q: DQuat) {
    for c in q.to_array() {
        s.f64(c);
    }
}

fn pose<S: StateSink>(s: &mut S, p: &Pose) {
    s.vec3(p.translation);
    quat(s, p.rotation);
}

pub(super) fn body<S: StateSink>(s: &mut S, b: &RigidBody) {
    s.u8(b.kind.code());
    s.vec3(b.com);
    quat(s, b.rotation);
    s.vec3(b.linvel);
    s.vec3(b.angvel);
    s.vec3(b.push_velocity);
    s.vec3(b.local_com);
    s.f64(b.inv_mass);
    quat(s, b.principal);
    s.vec3(b.inv_principal_inertia);
    s.f64(b.linear_damping);
    s.f64(b.angular_damping);
    s.f64(b.gravity_scale);
    s.f64(b.drag_linear);
    s.f64(b.drag_quadratic);
    s.f64(b.friction_static);
    s.f64(b.friction_dynamic);
    s.f64(b.restitution);
    s.u8(b.friction_combine.code() | (b.restitution_combine.code() << 4));
    s.f64(b.contact_force_threshold);
    s.f64(b.sleep_time);
    s.u8(u8::from(b.ccd)
        | (u8::from(b.can_sleep) << 1)
        | (u8::from(b.sleeping) << 2)
        | (u8::from(b.quarantined) << 3)
        | (u8::from(b.sensor) << 4));
    s.vec3(b.control_force);
    s.vec3(b.control_torque);
    match &b.shape {
        None => s.u8(0),
        Some(sh) => {
            s.u8(1);
            shape(s, sh);
        }
    }
}

fn points<S: StateSink>(s: &mut S, p: &[DVec3]) {
    s.u64(p.len() as u64);
    for &v in p {
        s.vec3(v);
    }
}

fn shape<S: StateSink>(s: &mut S, sh: &Shape) {
    match sh {
        Shape::Sphere { radius } => {
            s.u8(0);
            s.f64(*radius);
        }
        Shape::Cuboid { half_extents } => {
            s.u8(1);
            s.vec3(*half_extents);
        }
        Shape::Capsule {
            half_height,
            radius,
        } => {
            s.u8(2);
            s.f64(*half_height);
            s.f64(*radius);
        }
        Shape::Cylinder {
            half_height,
            radius,
        } => {
            s.u8(3);
            s.f64(*half_height);
            s.f64(*radius);
        }
        Shape::ConvexHull(h) => {
            s.u8(4);
            points(s, h.vertices());
        }
        Shape::TriMesh(m) => {
            s.u8(5);
            points(s, m.vertices());
            s.u64(m.triangles().len() as u64);
            for t in m.triangles() {
                for &i in t {
                    s.u32(i);
                }
            }
        }
        Shape::HeightField(h) => {
            s.u8(6);
            s.u64(h.rows() as u64);
            s.u64(h.cols() as u64);
            s.vec3(h.scale());
            s.u64(h.heights().len() as u64);
            for &x in h.heights() {
                s.f64(x);
            }
        }
        Shape::Compound(parts) => {
            s.u8(7);
            s.u64(parts.len() as u64);
            for (p, child) in parts.iter() {
                pose(s, p);
                shape(s, child);
            }
        }
    }
}

fn shape_err(e: impl std::fmt::Display) -> SavedStateError {
    SavedStateError::Invalid(format!("shape: {e}"))
}

impl Reader<'_> {
    fn quat(&mut self, what: &str) -> Result<DQuat, SavedStateError> {
        let q = DQuat::from_xyzw(
            self.finite(what)?,
            self.finite(what)?,
            self.finite(what)?,
            self.finite(what)?,
        );
        if (q.length() - 1.0).abs() > 1e-6 {
            return invalid(format!("{what} is not a unit quaternion"));
        }
        Ok(q)
    }

    fn points(&mut self, what: &str) -> Result<Vec<DVec3>, SavedStateError> {
        self.vec3s(what)
    }

    pub(super) fn body(&mut self) -> Result<RigidBody, SavedStateError> {
        let kind = BodyKind::from_code(self.u8()?)
            .ok_or_else(|| SavedStateError::Invalid("body kind".into()))?;
        let com = self.vec3("body centre of mass")?;
        let rotation = self.quat("body rotation")?;
        let linvel = self.vec3("body velocity")?;
        let angvel = self.vec3("body angular velocity")?;
        // Version 4 and older did not keep the push-out.
        let push_velocity = if self.version >= 5 {
            self.vec3("body push velocity")?
        } else {
            DVec3::ZERO
        };
        let local_com = self.vec3("body local centre of mass")?;
        let inv_mass = self.finite("body inverse mass")?;
        let principal = self.quat("body principal frame")?;
        let inv_principal_inertia = self.vec3("body inverse inertia")?;
        let linear_damping = self.finite("linear damping")?;
        let angular_damping = self.finite("angular damping")?;
        let gravity_scale = self.finite("gravity scale")?;
        let drag_linear = self.finite("body linear drag")?;
        let drag_quadratic = self.finite("body quadratic drag")?;
        let friction_static = self.finite("static friction")?;
        let friction_dynamic = self.finite("dynamic friction")?;
        let restitution = self.finite("restitution")?;
        let rules = self.u8()?;
        let (Some(friction_combine), Some(restitution_combine)) = (
            CombineRule::from_code(rules & 0xf),
            CombineRule::from_code(rules >> 4),
        ) else {
            return invalid(format!("unknown combine rules {rules:#x}"));
        };
        let contact_force_threshold = self.finite("contact force threshold")?;
        let sleep_time = self.finite("sleep time")?;
        if friction_static < 0.0 || friction_dynamic < 0.0 || !(0.0..=1.0).contains(&restitution) {
            return invalid("friction or restitution out of range");
        }
        let bits = self.u8()?;
        if bits > 0b1_1111 {
            return invalid("unknown body flag");
        }
        let control_force = self.vec3("body control force")?;
        let control_torque = self.vec3("body control torque")?;
        let shape = match self.u8()? {
            0 => None,
            1 => Some(self.shape(0)?),
            t => return invalid(format!("shape presence tag {t}")),
        };
        let dynamic = kind == BodyKind::Dynamic;
        let masses_ok = if dynamic {
            inv_mass > 0.0 && inv_principal_inertia.min_element() > 0.0
        } else {
            inv_mass == 0.0 && inv_principal_inertia == DVec3::ZERO
        };
        if !masses_ok
            || linear_damping < 0.0
            || angular_damping < 0.0
            || drag_linear < 0.0
            || drag_quadratic < 0.0
        {
            return invalid("body mass, inertia or damping out of range");
        }
        let radius = crate::rigid::body::bounding_radius(shape.as_ref(), local_com);
        Ok(RigidBody {
            radius,
            kind,
            com,
            rotation,
            linvel,
            angvel,
            push_velocity,
            local_com,
            inv_mass,
            principal,
            inv_principal_inertia,
            shape,
            linear_damping,
            angular_damping,
            gravity_scale,
            drag_linear,
            drag_quadratic,
            friction_static,
            friction_dynamic,
            restitution,
            friction_combine,
            restitution_combine,
            sensor: bits & 16 != 0,
            sleep_time,
            contact_force_threshold,
            ccd: bits & 1 != 0,
            can_sleep: bits & 2 != 0,
            sleeping: bits & 4 != 0,
            quarantined: bits & 8 != 0,
            control_force,
            control_torque,
        })
    }

    fn shape(&mut self, depth: u32) -> Result<Shape, SavedStateError> {
        let s = match self.u8()? {
            0 => Shape::sphere(self.finite("sphere radius")?),
            1 => Shape::cuboid(self.vec3("box half extents")?),
            2 => Shape::capsule(
                self.finite("capsule half height")?,
                self.finite("capsule radius")?,
            ),
            3 => Shape::cylinder(
                self.finite("cylinder half height")?,
                self.finite("cylinder radius")?,
            ),
            4 => {
                let p = self.points("hull vertex")?;
                let h = Shape::convex_hull(&p).map_err(shape_err)?;
                // The hull of a hull's own vertices must be the same hull, or
                // saving after restore would not give the same bytes.
                match &h {
                    Shape::ConvexHull(c) if c.vertices() == p.as_slice() => Ok(h),
                    _ => return invalid("hull vertices do not rebuild the same hull"),
                }
            }
            5 => {
                let vertices = self.points("mesh vertex")?;
                let n = self.count(12)?;
                let triangles = (0..n)
                    .map(|_| Ok([self.u32()?, self.u32()?, self.u32()?]))
                    .collect::<Result<Vec<_>, SavedStateError>>()?;
                Shape::trimesh(vertices, triangles)
            }
            6 => {
                let rows = self.u64()? as usize;
                let cols = self.u64()? as usize;
                let scale = self.vec3("heightfield scale")?;
                let heights = self.f64s("height")?;
                Shape::heightfield(heights, rows, cols, scale)
            }
            7 => {
                if depth >= MAX_COMPOUND_DEPTH {
                    return invalid("compound shapes nested too deep");
                }
                let n = self.count(57)?;
                let mut parts = Vec::with_capacity(n);
                for _ in 0..n {
                    let p = Pose {
                        translation: self.vec3("compound part position")?,
                        rotation: self.quat("compound part rotation")?,
                    };
                    parts.push((p, self.shape(depth + 1)?));
                }
                Shape::compound(parts)
            }
            t => return invalid(format!("shape kind {t}")),
        };
        s.map_err(shape_err)
    }
}

pub(super) fn solver<S: StateSink>(s: &mut S, c: &SolverConfig) {
    s.u32(c.substeps);
    s.f64(c.contact_hertz);
    s.f64(c.contact_damping_ratio);
    s.f64(c.push_out);
    s.f64(c.restitution_threshold);
    s.f64(c.stick_speed);
    s.u8(u8::from(c.sleep.enabled));
    s.f64(c.sleep.linear_tolerance);
    s.f64(c.sleep.angular_tolerance);
    s.f64(c.sleep.time_to_sleep);
}

/// `x` in single precision, which the contact cache keeps; an error
/// where it is beyond single precision's range (it would be saved as an
/// infinity, which no save may hold).
fn single(x: f64, what: &str) -> Result<f32, SavedStateError> {
    let y = x as f32;
    if y.is_finite() {
        Ok(y)
    } else {
        invalid(format!("{what} is beyond single precision"))
    }
}

fn vec3f<S: StateSink>(s: &mut S, v: Vec3) {
    for c in v.to_array() {
        s.f32(c);
    }
}

/// The contact cache: each manifold's key, its normal in A's frame, its
/// reference (when it can be used again), its impulse and separation at
/// the step that last solved it (what the pair queries read) and its
/// points, all in single precision as the cache keeps them (see
/// [`CachedPoint`]).
pub(super) fn contacts<S: StateSink>(s: &mut S, cache: &ContactCache) {
    s.u64(cache.len() as u64);
    for (k, m) in cache.iter() {
        for v in [k.a.0, k.a.1, k.b.0, k.b.1, k.child_a, k.child_b] {
            s.u32(v);
        }
        vec3f(s, m.normal_a);
        match &m.reference {
            None => s.u8(0),
            Some(r) => {
                s.u8(if r.in_a { 1 } else { 2 });
                vec3f(s, r.translation);
                for c in r.rotation.to_array() {
                    s.f32(c);
                }
                s.f32(r.reach);
            }
        }
        s.f32(m.impulse);
        s.f32(m.separation);
        s.u8(m.points.len() as u8);
        for p in &m.points {
            s.u32(p.id);
            vec3f(s, p.anchor_a);
            vec3f(s, p.anchor_b);
            s.f32(p.gap);
            s.f32(p.normal);
            s.f32(p.tangent[0]);
            s.f32(p.tangent[1]);
        }
    }
}

impl Reader<'_> {
    pub(super) fn solver(&mut self) -> Result<SolverConfig, SavedStateError> {
        let c = SolverConfig {
            substeps: self.u32()?,
            contact_hertz: self.finite("contact hertz")?,
            contact_damping_ratio: self.finite("contact damping ratio")?,
            push_out: self.finite("push-out speed")?,
            restitution_threshold: self.finite("restitution threshold")?,
            stick_speed: self.finite("stick speed")?,
            sleep: crate::rigid::island::SleepConfig {
                enabled: match self.u8()? {
                    0 => false,
                    1 => true,
                    t => return invalid(format!("sleep flag {t}")),
                },
                linear_tolerance: self.finite("linear sleep tolerance")?,
                angular_tolerance: self.finite("angular sleep tolerance")?,
                time_to_sleep: self.finite("time to sleep")?,
            },
        };
        let ok = (1..=64).contains(&c.substeps)
            && c.contact_hertz > 0.0
            && c.contact_damping_ratio >= 0.0
            && c.push_out > 0.0
            && c.restitution_threshold >= 0.0
            && c.stick_speed >= 0.0
            && c.sleep.linear_tolerance >= 0.0
            && c.sleep.angular_tolerance >= 0.0
            && c.sleep.time_to_sleep >= 0.0;
        if !ok {
            return invalid("solver settings out of range");
        }
        Ok(c)
    }

    /// A real as this version keeps it in the contact cache: single
    /// precision from version 6, double before (rounded).
    fn cached_real(&mut self, what: &str) -> Result<f32, SavedStateError> {
        if self.version >= 6 {
            self.finite32(what)
        } else {
            single(self.finite(what)?, what)
        }
    }

    fn cached_vec3(&mut self, what: &str) -> Result<Vec3, SavedStateError> {
        Ok(Vec3::new(
            self.cached_real(what)?,
            self.cached_real(what)?,
            self.cached_real(what)?,
        ))
    }

    /// The contact cache (see [`contacts`]; earlier versions below).
    pub(super) fn contacts(
        &mut self,
    ) -> Result<BTreeMap<ContactKey, CachedManifold>, SavedStateError> {
        // Version 3 kept each point's id, anchor on A and impulses only.
        let whole = self.version >= 4;
        // Bytes of the smallest manifold and point.
        let (manifold_size, point_size) = match self.version {
            3 => (32, 52),
            4 | 5 => (57, 84),
            _ => (46, 44),
        };
        let n = self.count(manifold_size)?;
        let mut cache = BTreeMap::new();
        for _ in 0..n {
            let key = ContactKey {
                a: (self.u32()?, self.u32()?),
                b: (self.u32()?, self.u32()?),
                child_a: self.u32()?,
                child_b: self.u32()?,
            };
            let (normal_a, reference) = if whole {
                let normal_a = self.cached_vec3("contact normal")?;
                if (normal_a.as_dvec3().length() - 1.0).abs() > 1e-6 {
                    return invalid("a cached contact normal is not a unit vector");
                }
                let reference = match self.u8()? {
                    0 => None,
                    tag @ (1 | 2) => {
                        let translation = self.cached_vec3("contact reference translation")?;
                        let rotation = Quat::from_array([
                            self.cached_real("contact reference rotation")?,
                            self.cached_real("contact reference rotation")?,
                            self.cached_real("contact reference rotation")?,
                            self.cached_real("contact reference rotation")?,
                        ]);
                        if (rotation.as_dquat().length() - 1.0).abs() > 1e-6 {
                            return invalid("contact reference rotation is not a unit quaternion");
                        }
                        let r = Reference {
                            in_a: tag == 1,
                            translation,
                            rotation,
                            reach: self.cached_real("contact reach")?,
                        };
                        if r.reach < 0.0 {
                            return invalid("a cached manifold's reach is negative");
                        }
                        Some(r)
                    }
                    t => return invalid(format!("contact reference tag {t}")),
                };
                (normal_a, reference)
            } else {
                (Vec3::ZERO, None)
            };
            // Before version 6 the pair queries' figures were kept apart,
            // by pair (see `pairs_into`).
            let (impulse, separation) = if self.version >= 6 {
                (
                    self.finite32("contact impulse")?,
                    self.finite32("contact separation")?,
                )
            } else {
                (0.0, 0.0)
            };
            if impulse < 0.0 {
                return invalid("a cached manifold's impulse is negative");
            }
            let m = if self.version >= 6 {
                usize::from(self.u8()?)
            } else {
                self.count(point_size)?
            };
            if m > crate::rigid::contact::MAX_POINTS {
                return invalid("too many points in a cached manifold");
            }
            let points = (0..m)
                .map(|_| {
                    let id = self.u32()?;
                    let anchor_a = self.cached_vec3("contact anchor")?;
                    let (anchor_b, gap) = if whole {
                        (
                            self.cached_vec3("contact anchor")?,
                            self.cached_real("contact gap")?,
                        )
                    } else {
                        (Vec3::ZERO, 0.0)
                    };
                    Ok(CachedPoint {
                        id,
                        anchor_a,
                        anchor_b,
                        gap,
                        normal: self.cached_real("contact impulse")?,
                        tangent: [
                            self.cached_real("friction impulse")?,
                            self.cached_real("friction impulse")?,
                        ],
                    })
                })
                .collect::<Result<Vec<_>, SavedStateError>>()?;
            let kept = CachedManifold {
                normal_a,
                reference,
                points,
                impulse,
                separation,
            };
            if cache.insert(key, kept).is_some() {
                return invalid("duplicate cached manifold");
            }
        }
        Ok(cache)
    }
}

pub(super) fn touching<S: StateSink>(s: &mut S, set: &BTreeSet<(BodyHandle, BodyHandle)>) {
    s.u64(set.len() as u64);
    for (a, b) in set {
        for v in [a.index, a.generation, b.index, b.generation] {
            s.u32(v);
        }
    }
}

pub(super) fn bounds<S: StateSink>(s: &mut S, b: Option<Aabb>) {
    match b {
        None => s.u8(0),
        Some(b) => {
            s.u8(1);
            s.vec3(b.min);
            s.vec3(b.max);
        }
    }
}

impl Reader<'_> {
    pub(super) fn touching(
        &mut self,
    ) -> Result<BTreeSet<(BodyHandle, BodyHandle)>, SavedStateError> {
        let n = self.count(16)?;
        let mut set = BTreeSet::new();
        for _ in 0..n {
            let a = self.body_handle()?;
            let b = self.body_handle()?;
            set.insert((a, b));
        }
        Ok(set)
    }

    /// The pairs in contact that version 5 kept apart from the contact
    /// cache (handle order; the figures the pair queries report), put
    /// back into the pairs' manifolds: the first of a pair's manifolds
    /// takes the pair's impulse, and all its separation. (Its normal is
    /// read from the manifold, turned with A.)
    pub(super) fn pairs_into(
        &mut self,
        cache: &mut BTreeMap<ContactKey, CachedManifold>,
    ) -> Result<(), SavedStateError> {
        let n = self.count(60)?;
        let mut last: Option<(BodyHandle, BodyHandle)> = None;
        let key = |h: BodyHandle| (h.index, h.generation);
        for _ in 0..n {
            let a = self.body_handle()?;
            let b = self.body_handle()?;
            let normal = self.vec3("contact pair normal")?;
            let separation = self.finite("contact pair separation")?;
            let impulse = self.finite("contact pair impulse")?;
            let points = self.u32()?;
            if key(a) >= key(b) || last.is_some_and(|(p, q)| (key(p), key(q)) >= (key(a), key(b))) {
                return invalid("contact pairs are not in handle order");
            }
            if (normal.length() - 1.0).abs() > 1e-6 || impulse < 0.0 || points == 0 {
                return invalid("a contact pair's normal, impulse or point count is out of range");
            }
            last = Some((a, b));
            let from = ContactKey {
                a: key(a),
                b: key(b),
                child_a: 0,
                child_b: 0,
            };
            let mut first = true;
            for (_, m) in cache
                .range_mut(from..)
                .take_while(|(k, _)| (k.a, k.b) == (key(a), key(b)))
            {
                m.impulse = if first {
                    single(impulse, "contact pair impulse")?
                } else {
                    0.0
                };
                m.separation = single(separation, "contact pair separation")?;
                first = false;
            }
        }
        Ok(())
    }

    /// A body handle: its arena index, then its generation.
    pub(super) fn body_handle(&mut self) -> Result<BodyHandle, SavedStateError> {
        Ok(BodyHandle {
            index: self.u32()?,
            generation: self.u32()?,
        })
    }

    pub(super) fn bounds(&mut self) -> Result<Option<Aabb>, SavedStateError> {
        match self.u8()? {
            0 => Ok(None),
            1 => {
                let (min, max) = (self.vec3("bounds min")?, self.vec3("bounds max")?);
                if min.cmpgt(max).any() {
                    return invalid("world bounds min exceeds max");
                }
                Ok(Some(Aabb { min, max }))
            }
            t => invalid(format!("bounds tag {t}")),
        }
    }
}

pub(super) fn joint<S: StateSink>(s: &mut S, j: &Joint) {
    let d = &j.desc;
    for v in [d.a.index, d.a.generation, d.b.index, d.b.generation] {
        s.u32(v);
    }
    s.vec3(d.anchor_a);
    s.vec3(d.anchor_b);
    s.f64(d.break_force);
    let opt2 = |s: &mut S, o: Option<(f64, f64)>| match o {
        None => s.u8(0),
        Some((x, y)) => {
            s.u8(1);
            s.f64(x);
            s.f64(y);
        }
    };
    match d.kind {
        JointKind::Ball => s.u8(0),
        JointKind::Fixed => s.u8(1),
        JointKind::Hinge {
            axis_a,
            axis_b,
            limits,
            motor,
        } => {
            s.u8(2);
            s.vec3(axis_a);
            s.vec3(axis_b);
            opt2(s, limits);
            opt2(s, motor);
        }
        JointKind::SwingTwist {
            axis_a,
            axis_b,
            swing_limit,
            twist_limits,
        } => {
            s.u8(4);
            s.vec3(axis_a);
            s.vec3(axis_b);
            s.f64(swing_limit);
            s.f64(twist_limits.0);
            s.f64(twist_limits.1);
        }
        JointKind::Prismatic {
            axis_a,
            limits,
            motor,
        } => {
            s.u8(5);
            s.vec3(axis_a);
            opt2(s, limits);
            opt2(s, motor);
        }
        JointKind::Distance { min, max, spring } => {
            s.u8(3);
            s.f64(min);
            s.f64(max);
            match spring {
                None => s.u8(0),
                Some((r, hz, z)) => {
                    s.u8(1);
                    s.f64(r);
                    s.f64(hz);
                    s.f64(z);
                }
            }
        }
    }
    quat(s, j.reference);
    s.vec3(j.linear_impulse);
    s.vec3(j.angular_impulse);
    s.f64(j.limit_impulse[0]);
    s.f64(j.limit_impulse[1]);
    s.f64(j.swing_impulse);
    s.f64(j.motor_impulse);
    s.f64(j.spring_impulse);
    s.f64(j.distance_impulse[0]);
    s.f64(j.distance_impulse[1]);
}

impl Reader<'_> {
    fn opt2(&mut self, what: &str) -> Result<Option<(f64, f64)>, SavedStateError> {
        match self.u8()? {
            0 => Ok(None),
            1 => Ok(Some((self.finite(what)?, self.finite(what)?))),
            t => invalid(format!("{what} tag {t}")),
        }
    }

    pub(super) fn joint(&mut self) -> Result<Joint, SavedStateError> {
        let a = self.body_handle()?;
        let b = self.body_handle()?;
        let anchor_a = self.vec3("joint anchor")?;
        let anchor_b = self.vec3("joint anchor")?;
        let break_force = self.finite("joint break force")?;
        let kind = match self.u8()? {
            0 => JointKind::Ball,
            1 => JointKind::Fixed,
            2 => JointKind::Hinge {
                axis_a: self.vec3("hinge axis")?,
                axis_b: self.vec3("hinge axis")?,
                limits: self.opt2("hinge limits")?,
                motor: self.opt2("hinge motor")?,
            },
            3 => JointKind::Distance {
                min: self.finite("distance min")?,
                max: self.finite("distance max")?,
                spring: match self.u8()? {
                    0 => None,
                    1 => Some((
                        self.finite("spring")?,
                        self.finite("spring")?,
                        self.finite("spring")?,
                    )),
                    t => return invalid(format!("spring tag {t}")),
                },
            },
            4 => JointKind::SwingTwist {
                axis_a: self.vec3("twist axis")?,
                axis_b: self.vec3("twist axis")?,
                swing_limit: self.finite("swing limit")?,
                twist_limits: (self.finite("twist limit")?, self.finite("twist limit")?),
            },
            5 => JointKind::Prismatic {
                axis_a: self.vec3("prismatic axis")?,
                limits: self.opt2("prismatic limits")?,
                motor: self.opt2("prismatic motor")?,
            },
            t => return invalid(format!("joint kind {t}")),
        };
        if a == b || break_force < 0.0 {
            return invalid("joint joins a body to itself or has a negative break force");
        }
        Ok(Joint {
            desc: JointDesc {
                a,
                b,
                anchor_a,
                anchor_b,
                kind,
                break_force,
            },
            reference: self.quat("joint reference")?,
            linear_impulse: self.vec3("joint impulse")?,
            angular_impulse: self.vec3("joint impulse")?,
            limit_impulse: [self.finite("joint impulse")?, self.finite("joint impulse")?],
            swing_impulse: self.finite("joint impulse")?,
            motor_impulse: self.finite("joint impulse")?,
            spring_impulse: self.finite("joint impulse")?,
            distance_impulse: [self.finite("joint impulse")?, self.finite("joint impulse")?],
        })
    }
}

pub(super) fn attachment<S: StateSink>(s: &mut S, a: &Attachment) {
    let p = a.particle;
    for v in [
        p.system.index,
        p.system.generation,
        p.slot,
        p.generation,
        a.body.index,
        a.body.generation,
    ] {
        s.u32(v);
    }
    s.vec3(a.anchor);
    s.f64(a.params.rest_length);
    s.f64(a.params.stiffness);
    s.f64(a.params.damping);
}

impl Reader<'_> {
    pub(super) fn attachment(&mut self) -> Result<Attachment, SavedStateError> {
        let system = crate::handle::SystemHandle {
            index: self.u32()?,
            generation: self.u32()?,
        };
        let particle = crate::handle::ParticleHandle {
            system,
            slot: self.u32()?,
            generation: self.u32()?,
        };
        let body = self.body_handle()?;
        let anchor = self.vec3("attachment anchor")?;
        let params = crate::spring::SpringParams {
            rest_length: self.finite("attachment rest length")?,
            stiffness: self.finite("attachment stiffness")?,
            damping: self.finite("attachment damping")?,
        };
        params
            .validate()
            .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
        Ok(Attachment {
            particle,
            body,
            anchor,
            params,
        })
    }
}
