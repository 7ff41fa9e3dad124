//! What the GPU path supports, and the per-step uniform block.
//!
//! Forces may change between steps (`World::set_force`, `add_force`,
//! `remove_force` and the integrator are all allowed while a system lives on
//! the GPU), so every step recompiles the system's current forces into a
//! fresh [`Params`] and refuses, before anything is dispatched, what the
//! shaders cannot do.

use bytemuck::Zeroable;
use glam::DVec3;
use inertia_shaders::layout as wgsl;

use crate::error::PhysicsError;
use crate::forces::{Force, GravityMethod};
use crate::integrator::Integrator;
use crate::particle_system::ParticleSystem;

use super::layout::{to_f32, vec4_f32, FieldForce, Params};

/// Refuses what the GPU path does not implement: integrators other than
/// forward and symplectic Euler, Barnes–Hut gravity, and more force
/// generators than the uniform block holds.
pub(crate) fn check_supported(sys: &ParticleSystem) -> Result<(), PhysicsError> {
    match sys.integrator {
        Integrator::ForwardEuler | Integrator::SymplecticEuler => {}
        other => {
            return Err(PhysicsError::Gpu(format!(
                "the GPU backend integrates with forward or symplectic Euler only, \
                 not {}; switch the integrator or keep the system on the CPU",
                other.name()
            )))
        }
    }
    let (mut mutual, mut fields) = (0usize, 0usize);
    for (_, _, e) in sys.forces.iter() {
        match e.force {
            Force::MutualGravity(g) => {
                if let GravityMethod::BarnesHut { .. } = g.method {
                    return Err(PhysicsError::Gpu(
                        "Barnes-Hut mutual gravity is not implemented on the GPU backend; \
                         use GravityMethod::Exact (tiled on the GPU) or keep the system on the CPU"
                            .into(),
                    ));
                }
                mutual += 1;
            }
            Force::Wind(_) | Force::Buoyancy(_) | Force::Explosion(_) => fields += 1,
            Force::UniformGravity(_) | Force::Drag(_) => {}
        }
    }
    if mutual > wgsl::MAX_MUTUAL_GRAVITY {
        return Err(PhysicsError::Gpu(format!(
            "{mutual} mutual-gravity generators on one system; the GPU backend takes at most {}",
            wgsl::MAX_MUTUAL_GRAVITY
        )));
    }
    if fields > wgsl::MAX_FIELD_FORCES {
        return Err(PhysicsError::Gpu(format!(
            "{fields} wind, buoyancy and explosion generators on one system; \
             the GPU backend takes at most {}",
            wgsl::MAX_FIELD_FORCES
        )));
    }
    Ok(())
}

/// The uniform block for stepping `sys` by `dt` s from time `t` s under
/// the world's `gravity` (m/s²) (one substep; the caller plans the
/// substeps first).
pub(crate) fn compile(
    sys: &ParticleSystem,
    gravity: DVec3,
    t: f64,
    dt: f64,
) -> Result<Params, PhysicsError> {
    check_supported(sys)?;
    let dt32 = to_f32("time step dt", dt)?;
    if dt32 <= 0.0 {
        return Err(PhysicsError::Gpu(format!(
            "time step dt = {dt} s rounds to 0 in the GPU backend's f32"
        )));
    }
    let field = sys.field_forces(gravity, t, dt);
    let mut p = Params::zeroed();
    p.gravity = vec4_f32("uniform gravity", field.gravity, 0.0)?;
    p.n = sys.len() as u32;
    p.n_springs = sys.topology.a.len() as u32;
    // Set by the substep plan (`ParticleSystem::substeps_for`, called first):
    // below 1 when even the most substeps cannot keep the springs stable.
    p.spring_scale = [
        sys.topology.stiffness_scale as f32,
        sys.topology.damping_scale as f32,
        0.0,
        0.0,
    ];
    p.symplectic = u32::from(sys.integrator == Integrator::SymplecticEuler);
    p.dt = dt32;
    if let Some(d) = field.drag {
        p.has_drag = 1;
        p.drag_linear_scale = to_f32("drag linear scale", d.linear_scale)?;
        p.drag_quadratic_scale = to_f32("drag quadratic scale", d.quadratic_scale)?;
    }
    let mut k = 0;
    for w in &field.winds {
        p.fields[k] = FieldForce {
            a: vec4_f32("wind", w.dir, w.speed)?,
            b: [to_f32("wind pressure", w.half_rho_c)?, 0.0, 0.0, 0.0],
            c: [0.0; 4],
        };
        k += 1;
    }
    for b in &field.buoyancy {
        p.fields[k] = FieldForce {
            a: vec4_f32("buoyancy", b.up, b.surface_height)?,
            b: [
                to_f32("fluid density", b.fluid_density)?,
                to_f32("buoyancy gravity", b.gravity)?,
                to_f32("fluid drag", b.fluid_drag)?,
                0.0,
            ],
            c: [0.0; 4],
        };
        k += 1;
    }
    for e in &field.explosions {
        // Times relative to the explosion, computed in f64: sim time may be
        // large, the interval that matters is short.
        p.fields[k] = FieldForce {
            a: vec4_f32("explosion", e.center, t - e.start_time)?,
            b: [
                to_f32("explosion front speed", e.front_speed)?,
                to_f32("explosion front thickness", e.front_thickness)?,
                to_f32("explosion peak pressure", e.peak_pressure)?,
                to_f32("explosion reference radius", e.reference_radius)?,
            ],
            c: [to_f32("explosion max radius", e.max_radius)?, 0.0, 0.0, 0.0],
        };
        k += 1;
    }
    p.n_wind = field.winds.len() as u32;
    p.n_buoyancy = field.buoyancy.len() as u32;
    p.n_explosion = field.explosions.len() as u32;
    for (_, _, e) in sys.forces.iter() {
        if let Force::MutualGravity(g) = e.force {
            p.mutual[p.n_mutual as usize] = [
                to_f32("gravitational constant", g.g_constant)?,
                to_f32("gravity softening squared", g.softening * g.softening)?,
                0.0,
                0.0,
            ];
            p.n_mutual += 1;
        }
    }
    p.has_interaction = u32::from(p.n_springs > 0 || p.n_mutual > 0);
    p.particle_control = u32::from(sys.control_active);
    p.n_groups = sys.group_control.len() as u32;
    p.group_base = if sys.control_active { p.n } else { 0 };
    Ok(p)
}
