//! A WGSL program of several compute entry points that share one bind
//! group: its layout, made from a uniform block at binding 0 and storage
//! buffers after it, and one pipeline per entry point.

/// One program: its bind group layout, and what each entry point's
/// pipeline is made from.
pub(crate) struct Program {
    /// The bind group every entry point takes (group 0).
    pub(crate) layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
}

/// A storage buffer at `binding`.
pub(crate) fn storage_binding(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The uniform block of `P` at binding 0, bound at a dynamic offset (one
/// block per dispatch in one buffer) or not.
pub(crate) fn uniform_binding<P>(dynamic_offset: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic_offset,
            min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<P>() as u64),
        },
        count: None,
    }
}

impl Program {
    /// Compiles `source` (WGSL) for the bindings `entries`.
    pub(crate) fn new(
        device: &wgpu::Device,
        label: &str,
        source: &'static str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        Self {
            layout,
            pipeline_layout,
            module,
        }
    }

    /// The pipeline of entry point `entry`.
    pub(crate) fn pipeline(&self, device: &wgpu::Device, entry: &str) -> wgpu::ComputePipeline {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    }
}
