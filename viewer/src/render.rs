//! Draws a [`DrawList`] with wgpu: one mesh per shape, its entities drawn
//! as instances (frame and colour per instance), lit by `viewer_scene.wgsl`,
//! multisampled where the adapter can, then the HUD (egui) on top. The same
//! renderer draws into a window's surface and into an off-screen texture.

use std::collections::HashMap;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::camera::OrbitCamera;
use crate::mesh::{mesh_of, Vertex};
use crate::scene::{Catalogue, DrawList, Finish, ShapeKey};

/// The sky (clear colour and fog), linear RGB.
pub const SKY: [f32; 3] = [0.42, 0.56, 0.78];
/// Fog density, 1/m.
const FOG_DENSITY: f32 = 0.004;
/// Samples per pixel when the adapter allows it.
const WANTED_SAMPLES: u32 = 4;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// One instance as the vertex shader reads it (locations 2 to 6).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Instance {
    model: [[f32; 4]; 4],
    color: [f32; 4],
}

/// The uniform block `Camera` of the scene shader.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct CameraBlock {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    sun: [f32; 4],
    sky: [f32; 4],
}

struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

/// What the HUD drew this frame, ready for egui's renderer.
pub struct HudPaint {
    /// Tessellated shapes.
    pub primitives: Vec<egui::ClippedPrimitive>,
    /// Font and image textures to upload or free.
    pub textures: egui::TexturesDelta,
    /// Pixels per egui point.
    pub pixels_per_point: f32,
}

impl std::fmt::Debug for HudPaint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HudPaint")
            .field("primitives", &self.primitives.len())
            .field("pixels_per_point", &self.pixels_per_point)
            .finish_non_exhaustive()
    }
}

/// Attachments sized to the target.
struct Attachments {
    size: (u32, u32),
    depth: wgpu::TextureView,
    /// The multisampled colour, resolved into the target (none at 1 sample).
    color: Option<wgpu::TextureView>,
}

/// The scene and HUD renderer for one device and target format.
pub struct Renderer {
    format: wgpu::TextureFormat,
    samples: u32,
    opaque: wgpu::RenderPipeline,
    gridded: wgpu::RenderPipeline,
    translucent: wgpu::RenderPipeline,
    camera: wgpu::Buffer,
    camera_group: wgpu::BindGroup,
    meshes: HashMap<ShapeKey, GpuMesh>,
    instances: Option<wgpu::Buffer>,
    /// The picture's own meshes ([`DrawList::surfaces`]), one after the
    /// other, rewritten every picture.
    surface_vertices: Option<wgpu::Buffer>,
    surface_indices: Option<wgpu::Buffer>,
    attachments: Option<Attachments>,
    hud: egui_wgpu::Renderer,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("format", &self.format)
            .field("samples", &self.samples)
            .field("meshes", &self.meshes.len())
            .finish_non_exhaustive()
    }
}

impl Renderer {
    /// A renderer for targets of `format` on `adapter`'s `device`.
    pub fn new(
        adapter: &wgpu::Adapter,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
    ) -> Self {
        let multisample_ok = adapter
            .get_texture_format_features(format)
            .flags
            .sample_count_supported(WANTED_SAMPLES)
            && adapter
                .get_texture_format_features(DEPTH_FORMAT)
                .flags
                .sample_count_supported(WANTED_SAMPLES);
        let samples = if multisample_ok { WANTED_SAMPLES } else { 1 };
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewer_scene.wgsl"),
            source: wgpu::ShaderSource::Wgsl(inertia_shaders::VIEWER_SCENE.into()),
        });
        let camera_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let camera = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("camera"),
            size: std::mem::size_of::<CameraBlock>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let camera_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("camera"),
            layout: &camera_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: camera.as_entire_binding(),
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene"),
            bind_group_layouts: &[Some(&camera_layout)],
            immediate_size: 0,
        });
        let vertex_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
        let instance_attributes = wgpu::vertex_attr_array![
            2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4, 6 => Float32x4
        ];
        let buffers = [
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &vertex_attributes,
            }),
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Instance>() as u64,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &instance_attributes,
            }),
        ];
        let pipeline = |label: &str, fragment: &str, blend: Option<wgpu::BlendState>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    // Both sides: scenery meshes are often open.
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(blend.is_none()),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState {
                    count: samples,
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(fragment),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let opaque = pipeline("opaque", "fs_main", None);
        let gridded = pipeline("gridded", "fs_gridded", None);
        let translucent = pipeline(
            "translucent",
            "fs_main",
            Some(wgpu::BlendState::ALPHA_BLENDING),
        );
        let hud = egui_wgpu::Renderer::new(device, format, egui_wgpu::RendererOptions::default());
        Self {
            format,
            samples,
            opaque,
            gridded,
            translucent,
            camera,
            camera_group,
            meshes: HashMap::new(),
            instances: None,
            surface_vertices: None,
            surface_indices: None,
            attachments: None,
            hud,
        }
    }

    /// The target format this renderer draws.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Samples per pixel (4, or 1 where the adapter cannot multisample).
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Makes the depth and multisampled attachments for `size` unless they
    /// are already that size.
    fn attachments(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if self.attachments.as_ref().is_none_or(|a| a.size != size) {
            let texture = |label: &str, format| {
                device
                    .create_texture(&wgpu::TextureDescriptor {
                        label: Some(label),
                        size: wgpu::Extent3d {
                            width: size.0,
                            height: size.1,
                            depth_or_array_layers: 1,
                        },
                        mip_level_count: 1,
                        sample_count: self.samples,
                        dimension: wgpu::TextureDimension::D2,
                        format,
                        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                        view_formats: &[],
                    })
                    .create_view(&Default::default())
            };
            self.attachments = Some(Attachments {
                size,
                depth: texture("depth", DEPTH_FORMAT),
                color: (self.samples > 1).then(|| texture("multisampled colour", self.format)),
            });
        }
    }

    fn upload_meshes(&mut self, device: &wgpu::Device, catalogue: &Catalogue, list: &DrawList) {
        for item in &list.items {
            if self.meshes.contains_key(&item.shape) {
                continue;
            }
            let Some(shape) = catalogue.shape(item.shape) else {
                continue;
            };
            let mesh = mesh_of(shape);
            if mesh.indices.is_empty() {
                continue;
            }
            let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("mesh vertices"),
                contents: bytemuck::cast_slice(&mesh.vertices),
                usage: wgpu::BufferUsages::VERTEX,
            });
            let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("mesh indices"),
                contents: bytemuck::cast_slice(&mesh.indices),
                usage: wgpu::BufferUsages::INDEX,
            });
            self.meshes.insert(
                item.shape,
                GpuMesh {
                    vertices,
                    indices,
                    index_count: mesh.indices.len() as u32,
                },
            );
        }
    }

    /// Records the drawing of `list` seen by `camera`, and `hud` over it,
    /// into `target` (a view of a texture of `size` pixels in this
    /// renderer's format).
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        size: (u32, u32),
        catalogue: &Catalogue,
        list: &DrawList,
        camera: &OrbitCamera,
        hud: Option<HudPaint>,
    ) {
        self.upload_meshes(device, catalogue, list);
        let sun = Vec3::new(0.45, 0.8, 0.3).normalize();
        let block = CameraBlock {
            view_proj: camera
                .view_proj(size.0 as f32 / size.1.max(1) as f32)
                .to_cols_array_2d(),
            eye: camera.eye().extend(1.0).to_array(),
            sun: sun.extend(0.0).to_array(),
            sky: [SKY[0], SKY[1], SKY[2], FOG_DENSITY],
        };
        queue.write_buffer(&self.camera, 0, bytemuck::bytes_of(&block));

        // Instances of the drawable items, in the list's order: runs of
        // one shape each.
        let mut instances = Vec::with_capacity(list.items.len());
        // (shape, finish, instances)
        let mut runs: Vec<(ShapeKey, Finish, std::ops::Range<u32>)> = Vec::new();
        for item in list
            .items
            .iter()
            .filter(|i| self.meshes.contains_key(&i.shape))
        {
            let k = instances.len() as u32;
            instances.push(Instance {
                model: item.model.to_cols_array_2d(),
                color: item.color,
            });
            match runs.last_mut() {
                Some((shape, finish, range)) if *shape == item.shape && *finish == item.finish => {
                    range.end = k + 1;
                }
                _ => runs.push((item.shape, item.finish, k..k + 1)),
            }
        }
        // The picture's own meshes, each one instance at the origin:
        // (finish, index range, first vertex, instance).
        let mut surface_vertices: Vec<Vertex> = Vec::new();
        let mut surface_indices: Vec<u32> = Vec::new();
        let mut surfaces = Vec::with_capacity(list.surfaces.len());
        for surface in &list.surfaces {
            let k = instances.len() as u32;
            instances.push(Instance {
                model: glam::Mat4::IDENTITY.to_cols_array_2d(),
                color: surface.color,
            });
            let first = surface_indices.len() as u32;
            let base = surface_vertices.len() as i32;
            surface_vertices.extend_from_slice(&surface.mesh.vertices);
            surface_indices.extend_from_slice(&surface.mesh.indices);
            let end = surface_indices.len() as u32;
            surfaces.push((surface.finish, first..end, base, k..k + 1));
        }
        grow_and_write(
            device,
            queue,
            &mut self.instances,
            "instances",
            wgpu::BufferUsages::VERTEX,
            bytemuck::cast_slice(&instances),
        );
        grow_and_write(
            device,
            queue,
            &mut self.surface_vertices,
            "surface vertices",
            wgpu::BufferUsages::VERTEX,
            bytemuck::cast_slice(&surface_vertices),
        );
        grow_and_write(
            device,
            queue,
            &mut self.surface_indices,
            "surface indices",
            wgpu::BufferUsages::INDEX,
            bytemuck::cast_slice(&surface_indices),
        );
        self.attachments(device, size);
        let instance_buffer = self.instances.as_ref().expect("just made");
        let attachments = self.attachments.as_ref().expect("just made");
        let (view, resolve) = match &attachments.color {
            Some(ms) => (ms, Some(target)),
            None => (target, None),
        };
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: resolve,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: f64::from(SKY[0]),
                            g: f64::from(SKY[1]),
                            b: f64::from(SKY[2]),
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &attachments.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.camera_group, &[]);
            pass.set_vertex_buffer(1, instance_buffer.slice(..));
            // Opaque things first (instanced shapes, then the picture's own
            // meshes), then the see-through ones over them.
            for see_through in [false, true] {
                for (shape, finish, range) in &runs {
                    if (*finish == Finish::Translucent) != see_through {
                        continue;
                    }
                    let mesh = &self.meshes[shape];
                    pass.set_pipeline(self.pipeline(*finish));
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..mesh.index_count, 0, range.clone());
                }
                let (Some(vertices), Some(indices)) =
                    (&self.surface_vertices, &self.surface_indices)
                else {
                    continue;
                };
                pass.set_vertex_buffer(0, vertices.slice(..));
                pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                for (finish, range, base, instance) in &surfaces {
                    if (*finish == Finish::Translucent) == see_through {
                        pass.set_pipeline(self.pipeline(*finish));
                        pass.draw_indexed(range.clone(), *base, instance.clone());
                    }
                }
            }
        }

        if let Some(hud) = hud {
            self.draw_hud(device, queue, encoder, target, size, hud);
        }
    }

    /// The pipeline that draws surfaces of `finish`.
    fn pipeline(&self, finish: Finish) -> &wgpu::RenderPipeline {
        match finish {
            Finish::Translucent => &self.translucent,
            Finish::Gridded => &self.gridded,
            Finish::Plain => &self.opaque,
        }
    }

    fn draw_hud(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        size: (u32, u32),
        mut hud: HudPaint,
    ) {
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [size.0, size.1],
            pixels_per_point: hud.pixels_per_point,
        };
        for (id, deltas) in &hud.textures.set {
            for delta in deltas {
                self.hud.update_texture(device, queue, *id, delta);
            }
        }
        let extra = self
            .hud
            .update_buffers(device, queue, encoder, &hud.primitives, &screen);
        if !extra.is_empty() {
            queue.submit(extra);
        }
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("hud"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let mut pass = pass.forget_lifetime();
            self.hud.render(&mut pass, &hud.primitives, &screen);
        }
        for id in &hud.textures.free {
            self.hud.free_texture(id);
        }
        // Applied: egui checks that no delta is dropped unseen.
        hud.textures.clear();
    }
}

/// Writes `bytes` at the start of `buffer`, made (again) larger when it
/// cannot hold them; nothing is written for none.
fn grow_and_write(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &mut Option<wgpu::Buffer>,
    label: &'static str,
    usage: wgpu::BufferUsages,
    bytes: &[u8],
) {
    let len = bytes.len() as u64;
    if buffer.as_ref().is_none_or(|b| b.size() < len) {
        *buffer = Some(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: len.next_power_of_two().max(4096),
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }));
    }
    if let Some(b) = buffer.as_ref().filter(|_| len > 0) {
        queue.write_buffer(b, 0, bytes);
    }
}
