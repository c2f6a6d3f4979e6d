//! Synthetic bake outputs for tests (no bake is needed): `base.pack` from
//! `manifests/demo.ron`'s procedural park, `index.pack`, and one cell pack per cell
//! with hand-made proxies of every drawable kind (paper 000 §3: SvMesh, Cluster,
//! MvMesh with per-triangle view masks), written with `format`'s writer API.
//!
//! The proxies' textures are flat patterns, not real captures: they exercise the
//! player's projective texturing, masks and streaming, not the bake's quality.

use crate::camera::Camera;
use format::manifest::{parse_manifest, CellParams};
use format::pack::{
    BasePack, CellPack, GridParams, Index, IndexEntry, PackError, PackedInstance, PackedModel,
    Proxy, ProxyKind, ProxyMember, ProxyView, Texture, TextureEncoding,
};
use format::{Ground, Mesh};
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::path::{Path, PathBuf};

const SQRT3: f64 = 1.732_050_807_568_877_2;

/// Why synthetic data could not be written.
#[derive(Debug, thiserror::Error)]
pub enum TestDataError {
    #[error("{0}")]
    Manifest(String),
    #[error("{0}")]
    Pack(#[from] PackError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The grid parameters the worker's `HexGrid` builds for a ground and cell size
/// (N = ceil(W / 1.5c), M = ceil(H / √3c + 1/2)).
pub fn grid_params(ground: Ground, cells: &CellParams) -> GridParams {
    let c = cells.cell_size as f64;
    let [w, h] = ground.size();
    let eps = 1e-6;
    let n_cols = ((w as f64 / (1.5 * c)) - eps).ceil().max(1.0) as u32;
    let n_rows = ((h as f64 / (SQRT3 * c)) + 0.5 - eps).ceil().max(1.0) as u32;
    GridParams {
        ground_min: ground.min,
        ground_max: ground.max,
        cell_size: cells.cell_size,
        min_eye_height: cells.min_eye_height,
        max_eye_height: cells.max_eye_height,
        n_cols,
        n_rows,
    }
}

/// World → texture coordinates of a capture taken with `camera` (column-major):
/// `uv = (M·p).xy / (M·p).w` with u = (ndc.x + 1)/2 to the right and
/// v = (1 − ndc.y)/2 downwards, so texel row 0 is the top of the capture (the worker's
/// pixel convention).
pub fn texture_matrix(camera: &Camera) -> [f32; 16] {
    let bias = Mat4::from_cols(
        Vec4::new(0.5, 0.0, 0.0, 0.0),
        Vec4::new(0.0, -0.5, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(0.5, 0.5, 0.0, 1.0),
    );
    (bias * camera.clip_from_world_gl()).to_cols_array()
}

/// A capture camera from `eye` that frames a box.
pub fn capture_camera(eye: Vec3, min: Vec3, max: Vec3, size: u32) -> Camera {
    let centre = (min + max) * 0.5;
    let r = (max - min).length() * 0.5;
    let mut dir = centre - eye;
    let d = dir.length();
    if d < 1e-3 {
        dir = Vec3::NEG_Z;
    }
    let half = if d > r * 1.01 {
        (r / d).asin() * 1.05
    } else {
        60f32.to_radians()
    };
    Camera {
        eye,
        dir,
        fov_y_deg: (2.0 * half).to_degrees().clamp(2.0, 150.0),
        width: size,
        height: size,
        near: 0.05,
        far: d + r + 10.0,
    }
}

/// What [`write_synthetic_bake`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntheticBake {
    pub grid: GridParams,
    pub cells: u32,
    pub instances: usize,
    pub triangles: u64,
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn grid_centre(g: &GridParams, id: u32) -> Vec2 {
    let c = g.cell_size as f64;
    let w = (g.ground_max[0] - g.ground_min[0]) as f64;
    let origin_x = g.ground_min[0] as f64 + (w - (g.n_cols - 1) as f64 * 1.5 * c) / 2.0;
    let (col, row) = (id % g.n_cols, id / g.n_cols);
    let odd = if col % 2 == 1 { SQRT3 * c / 2.0 } else { 0.0 };
    Vec2::new(
        (origin_x + col as f64 * 1.5 * c) as f32,
        (g.ground_min[1] as f64 + row as f64 * SQRT3 * c + odd) as f32,
    )
}

fn neighbours(g: &GridParams, id: u32) -> Vec<u32> {
    let c = grid_centre(g, id);
    (0..g.n_cols * g.n_rows)
        .filter(|&o| o != id && grid_centre(g, o).distance(c) < 1.8 * g.cell_size)
        .collect()
}

fn write_index(dir: &Path, grid: &GridParams, fingerprint: [u8; 32]) -> Result<(), TestDataError> {
    let mut cells = Vec::new();
    for id in 0..grid.n_cols * grid.n_rows {
        cells.push(IndexEntry::for_file(
            dir,
            &format!("cells/{id}.pack"),
            id,
            neighbours(grid, id),
            fingerprint,
        )?);
    }
    Index {
        build_fingerprint: fingerprint,
        cells,
        groups: Vec::new(),
        base: None,
    }
    .write(&dir.join("index.pack"))?;
    Ok(())
}

fn mkdir(p: &Path) -> Result<(), TestDataError> {
    std::fs::create_dir_all(p).map_err(|source| TestDataError::Io {
        path: p.to_path_buf(),
        source,
    })
}

/// A `size²` texture: a two-tone checker of `colour` (8 squares across).
fn checker(colour: [u8; 4], size: u32) -> Texture {
    let dark = [
        (colour[0] as f32 * 0.8) as u8,
        (colour[1] as f32 * 0.8) as u8,
        (colour[2] as f32 * 0.8) as u8,
        255,
    ];
    let rgba: Vec<u8> = (0..size * size)
        .flat_map(|i| {
            let (x, y) = (i % size, i / size);
            if ((x * 8 / size) + (y * 8 / size)).is_multiple_of(2) {
                [colour[0], colour[1], colour[2], 255]
            } else {
                dark
            }
        })
        .collect();
    Texture::from_rgba8(size, size, &rgba, TextureEncoding::Rgba8Left)
        .expect("size and length agree")
}

fn mean_colour(mesh: &Mesh, tint: [f32; 3]) -> [u8; 4] {
    let n = mesh.albedo.len().max(1) as f32;
    let mut s = [0f32; 3];
    for a in &mesh.albedo {
        for k in 0..3 {
            s[k] += a[k] as f32;
        }
    }
    [
        (s[0] / n * tint[0]).min(255.0) as u8,
        (s[1] / n * tint[1]).min(255.0) as u8,
        (s[2] / n * tint[2]).min(255.0) as u8,
        255,
    ]
}

/// Writes `base.pack`, `index.pack` and `cells/<id>.pack` for the demo park into
/// `dir`. In each cell the instances whose centre lies within 1.2·c of the cell centre
/// are originals; of the others, every third is an MvMesh (views from the cell centre
/// and the first neighbour's centre; triangle masks cycle through {0}, {1}, {0,1}, ∅),
/// the last two form a Cluster, and the rest are SvMeshes with all their triangles.
pub fn write_synthetic_bake(dir: &Path) -> Result<SyntheticBake, TestDataError> {
    write_synthetic_bake_with(dir, false)
}

/// `manifests/demo.ron`'s plan with its generated park only: the hand-placed
/// showcase objects (the cluster group, the block, the pebbles) are for the real
/// bake, and the synthetic bake's figures in the player's tests are the park's.
/// The scene of every synthetic bake.
pub fn demo_park_plan() -> Result<format::manifest::Plan, TestDataError> {
    let manifest = repo_root().join("manifests/demo.ron");
    let mut plan = parse_manifest(&manifest).map_err(|e| TestDataError::Manifest(e.to_string()))?;
    if let format::manifest::SceneSpec::Park(park) = &mut plan.scene {
        park.placed.clear();
    }
    Ok(plan)
}

/// [`write_synthetic_bake`]; with `all_originals` every cell lists every instance as
/// an original (no proxies), so the hybrid must equal the full-geometry frame.
pub fn write_synthetic_bake_with(
    dir: &Path,
    all_originals: bool,
) -> Result<SyntheticBake, TestDataError> {
    let plan = demo_park_plan()?;
    let scene = scene::build_scene(&plan).map_err(|e| TestDataError::Manifest(e.to_string()))?;
    let grid = grid_params(scene.ground, &plan.cells);
    let fingerprint = [7u8; 32];
    let base = BasePack::from_scene(&scene, grid, fingerprint);
    mkdir(&dir.join("cells"))?;
    base.write(&dir.join("base.pack"))?;
    let eye_h = 0.5 * (grid.min_eye_height + grid.max_eye_height);
    let bounds: Vec<(Vec3, Vec3)> = (0..scene.instances.len())
        .map(|i| scene.instance_bounds(i))
        .collect();
    for id in 0..grid.n_cols * grid.n_rows {
        let c = grid_centre(&grid, id);
        let eye = Vec3::new(c.x, eye_h, c.y);
        let nb = neighbours(&grid, id);
        let eye2 = nb
            .first()
            .map(|&n| {
                let p = grid_centre(&grid, n);
                Vec3::new(p.x, eye_h, p.y)
            })
            .unwrap_or(eye + Vec3::X);
        let mut originals = Vec::new();
        let mut outside = Vec::new();
        for (i, (lo, hi)) in bounds.iter().enumerate() {
            let m = (*lo + *hi) * 0.5;
            if all_originals || Vec2::new(m.x, m.z).distance(c) < 1.2 * grid.cell_size {
                originals.push(i as u32);
            } else {
                outside.push(i as u32);
            }
        }
        let mut proxies = Vec::new();
        let cluster: Vec<u32> = if outside.len() >= 4 {
            outside.split_off(outside.len() - 2)
        } else {
            Vec::new()
        };
        let member = |i: u32, masks: bool| {
            let inst = &base.instances[i as usize];
            let mesh = &base.models[inst.model as usize].mesh;
            ProxyMember {
                instance: i,
                triangles: mesh.triangles.clone(),
                view_masks: if masks {
                    (0..mesh.triangles.len())
                        .map(|k| [1u8, 2, 3, 0][k % 4])
                        .collect()
                } else {
                    Vec::new()
                },
            }
        };
        let view = |from: Vec3, lo: Vec3, hi: Vec3, colour: [u8; 4]| {
            let cam = capture_camera(from, lo, hi, 32);
            ProxyView {
                eye: from.to_array(),
                matrix: texture_matrix(&cam),
                texture: checker(colour, 32),
            }
        };
        let colour_of = |i: u32| {
            let inst: &PackedInstance = &base.instances[i as usize];
            let model: &PackedModel = &base.models[inst.model as usize];
            mean_colour(&model.mesh, inst.tint)
        };
        for (k, &i) in outside.iter().enumerate() {
            let (lo, hi) = bounds[i as usize];
            if k % 3 == 0 {
                proxies.push(Proxy {
                    kind: ProxyKind::MvMesh,
                    members: vec![member(i, true)],
                    views: vec![
                        view(eye, lo, hi, colour_of(i)),
                        view(eye2, lo, hi, colour_of(i)),
                    ],
                    layers: None,
                });
            } else {
                proxies.push(Proxy {
                    kind: ProxyKind::SvMesh,
                    members: vec![member(i, false)],
                    views: vec![view(eye, lo, hi, colour_of(i))],
                    layers: None,
                });
            }
        }
        if !cluster.is_empty() {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for &i in &cluster {
                lo = lo.min(bounds[i as usize].0);
                hi = hi.max(bounds[i as usize].1);
            }
            proxies.push(Proxy {
                kind: ProxyKind::Cluster,
                members: cluster.iter().map(|&i| member(i, false)).collect(),
                views: vec![view(eye, lo, hi, colour_of(cluster[0]))],
                layers: None,
            });
        }
        CellPack {
            cell_id: id,
            fingerprint,
            far_group: None,
            originals,
            proxies,
        }
        .write(&dir.join(format!("cells/{id}.pack")))?;
    }
    write_index(dir, &grid, fingerprint)?;
    Ok(SyntheticBake {
        grid,
        cells: grid.n_cols * grid.n_rows,
        instances: base.instances.len(),
        triangles: scene.triangle_count(),
    })
}

/// A centre for [`write_quad_bake`]'s quad and a 64 × 64 capture of it from 20 units
/// in front (+z), 40° high: the projective-texture tests' setting.
pub fn quad_in_front() -> (Vec3, Camera) {
    let centre = Vec3::new(50.0, 6.0, 50.0);
    let capture = Camera {
        eye: Vec3::new(50.0, 6.0, 70.0),
        dir: Vec3::NEG_Z,
        fov_y_deg: 40.0,
        width: 64,
        height: 64,
        near: 0.5,
        far: 100.0,
    };
    (centre, capture)
}

/// A one-object bake: a 10 × 10 quad facing +z centred at `centre`, grey, drawn in
/// every cell as an SvMesh proxy textured by `texture` captured with `capture`; the
/// ground is 100 × 100 with 50-unit cells.
pub fn write_quad_bake(
    dir: &Path,
    centre: Vec3,
    capture: &Camera,
    texture: Texture,
) -> Result<GridParams, TestDataError> {
    write_quad_bake_views(
        dir,
        centre,
        ProxyKind::SvMesh,
        vec![(*capture, texture)],
        Vec::new(),
    )
}

/// [`write_quad_bake`] with any proxy kind, views and (MvMesh) per-triangle masks of
/// the quad's two triangles.
pub fn write_quad_bake_views(
    dir: &Path,
    centre: Vec3,
    kind: ProxyKind,
    views: Vec<(Camera, Texture)>,
    view_masks: Vec<u8>,
) -> Result<GridParams, TestDataError> {
    let h = 5.0;
    let positions = vec![
        [centre.x - h, centre.y - h, centre.z],
        [centre.x + h, centre.y - h, centre.z],
        [centre.x + h, centre.y + h, centre.z],
        [centre.x - h, centre.y + h, centre.z],
    ];
    let mesh = Mesh {
        positions,
        normals: vec![[0.0, 0.0, 1.0]; 4],
        albedo: vec![[128, 128, 128, 255]; 4],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let ground = Ground {
        min: [0.0, 0.0],
        max: [100.0, 100.0],
    };
    let grid = grid_params(
        ground,
        &CellParams {
            cell_size: 50.0,
            min_eye_height: 2.0,
            max_eye_height: 10.0,
        },
    );
    let fingerprint = [3u8; 32];
    let base = BasePack {
        scene_fingerprint: fingerprint,
        grid,
        models: vec![PackedModel {
            name: "quad".into(),
            content_hash: [1; 32],
            mesh: mesh.clone(),
            albedo_map: None,
        }],
        instances: vec![PackedInstance {
            model: 0,
            transform: Mat4::IDENTITY.to_cols_array(),
            tint: [1.0; 3],
        }],
        patches: None,
    };
    mkdir(&dir.join("cells"))?;
    base.write(&dir.join("base.pack"))?;
    for id in 0..grid.n_cols * grid.n_rows {
        CellPack {
            cell_id: id,
            fingerprint,
            far_group: None,
            originals: Vec::new(),
            proxies: vec![Proxy {
                kind,
                members: vec![ProxyMember {
                    instance: 0,
                    triangles: mesh.triangles.clone(),
                    view_masks: view_masks.clone(),
                }],
                views: views
                    .iter()
                    .map(|(cam, tex)| ProxyView {
                        eye: cam.eye.to_array(),
                        matrix: texture_matrix(cam),
                        texture: tex.clone(),
                    })
                    .collect(),
                layers: None,
            }],
        }
        .write(&dir.join(format!("cells/{id}.pack")))?;
    }
    write_index(dir, &grid, fingerprint)?;
    Ok(grid)
}

/// Issue 16: a one-object bake drawn in every cell as a LayeredImpostor: `texture`
/// (RGBA8, depth codes in alpha) seen from `capture` — its matrix is
/// [`texture_matrix`], so `q` is the eye-space depth — sliced into `layers` (corner
/// rays are filled in from the camera). The quad of [`write_quad_bake`] is the
/// member instance (not drawn: an impostor has no triangles).
pub fn write_impostor_bake(
    dir: &Path,
    capture: &Camera,
    texture: Texture,
    layers: format::pack::ImpostorLayers,
) -> Result<GridParams, TestDataError> {
    write_impostors_bake(dir, &[(*capture, texture, layers)])
}

/// [`write_impostor_bake`] with several LayeredImpostors in every cell's pack, in
/// the order given, each `(capture, texture, layers)` as there; all of the one
/// member instance (the quad, placed in front of the first capture).
pub fn write_impostors_bake(
    dir: &Path,
    impostors: &[(Camera, Texture, format::pack::ImpostorLayers)],
) -> Result<GridParams, TestDataError> {
    let Some((first, _, first_layers)) = impostors.first() else {
        return Err(TestDataError::Manifest("no impostor to write".into()));
    };
    let centre = first.eye + first.dir.normalize() * first_layers.near;
    let grid = write_quad_bake_views(dir, centre, ProxyKind::SvMesh, Vec::new(), Vec::new())?;
    let proxies: Vec<Proxy> = impostors
        .iter()
        .map(|(capture, texture, layers)| {
            let t = (capture.fov_y_deg.to_radians() / 2.0).tan();
            let r = t * capture.width as f32 / capture.height as f32;
            let to_world = capture.view().inverse();
            let ray = |s: f32, v: f32| {
                to_world
                    .transform_vector3(Vec3::new((2.0 * s - 1.0) * r, (1.0 - 2.0 * v) * t, -1.0))
                    .to_array()
            };
            let mut layers = layers.clone();
            layers.corner_rays = [ray(0.0, 0.0), ray(1.0, 0.0), ray(1.0, 1.0), ray(0.0, 1.0)];
            Proxy {
                kind: ProxyKind::LayeredImpostor,
                members: vec![ProxyMember {
                    instance: 0,
                    triangles: Vec::new(),
                    view_masks: Vec::new(),
                }],
                views: vec![ProxyView {
                    eye: capture.eye.to_array(),
                    matrix: texture_matrix(capture),
                    texture: texture.clone(),
                }],
                layers: Some(layers),
            }
        })
        .collect();
    let fingerprint = [3u8; 32];
    for id in 0..grid.n_cols * grid.n_rows {
        let path = dir.join(format!("cells/{id}.pack"));
        let mut cell = CellPack::read(&path).map_err(TestDataError::Pack)?;
        cell.proxies = proxies.clone();
        cell.write(&path).map_err(TestDataError::Pack)?;
    }
    write_index(dir, &grid, fingerprint)?;
    Ok(grid)
}
