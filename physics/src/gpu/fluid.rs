//! Position-based fluids on the GPU (`pbf.wgsl`): the same step as the
//! CPU path (`xpbd/fluid/step.rs`), stage for stage, in `f32` like it.
//!
//! | buffer | contents | written by |
//! |---|---|---|
//! | `params` | the step's uniform block ([`FluidParams`], the wall table in it), a slot per substep | CPU, every step |
//! | `x`, `v` | position, velocity (16 B each) | the passes |
//! | `prev`, `next` | start of the substep; corrected positions, then new velocities | the passes |
//! | `grid_points` | positions predicted for the whole step (where the neighbour grid places them; `gpu/grid.rs`) | `count` |
//! | `sorted` | per grid slot: predicted position and particle index | `scatter`, `sort_cells` |
//! | `cells` | per key: integer count, then cursor (atomics) | `count`, `scatter` |
//! | `start` | per key: first slot (exclusive prefix sum of the counts) | `scan` |
//! | `lambda` | per particle: the walls' gradient and λ | `densities` |
//! | `density` | per particle, kg/m³ | `densities` |
//! | `omega` | per particle: vorticity, 1/s | `vorticity` |
//! | `planes` | per particle: up to 4 walls near it over the step | `find_walls` |
//! | `shapes` | the bodies near the fluid (`gpu/bodies.rs`) | CPU, every step |
//! | `pushes` | per particle and plane: a substep's push on a dynamic body | `corrections`, `collide` |
//! | `partials` | per chunk and dynamic body, then per body: a substep's summed pushes | `reduce_chunks`, `reduce_bodies` |
//! | `motion` | per dynamic body: what the stage did to it | CPU, every step; `advance_bodies`, `take_pushes` |
//! | `readback` | staging copy of `x`, `v` and `density` for the CPU | copy |
//!
//! The neighbour grid is a hashed grid sorted by a counting sort on the
//! GPU: integer atomics count each key's particles and hand out slots,
//! then every key's slots are sorted by particle index, so every
//! neighbour sum runs in one fixed order and a run repeats bit for bit.
//! The CPU sums neighbours in index order, eight lanes at a time; the GPU
//! cell by cell: the same terms, added in another order. How far a GPU
//! run may stand from the CPU run is [`FLUID_GPU_TOLERANCE`].
//!
//! The dynamic bodies among the shapes share each contact with the
//! particles, as on the CPU (`gpu/bodies.rs`): each substep, each particle
//! keeps its push on the body behind each of its planes, passes sum them
//! per body in a fixed order and move the body, and after the step the
//! host reads back 80 bytes a body and applies them (it waits for the GPU
//! to finish the step to do so, readback or not).
//!
//! What the GPU path does not do is refused by
//! [`World::set_fluid_backend`](crate::World::set_fluid_backend): shapes
//! other than cuboids, spheres and capsules, and more than
//! [`MAX_GPU_BODIES`] bodies near the fluid (`gpu/bodies.rs`).
//! Emitters fire on the host between steps (the world reads the fluid
//! back, adds the shot and uploads it again).

use std::sync::Arc;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::error::PhysicsError;
use crate::xpbd::fluid::Fluid;

use super::bodies::{BodyBuffers, NearBodies, MAX_GPU_BODIES};
use super::buffers::at_least;
use super::context::GpuContext;
use super::grid::GridBuffers;
use super::program::{storage_binding, uniform_binding, Program};
use crate::xpbd::coupling::BodyChange;
use inertia_shaders::layout::{BODY_SLOTS, FLUID_PLANE_BYTES, PUSH_BYTES};

/// Largest distance (m) a GPU-stepped fluid particle may stand from the
/// CPU-stepped one after 24 steps at 60 Hz of a small dam break (1920
/// particles 5 cm apart in a static tank, its front across the tank and
/// onto the far wall: the parity test, `physics/tests/issue_16_gpu_fluid.rs`).
///
/// Both paths are `f32` and take the same stages, but the GPU adds each
/// particle's neighbours cell by cell where the CPU adds them in index
/// order, eight lanes at a time (and a GPU may fuse multiplies and adds):
/// after one step the two stand a few ulps apart (3·10⁻⁷ m on Mesa
/// lavapipe). A breaking dam is chaotic where it splashes: the worst
/// particle's difference doubles about every step and a half (10⁻⁵ m after
/// 9 steps, 10⁻³ m after 17, 9.5·10⁻³ m after 24, 0.15 m after 30 on
/// lavapipe), while the bulk stays close ([`FLUID_GPU_MEDIAN_TOLERANCE`]).
/// The bound, half a spacing, holds for that span only; longer runs
/// agree in their statistics (level, density), not particle by particle.
pub const FLUID_GPU_TOLERANCE: f32 = 2.5e-2;

/// Largest distance (m) the median particle of the parity test's dam may
/// stand from the CPU's after its 24 steps (measured on lavapipe:
/// 2.2·10⁻⁵ m; 9·10⁻⁵ m after 30 steps).
pub const FLUID_GPU_MEDIAN_TOLERANCE: f32 = 2e-4;

/// Storage buffers the fluid's passes bind.
const STORAGE_BUFFERS: u32 = 16;

/// Bytes between the step's uniform slots, one per substep (a multiple of
/// the dynamic-offset alignment every adapter allows, 256).
const SLOT: usize = std::mem::size_of::<FluidParams>().div_ceil(256) * 256;

/// WGSL `struct FluidParams` of `pbf.wgsl`: one step's uniform block.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FluidParams {
    /// m/s², w unused.
    gravity: [f32; 4],
    n: u32,
    table: u32,
    shapes: u32,
    tensile: u32,
    /// s.
    dt: f32,
    substep: f32,
    /// m, m².
    h: f32,
    h2: f32,
    /// 1/m.
    inv_cell: f32,
    /// m³.
    volume: f32,
    /// kg/m³.
    rest: f32,
    /// 1/m².
    relaxation: f32,
    poly6: f32,
    spiky: f32,
    spiky_grad: f32,
    self_weight: f32,
    /// m.
    cap: f32,
    /// m².
    tensile_scale: f32,
    /// m³.
    tensile_inv_w: f32,
    tensile_n: u32,
    /// m³.
    viscosity: f32,
    /// m.
    vorticity: f32,
    /// m.
    radius: f32,
    friction: f32,
    /// m.
    wall_reach: f32,
    wall_fall: f32,
    /// 1/m.
    wall_per_m: f32,
    wall_scale: f32,
    /// 1/kg.
    particle_inv_mass: f32,
    movable: u32,
    chunks: u32,
    /// The fraction of the step at the end of the slot's substep.
    t: f32,
    wall_phi: [[f32; 4]; 16],
    wall_psi: [[f32; 4]; 16],
}

const _: () =
    assert!(std::mem::size_of::<FluidParams>() == inertia_shaders::layout::FLUID_PARAMS_BYTES);

/// The fluid pipelines, one per entry point of `pbf.wgsl`, sharing one
/// bind group layout.
#[derive(Debug)]
pub(crate) struct FluidPipelines {
    layout: wgpu::BindGroupLayout,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    sort_cells: wgpu::ComputePipeline,
    find_walls: wgpu::ComputePipeline,
    predict: wgpu::ComputePipeline,
    densities: wgpu::ComputePipeline,
    corrections: wgpu::ComputePipeline,
    collide: wgpu::ComputePipeline,
    vorticity: wgpu::ComputePipeline,
    confine: wgpu::ComputePipeline,
    xsph: wgpu::ComputePipeline,
    take_velocities: wgpu::ComputePipeline,
    reduce_chunks: wgpu::ComputePipeline,
    reduce_bodies: wgpu::ComputePipeline,
    advance_bodies: wgpu::ComputePipeline,
    take_pushes: wgpu::ComputePipeline,
}

impl FluidPipelines {
    /// Compiles the pipelines; `None` when the adapter binds too few
    /// storage buffers per shader (uploads then say so).
    pub(crate) fn new(device: &wgpu::Device) -> Option<Self> {
        if device.limits().max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return None;
        }
        let mut entries = vec![uniform_binding::<FluidParams>(true)];
        entries.extend((1..=12).map(|b| storage_binding(b, false)));
        entries.push(storage_binding(13, true));
        entries.extend((14..=16).map(|b| storage_binding(b, false)));
        let program = Program::new(device, "pbf", inertia_shaders::PBF, &entries);
        let pipeline = |entry: &str| program.pipeline(device, entry);
        Some(Self {
            count: pipeline("count"),
            scan: pipeline("scan"),
            scatter: pipeline("scatter"),
            sort_cells: pipeline("sort_cells"),
            find_walls: pipeline("find_walls"),
            predict: pipeline("predict"),
            densities: pipeline("densities"),
            corrections: pipeline("corrections"),
            collide: pipeline("collide"),
            vorticity: pipeline("vorticity"),
            confine: pipeline("confine"),
            xsph: pipeline("xsph"),
            take_velocities: pipeline("take_velocities"),
            reduce_chunks: pipeline("reduce_chunks"),
            reduce_bodies: pipeline("reduce_bodies"),
            advance_bodies: pipeline("advance_bodies"),
            take_pushes: pipeline("take_pushes"),
            layout: program.layout,
        })
    }
}

/// The GPU buffers of one fluid.
#[derive(Debug)]
pub(crate) struct GpuFluid {
    /// Particles.
    pub(crate) n: u32,
    params: wgpu::Buffer,
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    density: wgpu::Buffer,
    /// The neighbour grid (`gpu/grid.rs`).
    grid: GridBuffers,
    /// The rigid bodies it meets (`gpu/bodies.rs`).
    bodies: BodyBuffers,
    readback: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// Substeps the uniform slots were sized for.
    substeps: u32,
}

/// Uploads `fluid`'s particles (positions, velocities, densities).
/// `pipelines` are the world's (`None` on an adapter that cannot run them).
pub(crate) fn upload(
    ctx: &GpuContext,
    pipelines: Option<&FluidPipelines>,
    fluid: &Fluid,
) -> Result<Arc<GpuFluid>, PhysicsError> {
    let pipelines = pipelines.ok_or_else(|| {
        PhysicsError::Gpu(format!(
            "the adapter binds {} storage buffers per shader; fluids on the GPU need {STORAGE_BUFFERS}",
            ctx.limits.max_storage_buffers_per_shader_stage
        ))
    })?;
    let n = fluid.len();
    let max_binding = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    // The largest per-particle buffers: walls, and the pushes kept with them.
    let plane_bytes = (n * BODY_SLOTS * FLUID_PLANE_BYTES.max(PUSH_BYTES)) as u64;
    if plane_bytes > max_binding || n > u32::MAX as usize / 4 {
        return Err(PhysicsError::Gpu(format!(
            "{n} fluid particles need {plane_bytes} bytes of walls, more than this adapter binds \
             ({max_binding} bytes); keep the fluid on the CPU"
        )));
    }
    let x: Vec<[f32; 4]> = fluid.x.iter().map(|p| [p.x, p.y, p.z, 0.0]).collect();
    let v: Vec<[f32; 4]> = fluid.v.iter().map(|u| [u.x, u.y, u.z, 0.0]).collect();
    let mut density = fluid.density.clone();
    density.resize(n, 0.0);
    ctx.scoped("uploading a fluid to the GPU", || {
        let d = &ctx.device;
        let init = |label: &str, bytes: &[u8], extra: wgpu::BufferUsages| {
            d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &at_least(bytes, 32),
                usage: wgpu::BufferUsages::STORAGE | extra,
            })
        };
        let scratch = |label: &str, bytes: usize, extra: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (bytes as u64).max(32),
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            })
        };
        let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let none = wgpu::BufferUsages::empty();
        let xb = init("fluid x", bytemuck::cast_slice(&x), copy);
        let vb = init("fluid v", bytemuck::cast_slice(&v), copy);
        let db = init("fluid density", bytemuck::cast_slice(&density), copy);
        let prev = scratch("fluid prev", 16 * n, none);
        let next = scratch("fluid next", 16 * n, none);
        let grid = GridBuffers::new(d, "fluid", n);
        let lambda = scratch("fluid lambda", 16 * n, none);
        let omega = scratch("fluid omega", 16 * n, none);
        let planes = scratch("fluid planes", BODY_SLOTS * FLUID_PLANE_BYTES * n, none);
        let bodies = BodyBuffers::new(d, "fluid", n, true, true);
        let substeps = fluid.step_constants().substeps.max(1);
        let params = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fluid params"),
            size: (SLOT * substeps as usize) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fluid readback"),
            size: (36 * n as u64).max(32),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let storage = [
            &xb,
            &vb,
            &prev,
            &next,
            &grid.points,
            &grid.sorted,
            &grid.cells,
            &grid.start,
            &lambda,
            &db,
            &omega,
            &planes,
            &bodies.shapes,
            &bodies.pushes,
            &bodies.partials,
            &bodies.motion,
        ];
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &params,
                offset: 0,
                size: wgpu::BufferSize::new(std::mem::size_of::<FluidParams>() as u64),
            }),
        }];
        entries.extend(
            storage
                .iter()
                .enumerate()
                .map(|(k, b)| wgpu::BindGroupEntry {
                    binding: k as u32 + 1,
                    resource: b.as_entire_binding(),
                }),
        );
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pbf"),
            layout: &pipelines.layout,
            entries: &entries,
        });
        Ok(Arc::new(GpuFluid {
            n: n as u32,
            params,
            x: xb,
            v: vb,
            density: db,
            grid,
            bodies,
            readback,
            group,
            substeps,
        }))
    })
}

/// The uniform block of a step of `dt` s under gravity `g` (m/s², the
/// fluid's scale applied) against `walls`.
fn params_for(fluid: &Fluid, gpu: &GpuFluid, dt: f32, g: Vec3, walls: &NearBodies) -> FluidParams {
    let c = fluid.step_constants();
    let k = c.kernels;
    let (phi, psi, per_m, scale) = fluid.wall_table().parts();
    let four = |t: &[f32]| {
        let mut out = [[0.0f32; 4]; 16];
        for (i, v) in t.iter().enumerate().take(64) {
            out[i / 4][i % 4] = *v;
        }
        out
    };
    FluidParams {
        gravity: [g.x, g.y, g.z, 0.0],
        n: gpu.n,
        table: gpu.grid.table,
        shapes: walls.shapes.len() as u32,
        tensile: u32::from(c.tensile_k > 0.0 && c.tensile_inv_w > 0.0),
        dt,
        substep: dt / c.substeps as f32,
        h: k.h,
        h2: k.h2,
        // The CPU's cells are a kernel radius wide.
        inv_cell: 1.0 / k.h,
        volume: c.volume,
        rest: c.rest_density,
        relaxation: c.relaxation,
        poly6: k.poly6,
        spiky: k.spiky,
        spiky_grad: k.spiky_grad,
        self_weight: k.spiky(0.0),
        cap: c.max_correction * c.spacing,
        tensile_scale: -c.tensile_k * k.h2,
        tensile_inv_w: c.tensile_inv_w,
        tensile_n: c.tensile_n,
        viscosity: c.viscosity * c.volume,
        vorticity: c.vorticity * dt,
        radius: c.collision_radius,
        friction: c.friction,
        wall_reach: k.h + c.spacing,
        wall_fall: g.length() * dt * dt,
        wall_per_m: per_m,
        wall_scale: scale,
        particle_inv_mass: 1.0 / c.mass,
        movable: walls.movable.len() as u32,
        chunks: gpu.bodies.chunks,
        t: 1.0,
        wall_phi: four(phi),
        wall_psi: four(psi),
    }
}

/// Steps `fluid` on the GPU by `dt` s under the world's `gravity` (m/s²)
/// against the bodies `walls` (`gpu/bodies.rs`); with `readback`,
/// copies the new positions, velocities and densities into the CPU
/// mirror. Returns what the particles gave the dynamic bodies, for
/// [`apply_changes`](crate::xpbd::coupling::apply_changes). A `dt` that is
/// not finite and > 0 does nothing, as on the CPU.
#[allow(clippy::too_many_arguments)]
pub(crate) fn step(
    ctx: &GpuContext,
    pipelines: Option<&FluidPipelines>,
    fluid: &mut Fluid,
    gpu: &GpuFluid,
    dt: f32,
    gravity: Vec3,
    walls: &NearBodies,
    readback: bool,
) -> Result<Vec<BodyChange>, PhysicsError> {
    let shapes = &walls.shapes;
    if gpu.n as usize != fluid.len() {
        return Err(PhysicsError::Gpu(
            "the fluid changed size since its upload".into(),
        ));
    }
    if shapes.len() > MAX_GPU_BODIES {
        return Err(PhysicsError::Gpu(format!(
            "fluids on the GPU collide with at most {MAX_GPU_BODIES} bodies"
        )));
    }
    if gpu.n == 0 || !(dt.is_finite() && dt > 0.0) {
        return Ok(Vec::new());
    }
    let c = fluid.step_constants();
    let mut g = gravity * c.gravity_scale;
    if !g.is_finite() {
        g = Vec3::ZERO;
    }
    if c.substeps.max(1) > gpu.substeps {
        return Err(PhysicsError::Gpu(
            "the fluid's substeps changed since its upload".into(),
        ));
    }
    let base = params_for(fluid, gpu, dt, g, walls);
    let substeps = c.substeps.max(1);
    // A uniform slot per substep, differing in `t` only.
    let mut bytes = vec![0u8; SLOT * substeps as usize];
    for k in 0..substeps {
        let p = FluidParams {
            t: (k + 1) as f32 / substeps as f32,
            ..base
        };
        let at = k as usize * SLOT;
        bytes[at..at + std::mem::size_of::<FluidParams>()].copy_from_slice(bytemuck::bytes_of(&p));
    }
    let movable = walls.movable.len();
    let pipes =
        pipelines.ok_or_else(|| PhysicsError::Gpu("no fluid pipelines on this adapter".into()))?;
    let particles = ctx.workgroups(gpu.n)?;
    let keys = ctx.workgroups(gpu.grid.table)?;
    // One workgroup a chunk, one invocation a body.
    let chunks = ctx.workgroups(gpu.bodies.chunks * inertia_shaders::layout::WORKGROUP_SIZE)?;
    let bodies = ctx.workgroups(movable as u32)?;
    ctx.scoped("a GPU fluid step", || {
        ctx.queue.write_buffer(&gpu.params, 0, &bytes);
        gpu.bodies.upload(&ctx.queue, walls);
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("fluid step"),
            });
        // Each dispatch is its own usage scope: wgpu puts a barrier
        // between two, so each pass sees the writes of the one before.
        // Each stage names the substep whose uniform slot it reads.
        let run = |encoder: &mut wgpu::CommandEncoder,
                   stages: &[(&wgpu::ComputePipeline, (u32, u32), u32)]| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("fluid step"),
                timestamp_writes: None,
            });
            for (pipeline, grid, substep) in stages {
                pass.set_bind_group(0, &gpu.group, &[*substep * SLOT as u32]);
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(grid.0, grid.1, 1);
            }
        };
        // 1. The neighbour grid: count, prefix sum, scatter, order.
        gpu.grid.record_counts(
            &mut encoder,
            [&pipes.count, &pipes.scan],
            &gpu.group,
            &[0],
            particles,
        );
        let mut stages = vec![
            (&pipes.scatter, particles, 0),
            (&pipes.sort_cells, keys, 0),
            // 2. The walls near each particle over the step.
            (&pipes.find_walls, particles, 0),
        ];
        // 3. The substeps; the dynamic bodies move on, the particles push
        // them, and they take the pushes.
        for k in 0..substeps {
            stages.push((&pipes.predict, particles, k));
            if movable > 0 {
                stages.push((&pipes.advance_bodies, bodies, k));
            }
            stages.extend([
                (&pipes.densities, particles, k),
                (&pipes.corrections, particles, k),
                (&pipes.collide, particles, k),
            ]);
            if movable > 0 {
                stages.extend([
                    (&pipes.reduce_chunks, chunks, k),
                    (&pipes.reduce_bodies, bodies, k),
                    (&pipes.take_pushes, bodies, k),
                ]);
            }
        }
        // 4. Vorticity confinement, then XSPH viscosity.
        if c.vorticity > 0.0 {
            stages.extend([
                (&pipes.vorticity, particles, 0),
                (&pipes.confine, particles, 0),
                (&pipes.take_velocities, particles, 0),
            ]);
        }
        if c.viscosity > 0.0 {
            stages.extend([
                (&pipes.xsph, particles, 0),
                (&pipes.take_velocities, particles, 0),
            ]);
        }
        run(&mut encoder, &stages);
        gpu.bodies.record_moves(&mut encoder, movable);
        if readback {
            gpu.record_readback(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    })?;
    let changes = gpu.bodies.read_moves(ctx, walls)?;
    if readback {
        read(ctx, fluid, gpu)?;
    } else if movable == 0 {
        let _ = ctx.device.poll(wgpu::PollType::Poll);
    }
    Ok(changes)
}

impl GpuFluid {
    /// Records a copy of the positions, velocities and densities into the
    /// staging buffer.
    fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let n = u64::from(self.n);
        if n == 0 {
            return;
        }
        encoder.copy_buffer_to_buffer(&self.x, 0, &self.readback, 0, 16 * n);
        encoder.copy_buffer_to_buffer(&self.v, 0, &self.readback, 16 * n, 16 * n);
        encoder.copy_buffer_to_buffer(&self.density, 0, &self.readback, 32 * n, 4 * n);
    }
}

/// Copies the GPU's positions, velocities and densities into the CPU
/// mirror (after a submitted [`GpuFluid::record_readback`]).
fn read(ctx: &GpuContext, fluid: &mut Fluid, gpu: &GpuFluid) -> Result<(), PhysicsError> {
    let n = gpu.n as usize;
    if n == 0 {
        return Ok(());
    }
    let bytes = ctx.read_back(&gpu.readback, 36 * n as u64, "a fluid")?;
    let xv: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes[..32 * n]);
    let density: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[32 * n..]);
    fluid.density.resize(n, 0.0);
    for i in 0..n {
        let [a, b, c, _] = xv[i];
        let [d, e, f, _] = xv[n + i];
        fluid.x[i] = Vec3::new(a, b, c);
        fluid.v[i] = Vec3::new(d, e, f);
        fluid.density[i] = density[i];
    }
    Ok(())
}

/// Copies the current state back (a step without readback left the mirror
/// stale).
pub(crate) fn download(
    ctx: &GpuContext,
    fluid: &mut Fluid,
    gpu: &GpuFluid,
) -> Result<(), PhysicsError> {
    if gpu.n as usize != fluid.len() {
        return Err(PhysicsError::Gpu(
            "the fluid changed size since its upload".into(),
        ));
    }
    ctx.scoped("reading a fluid back", || {
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("fluid download"),
            });
        gpu.record_readback(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    })?;
    read(ctx, fluid, gpu)
}
