//! Force generators, and the water regions that make entities.

use super::*;

impl Builder {
    pub(super) fn force(&mut self, at: &str, f: &ForceSpec) -> Result<(), SceneError> {
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

    pub(super) fn water_region(&mut self, at: &str, r: &RegionSpec) -> Result<(), SceneError> {
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
}
