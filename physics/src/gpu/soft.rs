//! Soft bodies on the GPU (`xpbd_soft.wgsl`): the same small steps as the
//! CPU path (`xpbd/soft/step.rs`), one dispatch per colour of each
//! constraint kind, in the CPU's colour order.
//!
//! | buffer | contents | written by |
//! |---|---|---|
//! | `params` | one 256-byte uniform slot per dispatch of a substep | CPU, every step |
//! | `x`, `v`, `prev` | particle position + inverse mass, velocity, start of substep (16 B each) | the passes |
//! | `distances` | distance constraints in colour order | upload; `flow` (rest lengths) |
//! | `bends`, `tets`, `tethers` | constraints in colour order | upload only |
//! | `attachments` | particles held to rigid bodies, each body's shape this step | CPU, every step |
//! | `shell` | the pressure shell's triangles and each particle's corners | upload only |
//! | `pressure` | per particle: the volume's gradient; per chunk: sums | the `shell_*` passes |
//! | `rest0` | each distance constraint's rest length as built | upload only |
//! | `shapes` | the rigid bodies near the body (`gpu/bodies.rs`) | CPU, every step |
//! | `contacts` | per particle: the bodies within its reach for the step | `find_contacts` |
//! | `pushes` | per particle and contact: what it gave a dynamic body | `collide` |
//! | `partials` | per chunk and dynamic body, then per body: a substep's summed pushes | `reduce_chunks`, `reduce_bodies` |
//! | `motion` | per dynamic body: what the stage did to it | CPU, every step; `advance_bodies`, `take_pushes` |
//! | `readback` | staging copy of `x` and `v` (and a plastic body's distances) for the CPU | copy |
//! | `moves` | staging copy of `motion` | copy |
//!
//! What runs here: gravity, damping, pins, distance, bending, volume,
//! tether and pressure constraints, attachments to rigid bodies of any
//! shape, contacts with rigid bodies (cuboids, spheres, capsules) with
//! friction, the dynamic ones sharing each correction within the stage as
//! on the CPU (`Coupling::press`; `gpu/bodies.rs`), plastic flow, and
//! self-collision (`gpu/self_collision.rs`, its own program, its passes
//! in this step's order). Tearing changes the body's constraints, so it
//! is found on the CPU from the positions read back after each step (a
//! tearing body is read back every step) and a torn body is uploaded
//! again (`World::stage_soft`). How far a GPU run may drift from the CPU
//! run is [`SOFT_GPU_TOLERANCE`].

use std::sync::Arc;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::error::PhysicsError;
use crate::xpbd::colouring::Coloured;
use crate::xpbd::coupling::BodyChange;
use crate::xpbd::soft::SoftBody;
use inertia_shaders::layout::{BODY_SLOTS, PUSH_BYTES};

use super::bodies::{BodyBuffers, GpuShape, NearBodies, MAX_GPU_BODIES};
use super::buffers::at_least;
use super::context::GpuContext;
use super::program::{storage_binding, uniform_binding, Program};
use super::self_collision::{GpuSelfCollision, SelfPipelines};

/// Largest distance (m) a GPU-stepped soft body's particle may stand from
/// the CPU-stepped one after 60 steps at 60 Hz of a hanging 32 × 32 cloth
/// (the parity test): both are `f32` and take the same colours in the same
/// order, but a GPU may fuse multiplies and adds and round divisions and
/// square roots its own way.
pub const SOFT_GPU_TOLERANCE: f32 = 2e-3;

/// Bytes between uniform slots (the dynamic-offset alignment every
/// adapter allows).
const SLOT: u64 = 256;

/// The uniform block of one dispatch (`SoftParams` in the shader).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SoftParams {
    gravity: [f32; 4],
    h: f32,
    inv_h2: f32,
    keep: f32,
    n: u32,
    offset: u32,
    count: u32,
    serial: u32,
    predict_next: u32,
    kind: u32,
    shapes: u32,
    movable: u32,
    chunks: u32,
    /// m.
    radius: f32,
    friction: f32,
    /// m: the collision radius and how far gravity takes a particle over
    /// the step (the shader adds the particle's own travel).
    reach: f32,
    /// s: the whole step.
    dt: f32,
    /// `collide`: the fraction of the step at its substep's end.
    t: f32,
    /// s.
    substep: f32,
    attachments: u32,
    /// The pressure shell's triangles, and the chunks `shell_sums` takes.
    triangles: u32,
    shell_chunks: u32,
    /// m³.
    goal_volume: f32,
    /// The pressure's compliance over h², 1/(Pa·s²).
    pressure_alpha: f32,
    /// `flow`: distance constraints, yield strain, largest permanent
    /// strain, and the fraction of the excess that flows this step.
    distances_n: u32,
    yield_strain: f32,
    max_strain: f32,
    flow_rate: f32,
    pad: u32,
}

const _: () =
    assert!(std::mem::size_of::<SoftParams>() == inertia_shaders::layout::SOFT_PARAMS_BYTES);

/// What a dispatch runs: the shader's entry points, `project` by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum EntryPoint {
    Predict,
    Finish,
    /// `project` of one constraint kind (the shader's `params.kind`).
    Project(ConstraintKind),
    FindContacts,
    Collide,
    ReduceChunks,
    ReduceBodies,
    AdvanceBodies,
    TakePushes,
    Attach,
    ShellGradient,
    ShellSums,
    ShellTotal,
    ShellApply,
    Flow,
    /// Self-collision (`gpu/self_collision.rs`, its own bind group).
    Scatter,
    SortCells,
    Keep,
    SelfCollide,
}

impl EntryPoint {
    /// Whether it is a self-collision pass, bound to that program's group.
    fn self_collision(self) -> bool {
        matches!(
            self,
            EntryPoint::Scatter
                | EntryPoint::SortCells
                | EntryPoint::Keep
                | EntryPoint::SelfCollide
        )
    }
}

/// The constraint kinds, numbered as the shader's `params.kind`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ConstraintKind {
    Distance = 0,
    Bending = 1,
    Volume = 2,
    Tether = 3,
}

/// The soft-body pipelines, sharing one bind group layout.
#[derive(Debug)]
pub(crate) struct SoftPipelines {
    layout: wgpu::BindGroupLayout,
    predict: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    project: wgpu::ComputePipeline,
    find_contacts: wgpu::ComputePipeline,
    collide: wgpu::ComputePipeline,
    reduce_chunks: wgpu::ComputePipeline,
    reduce_bodies: wgpu::ComputePipeline,
    advance_bodies: wgpu::ComputePipeline,
    take_pushes: wgpu::ComputePipeline,
    attach: wgpu::ComputePipeline,
    shell_gradient: wgpu::ComputePipeline,
    shell_sums: wgpu::ComputePipeline,
    shell_total: wgpu::ComputePipeline,
    shell_apply: wgpu::ComputePipeline,
    flow: wgpu::ComputePipeline,
    /// Self-collision's program.
    pub(crate) self_collision: SelfPipelines,
}

/// Storage buffers the soft body's passes bind.
const STORAGE_BUFFERS: u32 = 16;

impl SoftPipelines {
    /// Compiles the pipelines; `None` when the adapter binds too few
    /// storage buffers per shader (uploads then say so).
    pub(crate) fn new(device: &wgpu::Device) -> Option<Self> {
        if device.limits().max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return None;
        }
        let program = Program::new(
            device,
            "xpbd_soft",
            inertia_shaders::XPBD_SOFT,
            &[
                uniform_binding::<SoftParams>(true),
                storage_binding(1, false),
                storage_binding(2, false),
                storage_binding(3, false),
                storage_binding(4, false),
                storage_binding(5, true),
                storage_binding(6, true),
                storage_binding(7, true),
                storage_binding(8, true),
                storage_binding(9, false),
                storage_binding(10, false),
                storage_binding(11, false),
                storage_binding(12, false),
                storage_binding(13, true),
                storage_binding(14, true),
                storage_binding(15, false),
                storage_binding(16, true),
            ],
        );
        let self_collision = SelfPipelines::new(device)?;
        let pipeline = |entry: &str| program.pipeline(device, entry);
        Some(Self {
            self_collision,
            predict: pipeline("predict"),
            finish: pipeline("finish"),
            project: pipeline("project"),
            find_contacts: pipeline("find_contacts"),
            collide: pipeline("collide"),
            reduce_chunks: pipeline("reduce_chunks"),
            reduce_bodies: pipeline("reduce_bodies"),
            advance_bodies: pipeline("advance_bodies"),
            take_pushes: pipeline("take_pushes"),
            attach: pipeline("attach"),
            shell_gradient: pipeline("shell_gradient"),
            shell_sums: pipeline("shell_sums"),
            shell_total: pipeline("shell_total"),
            shell_apply: pipeline("shell_apply"),
            flow: pipeline("flow"),
            layout: program.layout,
        })
    }

    fn of(&self, e: EntryPoint) -> &wgpu::ComputePipeline {
        match e {
            EntryPoint::Predict => &self.predict,
            EntryPoint::Finish => &self.finish,
            EntryPoint::Project(_) => &self.project,
            EntryPoint::FindContacts => &self.find_contacts,
            EntryPoint::Collide => &self.collide,
            EntryPoint::ReduceChunks => &self.reduce_chunks,
            EntryPoint::ReduceBodies => &self.reduce_bodies,
            EntryPoint::AdvanceBodies => &self.advance_bodies,
            EntryPoint::TakePushes => &self.take_pushes,
            EntryPoint::Attach => &self.attach,
            EntryPoint::ShellGradient => &self.shell_gradient,
            EntryPoint::ShellSums => &self.shell_sums,
            EntryPoint::ShellTotal => &self.shell_total,
            EntryPoint::ShellApply => &self.shell_apply,
            EntryPoint::Flow => &self.flow,
            EntryPoint::Scatter => &self.self_collision.scatter,
            EntryPoint::SortCells => &self.self_collision.sort_cells,
            EntryPoint::Keep => &self.self_collision.keep,
            EntryPoint::SelfCollide => &self.self_collision.self_collide,
        }
    }
}

/// One dispatch of a substep.
#[derive(Debug, Clone, Copy)]
struct Dispatch {
    kind: ConstraintKind,
    offset: u32,
    count: u32,
    serial: bool,
}

/// The GPU buffers of one soft body.
#[derive(Debug)]
pub(crate) struct GpuSoftBody {
    n: u32,
    params: wgpu::Buffer,
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    /// The distance constraints (their rest lengths flow in a plastic
    /// body).
    distances: wgpu::Buffer,
    /// Distance constraints whose rest lengths flow and come back with
    /// the positions (a plastic body's; none otherwise).
    distances_n: u32,
    /// The attachments, rewritten every step.
    attachments: wgpu::Buffer,
    /// Attachments the buffer holds.
    attachments_n: u32,
    /// The pressure shell's triangles, and the chunks `shell_sums` takes.
    triangles: u32,
    shell_chunks: u32,
    /// The rigid bodies it meets (`gpu/bodies.rs`).
    bodies: BodyBuffers,
    /// Self-collision's buffers, for a body with it.
    self_collision: Option<GpuSelfCollision>,
    readback: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// A substep's dispatches after its first (predict or finish).
    colours: Vec<Dispatch>,
    /// Substeps the uniform slots were sized for.
    substeps: u32,
}

/// Why a soft body cannot step on the GPU, if it cannot.
pub(crate) fn check_supported(body: &SoftBody) -> Result<(), PhysicsError> {
    // The shell's lists count three corners a triangle in `u32`.
    if body.len() > u32::MAX as usize / 2 || body.triangles.len() > u32::MAX as usize / 4 {
        return Err(PhysicsError::Gpu(
            "soft bodies with this many particles step on the CPU only".into(),
        ));
    }
    Ok(())
}

/// WGSL `struct Attachment` of `xpbd_soft.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuAttachment {
    /// xyz: the point in the body's frame, m; w: the compliance, m/N.
    local: [f32; 4],
    /// x: the particle; y: the body's index among the step's shapes, or
    /// `u32::MAX` (the shader's `NONE`) when it is not there.
    who: [u32; 4],
}

const _: () =
    assert!(std::mem::size_of::<GpuAttachment>() == inertia_shaders::layout::SOFT_ATTACHMENT_BYTES);

/// `body`'s attachments as the shader takes them, each body found among
/// the step's shapes `near`.
fn attachments(body: &SoftBody, near: &NearBodies) -> Vec<GpuAttachment> {
    body.attachments
        .iter()
        .map(|a| {
            let l = a.local.as_vec3();
            let shape = near
                .shape_of((a.body.index, a.body.generation))
                .unwrap_or(u32::MAX);
            GpuAttachment {
                local: [l.x, l.y, l.z, a.compliance],
                who: [a.particle, shape, 0, 0],
            }
        })
        .collect()
}

/// The pressure shell as `xpbd_soft.wgsl`'s `shell` holds it: the
/// triangles, then per particle where its corners start (`n + 1`
/// offsets), then the corners (`triangle * 3 + corner`, in triangle
/// order). Empty for a body without pressure.
fn shell(body: &SoftBody) -> Vec<u32> {
    if body.pressure.is_none() {
        return Vec::new();
    }
    let n = body.len();
    let mut counts = vec![0u32; n + 1];
    for t in &body.triangles {
        for &i in t {
            counts[i as usize + 1] += 1;
        }
    }
    for i in 0..n {
        counts[i + 1] += counts[i];
    }
    let mut corners = vec![0u32; 3 * body.triangles.len()];
    let mut next = counts.clone();
    for (k, t) in body.triangles.iter().enumerate() {
        for (c, &i) in t.iter().enumerate() {
            corners[next[i as usize] as usize] = 3 * k as u32 + c as u32;
            next[i as usize] += 1;
        }
    }
    let mut out: Vec<u32> = body.triangles.iter().flatten().copied().collect();
    out.extend_from_slice(&counts);
    out.extend_from_slice(&corners);
    out
}

fn colours<C>(c: &Coloured<C>, kind: ConstraintKind, out: &mut Vec<Dispatch>) {
    let mut start = 0u32;
    for (k, &end) in c.ends.iter().enumerate() {
        out.push(Dispatch {
            kind,
            offset: start,
            count: end - start,
            serial: c.overflow && k + 1 == c.ends.len(),
        });
        start = end;
    }
}

fn storage(ctx: &GpuContext, label: &str, bytes: &[u8], extra: wgpu::BufferUsages) -> wgpu::Buffer {
    // Every binding holds at least one element.
    let data = at_least(bytes, 32);
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &data,
            usage: wgpu::BufferUsages::STORAGE | extra,
        })
}

/// Uploads `body` (its positions, velocities and constraints).
/// `pipelines` are the world's (`None` on an adapter that cannot run them).
pub(crate) fn upload(
    ctx: &GpuContext,
    pipelines: Option<&SoftPipelines>,
    body: &SoftBody,
) -> Result<Arc<GpuSoftBody>, PhysicsError> {
    check_supported(body)?;
    let pipelines = pipelines.ok_or_else(|| {
        PhysicsError::Gpu(format!(
            "the adapter binds {} storage buffers per shader; soft bodies on the GPU need {STORAGE_BUFFERS}",
            ctx.limits.max_storage_buffers_per_shader_stage
        ))
    })?;
    let n = body.len() as u32;
    let xw: Vec<[f32; 4]> = body
        .x
        .iter()
        .zip(&body.w)
        .map(|(p, w)| [p.x, p.y, p.z, *w])
        .collect();
    let v: Vec<[f32; 4]> = body.v.iter().map(|u| [u.x, u.y, u.z, 0.0]).collect();
    let distances: Vec<[u32; 4]> = body
        .distance
        .items
        .iter()
        .map(|d| [d.p[0], d.p[1], d.rest.to_bits(), d.compliance.to_bits()])
        .collect();
    let quad = |p: [u32; 4], rest: f32, compliance: f32| {
        [
            p[0],
            p[1],
            p[2],
            p[3],
            rest.to_bits(),
            compliance.to_bits(),
            0,
            0,
        ]
    };
    let bends: Vec<[u32; 8]> = body
        .bend
        .items
        .iter()
        .map(|b| quad(b.p, b.rest, b.compliance))
        .collect();
    let tets: Vec<[u32; 8]> = body
        .tets
        .items
        .iter()
        .map(|t| quad(t.p, t.rest, t.compliance))
        .collect();
    let tethers: Vec<[u32; 4]> = body
        .tethers
        .items
        .iter()
        .map(|t| [t.p[0], t.p[1], t.max.to_bits(), 0])
        .collect();
    let rest0: Vec<f32> = if body.material().plasticity.is_some() {
        body.distance.items.iter().map(|d| d.rest0).collect()
    } else {
        Vec::new()
    };
    let shell = shell(body);
    let mut plan = Vec::new();
    colours(&body.distance, ConstraintKind::Distance, &mut plan);
    colours(&body.bend, ConstraintKind::Bending, &mut plan);
    colours(&body.tets, ConstraintKind::Volume, &mut plan);
    colours(&body.tethers, ConstraintKind::Tether, &mut plan);
    // Predict, finish and predict, finish, the colours, and each
    // substep's contacts.
    let substeps = body.material().substeps.max(1);
    let slots = plan.len() as u64 + 3 + u64::from(substeps);
    if slots * SLOT > ctx.limits.max_buffer_size {
        return Err(PhysicsError::Gpu("too many colours for the GPU".into()));
    }
    let max_binding = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    let load_bytes = (body.len() * BODY_SLOTS * PUSH_BYTES) as u64;
    if body.material().collision_radius > 0.0 && load_bytes > max_binding {
        return Err(PhysicsError::Gpu(format!(
            "{} particles with contacts need {load_bytes} bytes of pushes, more than this \
             adapter binds ({max_binding} bytes); keep the soft body on the CPU",
            body.len()
        )));
    }
    let shell_chunks = if body.pressure.is_some() {
        let chunk = inertia_shaders::layout::SHELL_CHUNK;
        body.triangles
            .len()
            .div_ceil(chunk)
            .max(body.len().div_ceil(chunk)) as u32
    } else {
        0
    };
    // A plastic body's distances come back with its positions.
    let plastic_distances = if rest0.is_empty() {
        0
    } else {
        body.distance.items.len() as u32
    };
    ctx.scoped("uploading a soft body to the GPU", || {
        let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let x = storage(ctx, "soft x", bytemuck::cast_slice(&xw), copy);
        let vb = storage(ctx, "soft v", bytemuck::cast_slice(&v), copy);
        let prev = storage(
            ctx,
            "soft prev",
            bytemuck::cast_slice(&xw),
            wgpu::BufferUsages::empty(),
        );
        let d = storage(
            ctx,
            "soft distances",
            bytemuck::cast_slice(&distances),
            wgpu::BufferUsages::COPY_SRC,
        );
        let b = storage(
            ctx,
            "soft bends",
            bytemuck::cast_slice(&bends),
            wgpu::BufferUsages::empty(),
        );
        let t = storage(
            ctx,
            "soft tets",
            bytemuck::cast_slice(&tets),
            wgpu::BufferUsages::empty(),
        );
        let te = storage(
            ctx,
            "soft tethers",
            bytemuck::cast_slice(&tethers),
            wgpu::BufferUsages::empty(),
        );
        let none = wgpu::BufferUsages::empty();
        let sh = storage(
            ctx,
            "soft pressure shell",
            bytemuck::cast_slice(&shell),
            none,
        );
        let r0 = storage(ctx, "soft rest lengths", bytemuck::cast_slice(&rest0), none);
        let params = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("soft params"),
            size: slots * SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Contacts with rigid bodies, for a body with a collision radius.
        let touches = body.material().collision_radius > 0.0;
        let per_particle = |bytes: usize| if touches { bytes * n as usize } else { 0 };
        let scratch = |label: &str, bytes: usize, extra: wgpu::BufferUsages| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (bytes as u64).max(32),
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            })
        };
        let contacts = scratch("soft contacts", per_particle(16), none);
        let attached = body.attachments.len();
        let attachments = scratch(
            "soft attachments",
            attached * std::mem::size_of::<GpuAttachment>(),
            wgpu::BufferUsages::COPY_DST,
        );
        // Per particle, per chunk, and the multiplier.
        let sums = if body.pressure.is_some() {
            n as usize + shell_chunks as usize + 1
        } else {
            0
        };
        let pressure = scratch("soft pressure", 16 * sums, none);
        let bodies = BodyBuffers::new(&ctx.device, "soft", n as usize, attached > 0, touches);
        let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("soft readback"),
            size: readback_bytes(n, plastic_distances).max(32),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("soft"),
            layout: &pipelines.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &params,
                        offset: 0,
                        size: wgpu::BufferSize::new(std::mem::size_of::<SoftParams>() as u64),
                    }),
                },
                entry(1, &x),
                entry(2, &vb),
                entry(3, &prev),
                entry(4, &d),
                entry(5, &b),
                entry(6, &t),
                entry(7, &te),
                entry(8, &bodies.shapes),
                entry(9, &contacts),
                entry(10, &bodies.pushes),
                entry(11, &bodies.partials),
                entry(12, &bodies.motion),
                entry(13, &attachments),
                entry(14, &sh),
                entry(15, &pressure),
                entry(16, &r0),
            ],
        });
        let self_collision = (body.material().self_collision && touches)
            .then(|| GpuSelfCollision::new(&ctx.device, &pipelines.self_collision, body, &x));
        Ok(Arc::new(GpuSoftBody {
            self_collision,
            n,
            params,
            x,
            v: vb,
            distances: d,
            distances_n: plastic_distances,
            attachments,
            attachments_n: attached as u32,
            triangles: if body.pressure.is_some() {
                body.triangles.len() as u32
            } else {
                0
            },
            shell_chunks,
            bodies,
            readback,
            group,
            colours: plan,
            substeps,
        }))
    })
}

/// Steps `body` on the GPU by `dt` s under `gravity` (m/s², the world's)
/// against the rigid bodies `near` it (`gpu/bodies.rs`: those it touches
/// and those it is attached to, as its collision radius and
/// [`SoftBody::attached_bodies`] say); with `readback`, copies the new
/// positions and velocities (and a plastic body's rest lengths) into the
/// CPU mirror. `travel` is how far a particle can go in the step (m,
/// [`SoftBody::travel`], from a fresh mirror): a self-colliding body
/// needs it for its candidates' reach. Returns what the particles gave the
/// dynamic bodies, for
/// [`apply_changes`](crate::xpbd::coupling::apply_changes).
// The CPU step's inputs (`xpbd/soft/step.rs`) and the GPU's own.
#[allow(clippy::too_many_arguments)]
pub(crate) fn step(
    ctx: &GpuContext,
    pipelines: Option<&SoftPipelines>,
    body: &mut SoftBody,
    gpu: &GpuSoftBody,
    dt: f32,
    gravity: Vec3,
    near: &NearBodies,
    travel: Option<f32>,
    readback: bool,
) -> Result<Vec<BodyChange>, PhysicsError> {
    if gpu.n as usize != body.len() {
        return Err(PhysicsError::Gpu(
            "the soft body changed shape since its upload".into(),
        ));
    }
    let m = body.material();
    let n = m.substeps.max(1);
    let h = dt / n as f32;
    let g = gravity * m.gravity_scale as f32;
    let radius = m.collision_radius as f32;
    let shapes: &[GpuShape] = &near.shapes;
    if shapes.len() > MAX_GPU_BODIES {
        return Err(PhysicsError::Gpu(format!(
            "particles on the GPU meet at most {MAX_GPU_BODIES} bodies in a step"
        )));
    }
    let movable = near.movable.len();
    if body.attachments.len() > gpu.attachments_n as usize {
        return Err(PhysicsError::Gpu(
            "the soft body gained attachments since its upload".into(),
        ));
    }
    let held = attachments(body, near);
    let (goal_volume, pressure_compliance) = body
        .pressure
        .map_or((0.0, 0.0), |p| (p.target, p.compliance));
    let (yield_strain, max_strain, flow_rate) = m.plasticity.map_or((0.0, 0.0, 0.0), |p| {
        (
            p.yield_strain as f32,
            p.max_strain as f32,
            (p.creep as f32 * dt).min(1.0),
        )
    });
    let inv_h2 = 1.0 / (h * h);
    let base = SoftParams {
        gravity: [g.x, g.y, g.z, 0.0],
        h,
        inv_h2,
        keep: (1.0 - m.damping as f32 * h).max(0.0),
        n: gpu.n,
        offset: 0,
        count: 0,
        serial: 0,
        predict_next: 0,
        kind: 0,
        shapes: shapes.len() as u32,
        movable: movable as u32,
        chunks: gpu.bodies.chunks,
        radius,
        friction: m.friction as f32,
        reach: radius + g.length() * dt * dt + 1e-3,
        dt,
        t: 1.0,
        substep: h,
        attachments: held.len() as u32,
        triangles: gpu.triangles,
        shell_chunks: gpu.shell_chunks,
        goal_volume,
        pressure_alpha: pressure_compliance * inv_h2,
        distances_n: gpu.distances_n,
        yield_strain,
        max_strain,
        flow_rate,
        pad: 0,
    };
    if n > gpu.substeps {
        return Err(PhysicsError::Gpu(
            "the soft body's substeps changed since its upload".into(),
        ));
    }
    // Slots: 0 predict, 1 finish and predict, 2 finish, then the colours,
    // then each substep's contacts.
    let contact_slot = |k: u32| gpu.colours.len() + 3 + k as usize;
    let mut bytes = vec![0u8; contact_slot(n) * SLOT as usize];
    let mut put = |slot: usize, p: SoftParams| {
        let at = slot * SLOT as usize;
        bytes[at..at + std::mem::size_of::<SoftParams>()].copy_from_slice(bytemuck::bytes_of(&p));
    };
    put(0, base);
    put(
        1,
        SoftParams {
            predict_next: 1,
            ..base
        },
    );
    put(2, base);
    for (k, d) in gpu.colours.iter().enumerate() {
        put(
            k + 3,
            SoftParams {
                offset: d.offset,
                count: d.count,
                serial: u32::from(d.serial),
                kind: d.kind as u32,
                ..base
            },
        );
    }
    for k in 0..n {
        put(
            contact_slot(k),
            SoftParams {
                t: (k + 1) as f32 / n as f32,
                ..base
            },
        );
    }
    // Self-collision's candidates: within the contact distance plus twice
    // how far the fastest particle goes in the step (the CPU's reach).
    let reach = travel.map_or(0.0, |t| 2.0 * radius + 2.0 * t);
    let own = gpu
        .self_collision
        .as_ref()
        .filter(|_| reach.is_finite() && reach > 0.0);
    let particles = ctx.workgroups(gpu.n)?;
    // One workgroup a chunk, one invocation a body.
    let chunks = ctx.workgroups(gpu.bodies.chunks * inertia_shaders::layout::WORKGROUP_SIZE)?;
    let bodies = ctx.workgroups(movable as u32)?;
    let one = (1, 1);
    let shell_chunks = ctx.workgroups(gpu.shell_chunks)?;
    let flows = ctx.workgroups(gpu.distances_n)?;
    let keys = ctx.workgroups(own.map_or(0, |o| o.table()))?;
    let grids = gpu
        .colours
        .iter()
        .map(|d| ctx.workgroups(if d.serial { 1 } else { d.count }))
        .collect::<Result<Vec<_>, _>>()?;
    let pipes = pipelines
        .ok_or_else(|| PhysicsError::Gpu("no soft-body pipelines on this adapter".into()))?;
    ctx.scoped("a GPU soft-body step", || {
        ctx.queue.write_buffer(&gpu.params, 0, &bytes);
        gpu.bodies.upload(&ctx.queue, near);
        if !held.is_empty() {
            ctx.queue
                .write_buffer(&gpu.attachments, 0, bytemuck::cast_slice(&held));
        }
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("soft step"),
            });
        if let Some(own) = own {
            own.write_params(&ctx.queue, reach, 2.0 * radius);
            own.record_counts(&mut encoder, &pipes.self_collision, particles);
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("soft step"),
                timestamp_writes: None,
            });
            let mut run = |entry: EntryPoint, slot: usize, grid: (u32, u32)| {
                pass.set_pipeline(pipes.of(entry));
                match own {
                    Some(own) if entry.self_collision() => pass.set_bind_group(0, &own.group, &[]),
                    _ => pass.set_bind_group(0, &gpu.group, &[(slot as u64 * SLOT) as u32]),
                }
                pass.dispatch_workgroups(grid.0, grid.1, 1);
            };
            if own.is_some() {
                run(EntryPoint::Scatter, 0, particles);
                run(EntryPoint::SortCells, 0, keys);
            }
            // Contacts are looked for where the particles touch bodies
            // (the shapes of a body without a collision radius are only
            // those it is attached to).
            let touches = radius > 0.0 && !shapes.is_empty();
            if touches {
                run(EntryPoint::FindContacts, 0, particles);
            }
            for k in 0..n {
                if k == 0 {
                    run(EntryPoint::Predict, 0, particles);
                } else {
                    run(EntryPoint::Finish, 1, particles);
                }
                for (c, d) in gpu.colours.iter().enumerate() {
                    run(EntryPoint::Project(d.kind), c + 3, grids[c]);
                }
                if gpu.shell_chunks > 0 {
                    run(EntryPoint::ShellGradient, 0, particles);
                    run(EntryPoint::ShellSums, 0, shell_chunks);
                    run(EntryPoint::ShellTotal, 0, one);
                    run(EntryPoint::ShellApply, 0, particles);
                }
                if movable > 0 {
                    run(EntryPoint::AdvanceBodies, 0, bodies);
                }
                if !held.is_empty() {
                    run(EntryPoint::Attach, contact_slot(k), one);
                }
                if touches {
                    run(EntryPoint::Collide, contact_slot(k), particles);
                    if movable > 0 {
                        run(EntryPoint::ReduceChunks, 0, chunks);
                        run(EntryPoint::ReduceBodies, 0, bodies);
                        run(EntryPoint::TakePushes, 0, bodies);
                    }
                }
                if own.is_some() {
                    run(EntryPoint::Keep, 0, particles);
                    run(EntryPoint::SelfCollide, 0, particles);
                }
            }
            run(EntryPoint::Finish, 2, particles);
            if gpu.distances_n > 0 {
                run(EntryPoint::Flow, 0, flows);
            }
        }
        gpu.bodies.record_moves(&mut encoder, movable);
        if readback {
            gpu.record_readback(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    })?;
    let changes = gpu.bodies.read_moves(ctx, near)?;
    if readback {
        read(ctx, body, gpu)?;
    } else if movable == 0 {
        let _ = ctx.device.poll(wgpu::PollType::Poll);
    }
    Ok(changes)
}

impl GpuSoftBody {
    /// Records a copy of the positions, then the velocities, into the
    /// staging buffer.
    fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let size = u64::from(self.n) * 16;
        encoder.copy_buffer_to_buffer(&self.x, 0, &self.readback, 0, size);
        encoder.copy_buffer_to_buffer(&self.v, 0, &self.readback, size, size);
        if self.distances_n > 0 {
            let bytes = u64::from(self.distances_n) * 16;
            encoder.copy_buffer_to_buffer(&self.distances, 0, &self.readback, 2 * size, bytes);
        }
    }
}

/// Bytes read back for `n` particles and `distances` flowing distance
/// constraints: positions, velocities, then the constraints.
fn readback_bytes(n: u32, distances: u32) -> u64 {
    2 * u64::from(n) * 16 + u64::from(distances) * 16
}

/// Copies the GPU's positions and velocities (and a plastic body's rest
/// lengths) into the CPU mirror (after a submitted
/// [`GpuSoftBody::record_readback`]).
fn read(ctx: &GpuContext, body: &mut SoftBody, gpu: &GpuSoftBody) -> Result<(), PhysicsError> {
    let n = gpu.n as usize;
    let bytes = ctx.read_back(
        &gpu.readback,
        readback_bytes(gpu.n, gpu.distances_n),
        "a soft body",
    )?;
    let data: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
    for i in 0..n {
        let [a, b, c, _] = data[i];
        let [d, e, f, _] = data[n + i];
        body.x[i] = Vec3::new(a, b, c);
        body.prev[i] = body.x[i];
        body.v[i] = Vec3::new(d, e, f);
    }
    let distances: &[[u32; 4]] = bytemuck::cast_slice(&data[2 * n..]);
    for (d, g) in body.distance.items.iter_mut().zip(distances) {
        d.rest = f32::from_bits(g[2]);
    }
    Ok(())
}

/// Copies the current state back (a step without readback left the mirror
/// stale).
pub(crate) fn download(
    ctx: &GpuContext,
    body: &mut SoftBody,
    gpu: &GpuSoftBody,
) -> Result<(), PhysicsError> {
    ctx.scoped("reading a soft body back", || {
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("soft download"),
            });
        gpu.record_readback(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    })?;
    read(ctx, body, gpu)
}

/// Moves pinned particle `i` to `p` (m) on the GPU too.
pub(crate) fn set_pin(ctx: &GpuContext, gpu: &GpuSoftBody, i: usize, p: Vec3) {
    ctx.queue.write_buffer(
        &gpu.x,
        i as u64 * 16,
        bytemuck::cast_slice(&[p.x, p.y, p.z, 0.0f32]),
    );
}
