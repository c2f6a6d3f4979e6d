//! SVMesh / MVMesh / clustering / bake_cell / check_cell (paper 000 §3.1.2–§3.1.6,
//! issue 4). Every proxy mesh goes through `simplify::validate`.

mod common;
use common::{demo, fetched_model, in_pool};
use format::manifest::{BakeParams, CellParams};
use format::{Ground, Instance, Model, Scene};
use glam::{Mat4, Vec3};
use worker::bake::{bake_cell, bake_cell_with, Assignment, CellBake};
use worker::check::{check_cell, psnr_y};
use worker::grid::HexGrid;
use worker::lod_chain::LodChains;
use worker::mvmesh::derive_mvmesh;
use worker::raster::{
    render, render_with, CullMode, DrawItem, ProjectiveSurface, ProjectiveTextures, Shading, View,
    BACKGROUND_ID,
};
use worker::selfocc::{choose_representation, object_self_occluding_error, Representation};
use worker::simplify::{validate, validate_view_masks, Simplified};
use worker::svmesh::{derive_svmesh, ProxySettings};

/// Validates every proxy member of a bake against its input triangles (and MV masks).
fn validate_bake(scene: &Scene, bake: &CellBake) {
    for proxy in &bake.proxies {
        for m in &proxy.members {
            let inst = &scene.instances[m.instance as usize];
            let n = scene.models[inst.model as usize].mesh.positions.len();
            let out = Simplified {
                triangles: m.triangles.clone(),
                view_masks: m.view_masks.clone(),
                ..Simplified::default()
            };
            validate(n, &m.input_triangles, &out).unwrap();
            if !m.view_masks.is_empty() {
                validate_view_masks(&m.vertex_view_sets, &out).unwrap();
                let allowed = (1u32 << proxy.views.len()) - 1;
                assert!(m.view_masks.iter().all(|&b| b as u32 & !allowed == 0));
            }
        }
    }
}

/// [`demo`] and its [`busy_cell`].
fn demo_at_busy_cell() -> (Scene, HexGrid, CellParams, BakeParams, u32) {
    let (scene, grid, cells, params) = demo();
    let cell = busy_cell(&scene, &grid);
    (scene, grid, cells, params, cell)
}

/// The pooled PSNR(Y) of each of `bakes` of `cell` by `check_cell` (6 views, 256²).
fn pooled_psnrs<const N: usize>(
    scene: &Scene,
    grid: &HexGrid,
    cell: u32,
    cells: &CellParams,
    params: &BakeParams,
    bakes: [&CellBake; N],
) -> [f64; N] {
    bakes.map(|b| {
        check_cell(scene, grid, cell, cells, params, b, 6, 256)
            .unwrap()
            .pooled_psnr_y
    })
}

/// The demo cell holding the most instance centres (it has Originals and proxies).
fn busy_cell(scene: &Scene, grid: &HexGrid) -> u32 {
    let mut counts = vec![0u32; grid.cell_count() as usize];
    for i in 0..scene.instances.len() {
        let (lo, hi) = scene.instance_bounds(i);
        let c = (lo + hi) * 0.5;
        if let Some(id) = grid.cell_at(glam::Vec2::new(c.x, c.z)) {
            counts[id as usize] += 1;
        }
    }
    (0..counts.len() as u32)
        .max_by_key(|&i| (counts[i as usize], std::cmp::Reverse(i)))
        .unwrap()
}

#[test]
fn demo_bake_accounts_for_every_instance_once_and_validates() {
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let bake = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    assert_eq!(bake.assignment.len(), scene.instances.len());
    let mut seen = vec![0u32; scene.instances.len()];
    for &i in &bake.originals {
        seen[i as usize] += 1;
        assert_eq!(bake.assignment[i as usize], Assignment::Original);
    }
    for (k, p) in bake.proxies.iter().enumerate() {
        assert!(!p.views.is_empty(), "proxy {k} has no view");
        for m in &p.members {
            seen[m.instance as usize] += 1;
            assert_eq!(
                bake.assignment[m.instance as usize],
                Assignment::Proxy(k as u32)
            );
        }
    }
    for (i, a) in bake.assignment.iter().enumerate() {
        let expected = u32::from(*a != Assignment::Culled);
        assert_eq!(seen[i], expected, "instance {i}: {a:?}");
    }
    assert!(!bake.originals.is_empty(), "cell {cell} has no originals");
    assert!(!bake.proxies.is_empty());
    let s = &bake.stats;
    assert_eq!(
        s.originals + s.culled + s.sv_count + s.mv_count + s.cluster_members,
        s.instances
    );
    assert!(
        s.simplified_ratio > 0.0 && s.simplified_ratio < 1.0,
        "{s:?}"
    );
    validate_bake(&scene, &bake);
    eprintln!("demo cell {cell}: {s:#?}");
}

#[test]
fn demo_bake_is_identical_for_one_and_two_threads() {
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let fp = [7u8; 32];
    let one = in_pool(1, || {
        let b = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
        b.to_pack(fp).unwrap().encode().unwrap()
    });
    let two = in_pool(2, || {
        let b = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
        b.to_pack(fp).unwrap().encode().unwrap()
    });
    assert_eq!(one, two);
    // And a different cell gives a different pack.
    let other = (cell + 1) % grid.cell_count();
    let b = bake_cell(&scene, &grid, other, &cells, &params).unwrap();
    assert_ne!(b.to_pack(fp).unwrap().encode().unwrap(), one);
}

/// The output-sensitive path (issue 13): collapses that start from the models' LOD
/// chains give valid proxies, the same pack for one and two threads and for chains
/// built or loaded from the cache, fewer collapse inputs than the full meshes, and a
/// PSNR within 1 dB of the full-mesh bake.
#[test]
fn demo_bake_from_lod_chains_is_valid_deterministic_and_close() {
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let cache = tempfile::tempdir().unwrap();
    let (built, stats) = LodChains::prepare(&scene, Some(cache.path())).unwrap();
    assert_eq!(stats.built as usize, scene.models.len());
    let (loaded, stats) = LodChains::prepare(&scene, Some(cache.path())).unwrap();
    assert_eq!(stats.loaded as usize, scene.models.len());
    let fp = [7u8; 32];
    let pack = |chains: &LodChains, threads| {
        in_pool(threads, || {
            let reuse = worker::bake::ProxyReuse::new();
            let b =
                bake_cell_with(&scene, chains, &reuse, &grid, cell, &cells, &params, None).unwrap();
            validate_bake(&scene, &b);
            (b.to_pack(fp).unwrap().encode().unwrap(), b)
        })
    };
    let (one, chained) = pack(&built, 1);
    let (two, _) = pack(&loaded, 2);
    assert_eq!(one, two);
    let full = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    let inputs = |b: &CellBake| -> usize {
        b.proxies
            .iter()
            .flat_map(|p| &p.members)
            .map(|m| m.input_triangles.len())
            .sum()
    };
    assert!(
        inputs(&chained) < inputs(&full),
        "{} vs {}",
        inputs(&chained),
        inputs(&full)
    );
    let [with, without] = pooled_psnrs(&scene, &grid, cell, &cells, &params, [&chained, &full]);
    eprintln!("demo cell {cell}: chains {with:.2} dB, full meshes {without:.2} dB");
    assert!(with > without - 1.0, "{with} vs {without}");
}

/// Issue 27 item 3 (`worker::capture_memo`): one capture serves every start mesh.
/// The states a memoised capture yields for a level of the model's LOD chain (the
/// states as if front-facing, then the level's own front-facing test) equal the
/// states computed on the capture for that level, for every level, the full mesh,
/// and eyes around and inside the object's box.
#[test]
fn memoised_capture_states_equal_each_levels_own() {
    use worker::classify::{classify_objects, WindowDepth};
    use worker::lod_chain::LodChain;
    use worker::visibility::DepthTolerance;
    use worker::weights::{vertex_states_captured, vertex_states_if_front, with_front_facing};
    let (scene, _, _, _) = demo();
    let tol = DepthTolerance::default();
    let mut compared = 0;
    for instance in [0u32, 3, 7] {
        let item = DrawItem::instance(&scene, instance);
        let model = &scene.models[scene.instances[instance as usize].model as usize];
        let chain = LodChain::build(model).unwrap();
        let (lo, hi) = scene.instance_bounds(instance as usize);
        let mid = (lo + hi) * 0.5;
        let eyes = [
            mid + Vec3::new(60.0, 25.0, -40.0),
            mid + Vec3::new(-35.0, 8.0, 20.0),
            mid + Vec3::new(5.0, 90.0, 5.0),
        ];
        for eye in eyes {
            let cap = worker::capture::capture_objects(eye, &[item], 256).unwrap();
            let classes = classify_objects(
                &cap.capture,
                &[instance],
                3.4e-4,
                1.28e-4,
                WindowDepth::paper(50.0),
            );
            let if_front = vertex_states_if_front(
                item.mesh,
                item.transform,
                &cap.capture,
                &classes,
                instance,
                tol,
            );
            let levels = std::iter::once(&item.mesh.triangles[..])
                .chain(chain.levels.iter().map(|l| &l.triangles[..]));
            for triangles in levels {
                let own = vertex_states_captured(
                    item.mesh,
                    triangles,
                    &item.mesh.triangles,
                    item.transform,
                    &cap.capture,
                    &classes,
                    instance,
                    tol,
                );
                assert_eq!(
                    with_front_facing(&if_front, item.mesh, triangles, item.transform, eye),
                    own
                );
                compared += 1;
            }
        }
    }
    assert!(compared >= 9 * 2, "{compared} comparisons");
}

/// Issue 27 item 3: a cell baked with a memo that other cells filled (its
/// neighbours' captures from shared centres are hits) is the cell baked alone,
/// byte for byte, and the memo answered some of its lookups.
#[test]
fn a_cell_after_its_neighbours_is_the_cell_baked_alone() {
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let fp = [7u8; 32];
    let reuse = worker::bake::ProxyReuse::new();
    let bake = |chains: &LodChains, c: u32| {
        bake_cell_with(&scene, chains, &reuse, &grid, c, &cells, &params, None)
            .unwrap()
            .to_pack(fp)
            .unwrap()
            .encode()
            .unwrap()
    };
    let (alone, _) = LodChains::prepare(&scene, None).unwrap();
    let expected = bake(&alone, cell);
    let (shared, _) = LodChains::prepare(&scene, None).unwrap();
    for n in grid.neighbours(cell) {
        bake(&shared, n);
    }
    let (hits_before, _) = shared.captures().counts();
    assert_eq!(bake(&shared, cell), expected);
    let (hits, _) = shared.captures().counts();
    assert!(hits > hits_before, "no lookup of the cell was a hit");
}

/// Issue 32 item 2: a LOD chain in `lod/` rewritten with other valid vertex ids and
/// re-sealed (its checksum recomputed, as `LodChainFile::encode` does) was loaded and
/// changed the cell's pack. A chain is now checked against the model it names
/// (`LodChain::from_file`): this one does not match, so it is rebuilt (and the cache
/// rewritten), and the cell's pack is the clean bake's byte for byte.
#[test]
fn issue32_a_forged_lod_chain_is_rebuilt_and_the_pack_unchanged() {
    use format::lod::LodChainFile;
    use worker::lod_chain::chain_path;
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let cache = tempfile::tempdir().unwrap();
    let (chains, _) = LodChains::prepare(&scene, Some(cache.path())).unwrap();
    let pack = |chains: &LodChains| {
        let reuse = worker::bake::ProxyReuse::new();
        bake_cell_with(&scene, chains, &reuse, &grid, cell, &cells, &params, None)
            .unwrap()
            .to_pack([7u8; 32])
            .unwrap()
            .encode()
            .unwrap()
    };
    let clean = pack(&chains);
    // Every level of every chain: each vertex id of the level's triangles moved to
    // the next id the level uses (all ids stay valid, every count stays), sealed anew.
    let mut forged = 0;
    for model in &scene.models {
        let path = chain_path(cache.path(), &model.content_hash);
        let mut file = LodChainFile::decode(&std::fs::read(&path).unwrap()).unwrap();
        for level in &mut file.levels {
            let mut ids: Vec<u32> = level.triangles.iter().flatten().copied().collect();
            ids.sort_unstable();
            ids.dedup();
            let next = |v: u32| {
                let k = ids.binary_search(&v).unwrap();
                ids[(k + 1) % ids.len()]
            };
            for t in &mut level.triangles {
                *t = t.map(next);
            }
        }
        if file.levels.iter().any(|l| !l.triangles.is_empty()) {
            std::fs::write(&path, file.encode()).unwrap();
            assert!(LodChainFile::decode(&std::fs::read(&path).unwrap()).is_ok());
            forged += 1;
        }
    }
    assert!(forged > 0);
    let (again, stats) = LodChains::prepare(&scene, Some(cache.path())).unwrap();
    assert_eq!(
        stats.built, forged,
        "every forged chain is rebuilt: {stats:?}"
    );
    assert_eq!(stats.loaded as usize, scene.models.len() - forged as usize);
    for m in 0..scene.models.len() as u32 {
        assert_eq!(again.get(m), chains.get(m), "model {m}");
    }
    assert!(pack(&again) == clean, "the cell's pack changed");
    // The rebuilt chains were written back: the next run loads them all.
    let (_, stats) = LodChains::prepare(&scene, Some(cache.path())).unwrap();
    assert_eq!(stats.loaded as usize, scene.models.len());
}

#[test]
fn demo_check_cell_gives_a_good_psnr() {
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let bake = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    let report = check_cell(&scene, &grid, cell, &cells, &params, &bake, 6, 256).unwrap();
    eprintln!(
        "demo cell {cell}: PSNR-Y per view {:?}",
        report.per_view_psnr_y
    );
    assert_eq!(report.per_view_psnr_y.len(), 6);
    assert!(
        report.mean.is_finite() && report.mean > 30.0,
        "{}",
        report.mean
    );
    assert!(report.per_view_psnr_y[report.worst_view] <= report.mean);
    // The hybrid frame is not the reference frame (the check can fail).
    assert!(report.worst.reference != report.worst.proxy);
    assert!(psnr_y(&report.worst.reference, &report.worst.proxy) < 100.0);
}

#[test]
fn bake_rejects_a_missing_cell() {
    let (scene, grid, cells, params) = demo();
    assert!(bake_cell(&scene, &grid, grid.cell_count(), &cells, &params).is_err());
}

// ---- The bunny at the paper's size (000 Fig. 4 and Fig. 6) ----

const CELL_SIZE: f32 = 50.0;
const PAPER_MV: [usize; 6] = [1605, 945, 554, 392, 330, 306];
const PAPER_SV: [usize; 3] = [259, 254, 239];

/// The bunny scaled to 43 units on the ground at the centre of cell (col 0, row 0);
/// cells k rows away along +z are k·√3·c away.
fn bunny_scene() -> Option<(Scene, HexGrid, CellParams)> {
    let path = fetched_model("bunny.obj")?;
    let mut mesh = scene::load::load_model(&path).unwrap();
    scene::build::normalise(&mut mesh, [0.0; 3], 43.0).unwrap();
    let ground = Ground {
        min: [0.0, 0.0],
        max: [100.0, 900.0],
    };
    let grid = HexGrid::new(ground, CELL_SIZE);
    let c = grid.centre(grid.id(0, 0).unwrap());
    let scene = Scene {
        models: vec![Model {
            name: "bunny".into(),
            source: path.display().to_string(),
            mesh,
            content_hash: [0; 32],
            albedo_map: None,
            locked_vertices: Vec::new(),
            chunk_cell: None,
        }],
        instances: vec![Instance {
            model: 0,
            transform: Mat4::from_translation(Vec3::new(c.x, 0.0, c.y)),
            tint: Vec3::ONE,
        }],
        ground,
        model_bounds: Default::default(),
        instance_labels: Default::default(),
    };
    let cells = CellParams {
        cell_size: CELL_SIZE,
        min_eye_height: 5.0,
        max_eye_height: 15.0,
    };
    Some((scene, grid, cells))
}

#[test]
fn bunny_proxy_counts_match_the_paper() {
    let Some((scene, grid, cells)) = bunny_scene() else {
        return;
    };
    let params = BakeParams::default();
    let settings = ProxySettings::new(&params, CELL_SIZE);
    let mut rows = Vec::new();
    eprintln!("k | kind | paper | ours | input | views");
    for k in 1..=9u32 {
        let cell = grid.id(0, k as i64).unwrap();
        let prism = grid.prism(cell, cells.min_eye_height, cells.max_eye_height);
        let centre = worker::bake::cell_eye(&grid, cell, &cells);
        let (lo, hi) = scene.instance_bounds(0);
        let error = object_self_occluding_error(CELL_SIZE, params.image_res, centre, lo, hi);
        let rep = choose_representation(error, params.self_occluding_tolerance_px);
        let expected = if k <= 6 {
            Representation::Mv
        } else {
            Representation::Sv
        };
        assert_eq!(rep, expected, "k={k}: s = {error}");
        let (count, input, views, surface, mesh_tris) =
            bunny_proxy(&scene, &grid, &cells, cell, k <= 6, &settings);
        let paper = if k <= 6 {
            PAPER_MV[k as usize - 1]
        } else {
            PAPER_SV[k as usize - 7]
        };
        eprintln!(
            "{k} | {} | {paper} | {count} | {input} | {views}",
            if k <= 6 { "MV" } else { "SV" }
        );
        rows.push((k, paper, count));
        // Our default deviation bound (over the prism) on top: reported next to the
        // paper's algorithm (BENCHMARKS.md), never coarser than it.
        if k == 1 || k == 4 || k == 7 {
            let bounded = ProxySettings::for_cell(&params, CELL_SIZE, prism);
            let (count_bounded, ..) = bunny_proxy(&scene, &grid, &cells, cell, k <= 6, &bounded);
            eprintln!(
                "{k} | with the {} px deviation bound | {count_bounded}",
                params.max_deviation_px
            );
            assert!(
                count_bounded >= count,
                "k={k}: bounded {count_bounded} < {count}"
            );
        }
        if k == 1 || k == 4 || k == 7 {
            let path = std::env::temp_dir().join(format!("hexbake-bunny-{k}cells.png"));
            write_bunny_picture(&path, &scene, &mesh_tris, surface, centre, &prism);
            eprintln!("wrote {}", path.display());
        }
    }
    // Within a factor of 2 of the paper (issue 4), and coarser with distance for MV.
    for &(k, paper, ours) in &rows {
        assert!(
            ours * 2 >= paper && ours <= paper * 2,
            "k={k}: {ours} vs paper {paper} ({rows:?})"
        );
    }
    for w in rows[..6].windows(2) {
        assert!(w[1].2 <= w[0].2, "{rows:?}");
    }
}

/// The bunny's MVMesh (`mv`) or SVMesh for `cell`, validated: triangle count, input
/// triangles, views, its projective surface and its triangles.
fn bunny_proxy(
    scene: &Scene,
    grid: &HexGrid,
    cells: &CellParams,
    cell: u32,
    mv: bool,
    settings: &ProxySettings,
) -> (usize, usize, usize, ProjectiveSurface, Vec<[u32; 3]>) {
    let n = scene.models[0].mesh.positions.len();
    let centre = worker::bake::cell_eye(grid, cell, cells);
    if mv {
        let prism = grid.prism(cell, cells.min_eye_height, cells.max_eye_height);
        let mut eyes = vec![centre];
        eyes.extend(
            grid.neighbours(cell)
                .into_iter()
                .map(|c| worker::bake::cell_eye(grid, c, cells)),
        );
        let mv = derive_mvmesh(scene, &LodChains::none(), 0, &eyes, &prism, settings).unwrap();
        validate(n, &mv.member.input_triangles, &mv.member.simplified).unwrap();
        validate_view_masks(&mv.vertex_view_sets, &mv.member.simplified).unwrap();
        let s = &mv.member.simplified;
        (
            s.triangles.len(),
            mv.member.input_triangles.len(),
            mv.views.len(),
            ProjectiveSurface {
                views: mv.views.clone(),
                triangle_masks: Some(s.view_masks.clone()),
            },
            s.triangles.clone(),
        )
    } else {
        let sv = derive_svmesh(scene, &LodChains::none(), &[0], centre, settings).unwrap();
        let m = &sv.members[0];
        validate(n, &m.input_triangles, &m.simplified).unwrap();
        (
            m.simplified.triangles.len(),
            m.input_triangles.len(),
            1,
            ProjectiveSurface {
                views: vec![sv.view.clone()],
                triangle_masks: None,
            },
            m.simplified.triangles.clone(),
        )
    }
}

/// Left: the proxy textured from its captures, seen from a prism corner towards the
/// bunny; right: the proxy lit with its triangle edges drawn.
fn write_bunny_picture(
    path: &std::path::Path,
    scene: &Scene,
    triangles: &[[u32; 3]],
    surface: ProjectiveSurface,
    _centre: Vec3,
    prism: &worker::grid::Prism,
) {
    let model = &scene.models[0].mesh;
    let mesh = format::Mesh {
        positions: model.positions.clone(),
        normals: model.normals.clone(),
        albedo: model.albedo.clone(),
        triangles: triangles.to_vec(),
    };
    let transform = scene.instances[0].transform;
    let item = DrawItem {
        mesh: &mesh,
        transform,
        tint: Vec3::ONE,
        object_id: 0,
        triangles: None,
        albedo_map: None,
    };
    let eye = prism.corners()[8];
    let (lo, hi) = scene.instance_bounds(0);
    let target = (lo + hi) * 0.5;
    let dist = eye.distance(target);
    let fov = (2.0 * (30.0 / dist).atan()).to_degrees();
    let res = 384u32;
    let view = View::look_at_fov(eye, target, Vec3::Y, fov, res, res, 1.0, dist * 4.0).unwrap();
    let textures = ProjectiveTextures {
        viewer: eye,
        by_object: vec![Some(surface)],
    };
    let textured = render_with(
        &view,
        &[item],
        CullMode::Back,
        Shading::Projective(&textures),
    );
    let lit = render(&view, &[item], CullMode::Back);
    let mut wire = lit.color.clone();
    // Edges of the visible triangles.
    let visible: std::collections::BTreeSet<u32> = lit
        .triangle_id
        .iter()
        .copied()
        .filter(|&t| t != BACKGROUND_ID)
        .collect();
    for &t in &visible {
        let tri = mesh.triangles[t as usize];
        let p: Vec<_> = tri
            .iter()
            .filter_map(|&v| {
                view.project(transform.transform_point3(Vec3::from(mesh.positions[v as usize])))
            })
            .map(|(p, _)| p)
            .collect();
        if p.len() < 3 {
            continue;
        }
        for e in 0..3 {
            let (a, b) = (p[e], p[(e + 1) % 3]);
            let steps = (a.distance(b).ceil() as usize).max(1);
            for s in 0..=steps {
                let q = a.lerp(b, s as f32 / steps as f32);
                let (x, y) = (q.x as i64, q.y as i64);
                if x >= 0 && y >= 0 && x < res as i64 && y < res as i64 {
                    wire[(y * res as i64 + x) as usize] = [30, 30, 40, 255];
                }
            }
        }
    }
    let w = res as usize;
    let mut out = vec![[0u8; 4]; 2 * w * w];
    for y in 0..w {
        out[y * 2 * w..y * 2 * w + w].copy_from_slice(&textured.color[y * w..y * w + w]);
        out[y * 2 * w + w..y * 2 * w + 2 * w].copy_from_slice(&wire[y * w..y * w + w]);
    }
    worker::picture::write_rgba(path, 2 * res, res, &out).unwrap();
}

// ---- Captures, projective texturing, clustering ----

#[test]
fn capture_texture_matrix_maps_vertices_onto_their_capture_pixels() {
    let (scene, _, _, _) = demo();
    let item = DrawItem::instance(&scene, 0);
    let (lo, hi) = scene.instance_bounds(0);
    let eye = (lo + hi) * 0.5 + Vec3::new(60.0, 25.0, -40.0);
    let cap = worker::capture::capture_objects(eye, &[item], 512).unwrap();
    let tex = &cap.texture;
    assert!(cap.covered_pixels > 100);
    assert!(tex.width <= cap.capture.view.width + 2 * worker::capture::TEXTURE_PAD_PX);
    let mut offsets = Vec::new();
    for p in &item.mesh.positions {
        let w = item.transform.transform_point3(Vec3::from(*p));
        let (px, _) = cap.capture.view.project(w).unwrap();
        let c = tex.matrix * w.extend(1.0);
        let (u, v) = (c.x / c.w * tex.width as f32, c.y / c.w * tex.height as f32);
        offsets.push((px.x - u, px.y - v));
    }
    // One crop offset for every vertex: the matrix is the capture's projection,
    // shifted by the crop and flipped in y like the capture's rows.
    let (ox, oy) = offsets[0];
    assert!(offsets
        .iter()
        .all(|&(x, y)| (x - ox).abs() < 1e-2 && (y - oy).abs() < 1e-2));
    assert!((ox - ox.round()).abs() < 1e-2 && (oy - oy.round()).abs() < 1e-2);
    // Covered texels hold the capture's colours.
    let view = &cap.capture.view;
    let mut checked = 0;
    for y in 0..view.height as i64 {
        for x in 0..view.width as i64 {
            let q = cap.capture.index(x as u32, y as u32);
            if cap.capture.object_id[q] != 0 {
                continue;
            }
            let (tx, ty) = (x - ox.round() as i64, y - oy.round() as i64);
            let o = ((ty * tex.width as i64 + tx) * 4) as usize;
            assert_eq!(&tex.rgba[o..o + 3], &cap.capture.color[q][..3]);
            assert_eq!(tex.rgba[o + 3], 255);
            checked += 1;
        }
    }
    assert_eq!(checked, cap.covered_pixels);
}

#[test]
fn projective_texturing_from_the_capture_eye_reproduces_the_lit_render() {
    let (scene, _, _, _) = demo();
    let item = DrawItem::instance(&scene, 1);
    let (lo, hi) = scene.instance_bounds(1);
    let target = (lo + hi) * 0.5;
    let eye = target + Vec3::new(-50.0, 15.0, 45.0);
    let cap = worker::capture::capture_objects(eye, &[item], 1024).unwrap();
    let view = View::look_at_fov(eye, target, Vec3::Y, 30.0, 256, 256, 1.0, 500.0).unwrap();
    let lit = render(&view, &[item], CullMode::Back);
    let textures = ProjectiveTextures {
        viewer: eye,
        by_object: vec![
            None,
            Some(ProjectiveSurface {
                views: vec![cap.texture.clone()],
                triangle_masks: None,
            }),
        ],
    };
    let textured = render_with(
        &view,
        &[item],
        CullMode::Back,
        Shading::Projective(&textures),
    );
    let psnr = psnr_y(&lit.color, &textured.color);
    // Measured 57.4 dB (CPU rasterizer, deterministic); floor 55 dB (a 2.4 dB margin
    // for changes of the rasterizer's rounding, not of the method).
    println!("projective texturing vs lit render: {psnr:.2} dB");
    assert!(psnr >= 55.0, "{psnr}");
    assert!(psnr < 100.0, "textured render is not the lit one");
    // An object without a surface in the table stays lit.
    let other = ProjectiveTextures {
        viewer: eye,
        by_object: vec![],
    };
    let unlit = render_with(&view, &[item], CullMode::Back, Shading::Projective(&other));
    assert_eq!(unlit.color, lit.color);
}

#[test]
fn greedy_clustering_follows_the_paper_conditions() {
    use worker::cluster::{greedy_clusters, ClusterCandidate, ClusterSettings};
    let settings = ClusterSettings {
        centre: Vec3::new(0.0, 10.0, 0.0),
        cell_size: 50.0,
        image_res: 1024,
        self_occluding_tolerance_px: 5.0,
    };
    let boxed = |instance: u32, x: f32, z: f32, size: f32| ClusterCandidate {
        instance,
        aabb_min: Vec3::new(x - size / 2.0, 0.0, z - size / 2.0),
        aabb_max: Vec3::new(x + size / 2.0, size, z + size / 2.0),
    };
    // Far away, overlapping in view: one cluster. Opposite directions: apart.
    let far = [
        boxed(0, 1500.0, 0.0, 20.0),
        boxed(1, 1505.0, 8.0, 20.0),
        boxed(2, -1500.0, 0.0, 20.0),
    ];
    let clusters = greedy_clusters(&far, &settings);
    assert_eq!(clusters, vec![vec![0, 1], vec![2]]);
    // Overlapping in view (the union's texture is barely larger than one of them)
    // but one 100 units behind the other: the union's self-occluding error
    // (≈ 12.7 px) exceeds T_s.
    let deep = [boxed(0, 600.0, 0.0, 20.0), boxed(1, 700.0, 0.0, 20.0)];
    let clusters = greedy_clusters(&deep, &settings);
    assert_eq!(clusters, vec![vec![0], vec![1]]);
    // Every candidate exactly once, whatever the input order.
    let mut many: Vec<ClusterCandidate> = (0..12)
        .map(|i| boxed(i, 1200.0 + 7.0 * i as f32, 13.0 * (i % 3) as f32, 15.0))
        .collect();
    let a = greedy_clusters(&many, &settings);
    many.reverse();
    let b = greedy_clusters(&many, &settings);
    assert_eq!(a, b);
    let mut all: Vec<u32> = a.iter().flatten().copied().collect();
    all.sort_unstable();
    assert_eq!(all, (0..12).collect::<Vec<_>>());
    assert!(a.len() < 12, "{a:?}");
}

#[test]
fn tidy_selection_fills_small_holes_and_drops_small_specks() {
    use worker::svmesh::tidy_selection;
    // A 10 × 10 grid of quads (200 triangles), vertex (x, y) = y·11 + x.
    let triangles = common::quad_grid_triangles(10);
    let quad = |x: usize, y: usize| [2 * (y * 10 + x), 2 * (y * 10 + x) + 1];
    // Selected: the left half (x < 5) except one quad (a 2-triangle hole) at (2, 5);
    // plus one isolated quad at (8, 8) (a 2-triangle speck).
    let mut selected = vec![false; triangles.len()];
    for y in 0..10 {
        for x in 0..5 {
            for t in quad(x, y) {
                selected[t] = true;
            }
        }
    }
    for t in quad(2, 5) {
        selected[t] = false;
    }
    for t in quad(8, 8) {
        selected[t] = true;
    }
    let before = selected.clone();
    let changed = tidy_selection(&triangles, &mut selected, 4);
    assert_eq!(changed, 4);
    for t in quad(2, 5) {
        assert!(selected[t], "hole filled");
    }
    for t in quad(8, 8) {
        assert!(!selected[t], "speck dropped");
    }
    // Nothing else moved; with 0 nothing moves at all.
    let moved = before.iter().zip(&selected).filter(|(a, b)| a != b).count();
    assert_eq!(moved, 4);
    let mut again = before.clone();
    assert_eq!(tidy_selection(&triangles, &mut again, 0), 0);
    assert_eq!(again, before);
}

/// 0 turns the deviation bound off; any other value reaches `simplify`, which
/// refuses a negative or non-finite one (so a bad value is an error, never a
/// silently unbounded bake).
#[test]
fn deviation_setting_is_off_only_at_zero() {
    let prism = worker::grid::Prism {
        centre: glam::Vec2::ZERO,
        cell_size: 50.0,
        min_y: 5.0,
        max_y: 15.0,
    };
    let with = |d: f32| {
        let params = BakeParams {
            max_deviation_px: d,
            ..BakeParams::default()
        };
        ProxySettings::for_cell(&params, 50.0, prism).deviation
    };
    assert_eq!(with(0.0), None);
    assert_eq!(with(0.5).map(|b| (b.max_px, b.region)), Some((0.5, prism)));
    assert_eq!(with(-1.0).map(|b| b.max_px), Some(-1.0));
    assert!(with(f32::NAN).is_some_and(|b| b.max_px.is_nan()));
    assert_eq!(
        ProxySettings::new(&BakeParams::default(), 50.0).deviation,
        None
    );
}

/// The far field (issue 13 item 2): on the demo, some cell draws far objects from its
/// group; those objects are outside every prism of the group and become one SV or
/// cluster proxy of the group; the cell's hybrid (own proxies + group's) gives every
/// object exactly one representation, is valid, and its image stays within 1 dB of
/// the cell baked with a proxy of its own for every object.
#[test]
fn demo_far_field_is_shared_conservative_and_close() {
    use worker::far_field::{CellGroups, FarField};
    use worker::groups::bake_cell_hybrid;
    let (scene, grid, cells, params) = demo();
    assert!(params.far_field, "on by default");
    let groups = CellGroups::new(&grid);
    // The cell with the most far objects.
    let (cell, far) = (0..grid.cell_count())
        .map(|c| {
            let f = FarField::of_cell(&scene, &grid, &groups, c, &cells, &params).unwrap();
            (c, f)
        })
        .max_by_key(|(c, f)| {
            (
                f.instances.iter().filter(|&&x| x).count(),
                std::cmp::Reverse(*c),
            )
        })
        .unwrap();
    let n_far = far.instances.iter().filter(|&&x| x).count();
    assert!(n_far > 0, "some demo object is far from some group");
    for (i, _) in far.instances.iter().enumerate().filter(|(_, &x)| x) {
        let (lo, hi) = scene.instance_bounds(i);
        for &c in groups.cells(far.group) {
            let prism = grid.prism(c, cells.min_eye_height, cells.max_eye_height);
            assert!(
                !prism.intersects_aabb(lo, hi),
                "far instance {i} touches cell {c}"
            );
        }
    }
    let chains = LodChains::none();
    let hybrid = bake_cell_hybrid(&scene, &chains, &grid, &groups, cell, &cells, &params).unwrap();
    validate_bake(&scene, &hybrid);
    assert_eq!(hybrid.far_group, Some(far.group));
    let own = bake_cell_with(
        &scene,
        &chains,
        &worker::bake::ProxyReuse::new(),
        &grid,
        cell,
        &cells,
        &params,
        Some(&far),
    )
    .unwrap();
    assert_eq!(own.stats.far_objects as usize, n_far);
    // Every instance: original, culled, or in exactly one proxy of the hybrid.
    let mut seen = vec![0u32; scene.instances.len()];
    for p in &hybrid.proxies {
        for m in &p.members {
            seen[m.instance as usize] += 1;
        }
    }
    for (i, a) in hybrid.assignment.iter().enumerate() {
        match a {
            Assignment::Proxy(k) => {
                assert_eq!(seen[i], 1);
                assert!(hybrid.proxies[*k as usize]
                    .members
                    .iter()
                    .any(|m| m.instance == i as u32));
            }
            Assignment::Far => panic!("instance {i}: Far left in the hybrid"),
            _ => assert_eq!(seen[i], 0),
        }
    }
    let mut paper = params.clone();
    paper.far_field = false;
    let alone = bake_cell(&scene, &grid, cell, &cells, &paper).unwrap();
    let [with, without] = pooled_psnrs(&scene, &grid, cell, &cells, &params, [&hybrid, &alone]);
    eprintln!("demo cell {cell}: {n_far} far objects; far field {with:.2} dB, own proxies {without:.2} dB");
    assert!(with > without - 1.0, "{with} vs {without}");
}

/// Objective selection (issue 16) with the coarser mesh candidates: with a low
/// floor (20 dB, SSIM not checked) the impostors still fail but meshes derived
/// under a looser deviation bound pass, so some mesh proxy comes out with fewer
/// triangles than the paper's proxy of the same objects, none with more, and each
/// still validates (measured: 11 of the demo cell's 14; with the default floor,
/// 30 dB and SSIM 0.9, none on the demo).
#[test]
fn selection_keeps_a_coarser_mesh_where_it_is_cheapest_and_good_enough() {
    use format::manifest::QualityFloor;
    use format::pack::ProxyKind;
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let off = BakeParams {
        quality: None,
        ..params.clone()
    };
    let low = BakeParams {
        quality: Some(QualityFloor {
            min_psnr_db: 20.0,
            min_ssim: 0.0,
        }),
        ..params
    };
    let paper = bake_cell(&scene, &grid, cell, &cells, &off).unwrap();
    let selected = bake_cell(&scene, &grid, cell, &cells, &low).unwrap();
    validate_bake(&scene, &selected);
    let members = |p: &worker::bake::BakedProxy| -> Vec<u32> {
        p.members.iter().map(|m| m.instance).collect()
    };
    let (mut fewer, mut meshes) = (0, 0);
    for p in selected
        .proxies
        .iter()
        .filter(|p| p.kind != ProxyKind::LayeredImpostor)
    {
        let q = paper
            .proxies
            .iter()
            .find(|q| members(q) == members(p))
            .expect("the same objects in the paper's bake");
        assert_eq!(p.kind, q.kind);
        assert!(p.triangle_count() <= q.triangle_count());
        fewer += usize::from(p.triangle_count() < q.triangle_count());
        meshes += 1;
    }
    eprintln!("{fewer} of {meshes} mesh proxies coarser than the paper's");
    assert!(fewer > 0, "no coarser mesh was kept");
}

/// The quality check of every bake (issue 16 item 3): without `bake.quality` every
/// derived mesh proxy is still measured against its originals (from the sample
/// viewpoint farthest from its capture), so the cell's report has a worst view
/// below the cap and an error histogram over real pixels; and the measurement does
/// not change the pack. `bake.quality_check: false` turns it off.
#[test]
fn a_bake_without_selection_still_checks_its_proxies() {
    let (scene, grid, cells, params, cell) = demo_at_busy_cell();
    let off = BakeParams {
        quality: None,
        ..params
    };
    let bake = bake_cell(&scene, &grid, cell, &cells, &off).unwrap();
    let q = &bake.stats.quality;
    assert_eq!(q.measured as usize, bake.proxies.len());
    assert!(bake.proxies.iter().all(|p| p.quality.is_some()));
    assert!(q.worst_psnr_db < format::metrics::PSNR_CAP, "{q:?}");
    assert!(q.error_histogram.iter().sum::<u64>() > 1000, "{q:?}");
    let mut unchecked = bake.clone();
    for p in &mut unchecked.proxies {
        p.quality = None;
    }
    let fp = [3u8; 32];
    assert_eq!(
        bake.to_pack(fp).unwrap().encode().unwrap(),
        unchecked.to_pack(fp).unwrap().encode().unwrap()
    );
    // `bake.quality_check: false` skips it.
    let quiet = BakeParams {
        quality_check: false,
        ..off
    };
    let b = bake_cell(&scene, &grid, cell, &cells, &quiet).unwrap();
    assert_eq!(b.stats.quality.measured, 0);
    assert!(b.proxies.iter().all(|p| p.quality.is_none()));
}
