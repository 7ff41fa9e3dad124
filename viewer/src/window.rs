//! The viewer in a window (winit): the world drawn each frame the display
//! asks for, the camera driven by the mouse, the avatar by the keyboard.
//!
//! - Left drag: orbit. Right or middle drag: pan. Wheel: zoom.
//! - W A S D or the arrows: move the avatar (relative to the camera);
//!   Space: jump; E: push. F: follow the avatar.
//! - With the admin credential: P pauses or plays, N steps one tick, and
//!   the bottom panel has the clock's controls and the timeline scrubber.

use std::collections::HashSet;
use std::sync::Arc;

use glam::Vec3;
use inertia_protocol::admin::AdminRequest;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::controls::Wish;
use crate::render::Renderer;
use crate::view::Viewer;
use crate::ViewerError;

/// Opens a window on `view` and runs until it is closed.
pub fn run(view: Viewer) -> Result<(), ViewerError> {
    let event_loop = EventLoop::new()
        .map_err(|e| ViewerError::Window(format!("no display to open a window on: {e}")))?;
    let mut app = App {
        view,
        window: None,
        error: None,
        keys: HashSet::new(),
        drag: None,
        cursor: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewerError::Window(e.to_string()))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct Gpu {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    renderer: Renderer,
    egui: egui_winit::State,
}

struct App {
    view: Viewer,
    window: Option<Gpu>,
    error: Option<ViewerError>,
    keys: HashSet<KeyCode>,
    /// The button held for a drag, if any.
    drag: Option<MouseButton>,
    cursor: Option<(f64, f64)>,
}

impl Gpu {
    fn new(event_loop: &ActiveEventLoop, view: &Viewer) -> Result<Self, ViewerError> {
        let attributes = Window::default_attributes()
            .with_title("Inertia viewer")
            .with_inner_size(winit::dpi::LogicalSize::new(1280.0, 720.0));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| ViewerError::Window(e.to_string()))?,
        );
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        ));
        desc.backends = (wgpu::Backends::VULKAN | wgpu::Backends::GL).with_env();
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(Arc::clone(&window))
            .map_err(|e| ViewerError::Gpu(format!("no surface for the window: {e}")))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            apply_limit_buckets: false,
            compatible_surface: Some(&surface),
        }))
        .map_err(|e| ViewerError::Gpu(format!("no adapter can draw in the window: {e}")))?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("inertia-viewer"),
            required_limits:
                wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| ViewerError::Gpu(e.to_string()))?;
        let caps = surface.get_capabilities(&adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| ViewerError::Gpu("the surface offers no format".into()))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: Default::default(),
        };
        surface.configure(&device, &config);
        let renderer = Renderer::new(&adapter, &device, format);
        let egui = egui_winit::State::new(
            view.egui().clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(device.limits().max_texture_dimension_2d as usize),
        );
        Ok(Self {
            window,
            surface,
            device,
            queue,
            config,
            renderer,
            egui,
        })
    }

    fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&self.device, &self.config);
        }
    }
}

impl App {
    /// The avatar's movement and buttons from the keys held, the movement
    /// turned so that W walks away from the camera.
    fn send_input(&self) {
        let held = |keys: &[KeyCode]| keys.iter().any(|k| self.keys.contains(k));
        let forward = f32::from(u8::from(held(&[KeyCode::KeyW, KeyCode::ArrowUp])))
            - f32::from(u8::from(held(&[KeyCode::KeyS, KeyCode::ArrowDown])));
        let right = f32::from(u8::from(held(&[KeyCode::KeyD, KeyCode::ArrowRight])))
            - f32::from(u8::from(held(&[KeyCode::KeyA, KeyCode::ArrowLeft])));
        let cam = &self.view.camera;
        let ahead = (cam.target - cam.eye()) * Vec3::new(1.0, 0.0, 1.0);
        let ahead = ahead.normalize_or(Vec3::NEG_Z);
        let side = ahead.cross(Vec3::Y);
        let wish = ahead * forward + side * right;
        let wish = if wish.length() > 1.0 {
            wish.normalize()
        } else {
            wish
        };
        let yaw = (-ahead.x).atan2(-ahead.z);
        let wish = Wish {
            movement: [wish.x, wish.z],
            yaw,
            jump: held(&[KeyCode::Space]),
            action: held(&[KeyCode::KeyE]),
            lob: held(&[KeyCode::ShiftLeft, KeyCode::ShiftRight]),
        };
        // The game's own input, by the name in the welcome; a game the
        // viewer has no controls for is watched.
        self.view.controls().send(self.view.client(), wish);
    }

    fn on_key(&mut self, code: KeyCode, state: ElementState) {
        match state {
            ElementState::Pressed => {
                let fresh = self.keys.insert(code);
                if !fresh {
                    return;
                }
                match code {
                    KeyCode::KeyF => self.view.following = !self.view.following,
                    KeyCode::KeyP => {
                        let paused = self.view.admin_status().is_some_and(|s| s.paused);
                        self.view.admin_call(if paused {
                            AdminRequest::Resume
                        } else {
                            AdminRequest::Pause
                        });
                    }
                    KeyCode::KeyN => {
                        self.view.admin_call(AdminRequest::Step { ticks: 1 });
                    }
                    KeyCode::KeyR => self.view.kill_cam(),
                    _ => {}
                }
            }
            ElementState::Released => {
                self.keys.remove(&code);
            }
        }
        self.send_input();
    }

    fn redraw(&mut self) -> Result<(), ViewerError> {
        let Some(gpu) = &mut self.window else {
            return Ok(());
        };
        let input = gpu.egui.take_egui_input(&gpu.window);
        let prepared = self.view.prepare(Some(input));
        gpu.egui
            .handle_platform_output(&gpu.window, prepared.platform);
        let texture = match gpu.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                gpu.surface.configure(&gpu.device, &gpu.config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(())
            }
            other => return Err(ViewerError::Gpu(format!("the window's surface: {other:?}"))),
        };
        let target = texture.texture.create_view(&Default::default());
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        gpu.renderer.draw(
            &gpu.device,
            &gpu.queue,
            &mut encoder,
            &target,
            (gpu.config.width, gpu.config.height),
            &self.view.catalogue,
            &prepared.list,
            &self.view.camera,
            prepared.hud,
        );
        gpu.queue.submit([encoder.finish()]);
        gpu.window.pre_present_notify();
        gpu.queue.present(texture);
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            match Gpu::new(event_loop, &self.view) {
                Ok(gpu) => self.window = Some(gpu),
                Err(e) => {
                    self.error = Some(e);
                    event_loop.exit();
                }
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(gpu) = &mut self.window else {
            return;
        };
        let egui_took = gpu.egui.on_window_event(&gpu.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => gpu.resize(size.width, size.height),
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw() {
                    self.error = Some(e);
                    event_loop.exit();
                }
                if let Some(reason) = self.view.client().disconnected() {
                    self.error = Some(ViewerError::Connect(format!("disconnected: {reason:?}")));
                    event_loop.exit();
                }
            }
            WindowEvent::KeyboardInput { event, .. } if !egui_took => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    self.on_key(code, event.state);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => match state {
                ElementState::Pressed if !egui_took => self.drag = Some(button),
                ElementState::Released => self.drag = None,
                _ => {}
            },
            WindowEvent::CursorMoved { position, .. } => {
                let (x, y) = (position.x, position.y);
                if let (Some(button), Some((px, py))) = (self.drag, self.cursor) {
                    let (dx, dy) = ((x - px) as f32, (y - py) as f32);
                    match button {
                        MouseButton::Left => self.view.camera.orbit(dx, dy),
                        _ => self.view.camera.pan(dx, dy),
                    }
                }
                self.cursor = Some((x, y));
            }
            WindowEvent::MouseWheel { delta, .. } if !egui_took => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.view.camera.zoom(steps);
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(gpu) = &self.window {
            gpu.window.request_redraw();
        }
    }
}
