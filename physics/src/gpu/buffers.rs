//! The GPU buffers of one particle system and the bind groups that tie them
//! to the three pipelines.
//!
//! | buffer | contents | written by |
//! |---|---|---|
//! | `params` | per-step uniform block ([`Params`]) | CPU, every step |
//! | `bodies` | position, flags, velocity per particle (32 B) | pass 3 |
//! | `props` | per-particle constants (32 B) | upload only |
//! | `springs` | endpoints and parameters per spring (20 B) | upload only |
//! | `csr` | particle → springs adjacency (offsets, then entries) | upload only |
//! | `control` | per-particle then per-group control forces | upload only |
//! | `forces` | `[0, n)`: interaction force per particle (pass 2); `[n, n + springs)`: force per spring (pass 1) | passes 1, 2 |
//! | `readback` | staging copy of `bodies` for the CPU | copy |
//!
//! Every storage binding holds at least one element (32 bytes), so empty systems,
//! systems without springs and without control still bind.

use wgpu::util::DeviceExt;

use crate::error::PhysicsError;

use super::context::GpuContext;
use super::layout::{GpuBody, Params};

/// GPU buffers of one particle system.
///
/// Cloning shares the device buffers (wgpu handles are reference counted);
/// the engine never clones a system that lives on the GPU.
#[derive(Debug, Clone)]
pub(crate) struct GpuSystem {
    /// Particles.
    pub(crate) n: u32,
    /// Springs.
    pub(crate) n_springs: u32,
    pub(crate) params: wgpu::Buffer,
    pub(crate) bodies: wgpu::Buffer,
    pub(crate) readback: wgpu::Buffer,
    pub(crate) springs_group: wgpu::BindGroup,
    pub(crate) interactions_group: wgpu::BindGroup,
    pub(crate) integrate_group: wgpu::BindGroup,
    /// Whether the CPU mirror holds the current state: true after upload
    /// (then it holds the exact f64 values) and after a step with readback;
    /// false after a step without. `download` skips the copy when true.
    pub(crate) mirror_fresh: bool,
}

/// What [`GpuSystem::create`] uploads.
pub(crate) struct Contents<'a> {
    pub(crate) bodies: &'a [GpuBody],
    pub(crate) props: &'a [super::layout::Props],
    pub(crate) springs: &'a [super::layout::GpuSpring],
    pub(crate) csr: &'a [u32],
    pub(crate) control: &'a [[f32; 4]],
}

/// `data` as bytes, padded to at least `min` bytes.
pub(crate) fn at_least(data: &[u8], min: usize) -> Vec<u8> {
    let mut v = data.to_vec();
    if v.len() < min {
        v.resize(min, 0);
    }
    v
}

/// A bind group of `buffers`, whole, at bindings 0, 1, 2, … in order.
pub(crate) fn bind_buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupEntry {
            binding: k as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

impl GpuSystem {
    /// Creates and fills every buffer and bind group.
    pub(crate) fn create(ctx: &GpuContext, c: &Contents<'_>) -> Result<Self, PhysicsError> {
        let n = c.bodies.len();
        let n_springs = c.springs.len();
        let body_bytes = std::mem::size_of_val(c.bodies);
        let force_bytes = (n + n_springs) as u64 * 16;
        let max_binding = ctx.limits.max_storage_buffer_binding_size;
        let max_buffer = ctx.limits.max_buffer_size;
        for (what, bytes) in [
            ("particle state", body_bytes as u64),
            ("particle properties", std::mem::size_of_val(c.props) as u64),
            ("springs", std::mem::size_of_val(c.springs) as u64),
            ("spring adjacency", std::mem::size_of_val(c.csr) as u64),
            ("control forces", std::mem::size_of_val(c.control) as u64),
            ("force scratch", force_bytes),
        ] {
            if bytes > max_binding.min(max_buffer) {
                return Err(PhysicsError::Gpu(format!(
                    "{what} need {bytes} bytes, more than this adapter binds ({} bytes); \
                     split the system or keep it on the CPU",
                    max_binding.min(max_buffer)
                )));
            }
        }
        let (n32, s32) = (
            u32::try_from(n).map_err(|_| PhysicsError::Gpu("too many particles".into()))?,
            u32::try_from(n_springs).map_err(|_| PhysicsError::Gpu("too many springs".into()))?,
        );
        ctx.scoped("uploading a particle system", || {
            let d = &ctx.device;
            let storage = |label: &str, data: &[u8], extra: wgpu::BufferUsages| {
                d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &at_least(data, 32),
                    usage: wgpu::BufferUsages::STORAGE | extra,
                })
            };
            let params = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("particle params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bodies = storage(
                "particle bodies",
                bytemuck::cast_slice(c.bodies),
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            );
            let props = storage(
                "particle props",
                bytemuck::cast_slice(c.props),
                wgpu::BufferUsages::empty(),
            );
            let springs = storage(
                "particle springs",
                bytemuck::cast_slice(c.springs),
                wgpu::BufferUsages::empty(),
            );
            let csr = storage(
                "particle spring adjacency",
                bytemuck::cast_slice(c.csr),
                wgpu::BufferUsages::empty(),
            );
            let control = storage(
                "particle control forces",
                bytemuck::cast_slice(c.control),
                wgpu::BufferUsages::empty(),
            );
            let forces = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("particle forces"),
                size: force_bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            });
            let readback = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("particle readback"),
                size: (body_bytes as u64).max(16),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let group =
                |label: &str, pipeline: &wgpu::ComputePipeline, buffers: &[&wgpu::Buffer]| {
                    bind_buffers(d, label, &pipeline.get_bind_group_layout(0), buffers)
                };
            let springs_group = group(
                "particle springs",
                &ctx.springs,
                &[&params, &bodies, &springs, &forces],
            );
            let interactions_group = group(
                "particle interactions",
                &ctx.interactions,
                &[&params, &bodies, &props, &csr, &forces],
            );
            let integrate_group = group(
                "particle integrate",
                &ctx.integrate,
                &[&params, &bodies, &props, &control, &forces],
            );
            Ok(GpuSystem {
                n: n32,
                n_springs: s32,
                params,
                bodies,
                readback,
                springs_group,
                interactions_group,
                integrate_group,
                mirror_fresh: true,
            })
        })
    }

    /// Records a copy of the bodies into the staging buffer.
    pub(crate) fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.n > 0 {
            encoder.copy_buffer_to_buffer(
                &self.bodies,
                0,
                &self.readback,
                0,
                u64::from(self.n) * std::mem::size_of::<GpuBody>() as u64,
            );
        }
    }

    /// Maps the staging buffer (after a submitted [`record_readback`]) and
    /// returns the bodies it holds. Blocks until the GPU is done.
    ///
    /// [`record_readback`]: GpuSystem::record_readback
    pub(crate) fn read_bodies(&self, ctx: &GpuContext) -> Result<Vec<GpuBody>, PhysicsError> {
        if self.n == 0 {
            return Ok(Vec::new());
        }
        let bytes = u64::from(self.n) * std::mem::size_of::<GpuBody>() as u64;
        let data = ctx.read_back(&self.readback, bytes, "particle state")?;
        Ok(bytemuck::pod_collect_to_vec::<u8, GpuBody>(&data))
    }
}
