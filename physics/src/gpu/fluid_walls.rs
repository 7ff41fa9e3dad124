//! The rigid bodies a fluid on the GPU is kept out of: the world's static
//! and kinematic bodies, packed each step as `struct Shape` of
//! `pbf.wgsl`.
//!
//! On the CPU a fluid gathers the bodies near it through the coupling
//! (`xpbd/coupling.rs`), takes each particle's nearest surface from them
//! and pushes the dynamic ones back. The GPU path finds the nearest
//! surfaces in the shader instead, from this list (a body that is far from
//! every particle finds no surface, as on the CPU), so the particles never
//! come back to the CPU. It cannot push bodies back: a world with a
//! dynamic body is refused (the body would take no impulses), and so are
//! shapes the shader does not project onto.

use crate::arena::Arena;
use crate::error::PhysicsError;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::shape::Shape;

/// Most bodies a fluid on the GPU is kept out of (the shader tests every
/// one for every particle).
pub const MAX_FLUID_GPU_SHAPES: usize = 256;

/// Shape kinds, numbered as the shader's `SHAPE_*`.
const CUBOID: u32 = 0;
const SPHERE: u32 = 1;
const CAPSULE: u32 = 2;

/// WGSL `struct Shape` of `pbf.wgsl` (144 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuShape {
    /// x: kind.
    kind: [u32; 4],
    /// Pose: translation, m, and the rotation's columns.
    translation: [f32; 4],
    axis_x: [f32; 4],
    axis_y: [f32; 4],
    axis_z: [f32; 4],
    /// Cuboid: half extents, m; sphere: x radius; capsule: x half height,
    /// y radius.
    size: [f32; 4],
    /// Centre of mass, m; w the body's dynamic friction.
    com: [f32; 4],
    /// m/s.
    linvel: [f32; 4],
    /// rad/s.
    angvel: [f32; 4],
}

const _: () =
    assert!(std::mem::size_of::<GpuShape>() == inertia_shaders::layout::FLUID_SHAPE_BYTES);

fn v4(v: glam::DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// The bodies of `bodies` a fluid on the GPU is kept out of, in handle
/// order (the CPU's order). Refused with [`PhysicsError::Gpu`] naming the
/// body: a dynamic body (the GPU does not push bodies back), a shape the
/// shader does not handle (cuboids, spheres and capsules only), or more
/// than [`MAX_FLUID_GPU_SHAPES`] bodies.
pub(crate) fn gather(bodies: &Arena<RigidBody>) -> Result<Vec<GpuShape>, PhysicsError> {
    let mut out = Vec::new();
    for (index, _, b) in bodies.iter() {
        if b.sensor {
            continue;
        }
        let Some(shape) = b.shape.as_ref() else {
            continue;
        };
        if b.kind == BodyKind::Dynamic && !b.quarantined {
            return Err(PhysicsError::Gpu(format!(
                "fluids on the GPU do not push dynamic bodies (body {index} is dynamic); \
                 keep the fluid on the CPU or make the body static or kinematic"
            )));
        }
        let (kind, size) = match shape {
            Shape::Cuboid { half_extents } => (CUBOID, v4(*half_extents, 0.0)),
            Shape::Sphere { radius } => (SPHERE, [*radius as f32, 0.0, 0.0, 0.0]),
            Shape::Capsule {
                half_height,
                radius,
            } => (CAPSULE, [*half_height as f32, *radius as f32, 0.0, 0.0]),
            other => {
                return Err(PhysicsError::Gpu(format!(
                    "fluids on the GPU collide with cuboids, spheres and capsules only \
                     (body {index} is a {}); keep the fluid on the CPU",
                    other.kind_name()
                )))
            }
        };
        if out.len() == MAX_FLUID_GPU_SHAPES {
            return Err(PhysicsError::Gpu(format!(
                "fluids on the GPU collide with at most {MAX_FLUID_GPU_SHAPES} bodies"
            )));
        }
        let pose = b.pose();
        let r = glam::DMat3::from_quat(pose.rotation);
        out.push(GpuShape {
            kind: [kind, 0, 0, 0],
            translation: v4(pose.translation, 0.0),
            axis_x: v4(r.x_axis, 0.0),
            axis_y: v4(r.y_axis, 0.0),
            axis_z: v4(r.z_axis, 0.0),
            size,
            com: v4(b.com, b.friction_dynamic),
            linvel: v4(b.linvel, 0.0),
            angvel: v4(b.angvel, 0.0),
        });
    }
    Ok(out)
}
