//! `player view <out>`: an interactive walk through a bake (paper 000 §3.2 run-time
//! phase; §4.1.2 navigation at eye height). WASD walks at the path speed limit
//! (30 units/s), the arrow keys or dragging with the left mouse button turn, Q/E
//! lower/raise the eye within the cell prism's eye heights. The window title shows
//! FPS, triangles, the current cell and the cache state.
//!
//! Frames are rendered with the same offscreen renderer as `render`/`compare` (the
//! hybrid configuration, with streaming and prefetching) and copied into the window's
//! surface, so what the window shows is exactly what the headless tools measure.

use crate::frame::Mode;
use crate::gpu::{open_device_for, Renderer};
use crate::run::{write_png, Player};
use crate::stream::{StreamConfig, Streamer};
use glam::Vec3;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{DeviceEvent, DeviceId, ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// Options of `player view`.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    pub out: PathBuf,
    pub size: (u32, u32),
    pub stream: StreamConfig,
    /// Start position (x, z); default: the ground's centre.
    pub start: Option<(f32, f32)>,
    /// Quit after this many frames (for scripted screenshots).
    pub exit_after: Option<u64>,
    /// Save the last frame here as PNG on exit.
    pub screenshot: Option<PathBuf>,
}

struct State {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    config: wgpu::SurfaceConfiguration,
    bgra: bool,
    player: Player,
    streamer: Streamer,
    eye: Vec3,
    yaw: f32,
    pitch: f32,
    keys: Vec<KeyCode>,
    dragging: bool,
    last: Instant,
    fps_clock: Instant,
    fps_frames: u32,
    frames: u64,
    last_pixels: Vec<u8>,
}

struct App {
    opts: ViewOptions,
    state: Option<State>,
    error: Option<String>,
}

/// Opens the window and runs until it is closed (or `exit_after` frames).
pub fn run_view(opts: ViewOptions) -> Result<(), String> {
    let event_loop = EventLoop::new().map_err(|e| format!("cannot open a window: {e}"))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        opts,
        state: None,
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| format!("event loop: {e}"))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl App {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<State, String> {
        let (w, h) = self.opts.size;
        let window = Arc::new(
            event_loop
                .create_window(
                    Window::default_attributes()
                        .with_title("hexbake player")
                        .with_inner_size(winit::dpi::PhysicalSize::new(w, h))
                        .with_resizable(false),
                )
                .map_err(|e| format!("cannot create the window: {e}"))?,
        );
        let size = window.inner_size();
        let (w, h) = (size.width.max(1), size.height.max(1));
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(window.clone())),
        );
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| format!("cannot create a surface: {e}"))?;
        let (device, queue, summary, adapter) =
            open_device_for(&instance, Some(&surface)).map_err(|e| e.to_string())?;
        eprintln!("player: adapter {summary}");
        let caps = surface.get_capabilities(&adapter);
        if !caps.usages.contains(wgpu::TextureUsages::COPY_DST) {
            return Err("the window surface does not accept copies (COPY_DST)".into());
        }
        use wgpu::TextureFormat as F;
        let format = [
            F::Rgba8UnormSrgb,
            F::Rgba8Unorm,
            F::Bgra8UnormSrgb,
            F::Bgra8Unorm,
        ]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .ok_or_else(|| format!("no 8-bit RGBA/BGRA surface format in {:?}", caps.formats))?;
        let mut config = surface
            .get_default_config(&adapter, w, h)
            .ok_or("the surface is not supported by the adapter")?;
        config.format = format;
        config.usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_DST;
        surface.configure(&device, &config);
        let bake = crate::bake::Bake::open(&self.opts.out).map_err(|e| e.to_string())?;
        let renderer = Renderer::with_device(device.clone(), queue, summary, w, h)
            .map_err(|e| e.to_string())?;
        let models = renderer.upload_models(&bake.base);
        let streamer = Streamer::new(&bake, self.opts.stream.clone());
        let g = *bake.grid.params();
        let (x, z) = self.opts.start.unwrap_or((
            0.5 * (g.ground_min[0] + g.ground_max[0]),
            0.5 * (g.ground_min[1] + g.ground_max[1]),
        ));
        Ok(State {
            window,
            surface,
            device,
            config,
            bgra: matches!(format, F::Bgra8UnormSrgb | F::Bgra8Unorm),
            player: Player::from_parts(bake, renderer, models),
            streamer,
            eye: Vec3::new(x, g.min_eye_height, z),
            yaw: 0.0,
            pitch: 0.0,
            keys: Vec::new(),
            dragging: false,
            last: Instant::now(),
            fps_clock: Instant::now(),
            fps_frames: 0,
            frames: 0,
            last_pixels: Vec::new(),
        })
    }
}

impl State {
    fn dir(&self) -> Vec3 {
        Vec3::new(
            self.yaw.cos() * self.pitch.cos(),
            self.pitch.sin(),
            self.yaw.sin() * self.pitch.cos(),
        )
    }

    fn step(&mut self, dt: f32) {
        let g = *self.player.bake.grid.params();
        let speed = 30.0;
        let turn = 45f32.to_radians();
        let fwd = Vec3::new(self.yaw.cos(), 0.0, self.yaw.sin());
        let right = Vec3::new(-fwd.z, 0.0, fwd.x);
        let held = |k| self.keys.contains(&k);
        let mut mv = Vec3::ZERO;
        if held(KeyCode::KeyW) {
            mv += fwd;
        }
        if held(KeyCode::KeyS) {
            mv -= fwd;
        }
        if held(KeyCode::KeyD) {
            mv += right;
        }
        if held(KeyCode::KeyA) {
            mv -= right;
        }
        let mut dyaw = 0.0;
        if held(KeyCode::ArrowLeft) {
            dyaw -= turn * dt;
        }
        if held(KeyCode::ArrowRight) {
            dyaw += turn * dt;
        }
        let mut dy = 0.0;
        if held(KeyCode::KeyQ) {
            dy -= 5.0 * dt;
        }
        if held(KeyCode::KeyE) {
            dy += 5.0 * dt;
        }
        self.yaw += dyaw;
        self.eye += mv.normalize_or_zero() * speed * dt;
        self.eye.y =
            (self.eye.y + dy).clamp(g.min_eye_height, g.max_eye_height.max(g.min_eye_height));
    }

    fn frame(&mut self) {
        let now = Instant::now();
        let dt = (now - self.last).as_secs_f32().min(0.25);
        self.last = now;
        self.step(dt);
        let (w, h) = self.player.renderer.size();
        let cam = crate::camera::Camera {
            eye: self.eye,
            dir: self.dir(),
            fov_y_deg: 60.0,
            width: w,
            height: h,
            near: 0.25,
            far: self.player.bake.extent,
        };
        let (_, tris, _, stats) = self
            .player
            .draw(&cam, Mode::Hybrid, Some(&mut self.streamer));
        let Ok(mut px) = self.player.renderer.read_pixels() else {
            return;
        };
        if self.bgra {
            for p in px.chunks_exact_mut(4) {
                p.swap(0, 2);
            }
        }
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
                self.player.renderer.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &t.texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    &px,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(w * 4),
                        rows_per_image: Some(h),
                    },
                    wgpu::Extent3d {
                        width: w.min(self.config.width),
                        height: h.min(self.config.height),
                        depth_or_array_layers: 1,
                    },
                );
                self.player.renderer.queue.submit(std::iter::empty());
                self.player.renderer.queue.present(t);
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.device, &self.config);
            }
            _ => {}
        }
        if self.bgra {
            for p in px.chunks_exact_mut(4) {
                p.swap(0, 2);
            }
        }
        self.last_pixels = px;
        self.frames += 1;
        self.fps_frames += 1;
        let el = self.fps_clock.elapsed().as_secs_f64();
        if el >= 0.5 || self.frames == 1 {
            let fps = self.fps_frames as f64 / el.max(1e-6);
            self.window.set_title(&format!(
                "hexbake player — {fps:.1} FPS, {tris} triangles, cell {}, cache {} cells {:.1} MiB, hits {} misses {}, {} uploads queued",
                stats.cell.map_or("-".to_string(), |c| c.to_string()),
                self.streamer.resident_cells().len(),
                self.streamer.resident_bytes() as f64 / (1 << 20) as f64,
                stats.hits,
                stats.misses,
                self.streamer.queued_uploads()
            ));
            self.fps_clock = Instant::now();
            self.fps_frames = 0;
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.state.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(s) => {
                s.window.request_redraw();
                self.state = Some(s);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(s) = self.state.as_mut() else {
            return;
        };
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    if code == KeyCode::Escape {
                        event_loop.exit();
                    }
                    match event.state {
                        ElementState::Pressed if !s.keys.contains(&code) => s.keys.push(code),
                        ElementState::Released => s.keys.retain(|&k| k != code),
                        _ => {}
                    }
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => s.dragging = state == ElementState::Pressed,
            WindowEvent::RedrawRequested => {
                s.frame();
                if self.opts.exit_after.is_some_and(|n| s.frames >= n) {
                    event_loop.exit();
                } else {
                    s.window.request_redraw();
                }
            }
            _ => {}
        }
    }

    fn device_event(&mut self, _: &ActiveEventLoop, _: DeviceId, event: DeviceEvent) {
        if let (Some(s), DeviceEvent::MouseMotion { delta }) = (self.state.as_mut(), event) {
            if s.dragging {
                s.yaw += delta.0 as f32 * 0.004;
                s.pitch = (s.pitch - delta.1 as f32 * 0.004).clamp(-1.4, 1.4);
            }
        }
    }

    fn exiting(&mut self, _: &ActiveEventLoop) {
        if let (Some(s), Some(path)) = (self.state.as_ref(), self.opts.screenshot.as_ref()) {
            let (w, h) = s.player.renderer.size();
            if !s.last_pixels.is_empty() {
                if let Err(e) = write_png(path, w, h, &s.last_pixels) {
                    self.error = Some(e.to_string());
                }
            }
        }
    }
}
