//! Uploads (part of the renderer, [`Renderer`]): the models of a bake once (vertices,
//! patch-ordered indices, albedo textures; issue 18), the LOD baseline's levels, a
//! proxy's vertex and view buffers (its triangles reordered by normal cluster,
//! `crate::patches::cluster_proxy_vertices`) and its view textures as they arrive
//! (RGBA8, or BC1/BC3 natively or decoded on the CPU; issue 15), binding a proxy once
//! all its views are there.

use super::setup::{self, albedo_bind_group};
use super::{texture_2d, GpuClusters, GpuLod, GpuModel, GpuModels, GpuProxy, Renderer, MAX_VIEWS};
use crate::vertex::{ModelVertex, ProxyUniform, ProxyVertex};
use bytemuck::Zeroable;
use format::pack::{BasePack, Texture, TextureEncoding};
use glam::Vec3;
use wgpu::util::DeviceExt;

impl Renderer {
    /// A buffer holding `contents`, named `label` in GPU debugging tools.
    fn buffer_init(&self, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    }

    /// One model: vertices, its albedo texture (issue 18; too large for the adapter:
    /// untextured) and its triangles in `order` when given.
    fn upload_model(&self, m: &format::pack::PackedModel, order: Option<&Vec<u32>>) -> GpuModel {
        let mesh = &m.mesh;
        let uvs = m.albedo_map.as_ref().map(|a| &a.uvs);
        let verts: Vec<ModelVertex> = (0..mesh.positions.len())
            .map(|i| ModelVertex {
                pos: mesh.positions[i],
                normal: mesh.normals[i],
                albedo: mesh.albedo[i],
                uv: uvs.and_then(|u| u.get(i)).copied().unwrap_or([0.0; 2]),
            })
            .collect();
        let max = self.device.limits().max_texture_dimension_2d;
        let albedo = match &m.albedo_map {
            Some(a)
                if a.texture.validate().is_ok()
                    && a.texture.width <= max
                    && a.texture.height <= max =>
            {
                albedo_bind_group(
                    &self.device,
                    &self.queue,
                    &self.albedo_bgl,
                    &m.name,
                    (a.texture.width, a.texture.height),
                    &a.texture.rgba,
                    a.texture.wrap,
                )
            }
            Some(a) => {
                eprintln!(
                    "player: warning: model {}: albedo texture {}x{} not uploadable \
                     (max side {max}); drawn with its vertex colours",
                    m.name, a.texture.width, a.texture.height
                );
                self.white_albedo.clone()
            }
            None => self.white_albedo.clone(),
        };
        // wgpu refuses zero-sized vertex buffers with a binding; keep one vertex.
        let verts = if verts.is_empty() {
            vec![ModelVertex::zeroed()]
        } else {
            verts
        };
        let mut idx: Vec<u32> = match order {
            Some(order) => order
                .iter()
                .filter_map(|&t| mesh.triangles.get(t as usize))
                .flatten()
                .copied()
                .collect(),
            None => mesh.triangles.iter().flatten().copied().collect(),
        };
        let index_count = idx.len() as u32;
        if idx.is_empty() {
            idx = vec![0; 3];
        }
        GpuModel {
            vertices: self.buffer_init(
                &m.name,
                bytemuck::cast_slice(&verts),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: self.buffer_init(
                &m.name,
                bytemuck::cast_slice(&idx),
                wgpu::BufferUsages::INDEX,
            ),
            index_count,
            triangle_count: mesh.triangles.len() as u64,
            lods: Vec::new(),
            clusters: None,
            albedo,
            patch_ordered: order.is_some(),
            cpu_indices: if order.is_some() { idx } else { Vec::new() },
        }
    }

    /// Uploads every model of the base pack once. `draw_order`: per model, the
    /// triangle order of its tiles (`Bake::draw_order`, issue 17), for every mode
    /// alike, so that the full-geometry reference and the hybrid rasterize the
    /// triangles they share in the same order and equal-depth ties resolve the same
    /// way in both.
    pub fn upload_models(&self, base: &BasePack, draw_order: Option<&[Vec<u32>]>) -> GpuModels {
        let models = base
            .models
            .iter()
            .enumerate()
            .map(|(k, m)| self.upload_model(m, draw_order.and_then(|o| o.get(k))))
            .collect();
        // The ground rectangle, world space, drawn with an identity instance.
        let g = &base.grid;
        let ground_mesh = format::scene::Ground {
            min: g.ground_min,
            max: g.ground_max,
        }
        .mesh();
        let ground_verts: Vec<ModelVertex> = ground_mesh
            .triangles
            .iter()
            .flatten()
            .map(|&i| ModelVertex {
                pos: ground_mesh.positions[i as usize],
                normal: ground_mesh.normals[i as usize],
                albedo: ground_mesh.albedo[i as usize],
                uv: [0.0; 2],
            })
            .collect();
        let ground = self.buffer_init(
            "ground",
            bytemuck::cast_slice(&ground_verts),
            wgpu::BufferUsages::VERTEX,
        );
        GpuModels { models, ground }
    }

    /// Uploads the simplified levels (1..) of each model's LOD chain as index buffers
    /// over the model's vertex buffer; replaces earlier ones.
    pub fn upload_lods(&self, models: &mut GpuModels, set: &crate::lod::LodSet) {
        for (model, chain) in models.models.iter_mut().zip(&set.chains) {
            model.lods = chain
                .levels
                .iter()
                .skip(1)
                .map(|level| GpuLod {
                    indices: self.buffer_init(
                        "lod indices",
                        bytemuck::cast_slice(&level.indices),
                        wgpu::BufferUsages::INDEX,
                    ),
                    index_count: level.indices.len() as u32,
                    triangle_count: level.triangle_count(),
                })
                .collect();
        }
    }

    /// Uploads each model's cluster DAG (`cluster-lod` mode) as one index buffer over
    /// the model's vertex buffer, keeping a CPU copy for gathering; replaces earlier
    /// ones. A model without clusters keeps none (nothing drawn in that mode).
    pub fn upload_clusters(&self, models: &mut GpuModels, set: &crate::clusterlod::ClusterSet) {
        for (model, dag) in models.models.iter_mut().zip(&set.dags) {
            model.clusters = (!dag.indices.is_empty()).then(|| GpuClusters {
                indices: self.buffer_init(
                    "cluster indices",
                    bytemuck::cast_slice(&dag.indices),
                    wgpu::BufferUsages::INDEX,
                ),
                cpu_indices: dag.indices.clone(),
                bytes: 4 * dag.indices.len() as u64,
            });
        }
    }

    /// Creates a proxy's vertex and uniform buffers; textures come later through
    /// [`Renderer::upload_view_texture`]. `views`: each view's world → texture matrix,
    /// eye, and whether its colours are premultiplied by coverage (BC1 textures:
    /// punch-through alpha in format 4, fully opaque before, where it changes nothing).
    pub fn create_proxy(
        &self,
        vertices: &[ProxyVertex],
        views: &[([f32; 16], [f32; 3], bool)],
    ) -> GpuProxy {
        let mut u = ProxyUniform::zeroed();
        for (i, (m, eye, premultiplied)) in views.iter().take(MAX_VIEWS).enumerate() {
            u.tex_from_world[i] = *m;
            u.view_eye[i] = [eye[0], eye[1], eye[2], 1.0];
            u.counts[1] |= u32::from(*premultiplied) << i;
        }
        u.counts[0] = views.len().min(MAX_VIEWS) as u32;
        // Issue 17: triangles grouped by normal cluster for the per-frame test.
        let (vertices, clusters) =
            crate::patches::cluster_proxy_vertices(vertices, self.options.tile_size());
        let vertices = vertices.as_slice();
        let contents: &[u8] = if vertices.is_empty() {
            bytemuck::bytes_of(&ProxyVertex::ZERO)
        } else {
            bytemuck::cast_slice(vertices)
        };
        let vbuf = self.buffer_init("proxy vertices", contents, wgpu::BufferUsages::VERTEX);
        let uniform = self.buffer_init(
            "proxy views",
            bytemuck::bytes_of(&u),
            wgpu::BufferUsages::UNIFORM,
        );
        let lit_bind_group = self.bind_views(&uniform, &[]);
        let mut p = GpuProxy {
            vertices: vbuf,
            vertex_count: vertices.len() as u32,
            uniform,
            textures: vec![None; views.len().min(MAX_VIEWS)],
            bind_group: None,
            lit_bind_group,
            texture_bytes: 0,
            vertex_bytes: std::mem::size_of_val(vertices) as u64,
            clusters,
            view_slots: setup::MESH_VIEW_SLOTS
                .iter()
                .position(|&n| n as usize >= views.len().min(MAX_VIEWS))
                .unwrap_or(setup::MESH_VIEW_SLOTS.len() - 1),
            layered: vertices
                .iter()
                .any(|v| v.kind == format::pack::ProxyKind::LayeredImpostor as u32),
            bounds: vertices
                .iter()
                .fold(crate::camera::Aabb::EMPTY, |mut b, v| {
                    b.add(Vec3::from_array(v.pos));
                    b
                }),
        };
        self.try_bind(&mut p);
        p
    }

    /// Uploads view `view`'s texels as a pack stores them: RGBA8, or BC1/BC3 blocks
    /// (sides multiples of 4) — natively as `Bc1RgbaUnormSrgb` / `Bc3RgbaUnormSrgb`
    /// where [`Renderer::native_bc`], else decoded to RGBA8 sRGB on the CPU.
    pub fn upload_view_texels(
        &self,
        proxy: &mut GpuProxy,
        view: usize,
        width: u32,
        height: u32,
        encoding: TextureEncoding,
        data: &[u8],
    ) {
        let format = match encoding {
            TextureEncoding::Bc1 => wgpu::TextureFormat::Bc1RgbaUnormSrgb,
            TextureEncoding::Bc3 => wgpu::TextureFormat::Bc3RgbaUnormSrgb,
            _ => return self.upload_view_texture(proxy, view, width, height, data),
        };
        if view >= proxy.textures.len() {
            return;
        }
        let texture = Texture {
            width,
            height,
            encoding,
            data: data.to_vec(),
        };
        let max = self.device.limits().max_texture_dimension_2d;
        if let Err(what) = texture.validate() {
            eprintln!("player: warning: capture texture not uploadable ({what}); drawing it lit");
            proxy.textures[view] = Some(self.dummy_view.clone());
            self.try_bind(proxy);
            return;
        }
        if !self.options.bc_textures || width > max || height > max {
            match texture.to_rgba8() {
                Ok(rgba) => self.upload_view_texture(proxy, view, width, height, &rgba),
                Err(what) => {
                    eprintln!(
                        "player: warning: capture texture not decodable ({what}); drawing it lit"
                    );
                    proxy.textures[view] = Some(self.dummy_view.clone());
                    self.try_bind(proxy);
                }
            }
            return;
        }
        self.set_view_texture(proxy, view, "capture (BC)", format, (width, height), data);
    }

    /// Uploads view `view`'s RGBA8 sRGB texels (row-major, row 0 = v 0).
    pub fn upload_view_texture(
        &self,
        proxy: &mut GpuProxy,
        view: usize,
        width: u32,
        height: u32,
        rgba: &[u8],
    ) {
        if view >= proxy.textures.len() {
            return;
        }
        let max = self.device.limits().max_texture_dimension_2d;
        let expected = width as usize * height as usize * 4;
        if width == 0 || height == 0 || width > max || height > max || rgba.len() != expected {
            // Not uploadable here: the view samples as "no data" (alpha 0), so its
            // triangles fall back to the other view or the lit vertex colour.
            eprintln!(
                "player: warning: capture texture {width}x{height} ({} bytes) not uploadable (max side {max}); drawing it lit",
                rgba.len()
            );
            proxy.textures[view] = Some(self.dummy_view.clone());
            self.try_bind(proxy);
            return;
        }
        self.set_view_texture(
            proxy,
            view,
            "capture",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            (width, height),
            rgba,
        );
    }

    /// Creates view `view`'s texture from `data` in `format` (RGBA8 or BC blocks),
    /// counts its bytes and binds the proxy once all its views are there.
    fn set_view_texture(
        &self,
        proxy: &mut GpuProxy,
        view: usize,
        label: &str,
        format: wgpu::TextureFormat,
        (width, height): (u32, u32),
        data: &[u8],
    ) {
        let tex = self.device.create_texture_with_data(
            &self.queue,
            &texture_2d(
                label,
                (width, height),
                format,
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            ),
            wgpu::util::TextureDataOrder::LayerMajor,
            data,
        );
        proxy.texture_bytes += data.len() as u64;
        proxy.textures[view] = Some(tex.create_view(&Default::default()));
        self.try_bind(proxy);
    }

    fn try_bind(&self, p: &mut GpuProxy) {
        if p.bind_group.is_some() || p.textures.iter().any(|t| t.is_none()) {
            return;
        }
        p.bind_group = Some(self.bind_views(&p.uniform, &p.textures));
    }

    /// A proxy bind group: its view uniform, the sampler and its view textures (the
    /// "nothing captured" texture for missing ones and unused slots).
    fn bind_views(
        &self,
        uniform: &wgpu::Buffer,
        textures: &[Option<wgpu::TextureView>],
    ) -> wgpu::BindGroup {
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(&self.sampler),
            },
        ];
        for i in 0..MAX_VIEWS {
            let view = textures
                .get(i)
                .and_then(|t| t.as_ref())
                .unwrap_or(&self.dummy_view);
            entries.push(wgpu::BindGroupEntry {
                binding: 2 + i as u32,
                resource: wgpu::BindingResource::TextureView(view),
            });
        }
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("proxy"),
            layout: &self.proxy_bgl,
            entries: &entries,
        })
    }
}
