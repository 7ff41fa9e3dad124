//! Pictures without a window: the viewer draws into an off-screen texture
//! (on any adapter, Mesa's CPU drivers included), reads it back and writes
//! PNG files, a single screenshot or a sequence of frames.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::camera::OrbitCamera;
use crate::render::{HudPaint, Renderer};
use crate::scene::{Catalogue, DrawList};
use crate::view::Viewer;
use crate::ViewerError;

/// The off-screen format: 8-bit sRGB, as PNG files hold.
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// An RGBA picture, rows top to bottom, 8-bit sRGB.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width × height × 4` bytes.
    pub rgba: Vec<u8>,
}

impl Image {
    /// The pixel at (`x`, `y`).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = ((y * self.width + x) * 4) as usize;
        [
            self.rgba[i],
            self.rgba[i + 1],
            self.rgba[i + 2],
            self.rgba[i + 3],
        ]
    }

    /// Writes the picture as a PNG file.
    pub fn write_png(&self, path: &Path) -> Result<(), ViewerError> {
        let io = |e: std::io::Error| ViewerError::Image(format!("{}: {e}", path.display()));
        let file = std::fs::File::create(path).map_err(io)?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder
            .write_header()
            .map_err(|e| ViewerError::Image(format!("{}: {e}", path.display())))?;
        writer
            .write_image_data(&self.rgba)
            .map_err(|e| ViewerError::Image(format!("{}: {e}", path.display())))?;
        writer
            .finish()
            .map_err(|e| ViewerError::Image(format!("{}: {e}", path.display())))
    }
}

/// A device, and a texture to draw into and read back.
#[derive(Debug)]
pub struct OffScreen {
    device: wgpu::Device,
    queue: wgpu::Queue,
    renderer: Renderer,
    texture: wgpu::Texture,
    readback: wgpu::Buffer,
    size: (u32, u32),
    padded_row: u32,
    adapter: String,
    /// True once the HUD has been laid out (drawn) once.
    hud_laid_out: bool,
}

impl OffScreen {
    /// Opens the first adapter wgpu offers (Vulkan, else GL; a CPU driver
    /// will do) and makes a `width × height` target.
    pub fn new(width: u32, height: u32) -> Result<Self, ViewerError> {
        if width == 0 || height == 0 || width > 8192 || height > 8192 {
            return Err(ViewerError::Usage(format!(
                "a picture of {width}×{height} pixels: each side must be 1 to 8192"
            )));
        }
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = (wgpu::Backends::VULKAN | wgpu::Backends::GL).with_env();
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            apply_limit_buckets: false,
            compatible_surface: None,
        }))
        .map_err(|e| ViewerError::Gpu(format!("no graphics adapter: {e}")))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("inertia-viewer"),
            required_limits:
                wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| ViewerError::Gpu(format!("could not open {}: {e}", info.name)))?;
        let renderer = Renderer::new(&adapter, &device, FORMAT);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("picture"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let padded_row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("picture readback"),
            size: u64::from(padded_row) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Ok(Self {
            device,
            queue,
            renderer,
            texture,
            readback,
            size: (width, height),
            padded_row,
            hud_laid_out: false,
            adapter: format!("{} ({:?})", info.name, info.backend),
        })
    }

    /// The adapter drawn with, in words.
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// Samples per pixel the renderer uses.
    pub fn samples(&self) -> u32 {
        self.renderer.samples()
    }

    /// Draws `view`'s world as it should be shown now, HUD included when
    /// `hud` is true, and reads the picture back.
    pub fn capture(&mut self, view: &mut Viewer, hud: bool) -> Result<Image, ViewerError> {
        if hud && !self.hud_laid_out {
            // egui sizes a window on its first frame and shows it from the
            // second: the first frame is drawn and thrown away. A picture
            // has no time to fade in, so nothing is animated.
            self.hud_laid_out = true;
            view.egui()
                .all_styles_mut(|style| style.animation_time = 0.0);
            self.capture(view, hud)?;
        }
        let (w, h) = self.size;
        let input = hud.then(|| egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(w as f32, h as f32),
            )),
            max_texture_side: Some(self.device.limits().max_texture_dimension_2d as usize),
            ..Default::default()
        });
        let prepared = view.prepare(input);
        self.draw(&view.catalogue, &prepared.list, &view.camera, prepared.hud)
    }

    /// Draws `list` (its shapes from `catalogue`) seen by `camera`, and
    /// `hud` over it, and reads the picture back.
    pub fn draw(
        &mut self,
        catalogue: &Catalogue,
        list: &DrawList,
        camera: &OrbitCamera,
        hud: Option<HudPaint>,
    ) -> Result<Image, ViewerError> {
        let (w, h) = self.size;
        let target = self.texture.create_view(&Default::default());
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        self.renderer.draw(
            &self.device,
            &self.queue,
            &mut encoder,
            &target,
            self.size,
            catalogue,
            list,
            camera,
            hud,
        );
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([encoder.finish()]);
        let slice = self.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| ViewerError::Gpu(format!("waiting for the picture: {e}")))?;
        rx.recv()
            .map_err(|_| ViewerError::Gpu("the picture was never read back".into()))?
            .map_err(|e| ViewerError::Gpu(format!("reading the picture back: {e}")))?;
        let mut rgba = Vec::with_capacity((w * h * 4) as usize);
        {
            let mapped = slice
                .get_mapped_range()
                .map_err(|e| ViewerError::Gpu(format!("reading the picture back: {e}")))?;
            for row in mapped.chunks(self.padded_row as usize) {
                rgba.extend_from_slice(&row[..(w * 4) as usize]);
            }
        }
        self.readback.unmap();
        Ok(Image {
            width: w,
            height: h,
            rgba,
        })
    }
}

/// When the picture is taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum When {
    /// Once the world has been described and a second of snapshots has
    /// arrived (the interpolation buffer is full).
    Settled,
    /// Once the tick drawn reaches this one.
    AtTick(u64),
}

/// How long to wait for the world before giving up.
const WAIT_LIMIT: Duration = Duration::from_secs(60);

/// Waits until `when`, drawing (and discarding) frames at about 30 per
/// second so the viewer runs as it would on screen.
pub fn wait_for(view: &mut Viewer, when: When) -> Result<(), ViewerError> {
    let start = Instant::now();
    let tick_hz = f64::from(view.client().server_info().tick_hz.max(1));
    let limit = match when {
        When::Settled => WAIT_LIMIT,
        When::AtTick(t) => {
            let ahead = t.saturating_sub(view.client().server_info().tick) as f64 / tick_hz;
            WAIT_LIMIT + Duration::from_secs_f64(ahead.min(86_400.0))
        }
    };
    let mut first_snapshot: Option<Instant> = None;
    loop {
        // Takes in what was described (the catalogue) and samples the
        // world, as each frame on screen would; no picture is drawn until
        // the wait is over.
        let frame = view.update();
        if let Some(reason) = view.client().disconnected() {
            return Err(ViewerError::Connect(format!("disconnected: {reason:?}")));
        }
        if !frame.entities.is_empty() && first_snapshot.is_none() {
            first_snapshot = Some(Instant::now());
        }
        let described = frame.entities.iter().all(|e| view.catalogue.knows(e.id));
        let ready = match when {
            When::Settled => {
                described && first_snapshot.is_some_and(|t| t.elapsed() >= Duration::from_secs(1))
            }
            When::AtTick(t) => described && frame.render_tick >= t as f64,
        };
        if ready {
            return Ok(());
        }
        if start.elapsed() > limit {
            return Err(ViewerError::Timeout(format!(
                "{when:?} not reached in {:.0} s (drawing tick {:.0})",
                limit.as_secs_f64(),
                frame.render_tick
            )));
        }
        std::thread::sleep(Duration::from_millis(33));
    }
}

/// Writes frames `frame_00000.png`, … into `dir` at `fps` frames per
/// second for `seconds` of wall time; returns the files written.
pub fn record_frames(
    view: &mut Viewer,
    screen: &mut OffScreen,
    dir: &Path,
    seconds: f64,
    fps: f64,
    hud: bool,
) -> Result<Vec<PathBuf>, ViewerError> {
    let seconds_ok = seconds > 0.0 && seconds <= 3600.0;
    let fps_ok = fps > 0.0 && fps <= 240.0;
    if !seconds_ok || !fps_ok {
        return Err(ViewerError::Usage(format!(
            "--seconds {seconds} at {fps} frames a second: seconds must be in (0, 3600] and fps in (0, 240]"
        )));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| ViewerError::Image(format!("{}: {e}", dir.display())))?;
    let count = (seconds * fps).round().max(1.0) as u64;
    let start = Instant::now();
    let mut written = Vec::with_capacity(count as usize);
    for k in 0..count {
        let due = start + Duration::from_secs_f64(k as f64 / fps);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let image = screen.capture(view, hud)?;
        let path = dir.join(format!("frame_{k:05}.png"));
        image.write_png(&path)?;
        written.push(path);
    }
    Ok(written)
}
