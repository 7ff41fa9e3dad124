//! Soft bodies on the GPU (`xpbd_soft.wgsl`): the same small steps as the
//! CPU path (`xpbd/soft/step.rs`), one dispatch per colour of each
//! constraint kind, in the CPU's colour order.
//!
//! | buffer | contents | written by |
//! |---|---|---|
//! | `params` | one 256-byte uniform slot per dispatch of a substep | CPU, every step |
//! | `x`, `v`, `prev` | particle position + inverse mass, velocity, start of substep (16 B each) | the passes |
//! | `distances`, `bends`, `tets`, `tethers` | constraints in colour order | upload only |
//! | `readback` | staging copy of `x` and `v` for the CPU | copy |
//!
//! What runs here: gravity, damping, pins, distance, bending, volume and
//! tether constraints. Contacts with rigid bodies, attachments, pressure,
//! self-collision, plasticity and tearing run only on the CPU: a body that
//! uses any of them is refused ([`check_supported`]). How far a GPU run
//! may drift from the CPU run is [`SOFT_GPU_TOLERANCE`].

use std::sync::Arc;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::error::PhysicsError;
use crate::xpbd::colouring::Coloured;
use crate::xpbd::soft::SoftBody;

use super::buffers::at_least;
use super::context::GpuContext;
use super::program::{storage_binding, uniform_binding, Program};

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
    pad: [u32; 3],
}

const _: () =
    assert!(std::mem::size_of::<SoftParams>() == inertia_shaders::layout::SOFT_PARAMS_BYTES);

/// What a dispatch runs: the shader's entry points, `project` by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Entry {
    Predict,
    Finish,
    /// `project` of one constraint kind (the shader's `params.kind`).
    Project(Kind),
}

/// The constraint kinds, numbered as the shader's `params.kind`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
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
}

impl SoftPipelines {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let program = Program::new(
            device,
            "xpbd_soft",
            inertia_shaders::XPBD_SOFT,
            &[
                uniform_binding::<SoftParams>(true),
                storage_binding(1, false),
                storage_binding(2, false),
                storage_binding(3, false),
                storage_binding(4, true),
                storage_binding(5, true),
                storage_binding(6, true),
                storage_binding(7, true),
            ],
        );
        let pipeline = |entry: &str| program.pipeline(device, entry);
        Self {
            predict: pipeline("predict"),
            finish: pipeline("finish"),
            project: pipeline("project"),
            layout: program.layout,
        }
    }

    fn of(&self, e: Entry) -> &wgpu::ComputePipeline {
        match e {
            Entry::Predict => &self.predict,
            Entry::Finish => &self.finish,
            Entry::Project(_) => &self.project,
        }
    }
}

/// One dispatch of a substep.
#[derive(Debug, Clone, Copy)]
struct Dispatch {
    kind: Kind,
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
    readback: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// A substep's dispatches after its first (predict or finish).
    colours: Vec<Dispatch>,
}

/// Why a soft body cannot step on the GPU, if it cannot.
pub(crate) fn check_supported(body: &SoftBody) -> Result<(), PhysicsError> {
    let m = body.material();
    let refuse = |what: &str| {
        Err(PhysicsError::Gpu(format!(
            "soft bodies with {what} step on the CPU only"
        )))
    };
    if m.collision_radius > 0.0 {
        return refuse("contacts (a collision radius)");
    }
    if !body.attachments.is_empty() {
        return refuse("attachments to rigid bodies");
    }
    if body.pressure.is_some() {
        return refuse("pressure");
    }
    if m.self_collision {
        return refuse("self-collision");
    }
    if m.plasticity.is_some() {
        return refuse("plasticity");
    }
    if m.tear_strain.is_some() {
        return refuse("tearing");
    }
    if body.len() > u32::MAX as usize / 2 {
        return refuse("this many particles");
    }
    Ok(())
}

fn colours<C>(c: &Coloured<C>, kind: Kind, out: &mut Vec<Dispatch>) {
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
pub(crate) fn upload(ctx: &GpuContext, body: &SoftBody) -> Result<Arc<GpuSoftBody>, PhysicsError> {
    check_supported(body)?;
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
    let mut plan = Vec::new();
    colours(&body.distance, Kind::Distance, &mut plan);
    colours(&body.bend, Kind::Bending, &mut plan);
    colours(&body.tets, Kind::Volume, &mut plan);
    colours(&body.tethers, Kind::Tether, &mut plan);
    let slots = plan.len() as u64 + 3;
    if slots * SLOT > ctx.limits.max_buffer_size {
        return Err(PhysicsError::Gpu("too many colours for the GPU".into()));
    }
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
            wgpu::BufferUsages::empty(),
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
        let params = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("soft params"),
            size: slots * SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("soft readback"),
            size: (2 * u64::from(n) * 16).max(32),
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
            layout: &ctx.soft.layout,
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
            ],
        });
        Ok(Arc::new(GpuSoftBody {
            n,
            params,
            x,
            v: vb,
            readback,
            group,
            colours: plan,
        }))
    })
}

/// Steps `body` on the GPU by `dt` s under `gravity` (m/s², the world's);
/// with `readback`, copies the new positions and velocities into the CPU
/// mirror.
pub(crate) fn step(
    ctx: &GpuContext,
    body: &mut SoftBody,
    gpu: &GpuSoftBody,
    dt: f32,
    gravity: Vec3,
    readback: bool,
) -> Result<(), PhysicsError> {
    if gpu.n as usize != body.len() {
        return Err(PhysicsError::Gpu(
            "the soft body changed shape since its upload".into(),
        ));
    }
    let m = body.material();
    let n = m.substeps.max(1);
    let h = dt / n as f32;
    let g = gravity * m.gravity_scale as f32;
    let base = SoftParams {
        gravity: [g.x, g.y, g.z, 0.0],
        h,
        inv_h2: 1.0 / (h * h),
        keep: (1.0 - m.damping as f32 * h).max(0.0),
        n: gpu.n,
        offset: 0,
        count: 0,
        serial: 0,
        predict_next: 0,
        kind: 0,
        pad: [0; 3],
    };
    // Slots: 0 predict, 1 finish and predict, 2 finish, then the colours.
    let mut bytes = vec![0u8; (gpu.colours.len() + 3) * SLOT as usize];
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
    let particles = ctx.workgroups(gpu.n)?;
    let grids = gpu
        .colours
        .iter()
        .map(|d| ctx.workgroups(if d.serial { 1 } else { d.count }))
        .collect::<Result<Vec<_>, _>>()?;
    ctx.scoped("a GPU soft-body step", || {
        ctx.queue.write_buffer(&gpu.params, 0, &bytes);
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("soft step"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("soft step"),
                timestamp_writes: None,
            });
            let mut run = |entry: Entry, slot: usize, grid: (u32, u32)| {
                pass.set_pipeline(ctx.soft.of(entry));
                pass.set_bind_group(0, &gpu.group, &[(slot as u64 * SLOT) as u32]);
                pass.dispatch_workgroups(grid.0, grid.1, 1);
            };
            for k in 0..n {
                if k == 0 {
                    run(Entry::Predict, 0, particles);
                } else {
                    run(Entry::Finish, 1, particles);
                }
                for (c, d) in gpu.colours.iter().enumerate() {
                    run(Entry::Project(d.kind), c + 3, grids[c]);
                }
            }
            run(Entry::Finish, 2, particles);
        }
        if readback {
            gpu.record_readback(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    })?;
    if readback {
        read(ctx, body, gpu)?;
    } else {
        let _ = ctx.device.poll(wgpu::PollType::Poll);
    }
    Ok(())
}

impl GpuSoftBody {
    /// Records a copy of the positions, then the velocities, into the
    /// staging buffer.
    fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let size = u64::from(self.n) * 16;
        encoder.copy_buffer_to_buffer(&self.x, 0, &self.readback, 0, size);
        encoder.copy_buffer_to_buffer(&self.v, 0, &self.readback, size, size);
    }
}

/// Copies the GPU's positions and velocities into the CPU mirror (after
/// a submitted [`GpuSoftBody::record_readback`]).
fn read(ctx: &GpuContext, body: &mut SoftBody, gpu: &GpuSoftBody) -> Result<(), PhysicsError> {
    let n = gpu.n as usize;
    let bytes = ctx.read_back(&gpu.readback, 2 * n as u64 * 16, "a soft body")?;
    let data: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
    for i in 0..n {
        let [a, b, c, _] = data[i];
        let [d, e, f, _] = data[n + i];
        body.x[i] = Vec3::new(a, b, c);
        body.prev[i] = body.x[i];
        body.v[i] = Vec3::new(d, e, f);
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
