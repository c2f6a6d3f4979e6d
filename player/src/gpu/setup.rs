//! The renderer's fixed GPU objects, built once by [`Renderer::with_device`]
//! (`super::Renderer`): the offscreen targets, the three bind group layouts, the
//! pipelines, and the shared buffers, sampler and placeholder textures. One
//! function per object or family, in the order `with_device` calls them.

use super::{texture_2d, COLOR_FORMAT, DEPTH_FORMAT};
use crate::vertex::{Globals, InstanceRaw, ModelVertex, ProxyVertex, MAX_VIEWS};
use wgpu::util::DeviceExt;

/// The offscreen colour and depth targets and the colour readback buffer.
pub(super) struct Targets {
    pub color: wgpu::Texture,
    pub color_view: wgpu::TextureView,
    pub depth_view: wgpu::TextureView,
    pub readback: wgpu::Buffer,
    /// Bytes per readback row: `width × 4` rounded up to
    /// `COPY_BYTES_PER_ROW_ALIGNMENT`.
    pub padded_row: u32,
}

/// Step 1: a `width × height` `Rgba8UnormSrgb` colour target (copied back for
/// [`super::Renderer::read_pixels`]) and a `Depth32Float` depth target.
pub(super) fn targets(device: &wgpu::Device, width: u32, height: u32) -> Targets {
    let target = |label: &str, format, usage| {
        device.create_texture(&texture_2d(label, (width, height), format, usage))
    };
    let color = target(
        "color",
        COLOR_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let color_view = color.create_view(&Default::default());
    let depth = target(
        "depth",
        DEPTH_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let depth_view = depth.create_view(&Default::default());
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let padded_row = (width * 4).div_ceil(align) * align;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    Targets {
        color,
        color_view,
        depth_view,
        readback,
        padded_row,
    }
}

/// A uniform buffer binding.
fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A filterable 2D texture binding of the fragment stage.
fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A filtering sampler binding of the fragment stage.
fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// Step 2a: group 0 of every pipeline: the frame's [`Globals`].
pub(super) fn globals_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("globals"),
        entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
    })
}

/// Step 2b: group 1 of the proxy pipeline: the proxy's
/// [`ProxyUniform`](crate::vertex::ProxyUniform) (binding 0), the capture sampler
/// (1) and one texture per view (2 … 2 + [`MAX_VIEWS`]).
pub(super) fn proxy_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let mut entries = vec![
        // The vertex stage chooses each triangle's views (shader.wgsl vs_proxy).
        uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
        sampler_entry(1),
    ];
    entries.extend((0..MAX_VIEWS as u32).map(|i| texture_entry(2 + i)));
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("proxy"),
        entries: &entries,
    })
}

/// Step 2c: group 2 of the lit pipelines: a model's albedo texture (binding 0) and
/// its sampler (1), built by `albedo_bind_group`.
pub(super) fn albedo_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("albedo"),
        entries: &[texture_entry(0), sampler_entry(1)],
    })
}

/// The texture slots of the mesh-proxy pipelines: a proxy with n views is drawn by
/// the first with at least n (`GpuProxy::view_slots`; one without views by the
/// first).
pub(super) const MESH_VIEW_SLOTS: [u32; MAX_VIEWS] = {
    let mut slots = [0; MAX_VIEWS];
    let mut i = 0;
    while i < MAX_VIEWS {
        slots[i] = i as u32 + 1;
        i += 1;
    }
    slots
};

/// The renderer's pipelines.
pub(super) struct Pipelines {
    /// Originals: `vs_lit` / `fs_lit` over [`ModelVertex`] × [`InstanceRaw`].
    pub lit: wgpu::RenderPipeline,
    /// The ground: the lit pipeline's layout and vertices, `fs_ground`.
    pub ground: wgpu::RenderPipeline,
    /// Proxies with impostor layers: `vs_proxy` / `fs_proxy` over [`ProxyVertex`]
    /// (the layers' alpha test discards).
    pub proxy: wgpu::RenderPipeline,
    /// Mesh proxies (SV/MV meshes, clusters): `vs_proxy_mesh` / `fs_proxy_mesh`, which
    /// never discards, so hidden fragments can be rejected before shading; one per
    /// entry of [`MESH_VIEW_SLOTS`], the texture slots its fragment shader reads
    /// (shader.wgsl `VIEW_SLOTS`).
    pub proxy_mesh: [wgpu::RenderPipeline; MESH_VIEW_SLOTS.len()],
    /// Mesh proxies whose views share one atlas texture (issue 30 item 7):
    /// `vs_proxy_mesh` / `fs_proxy_atlas`, which samples only the two views it blends and
    /// never discards.
    pub proxy_atlas: wgpu::RenderPipeline,
}

/// Step 3: the shader module and the pipelines. All draw counter-clockwise
/// triangle lists with back faces culled, depth-tested (less) and written, into the
/// colour target without blending; they differ in layout, entry points and vertex
/// buffers. Group 1 is the proxies' (one shader module); the lit pipelines use
/// groups 0 and 2.
pub(super) fn pipelines(
    device: &wgpu::Device,
    source: String,
    globals: &wgpu::BindGroupLayout,
    proxy: &wgpu::BindGroupLayout,
    albedo: &wgpu::BindGroupLayout,
) -> Pipelines {
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("player shaders"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let lit_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("lit"),
        bind_group_layouts: &[Some(globals), None, Some(albedo)],
        immediate_size: 0,
    });
    let proxy_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("proxy"),
        bind_group_layouts: &[Some(globals), Some(proxy)],
        immediate_size: 0,
    });
    let targets = [Some(wgpu::ColorTargetState {
        format: COLOR_FORMAT,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })];
    let pipeline_with = |label: &str,
                         layout: &wgpu::PipelineLayout,
                         (vs, fs): (&str, &str),
                         buffers: &[Option<wgpu::VertexBufferLayout>],
                         constants: &[(&str, f64)]| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers,
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: Some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some(fs),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let pipeline = |label: &str,
                    layout: &wgpu::PipelineLayout,
                    stages: (&str, &str),
                    buffers: &[Option<wgpu::VertexBufferLayout>]| {
        pipeline_with(label, layout, stages, buffers, &[])
    };
    let lit_buffers = [Some(ModelVertex::layout()), Some(InstanceRaw::layout())];
    Pipelines {
        lit: pipeline("lit", &lit_layout, ("vs_lit", "fs_lit"), &lit_buffers),
        ground: pipeline("ground", &lit_layout, ("vs_lit", "fs_ground"), &lit_buffers),
        proxy: pipeline(
            "proxy",
            &proxy_layout,
            ("vs_proxy", "fs_proxy"),
            &[Some(ProxyVertex::layout())],
        ),
        proxy_mesh: MESH_VIEW_SLOTS.map(|slots| {
            pipeline_with(
                "proxy mesh",
                &proxy_layout,
                ("vs_proxy_mesh", "fs_proxy_mesh"),
                &[Some(ProxyVertex::layout())],
                &[("VIEW_SLOTS", slots as f64)],
            )
        }),
        proxy_atlas: pipeline(
            "proxy atlas",
            &proxy_layout,
            ("vs_proxy_mesh", "fs_proxy_atlas"),
            &[Some(ProxyVertex::layout())],
        ),
    }
}

/// [`Globals`] buffers: one for plain draws and one per list of a blended frame
/// (`Renderer::render_blend`: the lists `frame::blend_lists` makes, the shared one
/// and one per cell of a hexagon corner, `crate::transition::MAX_CELLS`; a list
/// beyond them would be dropped, and its pixels left without the scene). Each is
/// its own small buffer bound whole.
pub const GLOBAL_SLOTS: usize = 1 + 1 + crate::transition::MAX_CELLS;

/// What the pipelines bind besides per-model and per-proxy data.
pub(super) struct Shared {
    /// [`GLOBAL_SLOTS`] [`Globals`] buffers and group 0 of each.
    pub globals: Vec<wgpu::Buffer>,
    pub globals_bgs: Vec<wgpu::BindGroup>,
    /// The capture textures' sampler: clamped, bilinear, no mipmaps.
    pub sampler: wgpu::Sampler,
    /// A transparent 1 × 1 texture bound where a proxy has no view.
    pub dummy_view: wgpu::TextureView,
    /// Per-instance data of the frame (grown by `render` when needed).
    pub instances: wgpu::Buffer,
    /// Group 2 of untextured models and the ground: a white texel.
    pub white_albedo: wgpu::BindGroup,
}

/// Step 4: the globals buffer and group, the capture sampler, the placeholder
/// textures and the instance buffer.
pub(super) fn shared(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    globals_layout: &wgpu::BindGroupLayout,
    albedo_layout: &wgpu::BindGroupLayout,
) -> Shared {
    let globals: Vec<wgpu::Buffer> = (0..GLOBAL_SLOTS)
        .map(|_| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("globals"),
                size: std::mem::size_of::<Globals>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })
        .collect();
    let globals_bgs = globals
        .iter()
        .map(|buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("globals"),
                layout: globals_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                }],
            })
        })
        .collect();
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("capture"),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    let dummy = device.create_texture_with_data(
        queue,
        &texture_2d(
            "no view",
            (1, 1),
            wgpu::TextureFormat::Rgba8UnormSrgb,
            wgpu::TextureUsages::TEXTURE_BINDING,
        ),
        wgpu::util::TextureDataOrder::LayerMajor,
        &[0, 0, 0, 0],
    );
    let dummy_view = dummy.create_view(&Default::default());
    let instances = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("instances"),
        size: 1 << 16,
        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let white_albedo = albedo_bind_group(
        device,
        queue,
        albedo_layout,
        "white albedo",
        (1, 1),
        &[255; 4],
        [format::albedo::Wrap::Repeat; 2],
    );
    Shared {
        globals,
        globals_bgs,
        sampler,
        dummy_view,
        instances,
        white_albedo,
    }
}

/// Bind group 2 of the lit pipeline: an `Rgba8UnormSrgb` texture (sampled in
/// linear space, as `format::albedo` does on the CPU) and a linear, non-mipmapped
/// sampler with the texture's wrap modes.
pub(super) fn albedo_bind_group(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    (width, height): (u32, u32),
    rgba: &[u8],
    wrap: [format::albedo::Wrap; 2],
) -> wgpu::BindGroup {
    use format::albedo::Wrap;
    let texture = device.create_texture_with_data(
        queue,
        &texture_2d(
            label,
            (width, height),
            wgpu::TextureFormat::Rgba8UnormSrgb,
            wgpu::TextureUsages::TEXTURE_BINDING,
        ),
        wgpu::util::TextureDataOrder::LayerMajor,
        rgba,
    );
    let mode = |w: Wrap| match w {
        Wrap::Repeat => wgpu::AddressMode::Repeat,
        Wrap::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
        Wrap::ClampToEdge => wgpu::AddressMode::ClampToEdge,
    };
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        address_mode_u: mode(wrap[0]),
        address_mode_v: mode(wrap[1]),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(
                    &texture.create_view(&Default::default()),
                ),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
        ],
    })
}
