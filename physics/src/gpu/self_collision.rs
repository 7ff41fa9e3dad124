//! Cloth self-collision on the GPU (`xpbd_self_collision.wgsl`, after
//! `grid.wgsl`), for a soft body that steps there (`gpu/soft.rs`): the
//! CPU's method (`xpbd/soft/self_collision.rs`) on the GPU's neighbour
//! grid.
//!
//! | buffer | contents | written by |
//! |---|---|---|
//! | `params` | the step's uniform block ([`SelfParams`]) | CPU, every step |
//! | `x` | the soft body's positions (its own buffer) | the soft passes, `self_collide` |
//! | `grid_points`, `sorted`, `cells`, `start` | the neighbour grid (`gpu/grid.rs`) | the grid's passes |
//! | `joined` | which particles a constraint or a triangle joins (CSR) | upload only |
//! | `before` | the positions as a substep's pass found them | `keep` |
//!
//! Once a step the grid places each particle where it stands; its
//! candidates are the particles within the contact distance plus twice
//! how far the fastest particle goes in the step (from the velocities
//! read back: a self-colliding body on the GPU is read back every step).
//! Each substep, after the contacts with rigid bodies, `keep` and
//! `self_collide` push the close pairs apart, a Jacobi pass as on the CPU.
//! Candidates come in the grid's order, so a particle's pushes are summed
//! in another order than the CPU's: the runs agree within
//! [`SOFT_GPU_TOLERANCE`](super::soft::SOFT_GPU_TOLERANCE), not bit for
//! bit.

use wgpu::util::DeviceExt;

use crate::xpbd::soft::self_collision::joined;
use crate::xpbd::soft::SoftBody;

use super::buffers::{at_least, bind_buffers};
use super::grid::GridBuffers;
use super::program::{storage_binding, uniform_binding, Program};

/// Storage buffers its passes bind.
const STORAGE_BUFFERS: u32 = 7;

/// WGSL `struct SelfParams` of `xpbd_self_collision.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SelfParams {
    n: u32,
    table: u32,
    /// 1/m.
    inv_cell: f32,
    /// m².
    reach2: f32,
    /// m.
    contact: f32,
    pad: [u32; 3],
}

const _: () =
    assert!(std::mem::size_of::<SelfParams>() == inertia_shaders::layout::SELF_PARAMS_BYTES);

/// The self-collision pipelines, sharing one bind group layout.
#[derive(Debug)]
pub(crate) struct SelfPipelines {
    layout: wgpu::BindGroupLayout,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    pub(crate) scatter: wgpu::ComputePipeline,
    pub(crate) sort_cells: wgpu::ComputePipeline,
    pub(crate) keep: wgpu::ComputePipeline,
    pub(crate) self_collide: wgpu::ComputePipeline,
}

impl SelfPipelines {
    /// Compiles the pipelines; `None` when the adapter binds too few
    /// storage buffers per shader.
    pub(crate) fn new(device: &wgpu::Device) -> Option<Self> {
        if device.limits().max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return None;
        }
        let program = Program::new(
            device,
            "xpbd_self_collision",
            inertia_shaders::XPBD_SELF_COLLISION,
            &[
                uniform_binding::<SelfParams>(false),
                storage_binding(1, false),
                storage_binding(2, false),
                storage_binding(3, false),
                storage_binding(4, false),
                storage_binding(5, false),
                storage_binding(6, true),
                storage_binding(7, false),
            ],
        );
        let pipeline = |entry: &str| program.pipeline(device, entry);
        Some(Self {
            count: pipeline("count"),
            scan: pipeline("scan"),
            scatter: pipeline("scatter"),
            sort_cells: pipeline("sort_cells"),
            keep: pipeline("keep"),
            self_collide: pipeline("self_collide"),
            layout: program.layout,
        })
    }
}

/// The self-collision buffers of one soft body on the GPU.
#[derive(Debug)]
pub(crate) struct GpuSelfCollision {
    n: u32,
    params: wgpu::Buffer,
    grid: GridBuffers,
    pub(crate) group: wgpu::BindGroup,
}

impl GpuSelfCollision {
    /// The buffers for `body`, whose positions the GPU keeps in `x`.
    pub(crate) fn new(
        device: &wgpu::Device,
        pipelines: &SelfPipelines,
        body: &SoftBody,
        x: &wgpu::Buffer,
    ) -> Self {
        let n = body.len();
        let (start, list) = joined(body);
        let mut lists = start;
        lists.extend_from_slice(&list);
        let joined = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("soft joined"),
            contents: &at_least(bytemuck::cast_slice(&lists), 32),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let before = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("soft before"),
            size: (16 * n as u64).max(32),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("soft self-collision params"),
            size: std::mem::size_of::<SelfParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let grid = GridBuffers::new(device, "soft", n);
        let buffers = [
            &params,
            x,
            &grid.points,
            &grid.sorted,
            &grid.cells,
            &grid.start,
            &joined,
            &before,
        ];
        let group = bind_buffers(device, "soft self-collision", &pipelines.layout, &buffers);
        Self {
            n: n as u32,
            params,
            grid,
            group,
        }
    }

    /// Keys of the grid.
    pub(crate) fn table(&self) -> u32 {
        self.grid.table
    }

    /// Writes the step's block: candidates within `reach` (m, > 0 and
    /// finite), pairs kept `contact` (m) apart.
    pub(crate) fn write_params(&self, queue: &wgpu::Queue, reach: f32, contact: f32) {
        let p = SelfParams {
            n: self.n,
            table: self.grid.table,
            inv_cell: 1.0 / reach,
            reach2: reach * reach,
            contact,
            pad: [0; 3],
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
    }

    /// Records the grid's counts (`gpu/grid.rs`) in passes of their own,
    /// before the step's pass, which takes `scatter` and `sort_cells`.
    pub(crate) fn record_counts(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipelines: &SelfPipelines,
        particles: (u32, u32),
    ) {
        self.grid.record_counts(
            encoder,
            [&pipelines.count, &pipelines.scan],
            &self.group,
            &[],
            particles,
        );
    }
}
