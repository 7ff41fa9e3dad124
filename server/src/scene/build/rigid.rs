//! Rigid bodies: single bodies, generators of many, bridges and ragdolls.

use super::*;

impl Builder {
    /// Adds one body (at `offset` plus its own position) and its entity.
    pub(super) fn body(
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

    pub(super) fn generator(&mut self, at: &str, g: &Generator) -> Result<(), SceneError> {
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

    pub(super) fn bridge(&mut self, at: &str, b: &BridgeArgs<'_>) -> Result<(), SceneError> {
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

    pub(super) fn ragdoll(&mut self, at: &str, r: &RagdollSpec) -> Result<(), SceneError> {
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

    pub(super) fn body_named(&self, at: &str, name: &str) -> Result<BodyHandle, SceneError> {
        self.names
            .get(name)
            .copied()
            .ok_or_else(|| invalid(at, format!("no body is named `{name}`")))
    }
}

pub(super) struct BridgeArgs<'a> {
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
