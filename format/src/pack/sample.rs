//! Deterministic sample packs: the content of the golden files under `tests/data/`,
//! the seeds of the fuzzers, and the synthetic "realistic" cell of the benchmark.
//! Public so that tests, fuzz targets and benches across crates build the very same
//! packs; nothing here is used by a bake.

use super::base::{BasePack, GridParams, PackedInstance, PackedModel};
use super::cell::{
    CellPack, ImpostorLayer, ImpostorLayers, Proxy, ProxyKind, ProxyMember, ProxyView,
};
use super::index::{Index, IndexEntry};
use super::texture::{Texture, TextureEncoding};
use crate::mesh::Mesh;

/// A small deterministic generator (the park's [`crate::rng::splitmix64`], with
/// its own `below` and `unit`), so samples need no `rand`.
#[derive(Clone, Debug)]
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        crate::rng::splitmix64(&mut self.0)
    }

    /// Uniform in [0, n) (n > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n.max(1)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A `cols × rows` height-field grid mesh (2 · cols · rows triangles), a stand-in
/// for a scanned model. Vertex ids are shuffled within blocks of 64, so index
/// buffers have the local-but-irregular order of real meshes rather than the
/// perfectly regular order of a generated grid (which zstd would shrink 60×).
pub fn grid_mesh(cols: u32, rows: u32, seed: u64) -> Mesh {
    let mut rng = SplitMix(seed);
    let vertex_count = (cols + 1) * (rows + 1);
    let mut perm: Vec<u32> = (0..vertex_count).collect();
    for block in perm.chunks_mut(64) {
        for i in (1..block.len()).rev() {
            block.swap(i, rng.below(i as u64 + 1) as usize);
        }
    }
    let mut mesh = Mesh::default();
    for r in 0..=rows {
        for c in 0..=cols {
            let y = 0.1 * rng.unit();
            mesh.positions
                .push([c as f32 / cols as f32, y, r as f32 / rows as f32]);
            mesh.normals.push([0.0, 1.0, 0.0]);
            mesh.albedo
                .push([(c * 255 / cols) as u8, (r * 255 / rows) as u8, 128, 255]);
        }
    }
    let w = cols + 1;
    for r in 0..rows {
        for c in 0..cols {
            let v = r * w + c;
            mesh.triangles.push([v, v + w, v + 1]);
            mesh.triangles.push([v + 1, v + w, v + w + 1]);
        }
    }
    // Renumber: vertex v moves to slot perm[v].
    let mut positions = vec![[0.0; 3]; mesh.positions.len()];
    let mut albedo = vec![[0; 4]; mesh.albedo.len()];
    for (v, &p) in perm.iter().enumerate() {
        positions[p as usize] = mesh.positions[v];
        albedo[p as usize] = mesh.albedo[v];
    }
    mesh.positions = positions;
    mesh.albedo = albedo;
    for t in &mut mesh.triangles {
        *t = t.map(|v| perm[v as usize]);
    }
    mesh
}

/// An image that looks like a capture (DESIGN.md "Shading"): fixed sky colour
/// around a Lambert-shaded (ambient 0.3, L = normalize(0.4, 1, 0.3)) ellipsoid whose
/// albedo is a procedural stripe pattern with texel-scale detail, sRGB8.
pub fn capture_like_rgba(width: u32, height: u32, seed: u64) -> Vec<u8> {
    let mut rng = SplitMix(seed);
    let (cx, cy) = (
        0.5 + 0.1 * (rng.unit() - 0.5),
        0.5 + 0.1 * (rng.unit() - 0.5),
    );
    let (rx, ry) = (0.3 + 0.15 * rng.unit(), 0.35 + 0.1 * rng.unit());
    let base = [
        0.4 + 0.5 * rng.unit(),
        0.4 + 0.5 * rng.unit(),
        0.3 + 0.4 * rng.unit(),
    ];
    let l = {
        let v = [0.4f32, 1.0, 0.3];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    };
    let srgb = |x: f32| -> u8 {
        let x = x.clamp(0.0, 1.0);
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5) as u8
    };
    let mut out = Vec::with_capacity(width as usize * height as usize * 4);
    for y in 0..height {
        for x in 0..width {
            let u = (x as f32 + 0.5) / width as f32;
            let v = (y as f32 + 0.5) / height as f32;
            let (dx, dy) = ((u - cx) / rx, (cy - v) / ry);
            let d2 = dx * dx + dy * dy;
            if d2 >= 1.0 {
                out.extend_from_slice(&[135, 180, 235, 255]); // sky
                continue;
            }
            let n = [dx, dy, (1.0 - d2).sqrt()];
            let ndl = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).max(0.0);
            let shade = 0.3 + 0.7 * ndl;
            let stripe = if ((dx * 9.0 + dy * 4.0).sin() * (dy * 13.0).cos()) > 0.0 {
                1.0
            } else {
                0.6
            };
            // Texel-scale procedural detail (DESIGN.md: an albedo pattern fine enough
            // that simplified geometry needs the capture): ±8% value noise.
            let h = SplitMix(seed ^ ((x as u64) << 32) ^ y as u64).next_u64();
            let stripe = stripe * (0.92 + 0.16 * ((h >> 40) as f32 / (1u64 << 24) as f32));
            out.extend_from_slice(&[
                srgb(base[0] * stripe * shade),
                srgb(base[1] * stripe * shade),
                srgb(base[2] * stripe * shade),
                255,
            ]);
        }
    }
    out
}

/// [`small_base`] with both models textured (issue 18): one 2 × 1 texture (red,
/// blue; REPEAT × CLAMP_TO_EDGE) shared by both, so the writer stores it once; the
/// first model's UVs step by ½ along u, the second's are constant.
pub fn small_base_textured() -> BasePack {
    use crate::albedo::{AlbedoMap, AlbedoTexture, Wrap};
    let mut base = small_base();
    let texture = AlbedoTexture {
        width: 2,
        height: 1,
        rgba: vec![255, 0, 0, 255, 0, 0, 255, 255],
        wrap: [Wrap::Repeat, Wrap::ClampToEdge],
    };
    let n0 = base.models[0].mesh.vertex_count();
    base.models[0].albedo_map = Some(AlbedoMap {
        uvs: (0..n0).map(|i| [i as f32 * 0.5, 1.0]).collect(),
        texture: texture.clone(),
    });
    let n1 = base.models[1].mesh.vertex_count();
    base.models[1].albedo_map = Some(AlbedoMap {
        uvs: vec![[0.25, 0.0]; n1],
        texture,
    });
    base
}

/// The content of `tests/data/base-v1.pack`.
pub fn small_base() -> BasePack {
    let tetra = Mesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        normals: vec![
            [-0.577, -0.577, -0.577],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        albedo: vec![
            [255, 0, 0, 255],
            [0, 255, 0, 255],
            [0, 0, 255, 255],
            [255, 255, 255, 255],
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    };
    let translate = |x: f32, z: f32| {
        let mut m = [0.0f32; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        m[12] = x;
        m[14] = z;
        m
    };
    BasePack {
        scene_fingerprint: *blake3::hash(b"hexbake sample scene").as_bytes(),
        grid: GridParams {
            ground_min: [0.0, 0.0],
            ground_max: [100.0, 80.0],
            cell_size: 10.0,
            min_eye_height: 1.5,
            max_eye_height: 2.0,
            n_cols: 7,
            n_rows: 6,
        },
        models: vec![
            PackedModel {
                name: "tetra".into(),
                content_hash: *blake3::hash(b"tetra").as_bytes(),
                mesh: tetra,
                albedo_map: None,
            },
            PackedModel {
                name: "grid-16".into(),
                content_hash: *blake3::hash(b"grid").as_bytes(),
                mesh: grid_mesh(16, 16, 7),
                albedo_map: None,
            },
        ],
        instances: vec![
            PackedInstance {
                model: 0,
                transform: translate(10.0, 12.0),
                tint: [1.0, 1.0, 1.0],
            },
            PackedInstance {
                model: 1,
                transform: translate(30.0, 40.0),
                tint: [0.8, 0.9, 1.0],
            },
            PackedInstance {
                model: 1,
                transform: translate(60.0, 20.0),
                tint: [1.0, 0.7, 0.7],
            },
        ],
        patches: None,
    }
}

fn view(eye: [f32; 3], side: u32, seed: u64, encoding: TextureEncoding) -> ProxyView {
    let mut matrix = [0.0f32; 16];
    for (i, m) in matrix.iter_mut().enumerate() {
        *m = (i as f32 * 0.25 + seed as f32).sin();
    }
    ProxyView {
        eye,
        matrix,
        texture: Texture::from_rgba8(side, side, &capture_like_rgba(side, side, seed), encoding)
            .expect("valid sample texture"),
    }
}

/// The content of `tests/data/cell-v1.pack`: one proxy of each v1 kind
/// (SvMesh, Cluster with two members, MvMesh with three views).
pub fn small_cell() -> CellPack {
    let base = small_base();
    let grid_tris = &base.models[1].mesh.triangles;
    let mv_tris: Vec<[u32; 3]> = grid_tris.iter().step_by(3).copied().collect();
    let mv_masks = (0..mv_tris.len())
        .map(|i| [1u8, 3, 6, 5, 7][i % 5])
        .collect();
    CellPack {
        cell_id: 12,
        fingerprint: *blake3::hash(b"hexbake sample cell 12").as_bytes(),
        far_group: None,
        originals: vec![0],
        proxies: vec![
            Proxy {
                kind: ProxyKind::SvMesh,
                members: vec![ProxyMember {
                    instance: 1,
                    triangles: grid_tris[..200].to_vec(),
                    view_masks: vec![],
                }],
                views: vec![view([35.0, 1.7, 25.0], 16, 1, TextureEncoding::Rgba8Left)],
                layers: None,
            },
            Proxy {
                kind: ProxyKind::Cluster,
                members: vec![
                    ProxyMember {
                        instance: 0,
                        triangles: vec![[0, 2, 1], [1, 2, 3]],
                        view_masks: vec![],
                    },
                    ProxyMember {
                        instance: 2,
                        triangles: grid_tris[100..180].to_vec(),
                        view_masks: vec![],
                    },
                ],
                views: vec![view([35.0, 1.7, 25.0], 8, 2, TextureEncoding::Rgba8)],
                layers: None,
            },
            Proxy {
                kind: ProxyKind::MvMesh,
                members: vec![ProxyMember {
                    instance: 2,
                    triangles: mv_tris,
                    view_masks: mv_masks,
                }],
                views: vec![
                    view([35.0, 1.7, 25.0], 8, 3, TextureEncoding::Rgba8Left),
                    view([45.0, 1.7, 25.0], 8, 4, TextureEncoding::Rgba8Left),
                    view([40.0, 1.7, 33.0], 8, 5, TextureEncoding::Rgba8Left),
                ],
                layers: None,
            },
        ],
    }
}

/// The content of `tests/data/index-v1.pack`.
pub fn small_index() -> Index {
    let entry = |cell_id: u32, neighbours: Vec<u32>| IndexEntry {
        cell_id,
        file: format!("cells/{cell_id}.pack"),
        bytes: 1000 + cell_id as u64 * 37,
        checksum: *blake3::hash(&cell_id.to_le_bytes()).as_bytes(),
        neighbours,
        fingerprint: *blake3::hash(format!("job {cell_id}").as_bytes()).as_bytes(),
        group: None,
    };
    Index {
        build_fingerprint: *blake3::hash(b"hexbake sample build").as_bytes(),
        cells: vec![
            entry(5, vec![6, 12]),
            entry(6, vec![5, 12, 13]),
            entry(12, vec![5, 6]),
            entry(13, vec![]),
        ],
        groups: Vec::new(),
        base: None,
    }
}

/// The 13 × 10 capture with coverage of [`small_cell_v2`] and [`small_cell_v4`]: its
/// background (sky-coloured texels) not covered.
fn covered_capture_rgba() -> Vec<u8> {
    let mut covered = capture_like_rgba(13, 10, 11);
    for t in covered.chunks_exact_mut(4) {
        if t[..3] == [135, 180, 235] {
            t[3] = 0;
        }
    }
    covered
}

/// `cell` without the proxy members that are also its originals (and without the
/// proxies left with no member). The shipped sample cells list instance 0 both as an
/// original and as a member of their cluster, which readers refuse since issue 32
/// (`CellPack::check_against`); no bake writes that.
pub fn without_overlap(mut cell: CellPack) -> CellPack {
    let originals = cell.originals.clone();
    for p in &mut cell.proxies {
        p.members.retain(|m| !originals.contains(&m.instance));
    }
    cell.proxies.retain(|p| !p.members.is_empty());
    cell
}

/// The content of `tests/data/cell-v2.pack`: [`small_cell`] in far-field group 3, with
/// a BC3 and a BC1 texture (proxies 0 and 1, view 0).
pub fn small_cell_v2() -> CellPack {
    let mut cell = CellPack {
        far_group: Some(3),
        ..small_cell()
    };
    // Block-compressed textures (issue 15): a BC3 capture with coverage in alpha
    // (13 × 10 padded to 16 × 12) and an opaque BC1 one (6 × 9 padded to 8 × 12).
    let covered = covered_capture_rgba();
    cell.proxies[0].views[0].texture =
        Texture::from_rgba8_block(13, 10, &covered).expect("BC3 sample");
    let mut opaque = capture_like_rgba(6, 9, 12);
    for t in opaque.chunks_exact_mut(4) {
        t[3] = 255;
    }
    cell.proxies[1].views[0].texture =
        Texture::from_rgba8_block(6, 9, &opaque).expect("BC1 sample");
    cell
}

/// The content of `tests/data/cell-v4.pack`: [`small_cell_v2`] with its BC3 capture
/// written as format 4 writes coverage textures, BC1 with punch-through alpha
/// ([`Texture::from_rgba8_bc1_coverage`]).
pub fn small_cell_v4() -> CellPack {
    let mut cell = small_cell_v2();
    let covered = covered_capture_rgba();
    cell.proxies[0].views[0].texture =
        Texture::from_rgba8_bc1_coverage(13, 10, &covered).expect("BC1 coverage sample");
    cell
}

/// The content of `tests/data/cell-impostor-v3.pack` and `cell-impostor-v4.pack` (issue 16): [`small_cell_v2`]
/// plus a LayeredImpostor of instance 2 with three overlapping layers; its RGBA8
/// texture carries depth codes in alpha (0 outside a disc, 1..=255 inside).
pub fn small_cell_impostor() -> CellPack {
    let mut cell = small_cell_v2();
    let (w, h) = (12u32, 10u32);
    let mut rgba = capture_like_rgba(w, h, 13);
    for y in 0..h {
        for x in 0..w {
            let o = ((y * w + x) * 4 + 3) as usize;
            let (dx, dy) = (x as f32 - 5.5, y as f32 - 4.5);
            let r2 = dx * dx + dy * dy;
            rgba[o] = if r2 > 20.0 {
                0
            } else {
                1 + (r2 / 20.0 * 254.0) as u8
            };
        }
    }
    let mut v = view([35.0, 1.7, 25.0], 4, 14, TextureEncoding::Rgba8);
    v.texture = Texture::from_rgba8(w, h, &rgba, TextureEncoding::Rgba8).expect("sample");
    cell.proxies.push(Proxy {
        kind: ProxyKind::LayeredImpostor,
        members: vec![ProxyMember {
            instance: 2,
            triangles: Vec::new(),
            view_masks: Vec::new(),
        }],
        views: vec![v],
        layers: Some(ImpostorLayers {
            corner_rays: [
                [-0.1, 0.1, -1.0],
                [0.1, 0.1, -1.0],
                [0.1, -0.1, -1.0],
                [-0.1, -0.1, -1.0],
            ],
            near: 20.0,
            far: 24.0,
            layers: vec![
                ImpostorLayer {
                    depth: 20.6,
                    code_lo: 1,
                    code_hi: 86,
                },
                ImpostorLayer {
                    depth: 21.9,
                    code_lo: 85,
                    code_hi: 171,
                },
                ImpostorLayer {
                    depth: 23.3,
                    code_lo: 170,
                    code_hi: 255,
                },
            ],
        }),
    });
    cell
}

/// The content of `tests/data/group-v2.pack`: far-field group 3, the SvMesh and the
/// Cluster of [`small_cell`].
pub fn small_group() -> CellPack {
    let cell = small_cell();
    CellPack {
        cell_id: 3,
        fingerprint: *blake3::hash(b"hexbake sample group 3").as_bytes(),
        far_group: None,
        originals: Vec::new(),
        proxies: cell.proxies[..2].to_vec(),
    }
}

/// The content of `tests/data/group-v5.pack`: [`small_group`] naming its parent,
/// group 7 (format version 5, issue 27).
pub fn small_group_v5() -> CellPack {
    CellPack {
        far_group: Some(7),
        ..small_group()
    }
}

/// The content of `tests/data/index-v5.pack`: [`small_index_v2`] with a level-2
/// group 7 that is the parent of groups 1 and 3 (format version 5, issue 27).
pub fn small_index_v5() -> Index {
    let mut index = small_index_v2();
    for g in &mut index.groups {
        g.group = Some(7);
    }
    index.groups.push(IndexEntry {
        cell_id: 7,
        file: "groups/7.pack".into(),
        bytes: 2007,
        checksum: *blake3::hash(b"group 7").as_bytes(),
        neighbours: Vec::new(),
        fingerprint: *blake3::hash(b"group job 7").as_bytes(),
        group: None,
    });
    index
}

/// The content of `tests/data/index-v7.pack`: [`small_index_v5`] naming its
/// generation's base pack, [`small_base`] published under a name of its content
/// (format version 7, issue 32).
pub fn small_index_v7() -> Index {
    let base = small_base().encode().expect("the sample base encodes");
    let checksum = *blake3::hash(&base).as_bytes();
    Index {
        base: Some(super::BaseEntry {
            file: format!("base-{}.pack", &crate::fingerprint::to_hex(&checksum)[..16]),
            bytes: base.len() as u64,
            checksum,
        }),
        ..small_index_v5()
    }
}

/// The content of `tests/data/index-v2.pack`: [`small_index`] plus far-field groups
/// 1 (cells 5, 6) and 3 (cells 12, 13).
pub fn small_index_v2() -> Index {
    let mut index = small_index();
    for c in &mut index.cells {
        c.group = Some(if c.cell_id < 10 { 1 } else { 3 });
    }
    index.groups = [1u32, 3]
        .iter()
        .map(|&g| IndexEntry {
            cell_id: g,
            file: format!("groups/{g}.pack"),
            bytes: 2000 + u64::from(g),
            checksum: *blake3::hash(format!("group {g}").as_bytes()).as_bytes(),
            neighbours: Vec::new(),
            fingerprint: *blake3::hash(format!("group job {g}").as_bytes()).as_bytes(),
            group: None,
        })
        .collect();
    index
}

/// A base pack whose models are `model_count` grid meshes of `tris_per_model`
/// triangles (rounded to an even grid), one instance each.
pub fn synthetic_base(model_count: u32, tris_per_model: u32) -> BasePack {
    let side = ((tris_per_model / 2) as f32).sqrt().max(1.0) as u32;
    let mut base = small_base();
    base.models = (0..model_count)
        .map(|i| PackedModel {
            name: format!("model-{i}"),
            content_hash: *blake3::hash(&i.to_le_bytes()).as_bytes(),
            mesh: grid_mesh(side, side, i as u64),
            albedo_map: None,
        })
        .collect();
    base.instances = (0..model_count)
        .map(|i| PackedInstance {
            model: i,
            transform: small_base().instances[0].transform,
            tint: [1.0; 3],
        })
        .collect();
    base
}

/// A proxy-like subset of `triangles`: runs of 7 kept, 7 dropped, as a
/// half-edge-collapse simplifier keeping original vertices leaves them.
pub fn proxy_like_subset(triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    triangles
        .iter()
        .enumerate()
        .filter(|(i, _)| (i / 7) % 2 == 0)
        .map(|(_, t)| *t)
        .collect()
}

/// A cell of realistic size for benchmarks: `proxy_count` proxies over the models of
/// [`synthetic_base`] with about `total_triangles` triangles in all (each proxy a
/// [`proxy_like_subset`] of its model's triangles), every
/// `mv_every`-th proxy an MvMesh with three views, the others SvMesh with one, and
/// captures of `texture_side`² to `2 · texture_side`² texels (capture-like images).
pub fn synthetic_cell(
    proxy_count: u32,
    total_triangles: u32,
    mv_every: u32,
    texture_side: u32,
) -> CellPack {
    let base = synthetic_base(proxy_count, total_triangles / proxy_count.max(1) * 2);
    let mut rng = SplitMix(99);
    let mut proxies = Vec::new();
    for p in 0..proxy_count {
        let tris = &base.models[p as usize].mesh.triangles;
        let kept = proxy_like_subset(tris);
        let mv = mv_every > 0 && p % mv_every == mv_every - 1;
        let (kind, n_views) = if mv {
            (ProxyKind::MvMesh, 3usize)
        } else {
            (ProxyKind::SvMesh, 1)
        };
        let masks = if mv {
            kept.iter().map(|_| rng.below(7) as u8 + 1).collect()
        } else {
            Vec::new()
        };
        let views = (0..n_views)
            .map(|v| {
                let side = texture_side + (rng.below(texture_side as u64 + 1) as u32 & !15);
                let seed = p as u64 * 8 + v as u64;
                let mut pv = view(
                    [p as f32, 1.7, v as f32],
                    side,
                    seed,
                    TextureEncoding::Rgba8,
                );
                pv.texture =
                    Texture::from_rgba8_smallest(side, side, &capture_like_rgba(side, side, seed))
                        .expect("valid texture");
                pv
            })
            .collect();
        proxies.push(Proxy {
            kind,
            members: vec![ProxyMember {
                instance: p,
                triangles: kept,
                view_masks: masks,
            }],
            views,
            layers: None,
        });
    }
    CellPack {
        cell_id: 42,
        fingerprint: *blake3::hash(b"synthetic").as_bytes(),
        far_group: None,
        originals: (0..proxy_count).step_by(5).collect(),
        proxies,
    }
}

/// One fuzz input for a pack reader (the `fuzz/` targets of the base, cell and index
/// packs): `read` of `bytes` as they are, every section of them decoded, `read` of
/// them resealed ([`reseal`]) and of a structure-aware edit ([`mutate_decoded`], an
/// edit picked by a hash of the bytes). Results are dropped: a panic is the bug.
pub fn exercise_reader<T, E>(bytes: &[u8], read: impl Fn(&[u8]) -> Result<T, E>) {
    let _ = read(bytes);
    if let Ok(pack) = super::PackFile::from_bytes(bytes) {
        for s in pack.sections() {
            let _ = pack.section(s.kind);
        }
    }
    let mut resealed = bytes.to_vec();
    if reseal(&mut resealed) {
        let _ = read(&resealed);
    }
    let pick = bytes
        .iter()
        .fold(0u64, |h, &b| h.rotate_left(5) ^ u64::from(b));
    if let Some(edited) = mutate_decoded(bytes, pick) {
        let _ = read(&edited);
    }
}

/// Recomputes, in place, every section checksum and the header checksum of `bytes`
/// wherever the header and table are readable enough to locate them; returns whether
/// anything could be resealed. For fuzzers and tests only: it lets a mutated pack get
/// past the checksums so the *content* validation of the decoders is exercised too.
pub fn reseal(bytes: &mut [u8]) -> bool {
    use super::layout::{
        header_checksum, ENTRY_SIZE, HEADER_CHECKED_LEN, HEADER_SIZE, MAX_SECTIONS,
    };
    if bytes.len() < HEADER_SIZE {
        return false;
    }
    let count = u32::from_le_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
    if count > MAX_SECTIONS {
        return false;
    }
    let table_end = HEADER_SIZE + count as usize * ENTRY_SIZE;
    if bytes.len() < table_end {
        return false;
    }
    for i in 0..count as usize {
        let e = HEADER_SIZE + i * ENTRY_SIZE;
        let field =
            |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap_or([0; 8]));
        let (offset, stored) = (field(bytes, e + 8), field(bytes, e + 16));
        let Some(end) = offset.checked_add(stored) else {
            continue;
        };
        if end > bytes.len() as u64 {
            continue;
        }
        let sum = *blake3::hash(&bytes[offset as usize..end as usize]).as_bytes();
        bytes[e + 32..e + 64].copy_from_slice(&sum);
    }
    let sum = header_checksum(&bytes[..HEADER_CHECKED_LEN], &bytes[HEADER_SIZE..table_end]);
    bytes[HEADER_CHECKED_LEN..HEADER_SIZE].copy_from_slice(&sum);
    true
}

/// Runs every reader on `bytes` (and, when the input parses, every section's lazy
/// decoding): what the fuzz targets and the stable fuzz driver call. Returns how many
/// readers accepted the input. Must never panic.
pub fn exercise_readers(bytes: &[u8]) -> usize {
    use super::reader::PackFile;
    let mut accepted = 0;
    accepted += BasePack::from_bytes(bytes).is_ok() as usize;
    // Decoded cells and groups also decode every texture (BC blocks included).
    let textures = |cell: &CellPack| {
        for v in cell.proxies.iter().flat_map(|p| &p.views) {
            let _ = v.texture.to_rgba8();
        }
    };
    let cell = CellPack::from_bytes(bytes);
    if let Ok(c) = &cell {
        textures(c);
    }
    accepted += cell.is_ok() as usize;
    let group = CellPack::group_from_bytes(bytes);
    if let Ok(g) = &group {
        textures(g);
    }
    accepted += group.is_ok() as usize;
    accepted += Index::from_bytes(bytes).is_ok() as usize;
    if let Ok(pack) = PackFile::from_bytes(bytes) {
        for s in pack.sections() {
            let _ = pack.section(s.kind);
            let _ = pack.raw_slice::<[f32; 3]>(s.kind);
        }
    }
    accepted
}

/// Structure-aware mutation (issue 19): `bytes` (a pack that parses) with an
/// interesting 4-byte value — NaN, ±∞, −1.0, 0, 1e30, 1e-30, `u32::MAX`, 1 — written at a
/// 4-aligned offset of one section's *decoded* content, re-assembled with every
/// checksum valid, so that the content validation is what gets exercised, not the
/// checksums. `pick` chooses section, offset and value. `None` when `bytes` does not
/// parse, has no non-empty section, or cannot be re-assembled.
pub fn mutate_decoded(bytes: &[u8], pick: u64) -> Option<Vec<u8>> {
    use super::writer::{assemble, SectionData, TRY_INDICES};
    let pack = super::PackFile::from_bytes(bytes).ok()?;
    let mut sections: Vec<SectionData> = pack
        .sections()
        .iter()
        .map(|s| {
            Some(SectionData::new(
                s.kind,
                pack.section(s.kind).ok()?.into_owned(),
                TRY_INDICES,
            ))
        })
        .collect::<Option<_>>()?;
    let candidates: Vec<usize> = (0..sections.len())
        .filter(|&i| sections[i].raw.len() >= 4)
        .collect();
    if candidates.is_empty() {
        return None;
    }
    let mut rng = SplitMix(pick);
    let s = &mut sections[candidates[rng.below(candidates.len() as u64) as usize]];
    let at = (rng.below((s.raw.len() / 4) as u64) * 4) as usize;
    let values: [u32; 9] = [
        f32::NAN.to_bits(),
        f32::INFINITY.to_bits(),
        f32::NEG_INFINITY.to_bits(),
        (-1.0f32).to_bits(),
        0,
        1e30f32.to_bits(),
        1e-30f32.to_bits(),
        u32::MAX,
        1,
    ];
    let v = values[rng.below(values.len() as u64) as usize];
    s.raw[at..at + 4].copy_from_slice(&v.to_le_bytes());
    assemble(pack.file_kind(), &sections).ok()
}

/// [`small_base`] with patch data (issue 17, sections 0x010B–0x010D): each model's
/// triangles in patches of consecutive ids taken in reverse, flat normal cones
/// around +y, seeded sample bits over 18 directions × 2 shells.
pub fn small_base_patches() -> BasePack {
    use super::patches::{ModelPatch, ModelPatches, PatchSet};
    use crate::patch_visibility::{direction_count, PatchBounds};
    let mut base = small_base();
    let (level, shells) = (1u32, vec![1.5f32, 8.0]);
    let samples = direction_count(level) * shells.len();
    let words = samples.div_ceil(32);
    let mut rng = SplitMix(17);
    let models = base
        .models
        .iter()
        .map(|m| {
            let n = m.mesh.triangles.len() as u32;
            let per = n.div_ceil(3).max(1);
            let mut patches = Vec::new();
            let mut start = 0;
            while start < n {
                let count = per.min(n - start);
                let mut bits: Vec<u32> = (0..words).map(|_| rng.next_u64() as u32).collect();
                let spare = words * 32 - samples;
                if spare > 0 {
                    bits[words - 1] &= u32::MAX >> spare;
                }
                patches.push(ModelPatch {
                    triangle_count: count,
                    bounds: PatchBounds {
                        cone_axis: [0.0, 1.0, 0.0],
                        cone_cos: if start == 0 { -1.0 } else { 0.5 },
                        centre: [0.5, 0.25 * start as f32, 0.5],
                        offset: 0.125,
                    },
                    samples: bits,
                });
                start += count;
            }
            ModelPatches {
                centre: [0.5, 0.5, 0.5],
                radius: 2.0,
                patches,
                triangle_order: (0..n).rev().collect(),
            }
        })
        .collect();
    base.patches = Some(PatchSet {
        sample_level: level,
        shell_radius: shells,
        models,
    });
    base
}
