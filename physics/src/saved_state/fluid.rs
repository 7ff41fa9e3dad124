//! Fluids in the saved state: their description, their particles'
//! positions and velocities, and (from format 9) their emitters with the
//! shots they have fired and the particles they have added. A restored
//! fluid is rebuilt through [`Fluid::new`] and its emitters through the
//! checks [`Fluid::add_emitter`] makes, so every parameter is checked as
//! the API checks it.

use glam::DVec3;

use super::{invalid, option_f64, Reader, SavedStateError, StateSink};
use crate::xpbd::fluid::{Fluid, FluidDesc, FluidEmitter, MAX_FLUID_EMITTERS, MAX_FLUID_PARTICLES};

pub(super) fn fluid<S: StateSink>(s: &mut S, f: &Fluid) {
    let d = f.params();
    s.f64(d.spacing);
    option_f64(s, d.kernel_radius);
    s.f64(d.rest_density);
    s.u32(d.substeps);
    s.f64(d.viscosity);
    s.f64(d.vorticity);
    s.f64(d.tensile_k);
    s.u32(d.tensile_n);
    s.f64(d.tensile_dq);
    s.f64(d.relaxation);
    s.f64(d.gravity_scale);
    option_f64(s, d.collision_radius);
    s.f64(d.friction);
    s.u64(d.max_particles as u64);
    s.u64(f.len() as u64);
    for (x, v) in f.positions().iter().zip(f.velocities()) {
        for c in x.to_array().into_iter().chain(v.to_array()) {
            s.f32(c);
        }
    }
    s.u64(f.emitters().len() as u64);
    for e in f.emitters() {
        let d = e.desc();
        s.vec3(d.position);
        s.vec3(d.velocity);
        s.f64(d.radius);
        option_f64(s, d.interval);
        s.f64(d.start);
        option_f64(s, d.stop);
        match d.limit {
            None => s.u8(0),
            Some(l) => {
                s.u8(1);
                s.u64(l);
            }
        }
        s.u64(e.shots());
        s.u64(e.emitted());
    }
}

impl Reader<'_> {
    pub(super) fn fluid(&mut self) -> Result<Fluid, SavedStateError> {
        let mut d = FluidDesc::new(self.finite("fluid spacing")?);
        d.kernel_radius = self.option_f64("fluid kernel radius")?;
        d.rest_density = self.finite("fluid rest density")?;
        d.substeps = self.u32()?;
        d.viscosity = self.finite("fluid viscosity")?;
        d.vorticity = self.finite("fluid vorticity")?;
        d.tensile_k = self.finite("fluid tensile k")?;
        d.tensile_n = self.u32()?;
        d.tensile_dq = self.finite("fluid tensile dq")?;
        d.relaxation = self.finite("fluid relaxation")?;
        d.gravity_scale = self.finite("fluid gravity scale")?;
        d.collision_radius = self.option_f64("fluid collision radius")?;
        d.friction = self.finite("fluid friction")?;
        let cap = self.u64()?;
        if cap == 0 || cap > MAX_FLUID_PARTICLES as u64 {
            return invalid(format!("a fluid cap of {cap} particles"));
        }
        d.max_particles = cap as usize;
        let n = self.count(24)?;
        d.positions.reserve(n);
        d.velocities.reserve(n);
        for _ in 0..n {
            let x = [
                self.finite32("fluid position")?,
                self.finite32("fluid position")?,
                self.finite32("fluid position")?,
            ];
            let v = [
                self.finite32("fluid velocity")?,
                self.finite32("fluid velocity")?,
                self.finite32("fluid velocity")?,
            ];
            d.positions.push(DVec3::from(x.map(f64::from)));
            d.velocities.push(DVec3::from(v.map(f64::from)));
        }
        let mut fluid = Fluid::new(d).map_err(|e| SavedStateError::Invalid(e.to_string()))?;
        if self.version >= 9 {
            // Each emitter takes at least 83 bytes.
            let n = self.count(83)?;
            if n > MAX_FLUID_EMITTERS {
                return invalid(format!("{n} emitters on one fluid"));
            }
            for _ in 0..n {
                let position = self.vec3("fluid emitter position")?;
                let velocity = self.vec3("fluid emitter velocity")?;
                let mut e = FluidEmitter::new(position, velocity);
                e.radius = self.finite("fluid emitter radius")?;
                e.interval = self.option_f64("fluid emitter interval")?;
                e.start = self.finite("fluid emitter start")?;
                e.stop = self.option_f64("fluid emitter stop")?;
                e.limit = match self.u8()? {
                    0 => None,
                    1 => Some(self.u64()?),
                    t => return invalid(format!("fluid emitter limit tag {t}")),
                };
                let shots = self.u64()?;
                let emitted = self.u64()?;
                fluid
                    .restore_emitter(e, shots, emitted)
                    .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
            }
        }
        Ok(fluid)
    }
}
