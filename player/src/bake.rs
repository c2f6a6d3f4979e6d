//! A bake output directory as the player reads it (DESIGN.md "Data flow"; paper 000
//! §3.2: "the original meshes are loaded into main memory before the navigation", cell
//! data is loaded per cell as object ids and vertex ids).
//!
//! `base.pack` is read once; cell packs are memory-mapped through
//! [`format::pack::PackFile::open`], validated against the base pack and turned into a
//! [`PreparedCell`]: de-indexed world-space proxy triangles with their view masks and
//! the decoded capture texels, ready for upload.

use crate::camera::Aabb;
use crate::grid::CellGrid;
use crate::vertex::{normal_matrix, InstanceRaw, ProxyVertex, MAX_VIEWS};
use format::pack::index::LEGACY_BASE_FILE;
use format::pack::{BasePack, CellPack, Index, PackError, PackFile, ProxyKind, TextureEncoding};
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why a bake or one of its cells cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("{path}: cannot read the base pack: {source}")]
    Base { path: PathBuf, source: PackError },
    #[error("{path}: cannot read the index: {source}")]
    Index { path: PathBuf, source: PackError },
    #[error("cell {cell}: not in the index")]
    NotIndexed { cell: u32 },
    #[error("cell {cell}: {path}: {source}")]
    CellPack {
        cell: u32,
        path: PathBuf,
        source: PackError,
    },
    #[error("cell {cell}: {path}: does not belong to this bake: {differs}; rebake the cell (`pipeline run`)")]
    NotThisBake {
        cell: u32,
        path: PathBuf,
        /// What differs from `index.pack` (size, checksum or job fingerprint), with
        /// both values.
        differs: String,
    },
    #[error("cell {cell}: {path}: holds cell {found}")]
    WrongCell {
        cell: u32,
        path: PathBuf,
        found: u32,
    },
    #[error("cell {cell}: proxy {proxy}: {what}")]
    BadProxy {
        cell: u32,
        proxy: usize,
        what: String,
    },
}

/// The base data of a bake, shared by the render thread and the prefetch thread.
pub struct Bake {
    pub dir: PathBuf,
    pub base: Arc<BasePack>,
    /// `None` when `index.pack` is missing or corrupt (every cell is then drawn as
    /// originals; the error was logged).
    pub index: Option<Arc<Index>>,
    pub grid: CellGrid,
    /// Per instance: GPU instance data and world bounds.
    pub instances: Vec<InstanceRaw>,
    pub instance_bounds: Vec<Aabb>,
    /// Distance that covers the whole ground (far plane).
    pub extent: f32,
    /// Patch data for drawing originals patch by patch (issue 17); `None` without
    /// it or with every test of [`Bake::options`] switched off.
    pub patches: Option<crate::patches::PatchRuntime>,
    /// The same tiles with only the exact tests of [`Bake::options`] (per-tile
    /// normal cone and frustum, no patch bitfields): the culling `frustum` mode's
    /// originals get (issue 30 item 2, fair culling); `None` without patch data or
    /// with both tests off.
    pub exact_patches: Option<crate::patches::PatchRuntime>,
    /// Per model, its triangles in tile order (`patches::refine_patches`) when the
    /// base pack has patch data: the order every mode uploads them in.
    pub draw_order: Option<Vec<Vec<u32>>>,
    /// What it was opened with: the culling tests of its originals and proxies and
    /// the tile size of its patches.
    pub options: crate::DrawOptions,
}

impl Bake {
    /// Reads `<dir>/index.pack` (logged if bad) and the base pack it names
    /// (required; `base.pack` for an index before format version 7, or without a
    /// good index); its patches are tiled and tested as `options` say. The index is
    /// read first and only the files it names after it (issue 32), so a bake being
    /// rebaked meanwhile is seen as one generation whole.
    pub fn open(dir: &Path, options: &crate::DrawOptions) -> Result<Bake, BakeError> {
        let index_path = dir.join("index.pack");
        let index = Index::read(&index_path);
        let base_path = dir.join(index.as_ref().map_or(LEGACY_BASE_FILE, |i| i.base_file()));
        let base = match &index {
            Ok(i) => i.read_base(dir),
            Err(_) => BasePack::read(&base_path),
        }
        .map_err(|source| BakeError::Base {
            path: base_path,
            source,
        })?;
        // An index that does not belong to the base pack's grid is as bad as a
        // corrupt one (issue 32: a neighbour that is not adjacent, a cell past the grid).
        let index = match index.and_then(|i| i.check_against(&base).map(|()| i)) {
            Ok(i) => Some(Arc::new(i)),
            Err(source) => {
                let e = BakeError::Index {
                    path: index_path,
                    source,
                };
                eprintln!("player: error: {e}; drawing every cell as original geometry");
                None
            }
        };
        Ok(Bake::from_parts(dir, base, index, options))
    }

    pub fn from_parts(
        dir: &Path,
        base: BasePack,
        index: Option<Arc<Index>>,
        options: &crate::DrawOptions,
    ) -> Bake {
        let model_bounds: Vec<Aabb> = base
            .models
            .iter()
            .map(|m| {
                let mut b = Aabb::EMPTY;
                for p in &m.mesh.positions {
                    b.add(Vec3::from_array(*p));
                }
                b
            })
            .collect();
        let mut instances = Vec::with_capacity(base.instances.len());
        let mut instance_bounds = Vec::with_capacity(base.instances.len());
        for inst in &base.instances {
            let t = Mat4::from_cols_array(&inst.transform);
            instances.push(InstanceRaw::new(t, Vec3::from_array(inst.tint)));
            instance_bounds.push(model_bounds[inst.model as usize].transformed(&t));
        }
        let g = &base.grid;
        let diag = Vec3::new(
            g.ground_max[0] - g.ground_min[0],
            g.max_eye_height.max(1.0),
            g.ground_max[1] - g.ground_min[1],
        )
        .length();
        let scene = instance_bounds.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let scene_diag = if scene.is_empty() {
            0.0
        } else {
            (scene.max - scene.min).length()
        };
        // Issue 17: the patches' tiles, once; the upload takes their triangle order.
        let (draw_order, tiles): (Vec<Vec<u32>>, Vec<_>) = match &base.patches {
            Some(set) => set
                .models
                .iter()
                .zip(&base.models)
                .map(|(m, model)| {
                    crate::patches::refine_patches(m, &model.mesh, options.tile_size())
                })
                .unzip(),
            None => (Vec::new(), Vec::new()),
        };
        let exact = crate::DrawOptions {
            patch_bitfields: false,
            ..*options
        };
        let exact_patches = crate::patches::PatchRuntime::new(&base, tiles.clone(), &exact);
        let patches = crate::patches::PatchRuntime::new(&base, tiles, options);
        Bake {
            options: *options,
            patches,
            exact_patches,
            draw_order: base.patches.is_some().then_some(draw_order),
            dir: dir.to_path_buf(),
            grid: CellGrid::new(base.grid),
            base: Arc::new(base),
            index,
            instances,
            instance_bounds,
            extent: diag.max(scene_diag) * 2.0 + 100.0,
        }
    }

    /// Maps, validates and prepares one cell pack.
    pub fn load_cell(&self, cell: u32) -> Result<PreparedCell, BakeError> {
        load_cell(&self.dir, self.index.as_deref(), &self.base, cell)
    }
}

/// Groups every proxy's triangles by normal cluster and tile of at most `tile`
/// triangles ([`crate::patches::cluster_proxy_vertices`], what the renderer does when
/// it creates a proxy), so that the prefetch thread does it and not the render
/// thread when the cell arrives (issue 31, "no hitch"). The same result either way.
pub fn cluster_cell(cell: &mut PreparedCell, tile: usize) {
    for p in &mut cell.proxies {
        if p.clusters.is_none() {
            let (vertices, clusters) = crate::patches::cluster_proxy_vertices(&p.vertices, tile);
            p.vertices = vertices;
            p.clusters = Some((tile, clusters));
        }
    }
}

/// The streaming key of far-field group `group` (format version 2,
/// `groups/<id>.pack`): keys below the grid's cell count are cells, the rest groups.
pub fn group_key(base: &BasePack, group: u32) -> u32 {
    base.grid.n_cols * base.grid.n_rows + group
}

/// Loads the pack of streaming key `cell` of the bake in `dir` (usable from any
/// thread): a cell, or a far-field group for a key from [`group_key`].
pub fn load_cell(
    dir: &Path,
    index: Option<&Index>,
    base: &BasePack,
    cell: u32,
) -> Result<PreparedCell, BakeError> {
    let cells = base.grid.n_cols * base.grid.n_rows;
    let group = cell.checked_sub(cells);
    let entry = index
        .and_then(|i| match group {
            Some(g) => i.group(g),
            None => i.cell(cell),
        })
        .ok_or(BakeError::NotIndexed { cell })?;
    let path = dir.join(&entry.file);
    let file = PackFile::open(&path).map_err(|source| BakeError::CellPack {
        cell,
        path: path.clone(),
        source,
    })?;
    // The pack must be the one the index lists (issue 19): same size and checksum
    // (a pack left from another bake or setting, or copied in, is refused), then
    // the same job fingerprint.
    let not_this_bake = |differs: String| BakeError::NotThisBake {
        cell,
        path: path.clone(),
        differs,
    };
    entry
        .verify_bytes(&path, file.bytes())
        .map_err(|e| not_this_bake(e.to_string()))?;
    let pack = match group {
        Some(_) => CellPack::decode_group(&file),
        None => CellPack::decode(&file),
    }
    .map_err(|source| BakeError::CellPack {
        cell,
        path: path.clone(),
        source,
    })?;
    if pack.fingerprint != entry.fingerprint {
        return Err(not_this_bake(format!(
            "its job fingerprint {} differs from index.pack's {}",
            format::fingerprint::to_hex(&pack.fingerprint),
            format::fingerprint::to_hex(&entry.fingerprint)
        )));
    }
    if pack.cell_id != group.unwrap_or(cell) {
        return Err(BakeError::WrongCell {
            cell,
            path,
            found: pack.cell_id,
        });
    }
    // A cell's far-field group, or a group's parent (format version 5).
    if pack.far_group != entry.group {
        return Err(not_this_bake(format!(
            "its far-field group or parent {:?} differs from index.pack's {:?}",
            pack.far_group, entry.group
        )));
    }
    pack.check_against(base)
        .map_err(|source| BakeError::CellPack {
            cell,
            path: path.clone(),
            source,
        })?;
    prepare_cell(base, &pack)
}

/// One capture ready for upload.
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedView {
    pub matrix: [f32; 16],
    pub eye: [f32; 3],
    pub width: u32,
    pub height: u32,
    /// What `data` holds: decoded RGBA8 sRGB texels ([`TextureEncoding::Rgba8`], for
    /// the lossless pack encodings) or the pack's BC1/BC3 blocks as they are (uploaded
    /// natively, or decoded at upload where the adapter lacks BC sampling:
    /// [`crate::gpu::Renderer::upload_view_texels`]).
    pub encoding: TextureEncoding,
    pub data: Vec<u8>,
}

/// One proxy ready for upload.
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedProxy {
    pub kind: ProxyKind,
    /// The member instances (what the player draws as original geometry while the
    /// proxy's textures are not uploaded yet).
    pub members: Vec<u32>,
    pub vertices: Vec<ProxyVertex>,
    pub bounds: Aabb,
    pub views: Vec<PreparedView>,
    /// `vertices` already in normal-cluster and tile order, with the clusters and
    /// the tile size they were made for ([`cluster_cell`], on the prefetch thread);
    /// `None`: the renderer groups them when it creates the proxy.
    pub clusters: Option<(usize, Vec<crate::patches::ProxyCluster>)>,
}

/// One cell ready for upload.
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedCell {
    pub cell_id: u32,
    pub originals: Vec<u32>,
    pub proxies: Vec<PreparedProxy>,
}

impl PreparedCell {
    /// Bytes the cell occupies once uploaded (vertices and texels).
    pub fn bytes(&self) -> u64 {
        self.proxies
            .iter()
            .map(|p| {
                (p.vertices.len() * std::mem::size_of::<ProxyVertex>()) as u64
                    + p.views.iter().map(|v| v.data.len() as u64).sum::<u64>()
            })
            .sum()
    }
}

/// The quads of a layered impostor (paper 001; format `ImpostorLayers`): per layer
/// two triangles at `eye + depth · corner_ray`, wound counter-clockwise as seen from
/// the eye; `mask` carries the layer's depth codes (`code_lo | code_hi << 8`) and
/// the shader draws only the texels whose alpha code lies between them.
fn impostor_quads(
    eye: [f32; 3],
    layers: &format::pack::ImpostorLayers,
    vertices: &mut Vec<ProxyVertex>,
    bounds: &mut Aabb,
) {
    let eye = Vec3::from_array(eye);
    let rays = layers.corner_rays.map(Vec3::from_array);
    let axis = (rays[0] + rays[1] + rays[2] + rays[3]).normalize_or_zero();
    for layer in &layers.layers {
        let c = rays.map(|r| eye + layer.depth * r);
        let centroid = 0.25 * (c[0] + c[1] + c[2] + c[3]);
        let mask = u32::from(layer.code_lo) | (u32::from(layer.code_hi) << 8);
        for k in [0, 3, 2, 0, 2, 1] {
            bounds.add(c[k]);
            vertices.push(ProxyVertex {
                pos: c[k].to_array(),
                normal: (-axis).to_array(),
                albedo: [255, 255, 255, 255],
                tint: [1.0; 3],
                mask,
                centroid: centroid.to_array(),
                kind: ProxyKind::LayeredImpostor as u32,
            });
        }
    }
}

/// Turns a validated cell pack into world-space proxy triangle lists. Members'
/// triangles index their model's vertices placed by the member instance's transform.
/// View masks: MvMesh per triangle from the pack; SvMesh and Cluster use view 0 for
/// every triangle; a proxy without views is drawn lit.
pub fn prepare_cell(base: &BasePack, pack: &CellPack) -> Result<PreparedCell, BakeError> {
    let cell = pack.cell_id;
    let mut proxies = Vec::with_capacity(pack.proxies.len());
    for (pi, proxy) in pack.proxies.iter().enumerate() {
        if proxy.views.len() > MAX_VIEWS {
            return Err(BakeError::BadProxy {
                cell,
                proxy: pi,
                what: format!("{} views, at most {MAX_VIEWS}", proxy.views.len()),
            });
        }
        let mut views = Vec::with_capacity(proxy.views.len());
        for (vi, v) in proxy.views.iter().enumerate() {
            let (encoding, data) = if v.texture.encoding.is_block() {
                v.texture.validate().map_err(|what| BakeError::BadProxy {
                    cell,
                    proxy: pi,
                    what: format!("view {vi}: {what}"),
                })?;
                (v.texture.encoding, v.texture.data.clone())
            } else {
                let rgba = v.texture.to_rgba8().map_err(|what| BakeError::BadProxy {
                    cell,
                    proxy: pi,
                    what: format!("view {vi}: {what}"),
                })?;
                (TextureEncoding::Rgba8, rgba)
            };
            views.push(PreparedView {
                matrix: v.matrix,
                eye: v.eye,
                width: v.texture.width,
                height: v.texture.height,
                encoding,
                data,
            });
        }
        let default_mask: u32 = if views.is_empty() { 0 } else { 1 };
        let mut vertices = Vec::new();
        let mut bounds = Aabb::EMPTY;
        if let (ProxyKind::LayeredImpostor, Some(layers), Some(v)) =
            (proxy.kind, &proxy.layers, proxy.views.first())
        {
            impostor_quads(v.eye, layers, &mut vertices, &mut bounds);
        }
        for m in &proxy.members {
            let inst =
                base.instances
                    .get(m.instance as usize)
                    .ok_or_else(|| BakeError::BadProxy {
                        cell,
                        proxy: pi,
                        what: format!("instance {} out of range", m.instance),
                    })?;
            let mesh = &base.models[inst.model as usize].mesh;
            let t = Mat4::from_cols_array(&inst.transform);
            let nm = normal_matrix(&t);
            for (k, tri) in m.triangles.iter().enumerate() {
                let mask = if proxy.kind == ProxyKind::MvMesh {
                    m.view_masks.get(k).copied().unwrap_or(0) as u32
                } else {
                    default_mask
                };
                let mut world = [Vec3::ZERO; 3];
                for (j, &v) in tri.iter().enumerate() {
                    let p = mesh
                        .positions
                        .get(v as usize)
                        .ok_or_else(|| BakeError::BadProxy {
                            cell,
                            proxy: pi,
                            what: format!("vertex {v} out of range"),
                        })?;
                    world[j] = t.transform_point3(Vec3::from_array(*p));
                }
                let centroid = (world[0] + world[1] + world[2]) / 3.0;
                for (j, &v) in tri.iter().enumerate() {
                    let n = nm * Vec3::from_array(mesh.normals[v as usize]);
                    bounds.add(world[j]);
                    vertices.push(ProxyVertex {
                        pos: world[j].to_array(),
                        normal: n.normalize_or_zero().to_array(),
                        // A textured model's vertex: its colour × the texture there
                        // (issue 18), for the lit fallback.
                        albedo: match &base.models[inst.model as usize].albedo_map {
                            Some(map) => map.vertex_albedo(mesh.albedo[v as usize], v as usize),
                            None => mesh.albedo[v as usize],
                        },
                        tint: inst.tint,
                        mask,
                        centroid: centroid.to_array(),
                        kind: proxy.kind as u32,
                    });
                }
            }
        }
        proxies.push(PreparedProxy {
            kind: proxy.kind,
            members: proxy.members.iter().map(|m| m.instance).collect(),
            vertices,
            bounds,
            views,
            clusters: None,
        });
    }
    Ok(PreparedCell {
        cell_id: cell,
        originals: pack.originals.clone(),
        proxies,
    })
}
