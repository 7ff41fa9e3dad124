//! The rigid bodies a fluid or a soft body on the GPU meets over one step,
//! packed as `struct Shape` of `bodies.wgsl`, and what the particles do
//! to the dynamic ones.
//!
//! On the CPU the particles gather the bodies near them through the
//! coupling (`xpbd/coupling.rs`), take each particle's nearest surface
//! from them and share each contact's correction with a dynamic body. On
//! the GPU the shaders find the nearest surfaces from this list instead (a
//! body that is far from every particle finds no surface, as on the CPU),
//! so the particles never come back to the CPU. Each substep, each
//! particle keeps the push it gives the body behind each of its slots
//! (`BODY_SLOTS`, found once a step), two passes sum them per body in a
//! fixed order (`reduce_chunks`, `reduce_bodies`) and a third moves the
//! body by them (`take_pushes`, into `motion`). After the step only the
//! bodies' motions come back, 80 bytes each, and the bodies take them as
//! on the CPU ([`apply_changes`](crate::xpbd::coupling::apply_changes)).
//! Shapes the shaders do not project onto are refused.

use glam::{DMat3, DVec3};
use inertia_shaders::layout::{BODY_SLOTS, MOTION_BYTES, PUSH_BYTES, PUSH_CHUNK};

use crate::arena::Arena;
use crate::error::PhysicsError;
use crate::rigid::aabb::Aabb;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::shape::Shape;
use crate::xpbd::coupling::{BodyChange, Motion, StepStart};

use super::context::GpuContext;

/// Most bodies a fluid or soft body on the GPU meets in a step (the
/// shaders test every one for every particle once a step).
pub const MAX_GPU_BODIES: usize = 256;

/// Shape kinds, numbered as the shader's `SHAPE_*`.
const CUBOID: u32 = 0;
const SPHERE: u32 = 1;
const CAPSULE: u32 = 2;
/// A body particles are attached to but never touch (any shape).
const UNTOUCHED: u32 = 3;

/// A shape the particles cannot move (the shader's `NONE`).
const FIXED: u32 = u32::MAX;

/// WGSL `struct Shape` of `bodies.wgsl` (272 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuShape {
    /// x: kind; y: the body's slot among the movable ones, or `FIXED`.
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
    /// m/s: the body's mean velocity over the step.
    linvel: [f32; 4],
    /// rad/s: likewise.
    angvel: [f32; 4],
    /// x: inverse mass, 1/kg (0 for a body the particles cannot move).
    inv_mass: [f32; 4],
    /// The inverse inertia in the world's frame, by column, 1/(kg·m²).
    inv_inertia_x: [f32; 4],
    inv_inertia_y: [f32; 4],
    inv_inertia_z: [f32; 4],
    /// The rotation now and as the step began (quaternions, xyzw), the
    /// centre of mass as the step began (m), and the centre of mass in the
    /// body's frame (m): its path over the step.
    rotation: [f32; 4],
    start_rotation: [f32; 4],
    start_com: [f32; 4],
    local_com: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuShape>() == inertia_shaders::layout::SHAPE_BYTES);

/// WGSL `struct Motion` of `bodies.wgsl`: what a soft body's stage did
/// to a movable body (its move, m; its turn, a quaternion xyzw; the
/// velocities that came with them, m/s and rad/s; its shape's index).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuMotion {
    dx: [f32; 4],
    dq: [f32; 4],
    dv: [f32; 4],
    dw: [f32; 4],
    shape: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<GpuMotion>() == inertia_shaders::layout::MOTION_BYTES);

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

fn v3(v: [f32; 4]) -> DVec3 {
    DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
}

/// The bodies a fluid or soft body on the GPU meets over one step.
#[derive(Debug, Default)]
pub(crate) struct NearBodies {
    /// In handle order (the CPU's order).
    pub(crate) shapes: Vec<GpuShape>,
    /// The bodies the particles can move, by their slot.
    pub(crate) movable: Vec<Movable>,
    /// Each shape's body (arena index and generation).
    keys: Vec<(u32, u32)>,
}

/// A body the particles can move.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Movable {
    /// Arena index and generation.
    key: (u32, u32),
    /// Its index in [`NearBodies::shapes`].
    shape: u32,
}

impl NearBodies {
    /// The index in [`NearBodies::shapes`] of body `key`, if it is there.
    pub(crate) fn shape_of(&self, key: (u32, u32)) -> Option<u32> {
        self.keys.iter().position(|k| *k == key).map(|k| k as u32)
    }

    /// Every movable body unmoved, as a stage starts.
    pub(crate) fn still(&self) -> Vec<GpuMotion> {
        self.movable
            .iter()
            .map(|m| GpuMotion {
                dx: [0.0; 4],
                dq: [0.0, 0.0, 0.0, 1.0],
                dv: [0.0; 4],
                dw: [0.0; 4],
                shape: [m.shape, 0, 0, 0],
            })
            .collect()
    }

    /// What the stage did to the movable bodies, from their motions as the
    /// GPU left them (one [`GpuMotion`] per slot).
    pub(crate) fn moves(&self, moves: &[GpuMotion]) -> Vec<BodyChange> {
        self.movable
            .iter()
            .zip(moves)
            .map(|(m, g)| {
                let dq = glam::DQuat::from_xyzw(
                    f64::from(g.dq[0]),
                    f64::from(g.dq[1]),
                    f64::from(g.dq[2]),
                    f64::from(g.dq[3]),
                );
                (m.key, Motion::new(v3(g.dx), dq, v3(g.dv), v3(g.dw)))
            })
            .filter(|(_, moved)| *moved != Motion::default())
            .map(|(key, moved)| BodyChange::of_motion(key, moved))
            .collect()
    }
}

/// The box around particles `x` in which a rigid body's box must lie to
/// matter to them over a step: their bounds widened twice by `reach` (m),
/// once for the particles and once for the bodies, as the CPU's coupling
/// widens both.
pub(crate) fn near_box(x: &[glam::Vec3], reach: f32) -> Option<Aabb> {
    crate::xpbd::coupling::particle_bounds(x).map(|b| b.expanded(2.0 * f64::from(reach)))
}

/// The bodies of `bodies` particles on the GPU meet over a step, in handle
/// order, each moving at its mean velocity since `start` (the CPU's
/// friction, [`StepStart`]): the bodies `attached` names and, where the
/// particles `touch` bodies, every body whose box meets `near` (m; all of
/// them when `None`). Dynamic bodies take the particles' impulses back.
/// Refused with [`PhysicsError::Gpu`] naming the body: a shape the shader
/// does not touch (cuboids, spheres and capsules only; a body only
/// attached to may be of any shape), or more than [`MAX_GPU_BODIES`]
/// bodies.
pub(crate) fn gather(
    bodies: &Arena<RigidBody>,
    start: &StepStart,
    near: Option<&Aabb>,
    attached: &[(u32, u32)],
    touch: bool,
) -> Result<NearBodies, PhysicsError> {
    let mut out = NearBodies::default();
    for (index, generation, b) in bodies.iter() {
        if b.sensor {
            continue;
        }
        let Some(shape) = b.shape.as_ref() else {
            continue;
        };
        let pose = b.pose();
        let wanted = attached.contains(&(index, generation))
            || (touch && near.is_none_or(|near| shape.aabb(&pose).intersects(near)));
        if !wanted {
            continue;
        }
        let (kind, size) = match shape {
            _ if !touch => (UNTOUCHED, [0.0; 4]),
            Shape::Cuboid { half_extents } => (CUBOID, v4(*half_extents, 0.0)),
            Shape::Sphere { radius } => (SPHERE, [*radius as f32, 0.0, 0.0, 0.0]),
            Shape::Capsule {
                half_height,
                radius,
            } => (CAPSULE, [*half_height as f32, *radius as f32, 0.0, 0.0]),
            other => {
                return Err(PhysicsError::Gpu(format!(
                    "particles on the GPU collide with cuboids, spheres and capsules only \
                     (body {index} is a {}); keep them on the CPU",
                    other.kind_name()
                )))
            }
        };
        if out.shapes.len() == MAX_GPU_BODIES {
            return Err(PhysicsError::Gpu(format!(
                "particles on the GPU meet at most {MAX_GPU_BODIES} bodies in a step; \
                 keep them on the CPU"
            )));
        }
        let movable = b.kind == BodyKind::Dynamic && !b.quarantined && b.inv_mass > 0.0;
        let (slot, inv_mass, inv_inertia) = if movable {
            out.movable.push(Movable {
                key: (index, generation),
                shape: out.shapes.len() as u32,
            });
            let slot = out.movable.len() as u32 - 1;
            (slot, b.inv_mass, b.inverse_inertia_world())
        } else {
            (FIXED, 0.0, DMat3::ZERO)
        };
        let (linvel, angvel) = start
            .mean_velocity((index, generation), b.com, b.rotation)
            .unwrap_or((b.linvel, b.angvel));
        let (start_com, start_rotation) = start
            .pose_of((index, generation))
            .unwrap_or((b.com, b.rotation));
        out.keys.push((index, generation));
        let quat = |q: glam::DQuat| [q.x as f32, q.y as f32, q.z as f32, q.w as f32];
        let r = DMat3::from_quat(pose.rotation);
        out.shapes.push(GpuShape {
            kind: [kind, slot, 0, 0],
            translation: v4(pose.translation, 0.0),
            axis_x: v4(r.x_axis, 0.0),
            axis_y: v4(r.y_axis, 0.0),
            axis_z: v4(r.z_axis, 0.0),
            size,
            com: v4(b.com, b.friction_dynamic),
            linvel: v4(linvel, 0.0),
            angvel: v4(angvel, 0.0),
            inv_mass: [inv_mass as f32, 0.0, 0.0, 0.0],
            inv_inertia_x: v4(inv_inertia.x_axis, 0.0),
            inv_inertia_y: v4(inv_inertia.y_axis, 0.0),
            inv_inertia_z: v4(inv_inertia.z_axis, 0.0),
            rotation: quat(b.rotation),
            start_rotation: quat(start_rotation),
            start_com: v4(start_com, 0.0),
            local_com: v4(b.local_com, 0.0),
        });
    }
    Ok(out)
}

/// The GPU buffers of the bodies some particles meet: the step's shapes,
/// each particle's pushes (one per slot), their sums per chunk and per
/// body, and the movable bodies' motion with a staging copy of it.
#[derive(Debug)]
pub(crate) struct BodyBuffers {
    pub(crate) shapes: wgpu::Buffer,
    pub(crate) pushes: wgpu::Buffer,
    pub(crate) partials: wgpu::Buffer,
    pub(crate) motion: wgpu::Buffer,
    moves: wgpu::Buffer,
    /// Chunks of `PUSH_CHUNK` particles.
    pub(crate) chunks: u32,
}

impl BodyBuffers {
    /// The buffers for `n` particles (`label` names them): the shapes and
    /// motions where they `meet` bodies, the pushes too where they
    /// `touch` them (contacts; attachments move their bodies themselves);
    /// the smallest ones for what they never do.
    pub(crate) fn new(
        device: &wgpu::Device,
        label: &str,
        n: usize,
        meet: bool,
        touch: bool,
    ) -> Self {
        let met = |bytes: usize| if meet || touch { bytes } else { 0 };
        let touched = |bytes: usize| if touch { bytes } else { 0 };
        let buffer = |what: &str, bytes: usize, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("{label} {what}")),
                size: (bytes as u64).max(32),
                usage,
                mapped_at_creation: false,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let copy_dst = wgpu::BufferUsages::COPY_DST;
        let chunks = n.div_ceil(PUSH_CHUNK);
        Self {
            shapes: buffer(
                "shapes",
                met(MAX_GPU_BODIES * std::mem::size_of::<GpuShape>()),
                storage | copy_dst,
            ),
            pushes: buffer("pushes", touched(n * BODY_SLOTS * PUSH_BYTES), storage),
            partials: buffer(
                "summed pushes",
                touched((chunks + 1) * MAX_GPU_BODIES * PUSH_BYTES),
                storage,
            ),
            motion: buffer(
                "body motion",
                met(MAX_GPU_BODIES * MOTION_BYTES),
                storage | copy_dst | wgpu::BufferUsages::COPY_SRC,
            ),
            moves: buffer(
                "body moves",
                met(MAX_GPU_BODIES * MOTION_BYTES),
                wgpu::BufferUsages::MAP_READ | copy_dst,
            ),
            chunks: chunks as u32,
        }
    }

    /// Writes the step's bodies `near`, the movable ones not moved yet.
    pub(crate) fn upload(&self, queue: &wgpu::Queue, near: &NearBodies) {
        if !near.shapes.is_empty() {
            queue.write_buffer(&self.shapes, 0, bytemuck::cast_slice(&near.shapes));
        }
        if !near.movable.is_empty() {
            queue.write_buffer(&self.motion, 0, bytemuck::cast_slice(&near.still()));
        }
    }

    /// Records a copy of the first `movable` bodies' motion for reading.
    pub(crate) fn record_moves(&self, encoder: &mut wgpu::CommandEncoder, movable: usize) {
        if movable > 0 {
            let bytes = (movable * MOTION_BYTES) as u64;
            encoder.copy_buffer_to_buffer(&self.motion, 0, &self.moves, 0, bytes);
        }
    }

    /// What the stage did to the movable bodies `near` (after a submitted
    /// [`BodyBuffers::record_moves`]); waits for the GPU.
    pub(crate) fn read_moves(
        &self,
        ctx: &GpuContext,
        near: &NearBodies,
    ) -> Result<Vec<BodyChange>, PhysicsError> {
        let movable = near.movable.len();
        if movable == 0 {
            return Ok(Vec::new());
        }
        let bytes = ctx.read_back(
            &self.moves,
            (movable * MOTION_BYTES) as u64,
            "bodies' moves",
        )?;
        let moves: Vec<GpuMotion> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(near.moves(&moves))
    }
}
