//! Particle systems and what is made of particles: ropes and cloths.

use super::*;

impl Builder {
    pub(super) fn particle_system(&mut self, radius: f64) -> SystemHandle {
        // The world's gravity reaches the particles as it does the bodies.
        let sys = self.world.add_system(SystemDesc {
            collision_radius: radius,
            ..SystemDesc::default()
        });
        self.systems.push(sys);
        sys
    }

    pub(super) fn particle_entities(
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

    pub(super) fn rope(&mut self, at: &str, r: &RopeSpec) -> Result<(), SceneError> {
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

    pub(super) fn cloth(&mut self, at: &str, c: &ClothSpec) -> Result<(), SceneError> {
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
}
