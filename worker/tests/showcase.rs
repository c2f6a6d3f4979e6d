//! The demo's hand-placed showcase objects (issue 16): the 40-unit block, whose
//! proxies start from a coarse level of its LOD chain (two triangles a face), and
//! the 0.3-unit pebbles that the objective selection culls from far cells before
//! clustering (`bake.rs` step 2b).

mod common;
use common::repo;
use format::manifest::{parse_manifest, BakeParams, CellParams};
use format::Scene;
use worker::bake::{bake_cell, bake_cell_with, Assignment, ProxyReuse};
use worker::grid::HexGrid;
use worker::lod_chain::LodChains;
use worker::select::subpixel_from_region;

fn demo() -> (Scene, HexGrid, CellParams, BakeParams) {
    let plan = parse_manifest(&repo().join("manifests/demo.ron")).unwrap();
    let scene = plan.load_scene().unwrap();
    let grid = HexGrid::new(plan.ground, plan.cells.cell_size);
    (scene, grid, plan.cells, plan.bake)
}

/// The only instance of the model of `height` (the demo's block: 40 units).
fn instance_of_height(scene: &Scene, height: f32) -> u32 {
    let found: Vec<u32> = (0..scene.instances.len() as u32)
        .filter(|&i| {
            let (lo, hi) = scene.instance_bounds(i as usize);
            (hi.y - lo.y - height).abs() < 1e-3
        })
        .collect();
    assert_eq!(found.len(), 1, "one instance {height} tall");
    found[0]
}

/// A cell that sees two faces of the block starts its proxy from a chain level
/// where each face is two triangles. The speck tidying once counted those four
/// triangles as a speck (≤ 4 triangles) and dropped them: the proxy had no
/// triangle and the block vanished from the cell. Counted in the original
/// triangles they stand for, they are kept.
#[test]
fn a_large_flat_block_keeps_its_faces_when_starting_from_its_lod_chain() {
    let (scene, grid, cells, mut params) = demo();
    params.far_field = false;
    let block = instance_of_height(&scene, 40.0);
    let (chains, _) = LodChains::prepare(&scene, None).unwrap();
    let reuse = ProxyReuse::new();
    let mut checked = 0;
    for cell in 0..grid.cell_count() {
        let bake =
            bake_cell_with(&scene, &chains, &reuse, &grid, cell, &cells, &params, None).unwrap();
        let Assignment::Proxy(k) = bake.assignment[block as usize] else {
            continue;
        };
        let proxy = &bake.proxies[k as usize];
        let member = proxy.members.iter().find(|m| m.instance == block).unwrap();
        assert!(
            member.triangles.len() >= 2,
            "cell {cell}: the block's {:?} has {} triangles",
            proxy.kind,
            member.triangles.len()
        );
        checked += 1;
    }
    assert!(checked >= 3, "the block has a proxy in {checked} cells");
}

/// With objective selection, a pebble under a pixel from the whole prism is Culled
/// (and counted as culled by the selection), not clustered or given a proxy;
/// without it (the paper's algorithm), the same pebble gets a proxy.
#[test]
fn subpixel_objects_are_culled_before_clustering() {
    let (scene, grid, cells, mut params) = demo();
    params.far_field = false;
    assert!(params.quality.is_some(), "the demo selects by quality");
    let pebbles: Vec<u32> = (0..scene.instances.len() as u32)
        .filter(|&i| {
            let (lo, hi) = scene.instance_bounds(i as usize);
            hi.y - lo.y < 0.5
        })
        .collect();
    assert_eq!(pebbles.len(), 4);
    // A cell that all four pebbles subtend less than a pixel from.
    let cell = (0..grid.cell_count())
        .find(|&c| {
            let prism = grid.prism(c, cells.min_eye_height, cells.max_eye_height);
            pebbles.iter().all(|&i| {
                let (lo, hi) = scene.instance_bounds(i as usize);
                subpixel_from_region(lo, hi, &prism, params.image_res)
            })
        })
        .expect("a cell far from every pebble");
    let selected = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    for &i in &pebbles {
        assert_eq!(
            selected.assignment[i as usize],
            Assignment::Culled,
            "pebble {i}"
        );
    }
    assert!(selected.stats.selection_culled >= 4, "{:?}", selected.stats);
    assert!(selected.stats.culled >= 4);

    params.quality = None;
    let paper = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    for &i in &pebbles {
        assert!(
            matches!(paper.assignment[i as usize], Assignment::Proxy(_)),
            "pebble {i}: {:?}",
            paper.assignment[i as usize]
        );
    }
    assert_eq!(paper.stats.selection_culled, 0);
}
