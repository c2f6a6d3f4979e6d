//! Issue 29 item 2: objects wider than a cell are split along the grid at import
//! (`scene::chunk`). A terrain heightfield over the whole ground becomes one chunk per
//! cell; every triangle is kept once with its vertices bit for bit, so the split scene
//! draws exactly the pixels of the unsplit one (no crack along chunk borders).

use format::grid::HexGrid;
use format::{Ground, Instance, Model, Scene};
use glam::{Mat4, Vec3};
use worker::raster::{render, CullMode, DrawItem, View};

fn terrain_scene() -> Scene {
    let mesh = format::pack::sample::grid_mesh(48, 48, 7);
    Scene {
        models: vec![
            Model::new("terrain".into(), "test".into(), mesh, None),
            Model::new(
                "box".into(),
                "test".into(),
                format::Mesh::cuboid([-1.0, 0.0, -1.0], [1.0, 3.0, 1.0], [200, 90, 60, 255]),
                None,
            ),
        ],
        instances: vec![
            Instance {
                model: 0,
                transform: Mat4::from_scale(Vec3::new(200.0, 40.0, 200.0)),
                tint: Vec3::ONE,
            },
            Instance {
                model: 1,
                transform: Mat4::from_translation(Vec3::new(90.0, 4.0, 110.0)),
                tint: Vec3::ONE,
            },
        ],
        ground: Ground {
            min: [0.0, 0.0],
            max: [200.0, 200.0],
        },
        model_bounds: Default::default(),
        instance_labels: Default::default(),
    }
}

#[test]
fn a_terrain_becomes_one_chunk_per_cell_and_draws_the_same_pixels() {
    let scene = terrain_scene();
    let grid = HexGrid::new(scene.ground, 20.0);
    let mut split = scene.clone();
    let stats = scene::chunk::split_wide_objects(&mut split, &grid);
    assert_eq!(
        stats.split_objects, 1,
        "only the terrain is wider than two cells"
    );
    assert!(stats.chunks > 30, "{} chunks", stats.chunks);
    assert_eq!(split.instances.len(), 1 + stats.chunks as usize);
    // The box stays whole, and the terrain's model (now unused) is gone.
    assert_eq!(split.models.len(), 1 + stats.chunks as usize);
    assert!(split.models.iter().any(|m| m.name == "box"));
    assert!(split.models.iter().all(|m| m.name != "terrain"));
    // Every triangle once, with the original corner positions bit for bit.
    let corners = |s: &Scene| {
        let mut all: Vec<[[u32; 3]; 3]> = s
            .instances
            .iter()
            .filter(|i| s.models[i.model as usize].name != "box")
            .flat_map(|i| {
                let m = &s.models[i.model as usize].mesh;
                m.triangles
                    .iter()
                    .map(|t| t.map(|v| m.positions[v as usize].map(f32::to_bits)))
                    .collect::<Vec<_>>()
            })
            .collect();
        all.sort();
        all
    };
    assert_eq!(corners(&split), corners(&scene));
    // Each chunk stays within about a cell: no wider than two cell widths.
    for inst in &split.instances {
        let m = &split.models[inst.model as usize].mesh;
        let (lo, hi) = m.bounds().unwrap();
        let w = inst
            .transform
            .transform_vector3(Vec3::from(hi) - Vec3::from(lo));
        assert!(w.x.abs() <= 80.0 && w.z.abs() <= 80.0, "a chunk {w:?} wide");
    }
    // The same split again: the same scene.
    let mut again = scene.clone();
    scene::chunk::split_wide_objects(&mut again, &grid);
    assert_eq!(again, split);

    // No crack: both scenes draw the same colour and depth in every pixel.
    let view = View::look_at_fov(
        Vec3::new(-30.0, 90.0, -40.0),
        Vec3::new(110.0, 0.0, 120.0),
        Vec3::Y,
        60.0,
        256,
        256,
        0.5,
        1000.0,
    )
    .unwrap();
    let ground = scene.ground.mesh();
    let a = render(
        &view,
        &DrawItem::scene_with_ground(&scene, &ground),
        CullMode::Back,
    );
    let b = render(
        &view,
        &DrawItem::scene_with_ground(&split, &ground),
        CullMode::Back,
    );
    let terrain_pixels = a.object_id.iter().filter(|&&id| id == 0).count();
    assert!(terrain_pixels > 20_000, "{terrain_pixels} terrain pixels");
    assert_eq!(a.color, b.color);
    assert_eq!(a.depth, b.depth);
}

#[test]
fn objects_of_a_cell_or_two_stay_whole() {
    let mut scene = terrain_scene();
    // The terrain shrunk to 70 units: under two cell widths (80).
    scene.instances[0].transform = Mat4::from_scale(Vec3::new(70.0, 40.0, 70.0));
    let before = scene.clone();
    let grid = HexGrid::new(scene.ground, 20.0);
    let stats = scene::chunk::split_wide_objects(&mut scene, &grid);
    assert_eq!(stats, scene::chunk::ChunkStats::default());
    assert_eq!(scene, before);
}
