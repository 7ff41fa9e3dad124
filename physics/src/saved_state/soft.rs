//! Soft bodies in the saved state: particles, constraints (in their
//! colour order, with the colours' bounds, which decide the solve order
//! and so the bits of every later step), attachments and material.
//!
//! On restore every index is checked against the particle count, every
//! number for finiteness and range, and every colour for the colouring's
//! promise (no particle moved twice in a colour): a state that breaks it
//! would race on two threads, so it is refused.

use glam::Vec3;

use super::{invalid, option_f64, Reader, SavedStateError, StateSink};
use crate::xpbd::colouring::{Coloured, Touches};
use crate::xpbd::soft::constraints::{Bend, Distance, Tet, Tether};
use crate::xpbd::soft::{
    Plasticity, Pressure, SoftAttachment, SoftBody, SoftMaterial, MAX_SOFT_PARTICLES, MAX_SUBSTEPS,
};

fn vec3s<S: StateSink>(s: &mut S, v: &[Vec3]) {
    s.u64(v.len() as u64);
    for p in v {
        s.f32(p.x);
        s.f32(p.y);
        s.f32(p.z);
    }
}

fn f32s<S: StateSink>(s: &mut S, v: &[f32]) {
    s.u64(v.len() as u64);
    for x in v {
        s.f32(*x);
    }
}

fn coloured<S: StateSink, C>(s: &mut S, c: &Coloured<C>, mut item: impl FnMut(&mut S, &C)) {
    s.u64(c.items.len() as u64);
    for x in &c.items {
        item(s, x);
    }
    s.u64(c.ends.len() as u64);
    for e in &c.ends {
        s.u32(*e);
    }
    s.u8(u8::from(c.overflow));
}

pub(super) fn soft_body<S: StateSink>(s: &mut S, b: &SoftBody) {
    vec3s(s, &b.x);
    vec3s(s, &b.v);
    f32s(s, &b.w);
    coloured(s, &b.distance, |s, d| {
        s.u32(d.p[0]);
        s.u32(d.p[1]);
        s.f32(d.rest);
        s.f32(d.rest0);
        s.f32(d.compliance);
    });
    coloured(s, &b.bend, |s, d| {
        d.p.iter().for_each(|p| s.u32(*p));
        s.f32(d.rest);
        s.f32(d.compliance);
    });
    coloured(s, &b.tets, |s, d| {
        d.p.iter().for_each(|p| s.u32(*p));
        s.f32(d.rest);
        s.f32(d.compliance);
    });
    coloured(s, &b.tethers, |s, d| {
        s.u32(d.p[0]);
        s.u32(d.p[1]);
        s.f32(d.max);
    });
    match b.pressure {
        None => s.u8(0),
        Some(p) => {
            s.u8(1);
            s.f32(p.target);
            s.f32(p.compliance);
        }
    }
    s.u64(b.triangles.len() as u64);
    for t in &b.triangles {
        t.iter().for_each(|p| s.u32(*p));
    }
    s.u64(b.attachments.len() as u64);
    for a in &b.attachments {
        s.u32(a.particle);
        s.u32(a.body.index);
        s.u32(a.body.generation);
        s.vec3(a.local);
        s.f32(a.compliance);
    }
    let m = &b.material;
    s.u32(m.substeps);
    s.f64(m.damping);
    s.f64(m.gravity_scale);
    s.f64(m.collision_radius);
    s.f64(m.friction);
    s.u8(u8::from(m.self_collision));
    match m.plasticity {
        None => s.u8(0),
        Some(p) => {
            s.u8(1);
            s.f64(p.yield_strain);
            s.f64(p.creep);
            s.f64(p.max_strain);
        }
    }
    option_f64(s, m.tear_strain);
}

impl Reader<'_> {
    fn vec3s32(&mut self, what: &str) -> Result<Vec<Vec3>, SavedStateError> {
        let n = self.count(12)?;
        (0..n)
            .map(|_| {
                Ok(Vec3::new(
                    self.finite32(what)?,
                    self.finite32(what)?,
                    self.finite32(what)?,
                ))
            })
            .collect()
    }

    fn particle_index(&mut self, n: usize) -> Result<u32, SavedStateError> {
        let i = self.u32()?;
        if (i as usize) < n {
            Ok(i)
        } else {
            invalid(format!("soft body particle {i} of {n}"))
        }
    }

    fn non_negative32(&mut self, what: &str) -> Result<f32, SavedStateError> {
        let v = self.finite32(what)?;
        if v < 0.0 {
            return invalid(format!("{what} {v} is negative"));
        }
        Ok(v)
    }

    fn coloured<C: Touches + Clone + Sync>(
        &mut self,
        w: &[f32],
        min_size: usize,
        mut item: impl FnMut(&mut Self) -> Result<C, SavedStateError>,
    ) -> Result<Coloured<C>, SavedStateError> {
        let n = self.count(min_size)?;
        let items = (0..n).map(|_| item(self)).collect::<Result<Vec<C>, _>>()?;
        let ends = self.u32s()?;
        let overflow = match self.u8()? {
            0 => false,
            1 => true,
            t => return invalid(format!("colour overflow flag {t}")),
        };
        Coloured::from_parts(items, ends, overflow, w)
            .ok_or_else(|| SavedStateError::Invalid("a soft body's colouring is not valid".into()))
    }

    pub(super) fn soft_body(&mut self) -> Result<SoftBody, SavedStateError> {
        let x = self.vec3s32("soft body position")?;
        let n = x.len();
        if n == 0 || n > MAX_SOFT_PARTICLES {
            return invalid(format!("a soft body of {n} particles"));
        }
        let v = self.vec3s32("soft body velocity")?;
        let wn = self.count(4)?;
        let w = (0..wn)
            .map(|_| self.non_negative32("soft body inverse mass"))
            .collect::<Result<Vec<f32>, _>>()?;
        if v.len() != n || w.len() != n {
            return invalid("a soft body's velocities or masses do not match its particles");
        }
        let distance = self.coloured(&w, 20, |r| {
            let p = [r.particle_index(n)?, r.particle_index(n)?];
            let rest = r.finite32("soft edge rest length")?;
            let rest0 = r.finite32("soft edge rest length")?;
            let compliance = r.non_negative32("soft edge compliance")?;
            if rest <= 0.0 || rest0 <= 0.0 || p[0] == p[1] {
                return invalid("a degenerate soft edge");
            }
            Ok(Distance {
                p,
                rest,
                rest0,
                compliance,
            })
        })?;
        let bend = self.coloured(&w, 24, |r| {
            let p = [
                r.particle_index(n)?,
                r.particle_index(n)?,
                r.particle_index(n)?,
                r.particle_index(n)?,
            ];
            let rest = r.finite32("soft hinge rest angle")?;
            if rest.abs() > std::f32::consts::PI {
                return invalid(format!("soft hinge rest angle {rest}"));
            }
            Ok(Bend {
                p,
                rest,
                compliance: r.non_negative32("soft hinge compliance")?,
            })
        })?;
        let tets = self.coloured(&w, 24, |r| {
            let p = [
                r.particle_index(n)?,
                r.particle_index(n)?,
                r.particle_index(n)?,
                r.particle_index(n)?,
            ];
            let rest = r.finite32("soft tetrahedron rest volume")?;
            if rest <= 0.0 {
                return invalid("a soft tetrahedron of no volume");
            }
            Ok(Tet {
                p,
                rest,
                compliance: r.non_negative32("soft tetrahedron compliance")?,
            })
        })?;
        let tethers = self.coloured(&w, 12, |r| {
            let p = [r.particle_index(n)?, r.particle_index(n)?];
            Ok(Tether {
                p,
                max: r.non_negative32("soft tether length")?,
            })
        })?;
        if tethers.items.iter().any(|t| w[t.p[1] as usize] != 0.0) {
            return invalid("a soft tether's anchor is not pinned");
        }
        let pressure = match self.u8()? {
            0 => None,
            1 => {
                let target = self.finite32("soft pressure volume")?;
                if target <= 0.0 {
                    return invalid("a soft pressure volume of zero");
                }
                Some(Pressure {
                    target,
                    compliance: self.non_negative32("soft pressure compliance")?,
                })
            }
            t => return invalid(format!("soft pressure tag {t}")),
        };
        let tn = self.count(12)?;
        let triangles = (0..tn)
            .map(|_| {
                Ok([
                    self.particle_index(n)?,
                    self.particle_index(n)?,
                    self.particle_index(n)?,
                ])
            })
            .collect::<Result<Vec<_>, SavedStateError>>()?;
        let an = self.count(40)?;
        let mut attachments = Vec::with_capacity(an);
        for _ in 0..an {
            let particle = self.particle_index(n)?;
            let body = self.body_handle()?;
            let local = self.vec3("soft attachment point")?;
            attachments.push(SoftAttachment {
                particle,
                body,
                local,
                compliance: self.non_negative32("soft attachment compliance")?,
            });
        }
        let substeps = self.u32()?;
        let material = SoftMaterial {
            substeps,
            damping: self.finite("soft damping")?,
            gravity_scale: self.finite("soft gravity scale")?,
            collision_radius: self.finite("soft collision radius")?,
            friction: self.finite("soft friction")?,
            self_collision: match self.u8()? {
                0 => false,
                1 => true,
                t => return invalid(format!("soft self-collision flag {t}")),
            },
            plasticity: match self.u8()? {
                0 => None,
                1 => Some(Plasticity {
                    yield_strain: self.finite("plastic yield")?,
                    creep: self.finite("plastic creep")?,
                    max_strain: self.finite("plastic max strain")?,
                }),
                t => return invalid(format!("plasticity tag {t}")),
            },
            tear_strain: self.option_f64("tear strain")?,
        };
        if !(1..=MAX_SUBSTEPS).contains(&substeps) {
            return invalid(format!("soft body substeps {substeps}"));
        }
        material
            .validate()
            .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
        Ok(SoftBody {
            self_collision: Default::default(),
            backend: crate::particle_system::Backend::Cpu,
            prev: x.clone(),
            x,
            v,
            w,
            distance,
            bend,
            tets,
            tethers,
            pressure,
            triangles,
            attachments,
            material,
        })
    }
}
