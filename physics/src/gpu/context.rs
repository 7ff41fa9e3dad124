//! The GPU context: one wgpu adapter, device and queue, and the three
//! compiled particle pipelines, shared by every GPU system of a world.

use std::sync::{Arc, Mutex};

use crate::error::PhysicsError;

/// The error when no adapter is found: what was tried and what to install.
fn no_adapter(tried: wgpu::Backends) -> PhysicsError {
    let tried = match (
        tried.contains(wgpu::Backends::VULKAN),
        tried.contains(wgpu::Backends::GL),
    ) {
        (true, true) => "tried Vulkan and GL",
        (true, false) => "tried Vulkan only",
        (false, true) => "tried GL only",
        (false, false) => "WGPU_BACKEND excludes both Vulkan and GL",
    };
    PhysicsError::Gpu(format!(
        "no GPU adapter with compute shaders was found ({tried}). \
         On a machine without a GPU install Mesa's CPU drivers: \
         `apt-get install mesa-vulkan-drivers` (Vulkan lavapipe), or Mesa GL/EGL \
         (`apt-get install libegl-mesa0 libgl1-mesa-dri`, llvmpipe). \
         WGPU_BACKEND (e.g. `vulkan` or `gl`) restricts the search"
    ))
}

/// The wgpu device and compiled pipelines, shared by every GPU system.
///
/// Created once per [`World`](crate::World) on first use
/// ([`World::gpu_context`](crate::World::gpu_context)). Adapters are tried
/// on Vulkan, then (only if Vulkan has none) on GL; `WGPU_BACKEND=gl` or
/// `=vulkan` restricts the search. Within a backend a discrete GPU is
/// preferred, then integrated, virtual, other, and a CPU rasterizer (Mesa
/// lavapipe / llvmpipe) last.
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) info: wgpu::AdapterInfo,
    pub(crate) limits: wgpu::Limits,
    pub(crate) springs: wgpu::ComputePipeline,
    pub(crate) interactions: wgpu::ComputePipeline,
    pub(crate) integrate: wgpu::ComputePipeline,
    /// Errors that escaped every error scope (the default handler would
    /// panic); reported by the next call that checks.
    uncaptured: Arc<Mutex<Option<String>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.info.name)
            .field("backend", &self.info.backend)
            .finish_non_exhaustive()
    }
}

fn device_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

impl GpuContext {
    /// Opens an adapter and compiles the pipelines.
    ///
    /// Fails with [`PhysicsError::Gpu`] when no adapter with compute shaders
    /// exists (the message says what to install), or when the device or a
    /// pipeline cannot be created.
    pub fn new() -> Result<Self, PhysicsError> {
        let allowed = (wgpu::Backends::VULKAN | wgpu::Backends::GL).with_env();
        // Vulkan first; GL (EGL) only when Vulkan offers nothing, so that
        // machines with Vulkan never pay for (or print from) the GL probe.
        let mut adapters = Vec::new();
        for backends in [wgpu::Backends::VULKAN, wgpu::Backends::GL] {
            let backends = backends & allowed;
            if backends.is_empty() || !adapters.is_empty() {
                continue;
            }
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = backends;
            desc.flags = wgpu::InstanceFlags::empty().with_env();
            let instance = wgpu::Instance::new(desc);
            adapters = pollster::block_on(instance.enumerate_adapters(backends))
                .into_iter()
                .filter(|a| {
                    a.get_downlevel_capabilities()
                        .flags
                        .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
                })
                .collect();
        }
        adapters.sort_by_key(|a| device_rank(a.get_info().device_type));
        let adapter = adapters
            .into_iter()
            .next()
            .ok_or_else(|| no_adapter(allowed & (wgpu::Backends::VULKAN | wgpu::Backends::GL)))?;
        Self::from_adapter(adapter)
    }

    fn from_adapter(adapter: wgpu::Adapter) -> Result<Self, PhysicsError> {
        let info = adapter.get_info();
        // Ask for everything the adapter offers: big systems need big
        // storage bindings, and the shaders need nothing beyond the
        // downlevel defaults otherwise.
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("inertia-physics"),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| PhysicsError::Gpu(format!("could not open {}: {e}", info.name)))?;
        let uncaptured = Arc::new(Mutex::new(None));
        let sink = Arc::clone(&uncaptured);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut slot) = sink.lock() {
                slot.get_or_insert_with(|| e.to_string());
            }
        }));
        let limits = device.limits();
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipeline = |label: &str, source: &str| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let springs = pipeline("particle_springs", inertia_shaders::PARTICLE_SPRINGS);
        let interactions = pipeline(
            "particle_interactions",
            inertia_shaders::PARTICLE_INTERACTIONS,
        );
        let integrate = pipeline("particle_integrate", inertia_shaders::PARTICLE_INTEGRATE);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(PhysicsError::Gpu(format!(
                "compiling the particle shaders for {} failed: {e}",
                info.name
            )));
        }
        Ok(Self {
            device,
            queue,
            info,
            limits,
            springs,
            interactions,
            integrate,
            uncaptured,
        })
    }

    /// The adapter's name, e.g. "llvmpipe (LLVM 15.0.7, 256 bits)".
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// The graphics API in use: "vulkan" or "gl".
    pub fn backend_name(&self) -> &'static str {
        self.info.backend.to_str()
    }

    /// One line for reports: name, backend, device type and driver.
    pub fn description(&self) -> String {
        let kind = match self.info.device_type {
            wgpu::DeviceType::DiscreteGpu => "discrete GPU",
            wgpu::DeviceType::IntegratedGpu => "integrated GPU",
            wgpu::DeviceType::VirtualGpu => "virtual GPU",
            wgpu::DeviceType::Cpu => "CPU",
            wgpu::DeviceType::Other => "other",
        };
        let driver = [self.info.driver.as_str(), self.info.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        format!(
            "{} ({}, {kind}{}{driver})",
            self.info.name,
            self.backend_name(),
            if driver.is_empty() { "" } else { ", " }
        )
    }

    /// Whether the adapter is a software rasterizer running on the CPU
    /// (Mesa lavapipe or llvmpipe): timings then measure the CPU, not a GPU.
    pub fn is_cpu_adapter(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Full wgpu adapter information.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// Blocks until every GPU step submitted so far has finished. Steps
    /// without readback only *submit* work; time them up to this call.
    pub fn finish(&self) -> Result<(), PhysicsError> {
        self.wait()?;
        self.check_uncaptured()
    }

    /// Waits for the queue to drain.
    pub(crate) fn wait(&self) -> Result<(), PhysicsError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| PhysicsError::Gpu(format!("waiting for the GPU failed: {e}")))
    }

    /// Runs `f` inside a validation + out-of-memory error scope and turns
    /// anything it raised into [`PhysicsError::Gpu`] naming `what`.
    pub(crate) fn scoped<T>(
        &self,
        what: &str,
        f: impl FnOnce() -> Result<T, PhysicsError>,
    ) -> Result<T, PhysicsError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let validation = pollster::block_on(validation.pop());
        let oom = pollster::block_on(oom.pop());
        if let Some(e) = validation.or(oom) {
            return Err(PhysicsError::Gpu(format!("{what} failed: {e}")));
        }
        self.check_uncaptured()?;
        out
    }

    /// Workgroups for `items` invocations, as an `(x, y)` grid when one
    /// dimension is not enough; the shaders fold `y` back into a linear
    /// index.
    pub(crate) fn workgroups(&self, items: u32) -> Result<(u32, u32), PhysicsError> {
        let groups = items.div_ceil(inertia_shaders::layout::WORKGROUP_SIZE);
        let max = self.limits.max_compute_workgroups_per_dimension.max(1);
        if groups <= max {
            return Ok((groups, 1));
        }
        let y = groups.div_ceil(max);
        if y > max {
            return Err(PhysicsError::Gpu(format!(
                "{items} items exceed the adapter's dispatch limits"
            )));
        }
        Ok((max, y))
    }

    /// Maps the first `bytes` of the staging buffer `staging` (after a
    /// submitted copy into it), returns them and unmaps it. Blocks until
    /// the GPU is done; `what` names the data in errors.
    pub(crate) fn read_back(
        &self,
        staging: &wgpu::Buffer,
        bytes: u64,
        what: &str,
    ) -> Result<Vec<u8>, PhysicsError> {
        let slice = staging.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|_| PhysicsError::Gpu(format!("reading back {what} never completed")))?
            .map_err(|e| PhysicsError::Gpu(format!("mapping {what} for reading failed: {e}")))?;
        let out = slice
            .get_mapped_range()
            .map(|view| view.to_vec())
            .map_err(|e| PhysicsError::Gpu(format!("reading back {what}: {e}")));
        staging.unmap();
        out
    }

    /// Reports (once) an error that escaped every scope.
    pub(crate) fn check_uncaptured(&self) -> Result<(), PhysicsError> {
        match self.uncaptured.lock().ok().and_then(|mut s| s.take()) {
            Some(e) => Err(PhysicsError::Gpu(format!("GPU error: {e}"))),
            None => Ok(()),
        }
    }
}
