//! The neighbour grid on the GPU (`shaders/wgsl/grid.wgsl`, the head of the
//! fluid's and the self-collision's shaders): its buffers, and the passes
//! that count the particles per key before they are scattered.
//!
//! The grid is a hash table of cells, as the CPU's hashed layout
//! (`xpbd/grid.rs`), filled by a counting sort: `count` (an integer atomic
//! count per key) and `scan` (where each key's slots start), then, the
//! counts cleared to serve as cursors, `scatter` and `sort_cells` (each
//! key's slots in particle order).

use inertia_shaders::layout::FLUID_SLOT_BYTES;

/// Keys of the hash table for `n` particles: as on the CPU's hashed grid,
/// twice the particles rounded up to a power of two, at least 1024.
pub(crate) fn table_size(n: usize) -> usize {
    (2 * n).next_power_of_two().max(1024)
}

/// The grid's buffers for `n` particles.
#[derive(Debug)]
pub(crate) struct GridBuffers {
    /// Per particle: where the grid placed it (`grid_points`), m.
    pub(crate) points: wgpu::Buffer,
    /// Per slot: a particle and where it was placed (`sorted`).
    pub(crate) sorted: wgpu::Buffer,
    /// Per key: the count, then the scatter's cursor (`cells`).
    pub(crate) cells: wgpu::Buffer,
    /// Per key, where its slots start; one more than keys (`start`).
    pub(crate) start: wgpu::Buffer,
    /// Keys (a power of two).
    pub(crate) table: u32,
}

impl GridBuffers {
    /// The buffers for `n` particles, named after `label`.
    pub(crate) fn new(device: &wgpu::Device, label: &str, n: usize) -> Self {
        let table = table_size(n);
        let buffer = |what: &str, bytes: usize, extra: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("{label} {what}")),
                size: (bytes as u64).max(32),
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            })
        };
        let none = wgpu::BufferUsages::empty();
        Self {
            points: buffer("grid points", 16 * n, none),
            sorted: buffer("sorted", FLUID_SLOT_BYTES * n, none),
            cells: buffer("cells", 4 * table, wgpu::BufferUsages::COPY_DST),
            start: buffer("start", 4 * (table + 1), none),
            table: table as u32,
        }
    }

    /// Records the counts cleared, `count` over `particles` workgroups and
    /// `scan` in a pass of their own (`group` bound at `offset`), then the
    /// counts cleared again to serve as `scatter`'s cursors: the passes
    /// after this take `scatter` and `sort_cells`.
    pub(crate) fn record_counts(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        [count, scan]: [&wgpu::ComputePipeline; 2],
        group: &wgpu::BindGroup,
        offset: &[u32],
        particles: (u32, u32),
    ) {
        encoder.clear_buffer(&self.cells, 0, None);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("grid counts"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, group, offset);
            pass.set_pipeline(count);
            pass.dispatch_workgroups(particles.0, particles.1, 1);
            pass.set_pipeline(scan);
            pass.dispatch_workgroups(1, 1, 1);
        }
        encoder.clear_buffer(&self.cells, 0, None);
    }
}
