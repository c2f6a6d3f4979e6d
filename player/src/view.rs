//! `player view <out>`: an interactive walk through a bake (paper 000 §3.2 run-time
//! phase; §4.1.2 navigation at eye height). WASD walks at the path speed limit
//! (30 units/s), the arrow keys or dragging with the left mouse button turn, Q/E
//! lower/raise the eye within the cell prism's eye heights. M flips hybrid → full →
//! LOD baseline → hybrid at the same pose, C colours every triangle by its
//! representation (original, SV, MV, cluster, LOD level; [`crate::overlay`]), H hides
//! the overlay (FPS, frame ms, triangles, draw calls, cell, resident packs and queued
//! uploads).
//!
//! Frames are rendered with the same offscreen renderer as `render`/`compare` (the
//! hybrid configuration, with streaming and prefetching) and copied into the window's
//! surface, so what the window shows is exactly what the headless tools measure; the
//! overlay is drawn into that copy. [`ViewSession`] is the walk without a window:
//! `player view --headless --screenshot F` and the tests draw through it.

use crate::frame::Mode;
use crate::gpu::{open_device_for, Renderer};
use crate::overlay::{draw_overlay, OverlayInfo};
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
    /// Start heading in degrees (0 = +x, 90 = +z).
    pub yaw_deg: f32,
    /// Start pitch in degrees (positive = up).
    pub pitch_deg: f32,
    /// Start mode: hybrid, full or lod.
    pub mode: Mode,
    /// The pixel error of `lod` mode (`--lod-pixel-error`).
    pub lod_pixel_error: f32,
    /// τ of `cluster-lod` mode (`--cluster-tau`).
    pub cluster_tau: f32,
    /// Start with the representation colouring on.
    pub colours: bool,
    /// Start with the overlay shown.
    pub overlay: bool,
    /// Quit after this many frames (for scripted screenshots).
    pub exit_after: Option<u64>,
    /// Save the last frame here as PNG on exit.
    pub screenshot: Option<PathBuf>,
    /// The frame model's switches (`--no-backface`, `--tile-triangles`, ...).
    pub draw: crate::DrawOptions,
}

impl ViewOptions {
    /// Defaults for `out`: 1024 × 768, hybrid, overlay on, colouring off.
    pub fn new(out: PathBuf) -> ViewOptions {
        ViewOptions {
            out,
            size: (1024, 768),
            stream: StreamConfig::default(),
            start: None,
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            mode: Mode::Hybrid,
            lod_pixel_error: crate::lod::DEFAULT_PIXEL_ERROR,
            cluster_tau: crate::clusterlod::DEFAULT_TAU_PX,
            colours: false,
            overlay: true,
            exit_after: None,
            screenshot: None,
            draw: crate::DrawOptions::default(),
        }
    }
}

/// The walk without a window: pose, mode, colouring, overlay and the frame clock.
pub struct ViewSession {
    pub player: Player,
    pub streamer: Streamer,
    pub eye: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub mode: Mode,
    pub overlay: bool,
    /// When the previous frame was drawn, and the mean frame interval (exponential,
    /// 1/10 per frame): FPS = 1 / interval, what the window delivers.
    previous: Option<Instant>,
    interval_s: f64,
    pub frames: u64,
}

impl ViewSession {
    /// A session over an opened player, at the options' start pose.
    pub fn new(mut player: Player, opts: &ViewOptions) -> ViewSession {
        let streamer = Streamer::new(&player.bake, opts.stream.clone());
        let g = *player.bake.grid.params();
        let (x, z) = opts.start.unwrap_or((
            0.5 * (g.ground_min[0] + g.ground_max[0]),
            0.5 * (g.ground_min[1] + g.ground_max[1]),
        ));
        player.renderer.set_representation_colours(opts.colours);
        player.lod_pixel_error = opts.lod_pixel_error;
        player.cluster_tau = opts.cluster_tau;
        let mut session = ViewSession {
            player,
            streamer,
            eye: Vec3::new(x, g.min_eye_height, z),
            yaw: opts.yaw_deg.to_radians(),
            pitch: opts.pitch_deg.to_radians().clamp(-1.4, 1.4),
            mode: match opts.mode {
                Mode::Frustum => Mode::Full,
                m => m,
            },
            overlay: opts.overlay,
            previous: None,
            interval_s: 0.0,
            frames: 0,
        };
        let camera = session.camera();
        session.player.prime(&mut session.streamer, &camera);
        session
    }

    /// A session on an offscreen renderer (no window).
    pub fn open_headless(opts: &ViewOptions) -> Result<ViewSession, crate::run::RunError> {
        let player = Player::open(&opts.out, opts.size, &opts.draw)?;
        eprintln!("player: adapter {}", player.renderer.adapter());
        Ok(ViewSession::new(player, opts))
    }

    pub fn dir(&self) -> Vec3 {
        Vec3::new(
            self.yaw.cos() * self.pitch.cos(),
            self.pitch.sin(),
            self.yaw.sin() * self.pitch.cos(),
        )
    }

    pub fn camera(&self) -> crate::camera::Camera {
        let (w, h) = self.player.renderer.size();
        crate::camera::Camera {
            eye: self.eye,
            dir: self.dir(),
            fov_y_deg: 60.0,
            width: w,
            height: h,
            near: 0.25,
            far: self.player.bake.extent,
        }
    }

    /// The M key: hybrid → full → LOD baseline → cluster LOD → hybrid, same pose.
    pub fn cycle_mode(&mut self) {
        self.mode = match self.mode {
            Mode::Hybrid => Mode::Full,
            Mode::Full | Mode::Frustum => Mode::Lod,
            Mode::Lod => Mode::ClusterLod,
            Mode::ClusterLod => Mode::Hybrid,
        };
    }

    /// The C key: representation colouring on / off.
    pub fn toggle_colours(&mut self) {
        let on = !self.player.renderer.representation_colours();
        self.player.renderer.set_representation_colours(on);
    }

    /// Draws one frame at the current pose and mode, reads it back and draws the
    /// overlay into it. Returns the RGBA8 frame (row 0 at the top) and what the
    /// overlay showed.
    pub fn frame(&mut self) -> Result<(Vec<u8>, OverlayInfo), String> {
        let cam = self.camera();
        let (ms, list, stats) = self
            .player
            .draw_listed(&cam, self.mode, Some(&mut self.streamer));
        let mut px = self
            .player
            .renderer
            .read_pixels()
            .map_err(|e| e.to_string())?;
        self.frames += 1;
        let now = Instant::now();
        if let Some(prev) = self.previous {
            let dt = (now - prev).as_secs_f64();
            self.interval_s = if self.frames == 2 {
                dt
            } else {
                0.9 * self.interval_s + 0.1 * dt
            };
        }
        self.previous = Some(now);
        let fps = if self.interval_s > 0.0 {
            1.0 / self.interval_s
        } else {
            0.0
        };
        let info = OverlayInfo {
            mode: self.mode,
            fps,
            frame_ms: ms,
            triangles: list.triangles,
            draw_calls: list.draw_calls,
            clusters: list.clusters,
            cell: stats.cell,
            resident_packs: self.streamer.resident_cells().len(),
            resident_mib: self.streamer.resident_bytes() as f64 / (1 << 20) as f64,
            queued_uploads: self.streamer.queued_uploads(),
            pending_proxies: stats.pending_proxies,
            eye: self.eye.to_array(),
            colouring: self.player.renderer.representation_colours(),
        };
        if self.overlay {
            let (w, h) = self.player.renderer.size();
            draw_overlay(&mut px, w, h, &info);
        }
        Ok((px, info))
    }
}

/// `player view --headless`: draws `exit_after` frames (default 30: enough for the
/// streamer to load and upload the start cell) at the start pose without a window
/// and writes the last one, overlay included, to `screenshot`.
pub fn run_view_headless(opts: &ViewOptions) -> Result<(), crate::run::RunError> {
    let path = opts
        .screenshot
        .as_ref()
        .ok_or_else(|| crate::run::RunError::Write {
            path: opts.out.clone(),
            what: "--headless needs --screenshot FILE.png".into(),
        })?;
    let mut session = ViewSession::open_headless(opts)?;
    let frames = opts.exit_after.unwrap_or(30).max(1);
    let mut last = Vec::new();
    let mut info = OverlayInfo::default();
    for _ in 0..frames {
        (last, info) = session
            .frame()
            .map_err(|what| crate::run::RunError::Write {
                path: path.clone(),
                what,
            })?;
    }
    let (w, h) = session.player.renderer.size();
    write_png(path, w, h, &last)?;
    eprintln!(
        "player: {}: {} frames, {} mode, {} triangles, cell {}",
        path.display(),
        frames,
        info.mode.name(),
        info.triangles,
        info.cell.map_or("-".to_string(), |c| c.to_string())
    );
    Ok(())
}

struct State {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    config: wgpu::SurfaceConfiguration,
    bgra: bool,
    session: ViewSession,
    keys: Vec<KeyCode>,
    dragging: bool,
    last: Instant,
    title_clock: Instant,
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
        let draw = &self.opts.draw;
        let bake = crate::bake::Bake::open(&self.opts.out, draw).map_err(|e| e.to_string())?;
        let renderer = Renderer::with_device(device.clone(), queue, summary, (w, h), draw)
            .map_err(|e| e.to_string())?;
        let models = renderer.upload_models(&bake.base, bake.draw_order.as_deref());
        let session = ViewSession::new(Player::from_parts(bake, renderer, models), &self.opts);
        Ok(State {
            window,
            surface,
            device,
            config,
            bgra: matches!(format, F::Bgra8UnormSrgb | F::Bgra8Unorm),
            session,
            keys: Vec::new(),
            dragging: false,
            last: Instant::now(),
            title_clock: Instant::now(),
            last_pixels: Vec::new(),
        })
    }
}

impl State {
    fn step(&mut self, dt: f32) {
        let s = &mut self.session;
        let g = *s.player.bake.grid.params();
        let speed = 30.0;
        let turn = 45f32.to_radians();
        let fwd = Vec3::new(s.yaw.cos(), 0.0, s.yaw.sin());
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
        s.yaw += dyaw;
        s.eye += mv.normalize_or_zero() * speed * dt;
        s.eye.y = (s.eye.y + dy).clamp(g.min_eye_height, g.max_eye_height.max(g.min_eye_height));
    }

    fn frame(&mut self) -> Result<(), String> {
        let now = Instant::now();
        let dt = (now - self.last).as_secs_f32().min(0.25);
        self.last = now;
        self.step(dt);
        let (mut px, info) = self.session.frame()?;
        let (w, h) = self.session.player.renderer.size();
        if self.bgra {
            for p in px.chunks_exact_mut(4) {
                p.swap(0, 2);
            }
        }
        let renderer = &self.session.player.renderer;
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
                renderer.queue.write_texture(
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
                renderer.queue.submit(std::iter::empty());
                renderer.queue.present(t);
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
        if self.title_clock.elapsed().as_secs_f64() >= 0.5 || self.session.frames == 1 {
            self.window.set_title(&format!(
                "hexbake player — {} — {:.1} FPS, {} triangles, cell {}",
                info.mode.name(),
                info.fps,
                info.triangles,
                info.cell.map_or("-".to_string(), |c| c.to_string()),
            ));
            self.title_clock = Instant::now();
        }
        Ok(())
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
                    if event.state == ElementState::Pressed && !event.repeat {
                        match code {
                            KeyCode::KeyM => s.session.cycle_mode(),
                            KeyCode::KeyC => s.session.toggle_colours(),
                            KeyCode::KeyH => s.session.overlay = !s.session.overlay,
                            _ => {}
                        }
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
                if let Err(e) = s.frame() {
                    self.error = Some(e);
                    event_loop.exit();
                    return;
                }
                if self.opts.exit_after.is_some_and(|n| s.session.frames >= n) {
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
                s.session.yaw += delta.0 as f32 * 0.004;
                s.session.pitch = (s.session.pitch - delta.1 as f32 * 0.004).clamp(-1.4, 1.4);
            }
        }
    }

    fn exiting(&mut self, _: &ActiveEventLoop) {
        if let (Some(s), Some(path)) = (self.state.as_ref(), self.opts.screenshot.as_ref()) {
            let (w, h) = s.session.player.renderer.size();
            if !s.last_pixels.is_empty() {
                if let Err(e) = write_png(path, w, h, &s.last_pixels) {
                    self.error = Some(e.to_string());
                }
            }
        }
    }
}
