//! `#[repr(C)]` mirrors of the structs the particle shaders declare, and the
//! conversions from the CPU system (f64) to them (f32).
//!
//! The byte sizes are asserted against `inertia_shaders::layout`, whose test
//! checks them against naga's layout of the WGSL structs, so a field added
//! on one side only fails the build or the shader tests, not a simulation.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use inertia_shaders::layout as wgsl;

use crate::error::PhysicsError;
use crate::particle_system::ParticleSystem;

/// WGSL `struct GpuBody`: the state a step reads and writes (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub(crate) struct GpuBody {
    /// Position, m.
    pub(crate) pos: [f32; 3],
    /// `FLAG_*` bits.
    pub(crate) flags: u32,
    /// Velocity, m/s.
    pub(crate) vel: [f32; 3],
    pub(crate) pad0: u32,
}

/// WGSL `struct Props`: per-particle constants (32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub(crate) struct Props {
    /// 1/kg.
    pub(crate) inv_mass: f32,
    /// kg (converted from f64 `1 / inv_mass`, not inverted in f32).
    pub(crate) mass: f32,
    /// kg/s.
    pub(crate) drag_linear: f32,
    /// kg/m.
    pub(crate) drag_quadratic: f32,
    /// m².
    pub(crate) area: f32,
    /// m³.
    pub(crate) volume: f32,
    /// Radius of the sphere of `volume`, m (precomputed in f64 for buoyancy).
    pub(crate) radius: f32,
    /// Group id.
    pub(crate) group: u32,
}

/// WGSL `struct GpuSpring` (20 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub(crate) struct GpuSpring {
    /// Dense index of end a.
    pub(crate) a: u32,
    /// Dense index of end b.
    pub(crate) b: u32,
    /// m.
    pub(crate) rest_length: f32,
    /// N/m.
    pub(crate) stiffness: f32,
    /// N·s/m.
    pub(crate) damping: f32,
}

/// WGSL `struct FieldForce`: one wind, buoyancy or explosion (48 bytes);
/// the meaning of each lane is documented in `particle_integrate.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub(crate) struct FieldForce {
    pub(crate) a: [f32; 4],
    pub(crate) b: [f32; 4],
    pub(crate) c: [f32; 4],
}

/// WGSL `struct Params`: the uniform block written before every step.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub(crate) struct Params {
    /// xyz: sum of the uniform gravities, m/s².
    pub(crate) gravity: [f32; 4],
    /// x: factor on spring stiffness, y: on spring damping (1 unless the
    /// substep plan softened the springs, as on the CPU).
    pub(crate) spring_scale: [f32; 4],
    pub(crate) n: u32,
    pub(crate) n_springs: u32,
    /// 1 = symplectic Euler, 0 = forward Euler.
    pub(crate) symplectic: u32,
    /// 1 when pass 2 ran and `forces[i]` holds each particle's interaction force.
    pub(crate) has_interaction: u32,
    /// s.
    pub(crate) dt: f32,
    pub(crate) drag_linear_scale: f32,
    pub(crate) drag_quadratic_scale: f32,
    pub(crate) has_drag: u32,
    pub(crate) n_wind: u32,
    pub(crate) n_buoyancy: u32,
    pub(crate) n_explosion: u32,
    pub(crate) n_mutual: u32,
    /// 1 when `control[i]` holds a per-particle control force, N.
    pub(crate) particle_control: u32,
    /// Group control forces live at `control[group_base + g]` for `g < n_groups`.
    pub(crate) n_groups: u32,
    pub(crate) group_base: u32,
    /// 1 in the first substep of a world step: clears `FLAG_NEW_QUARANTINE`.
    pub(crate) first_substep: u32,
    /// Per mutual gravity: x = G (m³/(kg·s²)), y = ε² (m²).
    pub(crate) mutual: [[f32; 4]; wgsl::MAX_MUTUAL_GRAVITY],
    pub(crate) fields: [FieldForce; wgsl::MAX_FIELD_FORCES],
}

const _: () = {
    assert!(std::mem::size_of::<GpuBody>() == wgsl::BODY_BYTES);
    assert!(std::mem::size_of::<Props>() == wgsl::PROPS_BYTES);
    assert!(std::mem::size_of::<GpuSpring>() == wgsl::SPRING_BYTES);
    assert!(std::mem::size_of::<FieldForce>() == wgsl::FIELD_FORCE_BYTES);
    assert!(std::mem::size_of::<Params>() == wgsl::PARAMS_BYTES);
};

/// `v` as f32, refused if it does not fit (|v| > f32::MAX becomes infinite).
pub(crate) fn to_f32(what: &str, v: f64) -> Result<f32, PhysicsError> {
    let x = v as f32;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(PhysicsError::Gpu(format!(
            "{what} = {v} does not fit the GPU backend's f32 range (|x| <= {:e})",
            f32::MAX
        )))
    }
}

pub(crate) fn vec3_f32(what: &str, v: DVec3) -> Result<[f32; 3], PhysicsError> {
    Ok([to_f32(what, v.x)?, to_f32(what, v.y)?, to_f32(what, v.z)?])
}

pub(crate) fn vec4_f32(what: &str, v: DVec3, w: f64) -> Result<[f32; 4], PhysicsError> {
    let [x, y, z] = vec3_f32(what, v)?;
    Ok([x, y, z, to_f32(what, w)?])
}

/// The bodies (positions, velocities, flags) of `sys`.
pub(crate) fn bodies(sys: &ParticleSystem) -> Result<Vec<GpuBody>, PhysicsError> {
    (0..sys.len())
        .map(|i| {
            Ok(GpuBody {
                pos: vec3_f32("particle position", sys.position[i])?,
                flags: sys.flags[i],
                vel: vec3_f32("particle velocity", sys.velocity[i])?,
                pad0: 0,
            })
        })
        .collect()
}

/// The per-particle constants of `sys`.
pub(crate) fn props(sys: &ParticleSystem) -> Result<Vec<Props>, PhysicsError> {
    (0..sys.len())
        .map(|i| {
            let volume = sys.volume[i];
            Ok(Props {
                inv_mass: to_f32("inverse mass", sys.inv_mass[i])?,
                mass: to_f32("mass", 1.0 / sys.inv_mass[i])?,
                drag_linear: to_f32("linear drag coefficient", sys.drag_linear[i])?,
                drag_quadratic: to_f32("quadratic drag coefficient", sys.drag_quadratic[i])?,
                area: to_f32("particle area", sys.area[i])?,
                volume: to_f32("particle volume", volume)?,
                radius: to_f32(
                    "particle radius",
                    (volume * (3.0 / (4.0 * std::f64::consts::PI))).cbrt(),
                )?,
                group: sys.group[i],
            })
        })
        .collect()
}

/// The compiled springs of `sys` (its topology must be fresh).
pub(crate) fn springs(sys: &ParticleSystem) -> Result<Vec<GpuSpring>, PhysicsError> {
    let t = &sys.topology;
    (0..t.a.len())
        .map(|s| {
            let p = &t.params[s];
            Ok(GpuSpring {
                a: t.a[s],
                b: t.b[s],
                rest_length: to_f32("spring rest length", p.rest_length)?,
                stiffness: to_f32("spring stiffness", p.stiffness)?,
                damping: to_f32("spring damping", p.damping)?,
            })
        })
        .collect()
}

/// `offsets[0..=n]` followed by the adjacency entries, as pass 2 reads them.
pub(crate) fn csr(sys: &ParticleSystem) -> Vec<u32> {
    let t = &sys.topology;
    let mut out = Vec::with_capacity(t.offsets.len() + t.adj.len());
    out.extend_from_slice(&t.offsets);
    out.extend_from_slice(&t.adj);
    out
}

/// Per-particle control forces (if any were set) followed by the group
/// control forces, N. Never empty (a binding cannot be).
pub(crate) fn control(sys: &ParticleSystem) -> Result<Vec<[f32; 4]>, PhysicsError> {
    let mut out = Vec::new();
    if sys.control_active {
        for &c in &sys.control {
            out.push(vec4_f32("control force", c, 0.0)?);
        }
    }
    for &g in &sys.group_control {
        out.push(vec4_f32("group control force", g, 0.0)?);
    }
    if out.is_empty() {
        out.push([0.0; 4]);
    }
    Ok(out)
}
