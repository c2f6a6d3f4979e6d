//! Regional occlusion culling (issue 17, item 2; `worker/src/occlusion.rs`): proofs.
//!
//! - `no_culled_object_covers_a_pixel_from_1000_views_in_a_city`: in a test-sized
//!   city (format's `City` generator, procedural statues), for several street cells
//!   the objects culled from the cell's prism are checked against full-geometry
//!   frames from 1,000 random views inside those prisms (CPU rasterizer, object-ID
//!   buffer, back faces culled as the player does): the miss count must be 0.
//! - `bake_cell_culls_what_a_wall_hides_only_when_asked`: `bake.occlusion_culling`
//!   on a wall between the cell and a statue culls the statue; off, it gets a proxy.
//!   Fails if occlusion culling stops culling.
//! - a property test: random box walls and targets; whatever is culled is hidden
//!   from random points of the prism by ray casting against the walls. In about half
//!   the cases a wide, tall blocker wall stands between the prism and the target:
//!   there the target must be culled, so the ray check always has culled targets to
//!   check (without the blocker, random walls rarely hide a target and the property
//!   could pass without checking anything).

use format::manifest::{parse_manifest_str, BakeParams, CellParams};
use format::{Ground, Instance, Model, Scene};
use glam::{Mat4, Vec2, Vec3};
use proptest::prelude::*;
use scene::park::SplitMix64;
use std::path::Path;
use worker::bake::{bake_cell, Assignment};
use worker::grid::{HexGrid, Prism};
use worker::occlusion::{occluded_instances, OcclusionSettings};
use worker::raster::{render, CullMode, DrawItem, View, BACKGROUND_ID};

const CITY: &str = r#"(
    name: "test-city",
    ground: (min: (0.0, 0.0), max: (184.0, 184.0)),
    scene: City((
        seed: 5,
        block_size: 40.0,
        street_width: 16.0,
        buildings_per_block: 2,
        min_height: 8.0,
        max_height: 30.0,
        floor_height: 3.5,
        variants: 6,
        props: [
            (model: Procedural("torus_knot"), count: 16, target_height: 1.8),
            (model: Procedural("sphere"), count: 16, target_height: 1.2),
        ],
    )),
    cells: (cell_size: 16.0, min_eye_height: 1.5, max_eye_height: 2.5),
)"#;

/// A small deterministic generator (splitmix64): uniform f32 in [0, 1), 24 bits.
struct Rng(SplitMix64);
impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(SplitMix64::new(seed))
    }

    fn next(&mut self) -> f32 {
        (self.0.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn distance_to_box(p: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    (lo - p).max(p - hi).max(Vec3::ZERO).length()
}

#[test]
fn no_culled_object_covers_a_pixel_from_1000_views_in_a_city() {
    let plan = parse_manifest_str(CITY, Path::new("manifests/test-city.ron")).unwrap();
    let scene = scene::build_scene(&plan).unwrap();
    let grid = HexGrid::new(scene.ground, plan.cells.cell_size);
    let bounds: Vec<(Vec3, Vec3)> = (0..scene.instances.len())
        .map(|i| scene.instance_bounds(i))
        .collect();
    // Street cells: cells whose centre is not inside any building's box.
    let street_cells: Vec<u32> = (0..grid.cell_count())
        .filter(|&c| {
            let centre = grid.centre(c);
            let p = Vec3::new(centre.x, 2.0, centre.y);
            bounds
                .iter()
                .all(|&(lo, hi)| distance_to_box(p, lo, hi) > 1.0)
        })
        .collect();
    assert!(street_cells.len() >= 10, "{}", street_cells.len());
    let cells: Vec<u32> = (0..10)
        .map(|k| street_cells[k * street_cells.len() / 10])
        .collect();

    let near = 0.05;
    let mut rng = Rng::new(17);
    let (mut views, mut misses, mut culled_total, mut outside_total) = (0usize, 0usize, 0, 0);
    for &cell in &cells {
        let prism = grid.prism(cell, plan.cells.min_eye_height, plan.cells.max_eye_height);
        let candidates: Vec<u32> = (0..scene.instances.len() as u32)
            .filter(|&i| {
                let (lo, hi) = bounds[i as usize];
                !prism.intersects_aabb(lo, hi)
            })
            .collect();
        let hidden = occluded_instances(
            &scene,
            &prism,
            &candidates,
            &OcclusionSettings::for_prism(&prism),
        );
        let culled: Vec<u32> = candidates
            .iter()
            .zip(&hidden)
            .filter(|(_, &h)| h)
            .map(|(&i, _)| i)
            .collect();
        culled_total += culled.len();
        outside_total += candidates.len();
        let mut is_culled = vec![false; scene.instances.len()];
        for &i in &culled {
            is_culled[i as usize] = true;
        }
        // 100 views per cell: uniform eyes in the prism away from the walls (a wall
        // nearer than the near plane is clipped in any renderer), random directions.
        let mut cell_views = 0;
        while cell_views < 100 {
            let eye = prism.sample(rng.next(), rng.next(), rng.next());
            if bounds
                .iter()
                .any(|&(lo, hi)| distance_to_box(eye, lo, hi) < 4.0 * near)
            {
                continue;
            }
            let yaw = rng.next() * std::f32::consts::TAU;
            let pitch = (rng.next() - 0.5) * 0.8;
            let dir = Vec3::new(
                yaw.cos() * pitch.cos(),
                pitch.sin(),
                yaw.sin() * pitch.cos(),
            );
            let view =
                View::look_at_fov(eye, eye + dir, Vec3::Y, 60.0, 96, 96, near, 5000.0).unwrap();
            let items: Vec<DrawItem> = scene
                .instances
                .iter()
                .enumerate()
                .filter(|(i, _)| {
                    // Whole instances behind the eye draw nothing.
                    let (lo, hi) = bounds[*i];
                    worker::view::box_corners(lo, hi)
                        .iter()
                        .any(|&c| (c - eye).dot(dir) > 0.0)
                })
                .map(|(i, _)| DrawItem::instance(&scene, i as u32))
                .collect();
            let frame = render(&view, &items, CullMode::Back);
            misses += frame
                .object_id
                .iter()
                .filter(|&&id| id != BACKGROUND_ID && is_culled[id as usize])
                .count();
            cell_views += 1;
            views += 1;
        }
    }
    eprintln!(
        "occlusion proof: {views} views in {} cells, {culled_total} of {outside_total} \
         outside objects culled, {misses} pixels of culled objects",
        cells.len()
    );
    assert!(views >= 1000);
    assert_eq!(misses, 0, "culled objects cover {misses} pixels");
    // The test means something only if something is culled.
    assert!(
        culled_total * 5 >= outside_total,
        "{culled_total} of {outside_total}"
    );
}

fn box_mesh(lo: [f32; 3], hi: [f32; 3]) -> format::Mesh {
    format::Mesh::cuboid(lo, hi, [180, 170, 160, 255])
}

fn model(mesh: format::Mesh) -> Model {
    Model::new("m".into(), "test".into(), mesh, None)
}

/// An untinted instance of `model` translated to `at`.
fn placed(model: u32, at: Vec3) -> Instance {
    Instance {
        model,
        transform: Mat4::from_translation(at),
        tint: Vec3::ONE,
    }
}

#[test]
fn bake_cell_culls_what_a_wall_hides_only_when_asked() {
    let statue = scene::procedural::build("sphere").unwrap();
    let mut statue = statue;
    scene::build::normalise(&mut statue, [0.0; 3], 2.0).unwrap();
    let scene = Scene {
        models: vec![
            model(box_mesh([-30.0, 0.0, -3.0], [30.0, 20.0, 3.0])),
            model(statue),
        ],
        instances: vec![
            placed(0, Vec3::new(50.0, 0.0, 80.0)),
            placed(1, Vec3::new(50.0, 0.0, 100.0)),
        ],
        ground: Ground {
            min: [0.0, 0.0],
            max: [100.0, 120.0],
        },
        model_bounds: Default::default(),
        instance_labels: Default::default(),
    };
    let grid = HexGrid::new(scene.ground, 16.0);
    let cell = grid.cell_at(Vec2::new(50.0, 50.0)).unwrap();
    let cells = CellParams {
        cell_size: 16.0,
        min_eye_height: 1.5,
        max_eye_height: 2.5,
    };
    let mut params = BakeParams {
        image_res: 64,
        ..BakeParams::default()
    };
    params.occlusion_culling = true;
    let on = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    assert_eq!(
        on.assignment[1],
        Assignment::Culled,
        "the wall hides the statue"
    );
    assert!(matches!(on.assignment[0], Assignment::Proxy(_)));
    params.occlusion_culling = false;
    let off = bake_cell(&scene, &grid, cell, &cells, &params).unwrap();
    assert!(matches!(off.assignment[1], Assignment::Proxy(_)));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// Random walls and a random target: if the target is culled, no ray from 400
    /// random points of the prism to random points of its box escapes the walls.
    /// With `blocker`, a 60 × 30 × 6 wall at z = 17..23 (the bake test's wall) hides
    /// every target: any segment from the prism (|x| ≤ 10, y ≤ 3) to the target
    /// (|x| ≤ 22, y ≤ 6, z ≥ 28) crosses it at |x| ≤ 22, y ≤ 6, well inside its
    /// occluder shrunk by ε = 1.25: the target must be culled.
    #[test]
    fn culled_means_every_sampled_ray_hits_a_wall(
        walls in prop::collection::vec(
            (-40.0f32..40.0, 12.0f32..40.0, 2.0f32..30.0, 4.0f32..20.0, 1.0f32..12.0, 0.0f32..1.0),
            1..5),
        blocker in any::<bool>(),
        target in (-20.0f32..20.0, 30.0f32..60.0, 0.5f32..4.0, 0.5f32..6.0),
        seed in 0u64..1000,
    ) {
        let mut models = Vec::new();
        let mut instances = Vec::new();
        let mut boxes = Vec::new();
        let blocker = blocker.then_some((0.0, 20.0, 60.0, 30.0, 6.0, 0.0));
        for (x, z, w, h, d, yaw) in walls.into_iter().chain(blocker) {
            let lo = [-w / 2.0, 0.0, -d / 2.0];
            let hi = [w / 2.0, h, d / 2.0];
            let transform = Mat4::from_translation(Vec3::new(x, 0.0, z))
                * Mat4::from_rotation_y(yaw * 3.0);
            models.push(model(box_mesh(lo, hi)));
            instances.push(Instance { model: models.len() as u32 - 1, transform, tint: Vec3::ONE });
            boxes.push((transform.inverse(), Vec3::from(lo), Vec3::from(hi)));
        }
        let (tx, tz, ts, th) = target;
        models.push(model(box_mesh([-ts / 2.0, 0.0, -ts / 2.0], [ts / 2.0, th, ts / 2.0])));
        let target_id = instances.len() as u32;
        instances.push(placed(models.len() as u32 - 1, Vec3::new(tx, 0.0, tz)));
        let scene = Scene {
            models,
            instances,
            ground: Ground { min: [-100.0, -100.0], max: [100.0, 100.0] },
            model_bounds: Default::default(),
            instance_labels: Default::default(),
        };
        let prism = Prism { centre: Vec2::ZERO, cell_size: 10.0, min_y: 1.0, max_y: 3.0 };
        if prism.intersects_aabb(scene.instance_bounds(target_id as usize).0, scene.instance_bounds(target_id as usize).1) {
            return Ok(());
        }
        let hidden = occluded_instances(&scene, &prism, &[target_id], &OcclusionSettings::for_prism(&prism));
        if blocker.is_some() {
            prop_assert!(hidden[0], "the blocker wall hides the target, but it is not culled");
        }
        if hidden[0] {
            let (lo, hi) = scene.instance_bounds(target_id as usize);
            let mut rng = Rng::new(seed);
            for _ in 0..400 {
                let p = prism.sample(rng.next(), rng.next(), rng.next());
                let q = lo + (hi - lo) * Vec3::new(rng.next(), rng.next(), rng.next());
                // The segment p→q must cross the interior of some wall before q.
                let blocked = boxes.iter().any(|(inv, blo, bhi)| {
                    let o = inv.transform_point3(p);
                    let d = inv.transform_vector3(q - p);
                    let (mut t0, mut t1) = (0.0f32, 1.0f32);
                    for k in 0..3 {
                        if d[k].abs() < 1e-12 {
                            if o[k] <= blo[k] || o[k] >= bhi[k] { return false; }
                            continue;
                        }
                        let a = (blo[k] - o[k]) / d[k];
                        let b = (bhi[k] - o[k]) / d[k];
                        t0 = t0.max(a.min(b));
                        t1 = t1.min(a.max(b));
                    }
                    t0 < t1
                });
                prop_assert!(blocked, "a ray from {p} to {q} misses every wall");
            }
        }
    }
}
