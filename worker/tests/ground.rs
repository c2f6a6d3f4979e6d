//! Issue 29: objects that contain or underlie the viewer's region. The split's rule
//! (`bake::draws_as_original`): an object whose box's footprint overlaps a cell's
//! hexagon is drawn by the cell as an original, and is never far for a far-field
//! group whose hexagon it overlaps; every other object's box leaves the region's
//! centre outside, so its capture from there frames it.

use format::manifest::{BakeParams, CellParams};
use format::{Ground, Instance, Mesh, Model, Scene};
use glam::{Mat4, Vec2, Vec3};
use proptest::prelude::*;
use worker::bake::{draws_as_original, Assignment};
use worker::far_field::{served_instances, CellGroups, FarField};
use worker::grid::{HexGrid, Prism};
use worker::groups::bake_cell_hybrid;
use worker::lod_chain::LodChains;
use worker::raster::View;
use worker::view::ViewError;

proptest! {
    /// The rule for any prism and box: a box meeting the prism is drawn as an
    /// original; so is one over or under it (a point of the hexagon strictly inside
    /// the box's footprint); an outside box leaves every point of the column over
    /// the hexagon outside it, and the capture from the region's centre frames it
    /// (no "box not in front of the eye").
    #[test]
    fn split_rule_draws_what_is_over_or_under_the_region_and_frames_the_rest(
        cx in -200.0f32..200.0, cz in -200.0f32..200.0, c in 5.0f32..80.0,
        min_y in 0.0f32..20.0, dy in 0.0f32..20.0,
        lo in prop::array::uniform3(-400.0f32..400.0),
        size in prop::array::uniform3(0.0f32..500.0),
        samples in prop::collection::vec((0.0f32..1.0, 0.0f32..1.0, -50.0f32..80.0), 16),
    ) {
        let prism = Prism { centre: Vec2::new(cx, cz), cell_size: c, min_y, max_y: min_y + dy };
        let lo = Vec3::from_array(lo);
        let hi = lo + Vec3::from_array(size);
        let original = draws_as_original(&prism, lo, hi);
        if prism.intersects_aabb(lo, hi) {
            prop_assert!(original);
        }
        for (u, v, y) in samples {
            let p = prism.sample(u, v, 0.0);
            let inside_footprint = p.x > lo.x && p.x < hi.x && p.z > lo.z && p.z < hi.z;
            if inside_footprint {
                prop_assert!(original, "hexagon point {p:?} is over or under the box");
            }
            if !original {
                let q = Vec3::new(p.x, y, p.z);
                prop_assert!(!(q.cmpge(lo).all() && q.cmple(hi).all()), "{q:?} in the box");
            }
        }
        if !original {
            match View::tight_around(prism.centre3(), lo, hi, 64) {
                Ok(_) | Err(ViewError::TooLarge { .. }) => {}
                Err(e) => prop_assert!(false, "capture from the centre: {e}"),
            }
        }
    }
}

const GROUND: Ground = Ground {
    min: [0.0, 0.0],
    max: [300.0, 260.0],
};

fn model(name: &str, lo: [f32; 3], hi: [f32; 3]) -> Model {
    let mesh = Mesh::cuboid(lo, hi, [180, 170, 150, 255]);
    Model::new(name.into(), format!("test:{name}"), mesh, None)
}

/// A ground slab under the whole grid (instance 0), a long wall across a row of
/// cells (1), a deck above the eyes over a few cells (2) and three blocks standing
/// on the slab (3–5).
fn ground_scene() -> Scene {
    let models = vec![
        model("slab", [-10.0, -1.0, -10.0], [310.0, 0.0, 270.0]),
        model("wall", [20.0, 0.0, 120.0], [280.0, 8.0, 121.0]),
        model("deck", [60.0, 10.0, 180.0], [240.0, 11.0, 190.0]),
        model("block", [-3.0, 0.0, -3.0], [3.0, 6.0, 3.0]),
    ];
    let at = |model: u32, x: f32, z: f32| Instance {
        model,
        transform: Mat4::from_translation(Vec3::new(x, 0.0, z)),
        tint: Vec3::ONE,
    };
    Scene {
        models,
        instances: vec![
            at(0, 0.0, 0.0),
            at(1, 0.0, 0.0),
            at(2, 0.0, 0.0),
            at(3, 40.0, 40.0),
            at(3, 250.0, 60.0),
            at(3, 150.0, 230.0),
        ],
        ground: GROUND,
        model_bounds: Default::default(),
        instance_labels: Default::default(),
    }
}

#[test]
fn issue29_ground_slab_wall_and_deck_are_originals_where_they_overlap_and_never_far_there() {
    let scene = ground_scene();
    let cells = CellParams {
        cell_size: 50.0,
        min_eye_height: 2.0,
        max_eye_height: 6.0,
    };
    let params = BakeParams {
        image_res: 32,
        ..BakeParams::default()
    };
    let grid = HexGrid::new(GROUND, cells.cell_size);
    let groups = CellGroups::for_params(&grid, &params);
    let mut wall_cells = 0;
    for cell in 0..grid.cell_count() {
        let prism = grid.prism(cell, cells.min_eye_height, cells.max_eye_height);
        let bake = bake_cell_hybrid(
            &scene,
            &LodChains::none(),
            &grid,
            &groups,
            cell,
            &cells,
            &params,
        )
        .unwrap_or_else(|e| panic!("cell {cell}: {e}"));
        assert!(bake.originals.contains(&0), "cell {cell} lacks the slab");
        for i in 0..scene.instances.len() {
            let (lo, hi) = scene.instance_bounds(i);
            let original = bake.assignment[i] == Assignment::Original;
            assert_eq!(
                original,
                draws_as_original(&prism, lo, hi),
                "cell {cell}, instance {i}: {:?}",
                bake.assignment[i]
            );
        }
        wall_cells += usize::from(bake.assignment[1] == Assignment::Original);
        // No group of the cell's chain holds what the cell draws as original.
        let far = FarField::of_cell(&scene, &grid, &groups, cell, &cells, &params).unwrap();
        for &i in &bake.originals {
            assert!(!far.instances[i as usize], "cell {cell}: {i} is far");
        }
    }
    assert!(wall_cells >= 3 && wall_cells < grid.cell_count() as usize);
    for group in 0..groups.len() {
        let prism = groups.prism(&grid, group, &cells);
        let served = served_instances(&scene, &grid, &groups, group, &cells, &params);
        for (i, &far) in served.iter().enumerate() {
            let (lo, hi) = scene.instance_bounds(i);
            assert!(
                !(far && draws_as_original(&prism, lo, hi)),
                "group {group} serves instance {i}, which overlaps it"
            );
        }
        assert!(!served[0], "group {group} serves the slab");
    }
}
