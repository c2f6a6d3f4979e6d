//! The wgpu renderer (paper 000 §3.2 run-time rendering: inside objects "rendered as
//! normal", SVMeshes by projective texture mapping, MVMeshes by view-dependent
//! projective texturing with blending of two views; DESIGN.md "Shading").
//!
//! Headless: an offscreen `Rgba8UnormSrgb` colour target and a `Depth32Float` depth
//! target; [`Renderer::read_pixels`] copies the colour back with rows padded to
//! `COPY_BYTES_PER_ROW_ALIGNMENT` and strips the padding. Back-face culling is on
//! (counter-clockwise front faces, as the worker's rasterizer). Each model is uploaded
//! once ([`GpuModels`]); originals are drawn as instanced draws, one per model, with
//! per-instance transforms. Proxies are de-indexed world-space triangle lists carrying
//! each triangle's view mask and centroid (flat attributes), one draw per proxy;
//! a pack's layered impostors, and its single-view mesh proxies, are uploaded in
//! batches of up to [`MAX_VIEWS`], each batch one proxy (one draw) with its
//! members' textures in one atlas.
//! This file owns the GPU resources and the submission of a frame; what a frame
//! draws — the draw list, its counts and the plan the renderer uploads and encodes —
//! is decided in `gpu/frame_model.rs` (re-exported here: [`DrawList`]), the fixed GPU
//! objects are built in `gpu/setup.rs`, and models, proxies and their textures are
//! uploaded in `gpu/upload.rs`.

mod frame_model;
mod setup;
mod upload;

pub use frame_model::DrawList;
use frame_model::{FramePlan, Span};
pub use upload::{ProxySource, ViewInfo};

use crate::camera::Camera;
use crate::metrics::srgb_to_linear;
use crate::vertex::Globals;
use std::time::Instant;

/// Most views a proxy may have: the pack's limit ([`crate::vertex::MAX_VIEWS`]).
pub use crate::vertex::MAX_VIEWS;
/// Background colour (sRGB8): the CPU rasterizer's, [`format::shading::SKY`].
pub use format::shading::SKY;

/// The WGSL source: `shader.wgsl` after [`format::shading::wgsl_constants`] (the
/// shading, sRGB and view-limit constants, from their Rust home).
pub fn shader_source() -> String {
    format!(
        "{}{}",
        format::shading::wgsl_constants(),
        include_str!("shader.wgsl")
    )
}

/// [`shader_source`] for the pipelines of blended frames
/// ([`Renderer::render_blend`]): each fragment stage first discards fragments
/// outside the draw's dither range (shader.wgsl `dithered_out`). A separate module,
/// not a branch on a uniform, because llvmpipe turns early depth testing off for
/// any shader that can discard.
pub fn dithered_shader_source() -> String {
    shader_source().replace("/*DITHER*/", "if dithered_out(i.clip) { discard; }")
}

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Why the renderer could not start.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no graphics adapter found: {0}")]
    NoAdapter(String),
    #[error("cannot open the graphics device: {0}")]
    Device(String),
    #[error("reading the frame back failed: {0}")]
    Readback(String),
    #[error("frame size {width}x{height} outside 1..={max}")]
    BadSize { width: u32, height: u32, max: u32 },
}

/// What the renderer runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} (backend {}, device type {}, driver {})",
            self.name, self.backend, self.device_type, self.driver
        )
    }
}

/// The models of a bake on the GPU (uploaded once).
pub struct GpuModels {
    pub models: Vec<GpuModel>,
    /// The ground rectangle of the base pack's grid (world space, 6 vertices), drawn
    /// with every frame (issue 18; `format::scene::Ground::mesh`).
    ground: wgpu::Buffer,
}

pub struct GpuModel {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    pub index_count: u32,
    pub triangle_count: u64,
    /// Simplified levels 1.. of the LOD baseline ([`Renderer::upload_lods`]); they
    /// index `vertices`.
    pub lods: Vec<GpuLod>,
    /// The cluster DAG's index buffer of `cluster-lod` mode
    /// ([`Renderer::upload_clusters`]); it indexes `vertices`.
    pub clusters: Option<GpuClusters>,
    /// Bind group 2 of the lit pipeline: the model's albedo texture and sampler (its
    /// glTF wrap modes), or a white texel for an untextured model (issue 18).
    albedo: wgpu::BindGroup,
    /// `indices` holds the triangles grouped by patch (issue 17, `base.pack`'s
    /// patch sections), as [`DrawList::patched`] needs.
    pub patch_ordered: bool,
    /// A CPU copy of `indices` when patch-ordered: the visible tiles' indices of an
    /// instance are gathered from it into the frame's index buffer (one draw call
    /// per instance, [`FrameIndices`]).
    cpu_indices: Vec<u32>,
}

impl GpuModel {
    /// Level `l` of the model (0 = the original): its index buffer, index count and
    /// triangle count. A level that is not uploaded is drawn as the original.
    fn level(&self, l: u32) -> (&wgpu::Buffer, u32, u64) {
        match l.checked_sub(1).and_then(|k| self.lods.get(k as usize)) {
            Some(g) => (&g.indices, g.index_count, g.triangle_count),
            None => (&self.indices, self.index_count, self.triangle_count),
        }
    }
}

/// A model's cluster DAG on the GPU: every cluster's triangles in one index buffer,
/// and its CPU copy, from which an instance's selected clusters are gathered into
/// the frame's index buffer ([`crate::clusterlod`]).
pub struct GpuClusters {
    indices: wgpu::Buffer,
    cpu_indices: Vec<u32>,
    /// Bytes of the index buffer.
    pub bytes: u64,
}

/// One simplified level of a model on the GPU (an index buffer only).
pub struct GpuLod {
    indices: wgpu::Buffer,
    pub index_count: u32,
    pub triangle_count: u64,
}

/// A proxy on the GPU. Textures arrive one by one (the per-frame upload budget);
/// the proxy is drawable once every view's texture is there.
pub struct GpuProxy {
    vertices: wgpu::Buffer,
    pub vertex_count: u32,
    /// Per pack proxy it draws (a batch's members in order; one for a lone proxy):
    /// that member's vertex range [start, end) in `vertices` (members' triangles
    /// are contiguous, their tiles too), so a stand-in may draw some members only.
    pub member_spans: Vec<(u32, u32)>,
    uniform: wgpu::Buffer,
    textures: Vec<Option<wgpu::TextureView>>,
    bind_group: Option<wgpu::BindGroup>,
    /// Every view bound to the "nothing captured" texture: the proxy drawn with lit
    /// vertex colours while its textures wait in the upload queue.
    lit_bind_group: wgpu::BindGroup,
    pub texture_bytes: u64,
    pub vertex_bytes: u64,
    /// Its triangles' normal clusters (issue 17, [`crate::patches::ProxyCluster`]).
    pub clusters: Vec<crate::patches::ProxyCluster>,
    /// It has layered-impostor triangles (kind 4), drawn with the pipeline whose
    /// fragment shader may discard; every other proxy is drawn with the
    /// discard-free one (issue 17: early depth testing on llvmpipe).
    pub layered: bool,
    /// The entry of `setup::MESH_VIEW_SLOTS` it is drawn with: the fewest texture
    /// slots holding its views (issue 17: llvmpipe samples every slot the fragment
    /// shader may read).
    pub view_slots: usize,
    /// World bounds of its vertices (the draw order: nearest first).
    pub bounds: crate::camera::Aabb,
    /// Its vertex positions on the CPU (world; three per triangle) for occlusion
    /// culling when it may hide others ([`crate::occlusion`]): empty for a proxy
    /// with layered impostors, whose fragment stage discards.
    pub positions: Vec<[f32; 3]>,
    /// Its views in one texture (issue 30 item 7): a mesh proxy's, or a batch of
    /// single-view mesh proxies' (slot k = member k's one view), drawn with
    /// `fs_proxy_atlas`, or a batch of layered impostors' (slot k likewise), drawn
    /// with `fs_proxy`; `None`: one texture per view.
    atlas: Option<Atlas>,
}

/// A mesh proxy's views packed into one texture (issue 30 item 7): a fragment then
/// samples only the two views it blends (shader.wgsl `fs_proxy_atlas`), where with a
/// texture per view a CPU rasterizer samples every slot the shader may read. Made
/// for a mesh proxy of two or more views that share one encoding and fit the
/// device's largest texture side, and for a batch of layered impostors or of
/// single-view mesh proxies of one encoding (each member's one view;
/// `Renderer::create_pack_proxies`); the other proxies keep a texture per view.
struct Atlas {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    format: wgpu::TextureFormat,
    /// Per view: its rectangle (x, y, width, height) in texels; x and y are
    /// multiples of 4 (BC blocks).
    rects: Vec<[u32; 4]>,
}

impl GpuProxy {
    pub fn is_ready(&self) -> bool {
        self.bind_group.is_some()
    }

    pub fn triangle_count(&self) -> u64 {
        self.vertex_count as u64 / 3
    }

    /// The vertex ranges to draw from `view`: clusters wholly back-facing to its eye
    /// or outside its frustum are left out (issue 17); everything when `view` is
    /// `None`.
    pub fn ranges(&self, view: Option<&crate::patches::CullView>) -> Vec<(u32, u32)> {
        crate::patches::proxy_ranges(&self.clusters, self.vertex_count, view)
    }

    pub fn missing_textures(&self) -> usize {
        self.textures.iter().filter(|t| t.is_none()).count()
    }
}

/// The headless renderer.
pub struct Renderer {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Draw calls the last [`Renderer::render`] issued (what
    /// [`DrawList::draw_calls`] predicts).
    pub last_draw_calls: u64,
    adapter: AdapterSummary,
    width: u32,
    height: u32,
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
    /// The pipelines of ordinary draws: originals (`fs_lit`), the ground (alpha 0
    /// under [`Renderer::set_coverage_alpha`]: ground pixels are background to the
    /// metrics), proxies with impostor layers (`fs_proxy`, which may discard), mesh
    /// proxies (`fs_proxy_mesh`, never discards: early depth test possible; one per
    /// `setup::MESH_VIEW_SLOTS` entry, `GpuProxy::view_slots`) and mesh proxies with
    /// an atlas (`fs_proxy_atlas`, [`Atlas`]).
    plain: setup::Pipelines,
    /// The same built from [`dithered_shader_source`]: each fragment outside its
    /// draw's dither range is discarded ([`Renderer::render_blend`]).
    dithered: setup::Pipelines,
    /// Layout of the lit pipeline's group 2 (albedo texture + sampler).
    albedo_bgl: wgpu::BindGroupLayout,
    /// Group 2 of untextured models and the ground: a white texel.
    white_albedo: wgpu::BindGroup,
    /// The [`setup::GLOBAL_SLOTS`] globals buffers: slot 0 for plain draws, slot
    /// k + 1 for the k-th list of a blended frame (its dither range).
    globals: Vec<wgpu::Buffer>,
    /// Group 0 of each.
    globals_bgs: Vec<wgpu::BindGroup>,
    proxy_bgl: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    dummy_view: wgpu::TextureView,
    instances: wgpu::Buffer,
    /// The frame's gathered index buffer ([`FrameIndices`]), grown as needed.
    frame_indices: Option<wgpu::Buffer>,
    /// Clear the sky with alpha 0 instead of 1 ([`Renderer::set_coverage_alpha`]).
    coverage_alpha: bool,
    /// Colour by representation ([`Renderer::set_representation_colours`]).
    representation_colours: bool,
    /// Layered impostors of one pack drawn in batches ([`Renderer::set_impostor_batches`]).
    impostor_batches: bool,
    /// Single-view mesh proxies of one pack drawn in batches
    /// ([`Renderer::set_mesh_batches`]).
    mesh_batches: bool,
    /// What it draws with ([`Renderer::options`]): the tile size of proxies'
    /// clusters, and `bc_textures`: upload BC1/BC3 capture textures as they are (the
    /// device has `TEXTURE_COMPRESSION_BC` and the options did not turn it off);
    /// otherwise they are decoded to RGBA8 on the CPU first.
    options: crate::DrawOptions,
}

/// What creating a pack's GPU proxies needs of a [`Renderer`] (its device, queue,
/// proxy bind group layout, capture sampler, "nothing captured" texture and
/// options), cloned so that the prefetch thread can create them
/// ([`crate::stream`]): wgpu's device and queue may be used from any thread. A
/// snapshot: [`Renderer::set_impostor_batches`] and the like after it do not reach it.
#[derive(Clone, Debug)]
pub struct ProxyMaker {
    device: wgpu::Device,
    queue: wgpu::Queue,
    proxy_bgl: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    dummy_view: wgpu::TextureView,
    impostor_batches: bool,
    mesh_batches: bool,
    options: crate::DrawOptions,
}

impl ProxyMaker {
    /// Hands what was written since the last submit (atlases' clear texels) to the
    /// GPU without waiting, so that a frame's submit does not carry it.
    pub fn submit_writes(&self) {
        self.queue.submit([]);
    }

    /// The tile size of proxies' normal clusters (`DrawOptions::tile_size`).
    pub fn tile_size(&self) -> usize {
        self.options.tile_size()
    }
}

/// Opens an adapter: `WGPU_BACKEND` and the like from the environment,
/// high-performance preference (a real GPU where there is one).
pub fn open_device() -> Result<(wgpu::Device, wgpu::Queue, AdapterSummary), GpuError> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    open_device_for(&instance, None).map(|(d, q, s, _)| (d, q, s))
}

/// Opens an adapter of `instance` (compatible with `surface` if given) and its device.
pub fn open_device_for(
    instance: &wgpu::Instance,
    surface: Option<&wgpu::Surface<'_>>,
) -> Result<(wgpu::Device, wgpu::Queue, AdapterSummary, wgpu::Adapter), GpuError> {
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: surface,
        ..Default::default()
    }))
    .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
    let info = adapter.get_info();
    let summary = AdapterSummary {
        name: info.name.clone(),
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_string(),
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("hexbake player"),
        // BC sampling where the adapter has it (capture textures, issue 15).
        required_features: adapter.features() & wgpu::Features::TEXTURE_COMPRESSION_BC,
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| GpuError::Device(e.to_string()))?;
    Ok((device, queue, summary, adapter))
}

impl Renderer {
    /// A renderer with a `width × height` offscreen target drawing with `options`.
    pub fn new(
        width: u32,
        height: u32,
        options: &crate::DrawOptions,
    ) -> Result<Renderer, GpuError> {
        let (device, queue, adapter) = open_device()?;
        Renderer::with_device(device, queue, adapter, (width, height), options)
    }

    /// A renderer on an already opened device (e.g. one that presents to a window).
    pub fn with_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        adapter: AdapterSummary,
        (width, height): (u32, u32),
        options: &crate::DrawOptions,
    ) -> Result<Renderer, GpuError> {
        // Step 0: the frame size must fit the device's textures.
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::BadSize { width, height, max });
        }
        // Step 1: the offscreen colour and depth targets and the readback buffer.
        let targets = setup::targets(&device, width, height);
        // Step 2: bind group layouts: 0 the frame's globals (every pipeline), 1 a
        // proxy's views (proxy pipeline), 2 a model's albedo (lit pipelines).
        let globals_bgl = setup::globals_layout(&device);
        let proxy_bgl = setup::proxy_layout(&device);
        let albedo_bgl = setup::albedo_layout(&device);
        // Step 3: the shader and the lit, ground and proxy pipelines.
        let pipelines = |source: String| {
            setup::pipelines(&device, source, &globals_bgl, &proxy_bgl, &albedo_bgl)
        };
        let (plain, dithered) = (
            pipelines(shader_source()),
            pipelines(dithered_shader_source()),
        );
        // Step 4: globals buffer and group, capture sampler, placeholder textures,
        // instance buffer.
        let shared = setup::shared(&device, &queue, &globals_bgl, &albedo_bgl);
        // Step 5: BC capture textures natively where the device samples them and
        // the options do not turn it off.
        let options = crate::DrawOptions {
            bc_textures: options.bc_textures
                && device
                    .features()
                    .contains(wgpu::Features::TEXTURE_COMPRESSION_BC),
            ..*options
        };
        Ok(Renderer {
            device,
            queue,
            last_draw_calls: 0,
            adapter,
            width,
            height,
            color: targets.color,
            color_view: targets.color_view,
            depth_view: targets.depth_view,
            readback: targets.readback,
            padded_row: targets.padded_row,
            plain,
            dithered,
            albedo_bgl,
            white_albedo: shared.white_albedo,
            globals: shared.globals,
            globals_bgs: shared.globals_bgs,
            proxy_bgl,
            sampler: shared.sampler,
            dummy_view: shared.dummy_view,
            instances: shared.instances,
            frame_indices: None,
            coverage_alpha: false,
            representation_colours: false,
            impostor_batches: true,
            mesh_batches: true,
            options,
        })
    }

    /// With `on`, the sky is cleared with alpha 0 instead of 1; every pipeline writes
    /// alpha 1 without blending, so the alpha of [`Renderer::read_pixels`] is then a
    /// coverage mask (255 where a triangle was drawn, 0 on the sky) — what
    /// `player compare` tells object pixels by. Off by default: frames for PNGs and
    /// the window stay opaque.
    /// What it draws with, as in effect: `bc_textures` is false where the device
    /// cannot sample BC textures.
    pub fn options(&self) -> &crate::DrawOptions {
        &self.options
    }

    /// Whether BC capture textures are sampled natively (else decoded on the CPU).
    pub fn native_bc(&self) -> bool {
        self.options.bc_textures
    }

    pub fn set_coverage_alpha(&mut self, on: bool) {
        self.coverage_alpha = on;
    }

    /// With `on`, every triangle is drawn in its representation's debug colour
    /// ([`crate::representation::Representation`]), lit by DESIGN.md's Lambert term:
    /// originals, SV / MV / cluster proxies (textured or waiting), LOD levels ≥ 1.
    pub fn set_representation_colours(&mut self, on: bool) {
        self.representation_colours = on;
    }

    pub fn representation_colours(&self) -> bool {
        self.representation_colours
    }

    /// With `on` (the default), the layered impostors of a pack uploaded from now on
    /// are drawn in batches of up to [`MAX_VIEWS`], one draw call each
    /// ([`Renderer::create_pack_proxies`]); off, one draw call per impostor, as
    /// before (for comparisons: the frames are the same).
    pub fn set_impostor_batches(&mut self, on: bool) {
        self.impostor_batches = on;
    }

    /// With `on` (the default), the mesh proxies of a pack with exactly one view
    /// (SV meshes, and clusters or MV meshes of one view) uploaded from now on are
    /// drawn in batches of up to [`MAX_VIEWS`], one draw call each, with
    /// `fs_proxy_atlas` ([`Renderer::create_pack_proxies`]); off, one draw call per
    /// proxy, as before (for comparisons: the frames are the same to a level where
    /// an atlas coordinate rounds differently; `tests/render.rs`).
    pub fn set_mesh_batches(&mut self, on: bool) {
        self.mesh_batches = on;
    }

    /// What the prefetch thread needs to create GPU proxies like this renderer's.
    pub fn proxy_maker(&self) -> ProxyMaker {
        ProxyMaker {
            device: self.device.clone(),
            queue: self.queue.clone(),
            proxy_bgl: self.proxy_bgl.clone(),
            sampler: self.sampler.clone(),
            dummy_view: self.dummy_view.clone(),
            impostor_batches: self.impostor_batches,
            mesh_batches: self.mesh_batches,
            options: self.options,
        }
    }

    /// A second renderer on this one's device with a `width × height` target (e.g. a
    /// supersampled reference) and the same options: models uploaded by either can
    /// be drawn by both.
    pub fn sibling(&self, width: u32, height: u32) -> Result<Renderer, GpuError> {
        Renderer::with_device(
            self.device.clone(),
            self.queue.clone(),
            self.adapter.clone(),
            (width, height),
            &self.options,
        )
        .map(|mut r| {
            r.impostor_batches = self.impostor_batches;
            r.mesh_batches = self.mesh_batches;
            r
        })
    }

    pub fn adapter(&self) -> &AdapterSummary {
        &self.adapter
    }

    /// Triangles per spatial tile of a proxy's normal clusters
    /// ([`crate::DrawOptions::tile_triangles`], at least 1).
    pub fn tile_size(&self) -> usize {
        self.options.tile_size()
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// [`Renderer::render`] `repeats` times (at least once); the fastest draw's
    /// milliseconds (`compare --repeat`). The first draw also carries the texture
    /// uploads queued since the last submit (a cell's proxies on arrival), the others
    /// draw the frame only.
    pub fn render_fastest(
        &mut self,
        repeats: u32,
        camera: &Camera,
        models: &GpuModels,
        list: &DrawList<'_>,
    ) -> f64 {
        self.render_blend_fastest(repeats, camera, models, &[(list, None)])
    }

    /// [`Renderer::render_fastest`] of a blended frame ([`Renderer::render_blend`]).
    pub fn render_blend_fastest(
        &mut self,
        repeats: u32,
        camera: &Camera,
        models: &GpuModels,
        lists: &[(&DrawList<'_>, Option<(u32, u32)>)],
    ) -> f64 {
        (0..repeats.max(1))
            .map(|_| self.render_blend(camera, models, lists))
            .fold(f64::INFINITY, f64::min)
    }

    /// Draws one frame and waits for the GPU; returns the submit → done wall time in
    /// milliseconds. Proxies of `list.proxies` that are not ready (textures missing)
    /// are skipped; `list.lit_proxies` are drawn without their textures.
    pub fn render<'a>(&mut self, camera: &Camera, models: &GpuModels, list: &DrawList<'a>) -> f64 {
        self.render_blend(camera, models, &[(list, None)])
    }

    /// Draws one frame of several draw lists into one depth buffer (issue 31's
    /// cross-fades, [`crate::transition`]): a list with a dither range `Some((lo,
    /// hi))` keeps only the pixels whose 8 × 8 Bayer level (0..64,
    /// [`crate::transition::bayer8`]) lies in `lo..hi`, with the [`dithered_shader_source`]
    /// pipelines; `None` draws it whole. Lists whose ranges partition 0..64 each
    /// own their pixels, so every pixel shows exactly one list's complete image:
    /// no object drawn twice opaque, no gap. The ground is drawn once, first. At
    /// most [`setup::GLOBAL_SLOTS`] − 1 lists are drawn. Returns the frame time as
    /// [`Renderer::render`] does.
    pub fn render_blend<'a>(
        &mut self,
        camera: &Camera,
        models: &GpuModels,
        lists: &[(&DrawList<'a>, Option<(u32, u32)>)],
    ) -> f64 {
        let lists = &lists[..lists.len().min(setup::GLOBAL_SLOTS - 1)];
        // 1. The frame's globals (camera, eye, debug switches, palette), one copy
        //    per list with its dither range.
        self.write_globals(camera, lists.iter().map(|l| l.1));
        // 2. The frame model (`frame_model.rs`) of each list: every instance's data,
        //    one span per patched original and proxy (several ranges gathered into
        //    the frame's index buffer), proxies nearest first with their bind
        //    groups; each list's after the one before in the shared buffers.
        let mut plans = Vec::with_capacity(lists.len());
        let (mut instances, mut indices) = (0, 0);
        for (list, _) in lists {
            let plan = FramePlan::new(list, models, camera.eye, self.representation_colours)
                .shifted(instances, indices);
            instances += plan.instances.len() as u32;
            indices += plan.indices.len() as u32;
            plans.push(plan);
        }
        // 3. Their instance data and gathered indices to the GPU.
        self.upload_plans(&plans);
        // 4. One render pass: the ground, then per list its instanced originals
        //    and LOD levels, patched originals, proxies.
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        self.last_draw_calls = self.encode_frame(&mut enc, models, lists, &plans);
        // 5. Submit and wait: the frame time.
        let t0 = Instant::now();
        let idx = self.queue.submit([enc.finish()]);
        let _ = self.device.poll(wgpu::PollType::Wait {
            submission_index: Some(idx),
            timeout: None,
        });
        t0.elapsed().as_secs_f64() * 1e3
    }

    /// Submits the queue's pending writes (textures, buffers created with data) and
    /// waits for them: what a display frame that draws nothing still costs the GPU.
    /// Without it they would run in the next frame's submit, where a headless walk
    /// (`StreamConfig::display_frames_per_step`) would time the uploads of six
    /// display frames in one.
    pub fn flush_uploads(&self) {
        let idx = self.queue.submit([]);
        let _ = self.device.poll(wgpu::PollType::Wait {
            submission_index: Some(idx),
            timeout: None,
        });
    }

    /// Step 1 of [`Renderer::render_blend`]: the globals of the frame seen by
    /// `camera` at slot 0 (no dither range), and at slot k + 1 those with the k-th
    /// of `ranges` (`None`: every level).
    fn write_globals(&self, camera: &Camera, ranges: impl Iterator<Item = Option<(u32, u32)>>) {
        let mut g = Globals {
            clip_from_world: camera.clip_from_world_wgpu().to_cols_array(),
            eye: camera.eye.extend(1.0).to_array(),
            debug: [
                u32::from(self.representation_colours),
                u32::from(self.coverage_alpha),
                0,
                crate::transition::LEVELS,
            ],
            palette: crate::representation::Representation::linear_palette(),
        };
        let slots = std::iter::once(None).chain(ranges);
        for (buffer, range) in self.globals.iter().zip(slots) {
            let (lo, hi) = range.unwrap_or((0, crate::transition::LEVELS));
            g.debug[2] = lo;
            g.debug[3] = hi;
            self.queue.write_buffer(buffer, 0, bytemuck::bytes_of(&g));
        }
    }

    /// Step 3 of [`Renderer::render_blend`]: the plans' instances into the instance
    /// buffer and their gathered indices into the frame's index buffer, one plan
    /// after the other ([`FramePlan::shifted`]), each buffer grown as needed.
    fn upload_plans(&mut self, plans: &[FramePlan<'_>]) {
        let instance_bytes: u64 = plans
            .iter()
            .map(|p| std::mem::size_of_val(p.instances.as_slice()) as u64)
            .sum();
        if instance_bytes > self.instances.size() {
            self.instances = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("instances"),
                size: instance_bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        let index_bytes: u64 = plans
            .iter()
            .map(|p| std::mem::size_of_val(p.indices.as_slice()) as u64)
            .sum();
        if index_bytes > 0
            && self
                .frame_indices
                .as_ref()
                .is_none_or(|b| b.size() < index_bytes)
        {
            self.frame_indices = Some(self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame indices"),
                size: index_bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        // Each plan where its shifted instances and indices start.
        let (mut at_instance, mut at_index) = (0u64, 0u64);
        for p in plans {
            if !p.instances.is_empty() {
                self.queue.write_buffer(
                    &self.instances,
                    at_instance,
                    bytemuck::cast_slice(&p.instances),
                );
                at_instance += std::mem::size_of_val(p.instances.as_slice()) as u64;
            }
            if let (false, Some(b)) = (p.indices.is_empty(), &self.frame_indices) {
                self.queue
                    .write_buffer(b, at_index, bytemuck::cast_slice(&p.indices));
                at_index += std::mem::size_of_val(p.indices.as_slice()) as u64;
            }
        }
    }

    /// Step 4 of [`Renderer::render_blend`]: the frame's render pass, cleared to the
    /// sky (alpha 0 with coverage alpha) and depth 1: the ground, then each list's
    /// originals, then each list's proxies (with the dithered pipelines and the
    /// list's globals slot where it has a range); returns the draw calls issued.
    fn encode_frame(
        &self,
        enc: &mut wgpu::CommandEncoder,
        models: &GpuModels,
        lists: &[(&DrawList<'_>, Option<(u32, u32)>)],
        plans: &[FramePlan<'_>],
    ) -> u64 {
        let sky = |c: u8| srgb_to_linear(c);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: sky(SKY[0]),
                        g: sky(SKY[1]),
                        b: sky(SKY[2]),
                        a: if self.coverage_alpha { 0.0 } else { 1.0 },
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, Some(&self.globals_bgs[0]), &[]);
        // The ground first (issue 18): lit, white albedo texture; every list's.
        pass.set_pipeline(&self.plain.ground);
        pass.set_bind_group(2, Some(&self.white_albedo), &[]);
        pass.set_vertex_buffer(0, models.ground.slice(..));
        pass.set_vertex_buffer(1, self.instances.slice(..));
        let mut draws = 0;
        if let Some(plan) = plans.first() {
            let g = plan.ground_instance;
            pass.draw(0..6, g..g + 1);
            draws += 1;
        }
        // Every list's originals, then every list's proxies: as within one list,
        // an original is drawn before any proxy, so where two surfaces tie in
        // depth the same one wins as in each list drawn alone.
        for originals in [true, false] {
            for (k, ((list, range), plan)) in lists.iter().zip(plans).enumerate() {
                let pipes = match range {
                    Some(_) => {
                        pass.set_bind_group(0, Some(&self.globals_bgs[k + 1]), &[]);
                        &self.dithered
                    }
                    None => {
                        pass.set_bind_group(0, Some(&self.globals_bgs[0]), &[]);
                        &self.plain
                    }
                };
                draws += if originals {
                    self.draw_originals(&mut pass, pipes, models, list, plan)
                } else {
                    self.draw_proxies(&mut pass, pipes, plan)
                };
            }
        }
        draws
    }

    /// Instanced originals, then LOD levels, then patched originals and cluster-LOD
    /// instances (each its one span), with the lit pipeline; instances in the plan's order. Returns the
    /// draw calls.
    fn draw_originals(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipes: &setup::Pipelines,
        models: &GpuModels,
        list: &DrawList<'_>,
        plan: &FramePlan<'_>,
    ) -> u64 {
        let mut draws = 0u64;
        pass.set_pipeline(&pipes.lit);
        let mut first = plan.first_instance;
        for (m, inst) in &list.originals {
            let model = &models.models[*m as usize];
            let n = inst.len() as u32;
            if model.index_count > 0 && n > 0 {
                pass.set_bind_group(2, Some(&model.albedo), &[]);
                pass.set_vertex_buffer(0, model.vertices.slice(..));
                pass.set_vertex_buffer(1, self.instances.slice(..));
                pass.set_index_buffer(model.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..model.index_count, 0, first..first + n);
                draws += 1;
            }
            first += n;
        }
        for ((m, l), inst) in &list.levels {
            let model = &models.models[*m as usize];
            let n = inst.len() as u32;
            let (indices, count, _) = model.level(*l);
            if count > 0 && n > 0 {
                pass.set_bind_group(2, Some(&model.albedo), &[]);
                pass.set_vertex_buffer(0, model.vertices.slice(..));
                pass.set_vertex_buffer(1, self.instances.slice(..));
                pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..count, 0, first..first + n);
                draws += 1;
            }
            first += n;
        }
        let frame_indices = self.frame_indices.as_ref();
        for (k, (p, span)) in list.patched.iter().zip(&plan.patched).enumerate() {
            let instance = first + k as u32;
            let Some(span) = span else {
                continue;
            };
            let model = &models.models[p.model as usize];
            pass.set_bind_group(2, Some(&model.albedo), &[]);
            pass.set_vertex_buffer(0, model.vertices.slice(..));
            pass.set_vertex_buffer(1, self.instances.slice(..));
            let (buffer, r) = match (span, frame_indices) {
                (Span::Own(r), _) => (&model.indices, r),
                (Span::Gathered(r), Some(b)) => (b, r),
                (Span::Gathered(_), None) => continue,
            };
            pass.set_index_buffer(buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(r.clone(), 0, instance..instance + 1);
            draws += 1;
        }
        // Cluster LOD: each instance's selected clusters, one draw.
        let first = first + list.patched.len() as u32;
        for (k, (c, span)) in list.clusters.iter().zip(&plan.clusters).enumerate() {
            let instance = first + k as u32;
            let model = &models.models[c.model as usize];
            let (Some(span), Some(own)) = (span, model.clusters.as_ref()) else {
                continue;
            };
            pass.set_bind_group(2, Some(&model.albedo), &[]);
            pass.set_vertex_buffer(0, model.vertices.slice(..));
            pass.set_vertex_buffer(1, self.instances.slice(..));
            let (buffer, r) = match (span, frame_indices) {
                (Span::Own(r), _) => (&own.indices, r),
                (Span::Gathered(r), Some(b)) => (b, r),
                (Span::Gathered(_), None) => continue,
            };
            pass.set_index_buffer(buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(r.clone(), 0, instance..instance + 1);
            draws += 1;
        }
        draws
    }

    /// The plan's proxies in its order (mesh proxies nearest first, then impostors
    /// nearest first, so that the depth test rejects more hidden proxy fragments
    /// before they are shaded; `frame_model::near_to_far`): mesh proxies
    /// with a discard-free pipeline (the atlas one for proxies with an [`Atlas`],
    /// else the one for their number of views), impostor layers with the other, a
    /// pipeline switch only where that changes. Returns the draw calls.
    fn draw_proxies(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipes: &setup::Pipelines,
        plan: &FramePlan<'_>,
    ) -> u64 {
        let mut draws = 0u64;
        let frame_indices = self.frame_indices.as_ref();
        let mut bound = None;
        for d in &plan.proxies {
            let p = d.proxy;
            let key = (p.layered, p.atlas.is_some(), p.view_slots);
            if bound != Some(key) {
                bound = Some(key);
                pass.set_pipeline(if p.layered {
                    &pipes.proxy
                } else if p.atlas.is_some() {
                    &pipes.proxy_atlas
                } else {
                    &pipes.proxy_mesh[p.view_slots]
                });
            }
            pass.set_bind_group(1, Some(d.bind_group), &[]);
            pass.set_vertex_buffer(0, p.vertices.slice(..));
            match (&d.span, frame_indices) {
                (Span::Own(r), _) => pass.draw(r.clone(), 0..1),
                (Span::Gathered(r), Some(b)) => {
                    pass.set_index_buffer(b.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(r.clone(), 0, 0..1);
                }
                (Span::Gathered(_), None) => continue,
            }
            draws += 1;
        }
        draws
    }

    /// The last frame as tightly packed RGBA8 sRGB, row 0 at the top.
    pub fn read_pixels(&self) -> Result<Vec<u8>, GpuError> {
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
        let idx = self.queue.submit([enc.finish()]);
        let slice = self.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(idx),
                timeout: None,
            })
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        rx.recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let row = self.width as usize * 4;
        let mut out = Vec::with_capacity(row * self.height as usize);
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            for r in data.chunks(self.padded_row as usize) {
                out.extend_from_slice(&r[..row]);
            }
        }
        self.readback.unmap();
        Ok(out)
    }
}

/// The descriptor of every texture the renderer makes: 2-D, one mip level, one
/// sample, no view formats.
pub(crate) fn texture_2d<'a>(
    label: &'a str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::TextureDescriptor<'a> {
    wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    }
}
