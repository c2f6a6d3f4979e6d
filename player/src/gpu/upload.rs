//! Uploads (part of the renderer, [`Renderer`]): the models of a bake once (vertices,
//! patch-ordered indices, albedo textures; issue 18), the LOD baseline's levels, a
//! proxy's vertex and view buffers (its triangles reordered by normal cluster,
//! `crate::patches::cluster_proxy_vertices`) and its view textures as they arrive
//! (RGBA8, or BC1/BC3 natively or decoded on the CPU; issue 15), binding a proxy once
//! all its views are there.

use super::setup::{self, albedo_bind_group};
use super::{
    texture_2d, Atlas, GpuClusters, GpuLod, GpuModel, GpuModels, GpuProxy, ProxyMaker, Renderer,
    MAX_VIEWS,
};
use crate::vertex::{ModelVertex, ProxyUniform, ProxyVertex, PROXY_SLOTS};
use bytemuck::Zeroable;
use format::pack::{BasePack, Texture, TextureEncoding};
use glam::Vec3;
use wgpu::util::DeviceExt;

/// A buffer of `device` holding `contents`, named `label` in GPU debugging tools.
fn buffer_init(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage,
    })
}

impl Renderer {
    fn buffer_init(&self, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        buffer_init(&self.device, label, contents, usage)
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

    /// [`ProxyMaker::create_pack_proxies`] on this renderer's device.
    pub fn create_pack_proxies(&self, proxies: &[ProxySource]) -> Vec<(GpuProxy, Vec<usize>)> {
        self.proxy_maker().create_pack_proxies(proxies)
    }

    /// [`ProxyMaker::create_proxy`] on this renderer's device.
    pub fn create_proxy(&self, vertices: &[ProxyVertex], views: &[ViewInfo]) -> GpuProxy {
        self.proxy_maker().create_proxy(vertices, views)
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
        if proxy.atlas.is_some() {
            return self.write_atlas(proxy, view, (width, height), encoding, data);
        }
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

    /// Writes view `view`'s texels into the proxy's [`Atlas`] (decoding BC blocks to
    /// RGBA8 where the atlas holds RGBA8) and binds the proxy once all its views are
    /// there. Texels that do not match the view's rectangle or do not decode are
    /// left transparent, with a warning: the view samples as missing.
    fn write_atlas(
        &self,
        proxy: &mut GpuProxy,
        view: usize,
        (width, height): (u32, u32),
        encoding: TextureEncoding,
        data: &[u8],
    ) {
        let Some(atlas) = &proxy.atlas else {
            return;
        };
        let Some(&[x, y, w, h]) = atlas.rects.get(view) else {
            return;
        };
        // Only the BC paths need an owned `Texture` (to validate or decode it).
        let blocks = || Texture {
            width,
            height,
            encoding,
            data: data.to_vec(),
        };
        let texels: Result<std::borrow::Cow<[u8]>, String> = if (width, height) != (w, h) {
            Err(format!("{width}x{height}, the atlas holds {w}x{h}"))
        } else if atlas.format == wgpu::TextureFormat::Rgba8UnormSrgb {
            if encoding == TextureEncoding::Rgba8 {
                (data.len() == w as usize * h as usize * 4)
                    .then_some(std::borrow::Cow::Borrowed(data))
                    .ok_or_else(|| format!("{} bytes for {w}x{h} RGBA8", data.len()))
            } else {
                let texture = blocks();
                texture
                    .validate()
                    .map_err(|e| e.to_string())
                    .and_then(|()| texture.to_rgba8().map_err(|e| e.to_string()))
                    .map(std::borrow::Cow::Owned)
            }
        } else {
            // BC blocks as they are: validated, then written from the pack's bytes.
            blocks()
                .validate()
                .map_err(|e| e.to_string())
                .map(|()| std::borrow::Cow::Borrowed(data))
        };
        match texels {
            Ok(bytes) => {
                let (bytes_per_row, rows) = match atlas.format {
                    wgpu::TextureFormat::Bc1RgbaUnormSrgb => (w / 4 * 8, h / 4),
                    wgpu::TextureFormat::Bc3RgbaUnormSrgb => (w / 4 * 16, h / 4),
                    _ => (w * 4, h),
                };
                self.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &atlas.texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d { x, y, z: 0 },
                        aspect: wgpu::TextureAspect::All,
                    },
                    &bytes,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(bytes_per_row),
                        rows_per_image: Some(rows),
                    },
                    wgpu::Extent3d {
                        width: w,
                        height: h,
                        depth_or_array_layers: 1,
                    },
                );
            }
            Err(what) => eprintln!(
                "player: warning: capture texture not uploadable ({what}); that view is drawn as missing"
            ),
        }
        proxy.textures[view] = Some(atlas.view.clone());
        self.try_bind(proxy);
    }

    fn try_bind(&self, p: &mut GpuProxy) {
        self.proxy_maker().try_bind(p);
    }
}

impl ProxyMaker {
    fn buffer_init(&self, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        buffer_init(&self.device, label, contents, usage)
    }

    /// The GPU proxies of one pack's `proxies` (each its vertices and views), in
    /// pack order, each with the pack proxies it draws. A proxy is drawn alone
    /// ([`Renderer::create_proxy`]; its views are its slots), except that two
    /// classes are drawn in batches ([`proxy_batches`]) of members of one class and
    /// one encoding, up to [`PROXY_SLOTS`] views and [`BATCH_TEXELS`] texels in all,
    /// each batch one vertex buffer, one [`Atlas`] and one uniform, one bind group
    /// and one draw call, member k's views at consecutive slots from its base:
    /// layered impostors of one view (paper 001) when
    /// [`Renderer::set_impostor_batches`] is on ([`Renderer::create_impostor_batch`]),
    /// and mesh proxies (SV and MV meshes, clusters; paper 000 §3.2) when
    /// [`Renderer::set_mesh_batches`] is on ([`Renderer::create_mesh_batch`]); both
    /// are on by default. A batch whose atlas cannot be made is drawn member by
    /// member, as before.
    pub fn create_pack_proxies(&self, proxies: &[ProxySource]) -> Vec<(GpuProxy, Vec<usize>)> {
        let layered = format::pack::ProxyKind::LayeredImpostor as u32;
        let batchable: Vec<Option<(BatchKey, BatchCost)>> = proxies
            .iter()
            .map(
                |&ProxySource {
                     vertices, views, ..
                 }| {
                    let first = atlas_encoding(views)?;
                    let class = if vertices.is_empty() || views.len() > MAX_VIEWS {
                        None
                    } else if vertices.iter().all(|v| v.kind == layered) {
                        (self.impostor_batches && views.len() == 1).then_some(BatchClass::Impostors)
                    } else if vertices.iter().all(|v| v.kind != layered) {
                        self.mesh_batches.then_some(BatchClass::Meshes)
                    } else {
                        None
                    }?;
                    let cost = BatchCost {
                        slots: views.len(),
                        texels: views
                            .iter()
                            .map(|v| u64::from(v.width) * u64::from(v.height))
                            .sum(),
                    };
                    Some(((class, first), cost))
                },
            )
            .collect();
        let mut out = Vec::with_capacity(proxies.len());
        let limit = BatchCost {
            slots: PROXY_SLOTS,
            texels: BATCH_TEXELS,
        };
        for batch in proxy_batches(&batchable, limit) {
            if batch.len() > 1 {
                let members: Vec<ProxySource> = batch.iter().map(|&i| proxies[i]).collect();
                let made = match batchable[batch[0]] {
                    Some(((BatchClass::Impostors, ..), _)) => self.create_impostor_batch(&members),
                    Some(((BatchClass::Meshes, ..), _)) => self.create_mesh_batch(&members),
                    None => None,
                };
                if let Some(p) = made {
                    out.push((p, batch));
                    continue;
                }
            }
            for i in batch {
                out.push((self.create_proxy_from(&proxies[i]), vec![i]));
            }
        }
        out
    }

    /// Creates a proxy's vertex and uniform buffers, and its [`Atlas`] where it gets
    /// one; textures come later through [`Renderer::upload_view_texels`]. `views`:
    /// each view's world → texture matrix, eye, size and encoding (BC1 colours are
    /// premultiplied by coverage: punch-through alpha in format 4, fully opaque
    /// before, where it changes nothing).
    pub fn create_proxy(&self, vertices: &[ProxyVertex], views: &[ViewInfo]) -> GpuProxy {
        self.create_proxy_from(&ProxySource {
            vertices,
            views,
            clusters: None,
        })
    }

    /// [`Renderer::create_proxy`] of a [`ProxySource`] (its clusters used when given).
    fn create_proxy_from(&self, src: &ProxySource) -> GpuProxy {
        let layered = src
            .vertices
            .iter()
            .any(|v| v.kind == format::pack::ProxyKind::LayeredImpostor as u32);
        let atlas = if layered {
            None
        } else {
            self.create_atlas(src.views)
        };
        // Issue 17: triangles grouped by normal cluster for the per-frame test.
        let (vertices, clusters) = src.clustered(self.options.tile_size());
        self.finish_proxy(&vertices, clusters, src.views, atlas, layered)
    }

    /// A batch of layered impostors (paper 001 §4), each with its one view
    /// (`members`: one encoding), drawn as one proxy: member k's layer quads carry
    /// its slot (k) in bits 16–23 of their mask (bits 0–15: the layer's depth
    /// codes); `impostor_layer` reads that rectangle of the batch's [`Atlas`]
    /// ([`Renderer::create_batch`]).
    fn create_impostor_batch(&self, members: &[ProxySource]) -> Option<GpuProxy> {
        self.create_batch(members, true, |mask, base| (mask & 0xffff) | (base << 16))
    }

    /// A batch of mesh proxies (`members`: SV/MV meshes and clusters, paper 000
    /// §3.2, views of one encoding), drawn as one proxy with `fs_proxy_atlas`:
    /// member k's views take the slots from its base on, in their order, and its
    /// triangles carry the base in mask bits 16–23 beside their own view bits
    /// (0–7), so `vs_proxy_mesh` reads mask bit j as slot base + j and chooses the same
    /// views as for the member alone ([`Renderer::create_batch`]).
    fn create_mesh_batch(&self, members: &[ProxySource]) -> Option<GpuProxy> {
        self.create_batch(members, false, |mask, base| (mask & 0xff) | (base << 16))
    }

    /// One proxy drawing `members` (2 or more, [`PROXY_SLOTS`] views in all):
    /// member k's vertices, grouped by normal cluster as [`Renderer::create_proxy`]
    /// groups a lone proxy's (member by member, so each tile holds one member's
    /// triangles and culls as before), with their masks rewritten by
    /// `mask_of(mask, base)`, base being the slot of the member's first view; the
    /// uniform holds each view's `tex_from_world` and eye in its slot and its
    /// texture's rectangle of the batch's [`Atlas`]. `None` where the atlas cannot
    /// be made (`create_atlas`).
    fn create_batch(
        &self,
        members: &[ProxySource],
        layered: bool,
        mask_of: impl Fn(u32, u32) -> u32,
    ) -> Option<GpuProxy> {
        let views: Vec<ViewInfo> = members
            .iter()
            .flat_map(|m| m.views.iter().copied())
            .collect();
        if members.len() < 2 || views.len() > PROXY_SLOTS {
            return None;
        }
        let atlas = self.create_atlas(&views)?;
        let tile = self.options.tile_size();
        let mut vertices = Vec::new();
        let mut clusters = Vec::new();
        let mut base = 0u32;
        let mut spans = Vec::with_capacity(members.len());
        for member in members {
            let (v, c) = member.clustered(tile);
            let first = vertices.len() as u32;
            vertices.extend(v.iter().copied().map(|mut v| {
                v.mask = mask_of(v.mask, base);
                v
            }));
            base += member.views.len() as u32;
            spans.push((first, vertices.len() as u32));
            clusters.extend(c.into_iter().map(|mut c| {
                c.first += first;
                c
            }));
        }
        let mut p = self.finish_proxy(&vertices, clusters, &views, Some(atlas), layered);
        p.member_spans = spans;
        Some(p)
    }

    /// The proxy of `vertices` (already in cluster order, `clusters` over them) with
    /// `views` in its slots and `atlas` holding them, if any: its vertex buffer and
    /// view uniform; bound once its textures are there.
    fn finish_proxy(
        &self,
        vertices: &[ProxyVertex],
        clusters: Vec<crate::patches::ProxyCluster>,
        views: &[ViewInfo],
        atlas: Option<Atlas>,
        layered: bool,
    ) -> GpuProxy {
        let mut u = ProxyUniform::zeroed();
        for (i, v) in views.iter().take(PROXY_SLOTS).enumerate() {
            u.tex_from_world[i] = v.matrix;
            u.view_eye[i] = [v.eye[0], v.eye[1], v.eye[2], 1.0];
            u.counts[1] |= u32::from(v.encoding == TextureEncoding::Bc1) << i.min(31);
        }
        u.counts[0] = views.len().min(PROXY_SLOTS) as u32;
        let mut texture_bytes = 0;
        if let Some(a) = &atlas {
            let size = a.texture.size();
            u.counts[2] = size.width;
            u.counts[3] = size.height;
            for (r, rect) in u.rects.iter_mut().zip(&a.rects) {
                let (w, h) = (size.width as f32, size.height as f32);
                *r = [
                    rect[0] as f32 / w,
                    rect[1] as f32 / h,
                    rect[2] as f32 / w,
                    rect[3] as f32 / h,
                ];
            }
            texture_bytes = atlas_bytes(a.format, size.width, size.height) as u64;
        }
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
            member_spans: vec![(0, vertices.len() as u32)],
            uniform,
            textures: vec![None; views.len().min(PROXY_SLOTS)],
            bind_group: None,
            lit_bind_group,
            texture_bytes,
            vertex_bytes: std::mem::size_of_val(vertices) as u64,
            clusters,
            view_slots: setup::MESH_VIEW_SLOTS
                .iter()
                .position(|&n| n as usize >= views.len().min(MAX_VIEWS))
                .unwrap_or(setup::MESH_VIEW_SLOTS.len() - 1),
            layered,
            atlas,
            positions: if layered {
                Vec::new()
            } else {
                vertices.iter().map(|v| v.pos).collect()
            },
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

    /// The [`Atlas`] of a mesh proxy with `views`, where it gets one: two to
    /// [`PROXY_SLOTS`] views of one encoding with sides of at least 1 (multiples of 4
    /// for BC blocks), packed within the device's largest texture side. BC1/BC3 as
    /// they are where the device samples them natively, else RGBA8 (decoded on the
    /// CPU at upload, as the per-view path does). Every texel starts transparent
    /// ("nothing captured"), so a view whose texels cannot be used samples as a
    /// missing one does.
    fn create_atlas(&self, views: &[ViewInfo]) -> Option<Atlas> {
        let first = atlas_encoding(views)?;
        if views.len() < 2 || views.len() > PROXY_SLOTS {
            return None;
        }
        let native = self.options.bc_textures;
        let format = match first {
            TextureEncoding::Bc1 if native => wgpu::TextureFormat::Bc1RgbaUnormSrgb,
            TextureEncoding::Bc3 if native => wgpu::TextureFormat::Bc3RgbaUnormSrgb,
            TextureEncoding::Bc1 | TextureEncoding::Bc3 | TextureEncoding::Rgba8 => {
                wgpu::TextureFormat::Rgba8UnormSrgb
            }
            _ => return None,
        };
        let sizes: Vec<(u32, u32)> = views.iter().map(|v| (v.width, v.height)).collect();
        let max = self.device.limits().max_texture_dimension_2d;
        let ((width, height), rects) = pack_atlas(&sizes, max)?;
        let clear: Vec<u8> = match format {
            wgpu::TextureFormat::Bc1RgbaUnormSrgb => {
                TRANSPARENT_BC1.repeat((width / 4 * (height / 4)) as usize)
            }
            _ => vec![0; atlas_bytes(format, width, height)],
        };
        let texture = self.device.create_texture_with_data(
            &self.queue,
            &texture_2d(
                "capture atlas",
                (width, height),
                format,
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            ),
            wgpu::util::TextureDataOrder::LayerMajor,
            &clear,
        );
        let view = texture.create_view(&Default::default());
        Some(Atlas {
            texture,
            view,
            format,
            rects,
        })
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

/// One pack proxy for [`Renderer::create_pack_proxies`]: its vertices, its views and,
/// when the prefetch thread grouped them for the renderer's tile size
/// ([`crate::bake::cluster_cell`]), the clusters over `vertices` (then already in
/// cluster order).
#[derive(Clone, Copy, Debug)]
pub struct ProxySource<'a> {
    pub vertices: &'a [ProxyVertex],
    pub views: &'a [ViewInfo],
    pub clusters: Option<&'a [crate::patches::ProxyCluster]>,
}

impl ProxySource<'_> {
    /// The vertices in cluster order and the clusters: as given, or grouped now.
    fn clustered(
        &self,
        tile: usize,
    ) -> (
        std::borrow::Cow<'_, [ProxyVertex]>,
        Vec<crate::patches::ProxyCluster>,
    ) {
        match self.clusters {
            Some(c) => (std::borrow::Cow::Borrowed(self.vertices), c.to_vec()),
            None => {
                let (v, c) = crate::patches::cluster_proxy_vertices(self.vertices, tile);
                (std::borrow::Cow::Owned(v), c)
            }
        }
    }
}

/// What [`Renderer::create_proxy`] needs of a view before its texels arrive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewInfo {
    /// World → texture matrix.
    pub matrix: [f32; 16],
    /// The capture's eye.
    pub eye: [f32; 3],
    pub width: u32,
    pub height: u32,
    pub encoding: TextureEncoding,
}

/// A BC1 block that decodes to transparent black: both end colours 0 (so the block
/// is in three-colour mode) and every index 3 (transparent). An all-zero BC1 block
/// would be opaque black; all-zero BC3 and RGBA8 texels are transparent already.
const TRANSPARENT_BC1: [u8; 8] = [0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff];

/// Bytes of a `width` × `height` texture of `format` (RGBA8, BC1 or BC3).
fn atlas_bytes(format: wgpu::TextureFormat, width: u32, height: u32) -> usize {
    let blocks = (width / 4 * (height / 4)) as usize;
    match format {
        wgpu::TextureFormat::Bc1RgbaUnormSrgb => blocks * 8,
        wgpu::TextureFormat::Bc3RgbaUnormSrgb => blocks * 16,
        _ => width as usize * height as usize * 4,
    }
}

/// What a pack proxy may be batched as ([`Renderer::create_pack_proxies`]): the
/// two classes never share a batch (they are drawn with different pipelines).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BatchClass {
    /// A layered impostor with one view ([`Renderer::create_impostor_batch`]).
    Impostors,
    /// A mesh proxy ([`Renderer::create_mesh_batch`]).
    Meshes,
}

/// The one encoding of `views` when they can share an atlas: at least one view,
/// all of one encoding, sides of at least 1 (multiples of 4 for BC blocks).
fn atlas_encoding(views: &[ViewInfo]) -> Option<TextureEncoding> {
    let first = views.first()?.encoding;
    views
        .iter()
        .all(|v| {
            v.encoding == first
                && v.width > 0
                && v.height > 0
                && (!first.is_block() || (v.width % 4 == 0 && v.height % 4 == 0))
        })
        .then_some(first)
}

/// What a pack proxy may be batched with: its class and the encoding of its views.
pub(crate) type BatchKey = (BatchClass, TextureEncoding);

/// Most capture texels in one batch's atlas (4096², 8 MiB in BC1): a batch stays
/// well inside the 8192-texel side every adapter offers (`pack_atlas`'s shelves
/// waste some), and a cell's load does not clear one huge atlas at once.
pub(crate) const BATCH_TEXELS: u64 = 4096 * 4096;

/// What a proxy adds to a batch: view slots and capture texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BatchCost {
    pub slots: usize,
    pub texels: u64,
}

/// Which pack proxies are drawn together ([`Renderer::create_pack_proxies`]):
/// `batchable[i]` is proxy i's batch key (its class and the encoding of its views)
/// and cost when it may join a batch, else `None`. Proxies in pack order; each
/// batchable one joins the open batch of its key while that stays within `limit`
/// (slots and texels), else opens the key's next batch; a batch takes the place of
/// its first member (a group pack's impostors come sector by sector, bands by
/// distance: consecutive ones are neighbours, so a batch's bounds stay compact).
/// Every other proxy is a batch of its own. Each proxy is in exactly one batch,
/// members in pack order.
pub(crate) fn proxy_batches<K: Copy + PartialEq>(
    batchable: &[Option<(K, BatchCost)>],
    limit: BatchCost,
) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    // Per key: the batch being filled (an index of `out`) and what it holds.
    let mut open: Vec<(K, usize, BatchCost)> = Vec::new();
    for (i, b) in batchable.iter().enumerate() {
        let Some((key, cost)) = *b else {
            out.push(vec![i]);
            continue;
        };
        let found = open.iter().position(|&(e, _, _)| e == key);
        if let Some(k) = found {
            let (_, at, held) = &mut open[k];
            if held.slots + cost.slots <= limit.slots && held.texels + cost.texels <= limit.texels {
                out[*at].push(i);
                held.slots += cost.slots;
                held.texels += cost.texels;
                continue;
            }
            open.remove(k);
        }
        open.push((key, out.len(), cost));
        out.push(vec![i]);
    }
    out
}

/// An atlas's size and each view's rectangle (x, y, width, height) in it.
pub(crate) type PackedAtlas = ((u32, u32), Vec<[u32; 4]>);

/// Places rectangles of `sizes` (width, height) in shelves, tallest first (ties by
/// index), on rows about as wide as the square of their total area; every corner
/// and every row height a multiple of 4 (BC blocks). Returns the atlas's size and
/// each rectangle (x, y, width, height) in the order given; `None` when a side
/// would exceed `max` or nothing is given.
pub(crate) fn pack_atlas(sizes: &[(u32, u32)], max: u32) -> Option<PackedAtlas> {
    let r4 = |v: u32| v.div_ceil(4) * 4;
    let area: f64 = sizes
        .iter()
        .map(|&(w, h)| r4(w) as f64 * r4(h) as f64)
        .sum();
    let widest = sizes.iter().map(|&(w, _)| r4(w)).max()?;
    let row_width = widest.max(r4(area.sqrt().ceil() as u32));
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(sizes[i].1), i));
    let (mut x, mut y, mut row, mut width) = (0u32, 0u32, 0u32, 0u32);
    let mut rects = vec![[0u32; 4]; sizes.len()];
    for i in order {
        let (w, h) = sizes[i];
        if x > 0 && x + r4(w) > row_width {
            y += row;
            x = 0;
            row = 0;
        }
        rects[i] = [x, y, w, h];
        x += r4(w);
        row = row.max(r4(h));
        width = width.max(x);
    }
    let height = y + row;
    (width > 0 && height > 0 && width <= max && height <= max).then_some(((width, height), rects))
}

#[cfg(test)]
mod tests {
    use super::{pack_atlas, proxy_batches, BatchClass, BatchCost, TRANSPARENT_BC1};
    use format::pack::{Texture, TextureEncoding};

    /// The atlas's clear texels decode as "nothing captured" (alpha 0) in every
    /// format it is made in.
    #[test]
    fn atlas_clear_blocks_decode_transparent() {
        for (encoding, block) in [
            (TextureEncoding::Bc1, TRANSPARENT_BC1.to_vec()),
            (TextureEncoding::Bc3, vec![0u8; 16]),
        ] {
            let t = Texture {
                width: 8,
                height: 4,
                encoding,
                data: block.repeat(2),
            };
            let rgba = t.to_rgba8().unwrap();
            assert_eq!(rgba.len(), 8 * 4 * 4);
            assert!(rgba.chunks(4).all(|c| c[3] == 0), "{encoding:?}: {rgba:?}");
        }
        let opaque = Texture {
            width: 4,
            height: 4,
            encoding: TextureEncoding::Bc1,
            data: vec![0; 8],
        };
        assert!(opaque.to_rgba8().unwrap().chunks(4).all(|c| c[3] == 255));
    }

    /// Rectangles inside the atlas, on multiples of 4, never overlapping, each the
    /// size asked; too large for the side limit: none.
    #[test]
    fn atlas_rectangles_are_disjoint_aligned_and_inside() {
        let sizes = [
            (64, 32),
            (20, 100),
            (4, 4),
            (128, 8),
            (36, 36),
            (8, 60),
            (100, 100),
        ];
        let ((w, h), rects) = pack_atlas(&sizes, 8192).unwrap();
        assert_eq!(w % 4, 0);
        assert_eq!(h % 4, 0);
        for (k, (r, s)) in rects.iter().zip(&sizes).enumerate() {
            assert_eq!((r[2], r[3]), *s, "rect {k}");
            assert!(r[0] % 4 == 0 && r[1] % 4 == 0, "rect {k} at {r:?}");
            assert!(
                r[0] + r[2] <= w && r[1] + r[3] <= h,
                "rect {k} {r:?} outside {w}x{h}"
            );
            for (j, o) in rects.iter().enumerate().skip(k + 1) {
                let apart = r[0] + r[2] <= o[0]
                    || o[0] + o[2] <= r[0]
                    || r[1] + r[3] <= o[1]
                    || o[1] + o[3] <= r[1];
                assert!(apart, "rects {k} {r:?} and {j} {o:?} overlap");
            }
        }
        let used: u32 = sizes.iter().map(|(a, b)| a * b).sum();
        assert!(
            (w * h) as f64 <= 2.5 * used as f64,
            "{w}x{h} for {used} texels"
        );
        assert_eq!(pack_atlas(&[(5000, 5000), (5000, 5000)], 8192), None);
        assert_eq!(pack_atlas(&[], 8192), None);
    }

    /// Proxies of one key (class and encoding) share batches of at most `max`, in
    /// pack order, each batch where its first member was; other proxies stay alone;
    /// every proxy is drawn exactly once.
    #[test]
    fn proxy_batches_group_same_encoding_proxies() {
        let one = BatchCost {
            slots: 1,
            texels: 16,
        };
        let (r, b) = (
            Some((TextureEncoding::Rgba8, one)),
            Some((TextureEncoding::Bc3, one)),
        );
        let at_most = |n: usize| BatchCost {
            slots: n,
            texels: u64::MAX,
        };
        let plan = proxy_batches(&[None, r, r, b, r, None, b, r, r], at_most(3));
        assert_eq!(
            plan,
            vec![vec![0], vec![1, 2, 4], vec![3, 6], vec![5], vec![7, 8],]
        );
        let mut all: Vec<usize> = plan.into_iter().flatten().collect();
        all.sort_unstable();
        assert_eq!(all, (0..9).collect::<Vec<_>>());
        assert_eq!(
            proxy_batches(&[r; 17], at_most(8)),
            vec![(0..8).collect(), (8..16).collect(), vec![16]]
        );
        assert_eq!(
            proxy_batches::<()>(&[None, None], at_most(8)),
            vec![vec![0], vec![1]]
        );
        assert!(proxy_batches::<()>(&[], at_most(8)).is_empty());
    }

    /// Members fill a batch by their views and texels: one that would pass either
    /// limit opens the key's next batch, and one over a limit on its own stands
    /// alone (a batch of one).
    #[test]
    fn proxy_batches_respect_slots_and_texels() {
        let cost = |slots: usize, texels: u64| Some(((), BatchCost { slots, texels }));
        let limit = BatchCost {
            slots: 8,
            texels: 100,
        };
        let plan = proxy_batches(
            &[
                cost(7, 10),
                cost(1, 10),
                cost(7, 10),
                cost(2, 10),
                cost(1, 90),
                cost(1, 200),
            ],
            limit,
        );
        assert_eq!(plan, vec![vec![0, 1], vec![2], vec![3, 4], vec![5]]);
    }

    /// Layered impostors and mesh proxies of one encoding are batched
    /// apart (they are drawn with different pipelines).
    #[test]
    fn proxy_batches_keep_impostors_and_meshes_apart() {
        let e = TextureEncoding::Bc1;
        let one = BatchCost {
            slots: 1,
            texels: 1,
        };
        let (i, m) = (
            Some(((BatchClass::Impostors, e), one)),
            Some(((BatchClass::Meshes, e), one)),
        );
        let limit = BatchCost {
            slots: 8,
            texels: 8,
        };
        let plan = proxy_batches(&[m, i, m, None, i, m], limit);
        assert_eq!(plan, vec![vec![0, 2, 5], vec![1, 4], vec![3]]);
    }
}
