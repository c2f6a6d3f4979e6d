//! Scene building: normalisation, the nested Park generator (determinism, the
//! 2M ⊂ 4M ⊂ 8M subset property, no overlap) and `manifests/demo.ron`.

use format::manifest::{parse_manifest, parse_manifest_str};
use format::{Ground, Scene};
use proptest::prelude::*;
use scene::build::{footprint, normalise};
use scene::park::{self, ParkEntry, SlotGrid};
use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn demo_scene() -> Scene {
    let plan = parse_manifest(&repo_root().join("manifests/demo.ron")).expect("demo.ron parses");
    scene::build_scene(&plan).expect("demo scene builds")
}

/// Asserts each model of `scene` is normalised to its target height.
fn assert_normalised(scene: &Scene, target_heights: &[f32]) {
    for (model, &target) in scene.models.iter().zip(target_heights) {
        model.mesh.validate().unwrap();
        let (lo, hi) = model.mesh.bounds().unwrap();
        assert_eq!(lo[1], 0.0, "{}: base on y = 0", model.name);
        assert!(
            ((hi[1] - target) / target).abs() < 1e-5,
            "{}: height {} vs target {target}",
            model.name,
            hi[1]
        );
        for k in [0, 2] {
            assert!(
                (lo[k] + hi[k]).abs() <= 1e-5 * target,
                "{}: centred on axis {k}: {} .. {}",
                model.name,
                lo[k],
                hi[k]
            );
        }
        assert_eq!(model.content_hash, model.mesh.content_hash());
    }
}

#[test]
fn demo_manifest_loads_and_normalises() {
    let scene = demo_scene();
    // 18 generated statues of 6 models, then 14 placed objects of 5 more (the
    // cluster group's spheres, the block, the vase behind it, the pebbles, the
    // knots in the far corners).
    assert_eq!(scene.models.len(), 11);
    assert_eq!(scene.instances.len(), 32);
    assert_normalised(
        &scene,
        &[20.0, 30.0, 14.0, 10.0, 6.0, 8.0, 6.0, 40.0, 5.0, 0.3, 16.0],
    );
    let names: Vec<&str> = scene.models.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "torus_knot",
            "column",
            "vase",
            "sphere",
            "torus",
            "box",
            "sphere#2",
            "box#2",
            "vase#2",
            "sphere#3",
            "torus_knot#2"
        ]
    );
    // Every instance stands on the ground, inside the ground rectangle.
    for i in 0..scene.instances.len() {
        let (lo, hi) = scene.instance_bounds(i);
        assert!(lo.y.abs() < 1e-4, "instance {i} base at {}", lo.y);
        assert!(
            lo.x >= 0.0 && hi.x <= 300.0 && lo.z >= 0.0 && hi.z <= 260.0,
            "{i}: {lo} {hi}"
        );
    }
    println!(
        "demo: {} instances, {} triangles",
        scene.instances.len(),
        scene.triangle_count()
    );
}

#[test]
fn scene_building_is_deterministic() {
    let a = demo_scene();
    let b = demo_scene();
    assert_eq!(a, b);
    let bytes = |s: &Scene| serde_json::to_vec(s).unwrap();
    assert_eq!(bytes(&a), bytes(&b));
}

#[test]
fn pre_rotation_turns_the_model_before_normalising() {
    // The column is 8.4 tall and 3.2 wide: lying down (x rotated 90°), its height
    // is its diameter and its length runs along z.
    let upright = scene::procedural::build("column").unwrap();
    let mut lying = upright.clone();
    normalise(&mut lying, [90.0, 0.0, 0.0], 10.0).unwrap();
    let (lo, hi) = lying.bounds().unwrap();
    assert_eq!(lo[1], 0.0);
    assert!((hi[1] - 10.0).abs() < 1e-4);
    let [w, d] = footprint(&lying);
    assert!((w - 10.0).abs() < 0.05, "width {w}");
    assert!((d - 10.0 * 8.4 / 3.2).abs() < 0.1, "length {d}");
    lying.validate().unwrap();
    // Normals turned with the mesh: the top cap's normal (+y) now points along −z
    // or +z (R_x(90°) maps +y to +z).
    let top = upright
        .positions
        .iter()
        .position(|p| p[1] == 8.4 && p[0] == 0.0 && p[2] == 0.0)
        .expect("apex of the top cap");
    let n = lying.normals[top];
    assert!(n[2] > 0.99, "rotated normal {n:?}");
}

#[test]
fn flat_model_cannot_be_normalised() {
    let mut m = format::Mesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        normals: vec![[0.0, 1.0, 0.0]; 3],
        albedo: vec![[255; 4]; 3],
        triangles: vec![[0, 2, 1]],
    };
    assert!(normalise(&mut m, [0.0; 3], 5.0).is_err());
}

/// Issue 19: a nearly flat model scaled to its target height would reach beyond the
/// coordinate limit (f32 positions of 10¹⁰ and worse); it is refused, not baked.
#[test]
fn nearly_flat_wide_model_is_refused_when_normalised() {
    let mut m = format::Mesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1e-6, 1.0]],
        normals: vec![[0.0, 1.0, 0.0]; 3],
        albedo: vec![[255; 4]; 3],
        triangles: vec![[0, 2, 1]],
    };
    let before = m.clone();
    let e = normalise(&mut m, [0.0; 3], 10.0).unwrap_err();
    assert!(
        matches!(e, scene::build::NormaliseError::TooWide { .. }),
        "{e}"
    );
    assert!(e.to_string().contains("units wide"), "{e}");
    assert_eq!(m, before, "a refused model is left as it was");
}

#[test]
fn explicit_instances_and_shared_models() {
    let text = r#"(
        ground: (min: (-50.0, -50.0), max: (50.0, 50.0)),
        scene: Instances([
            (model: Procedural("box"), target_height: 2.0, translation: (5.0, 0.0, 7.0), rotation_y_deg: 90.0, scale: 2.0, tint: (1.0, 0.5, 0.25)),
            (model: Procedural("box"), target_height: 2.0, translation: (-5.0, 0.0, 7.0), rotation_y_deg: 0.0),
            (model: Procedural("box"), target_height: 3.0, translation: (0.0, 0.0, -9.0), rotation_y_deg: 0.0),
        ]),
        cells: (cell_size: 10.0, min_eye_height: 1.0, max_eye_height: 2.0),
    )"#;
    let plan = parse_manifest_str(text, Path::new("inline.ron")).unwrap();
    let scene = scene::build_scene(&plan).unwrap();
    // Same source and height → one model; another height → another model.
    assert_eq!(scene.models.len(), 2);
    assert_eq!(scene.models[0].name, "box");
    assert_eq!(scene.models[1].name, "box#2");
    assert_eq!(
        scene.instances.iter().map(|i| i.model).collect::<Vec<_>>(),
        [0, 0, 1]
    );
    let (lo, hi) = scene.instance_bounds(0);
    assert!((hi.y - 4.0).abs() < 1e-4 && lo.y.abs() < 1e-4, "scaled ×2");
    assert!(((lo.x + hi.x) / 2.0 - 5.0).abs() < 1e-4);
    assert!(((lo.z + hi.z) / 2.0 - 7.0).abs() < 1e-4);
    assert_eq!(scene.instances[0].tint.to_array(), [1.0, 0.5, 0.25]);
    assert_normalised(&scene, &[2.0, 3.0]);
}

/// The demo manifest with its counts replaced and without its placed objects (a
/// larger park would grow into them).
fn demo_with_counts(counts: [u32; 6]) -> String {
    let text = std::fs::read_to_string(repo_root().join("manifests/demo.ron")).unwrap();
    let mut out = String::new();
    let mut k = 0;
    let mut in_placed = false;
    for line in text.lines() {
        if line.trim_start().starts_with("placed: [") {
            in_placed = true;
        }
        if in_placed {
            in_placed = line.trim() != "],";
            continue;
        }
        if let Some(at) = line.find("count: ") {
            let end = at + 7 + line[at + 7..].find(',').unwrap();
            out.push_str(&format!(
                "{}count: {}{}\n",
                &line[..at],
                counts[k],
                &line[end..]
            ));
            k += 1;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    assert_eq!(k, 6);
    out
}

#[test]
fn smaller_park_is_a_subset_of_the_larger_one() {
    let path = repo_root().join("manifests/demo.ron");
    let small = scene::build_scene(
        &parse_manifest_str(&demo_with_counts([1, 2, 0, 3, 1, 1]), &path).unwrap(),
    )
    .unwrap();
    let large = scene::build_scene(
        &parse_manifest_str(&demo_with_counts([4, 5, 3, 3, 2, 6]), &path).unwrap(),
    )
    .unwrap();
    assert_eq!(small.models, large.models);
    assert_eq!(small.instances.len(), 8);
    assert_eq!(large.instances.len(), 23);
    for inst in &small.instances {
        assert!(
            large.instances.contains(inst),
            "small-park instance {inst:?} missing from the large park"
        );
    }
}

const GROUND: Ground = Ground {
    min: [0.0, 0.0],
    max: [1650.0, 2035.0],
};

fn entries(counts: &[u32], footprints: &[[f32; 2]]) -> Vec<ParkEntry> {
    counts
        .iter()
        .zip(footprints)
        .map(|(&count, &footprint)| ParkEntry { count, footprint })
        .collect()
}

/// Rotated footprint half extents of a placement.
fn half_extents(footprint: [f32; 2], yaw_deg: f32) -> [f64; 2] {
    let (s, c) = f64::from(yaw_deg).to_radians().sin_cos();
    let [w, d] = footprint.map(|x| f64::from(x) * 0.5);
    [c.abs() * w + s.abs() * d, s.abs() * w + c.abs() * d]
}

#[test]
fn park_order_is_round_robin_by_copy_then_model() {
    let fp = [[10.0, 5.0], [20.0, 20.0], [4.0, 30.0]];
    let (_, placed) =
        park::place(3, &entries(&[2, 1, 3], &fp), [1.0; 3], [1.0; 3], &GROUND).unwrap();
    let order: Vec<(usize, u32)> = placed.iter().map(|p| (p.model_entry, p.copy)).collect();
    assert_eq!(order, [(0, 0), (1, 0), (2, 0), (0, 1), (2, 1), (2, 2)]);
}

#[test]
fn park_reports_too_few_slots() {
    let ground = Ground {
        min: [0.0, 0.0],
        max: [100.0, 100.0],
    };
    // Slot side 1.1 × diag(30, 40) = 55: one slot fits.
    let err = park::place(
        1,
        &entries(&[2], &[[30.0, 40.0]]),
        [1.0; 3],
        [1.0; 3],
        &ground,
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            park::ParkError::NotEnoughSlots {
                needed: 2,
                available: 1,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn splitmix64_sequence_is_fixed() {
    // Reference values of splitmix64 from seed 0 (Vigna's reference implementation).
    let mut r = park::SplitMix64::new(0);
    assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
    assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    assert_eq!(r.next_u64(), 0x06C4_5D18_8009_454F);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Same seed and models, counts ≤: every instance of the smaller park is placed
    /// identically in the larger one; and the generator is deterministic.
    #[test]
    fn park_placements_are_nested(
        seed in any::<u64>(),
        small in prop::collection::vec(0u32..20, 8),
        extra in prop::collection::vec(0u32..15, 8),
        footprints in prop::collection::vec((5.0f32..60.0, 5.0f32..60.0), 8),
    ) {
        let fp: Vec<[f32; 2]> = footprints.iter().map(|&(w, d)| [w, d]).collect();
        let large: Vec<u32> = small.iter().zip(&extra).map(|(a, b)| a + b).collect();
        prop_assume!(small.iter().any(|&c| c > 0));
        let small_park = park::place(seed, &entries(&small, &fp), [0.5; 3], [1.0; 3], &GROUND);
        let large_park = park::place(seed, &entries(&large, &fp), [0.5; 3], [1.0; 3], &GROUND);
        let (Ok((_, small_placed)), Ok((_, large_placed))) = (small_park, large_park) else {
            // Only a lack of slots may fail, and then for the larger park first.
            return Ok(());
        };
        let again = park::place(seed, &entries(&large, &fp), [0.5; 3], [1.0; 3], &GROUND).unwrap().1;
        prop_assert_eq!(&again, &large_placed);
        prop_assert_eq!(small_placed.len() as u32, small.iter().sum::<u32>());
        for p in &small_placed {
            prop_assert!(large_placed.contains(p), "{:?} missing", p);
        }
    }

    /// Placements never overlap: each yawed footprint lies inside its own slot,
    /// slots are distinct, and the footprints' boxes are pairwise disjoint; the tint
    /// lies in its range.
    #[test]
    fn park_placements_do_not_overlap(
        seed in any::<u64>(),
        counts in prop::collection::vec(1u32..25, 1..9),
        footprints in prop::collection::vec((1.0f32..80.0, 1.0f32..80.0), 8),
    ) {
        let fp: Vec<[f32; 2]> = footprints.iter().map(|&(w, d)| [w, d]).collect();
        let e = entries(&counts, &fp[..counts.len()]);
        let grid = SlotGrid::new(&e, &GROUND).unwrap();
        let Ok((_, placed)) = park::place(seed, &e, [0.25, 0.5, 0.75], [0.5, 0.75, 1.0], &GROUND) else {
            return Ok(());
        };
        let half_slot = f64::from(grid.slot_size) * 0.5;
        let mut slots: Vec<usize> = placed.iter().map(|p| p.slot).collect();
        slots.sort_unstable();
        slots.dedup();
        prop_assert_eq!(slots.len(), placed.len());
        let boxes: Vec<[f64; 4]> = placed.iter().map(|p| {
            let [hx, hz] = half_extents(fp[p.model_entry], p.yaw_deg);
            let c = grid.centre(p.slot);
            let (x, z) = (f64::from(p.translation[0]), f64::from(p.translation[2]));
            assert!((x - c[0]).abs() + hx <= half_slot + 1e-3, "x outside slot");
            assert!((z - c[1]).abs() + hz <= half_slot + 1e-3, "z outside slot");
            for k in 0..3 {
                let lo = [0.25, 0.5, 0.75][k];
                assert!(p.tint[k] >= lo && p.tint[k] <= lo + 0.25, "tint {:?}", p.tint);
            }
            [x - hx, x + hx, z - hz, z + hz]
        }).collect();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (boxes[i], boxes[j]);
                let overlap = a[0] < b[1] - 1e-3 && b[0] < a[1] - 1e-3 && a[2] < b[3] - 1e-3 && b[2] < a[3] - 1e-3;
                prop_assert!(!overlap, "instances {} and {} overlap", i, j);
            }
        }
        // Inside the ground.
        for b in &boxes {
            prop_assert!(b[0] >= -1e-3 && b[1] <= 1650.0 + 1e-3 && b[2] >= -1e-3 && b[3] <= 2035.0 + 1e-3);
        }
    }
}

/// `pipeline scene --as-instances` writes a manifest whose bake parameters are the
/// original's, `bake.quality` included (the demo turns objective selection on).
#[test]
fn instance_list_keeps_every_bake_parameter() {
    let plan = parse_manifest(&repo_root().join("manifests/demo.ron")).unwrap();
    assert!(plan.bake.quality.is_some(), "the demo selects by quality");
    let text = scene::build::instances_manifest(&plan).unwrap();
    let listed = parse_manifest_str(&text, Path::new("demo-instances.ron")).unwrap();
    assert_eq!(listed.bake, plan.bake);
    assert_eq!(listed.cells, plan.cells);
    assert_eq!(listed.cells_per_job, plan.cells_per_job);
}

/// Every bake and cell parameter at a value other than its default survives
/// parse → `--as-instances` → parse (issue 28: the hand-written writer dropped
/// `quality_check`, so the listed manifest turned the check back on), and so do the
/// name, ground, cells per job, output and every instance field.
#[test]
fn instance_list_round_trips_every_non_default_parameter() {
    let text = r#"(
        name: "odd",
        ground: (min: (-10.5, 3.25), max: (190.0, 170.75)),
        scene: Instances([
            (model: Procedural("torus"), target_height: 7.5, translation: (20.0, 0.5, 30.0),
             rotation_y_deg: 33.3, scale: 1.5, tint: (0.5, 0.75, 0.25),
             pre_rotation_deg: (90.0, 10.0, -5.0)),
            (model: Procedural("box"), target_height: 3.0, translation: (120.0, 0.0, 90.0),
             rotation_y_deg: -12.0),
        ]),
        cells: (cell_size: 37.5, min_eye_height: 2.5, max_eye_height: 17.25),
        bake: (image_res: 320, self_occluding_tolerance_px: 3.5,
               edge_length_tolerance_px: 6.25, t_c0: 0.0005, t_c1: 0.0002,
               clustering: false, occlusion_culling: true, max_deviation_px: 0.0,
               far_field: false, quality: (min_psnr_db: 27.5, min_ssim: 0.85),
               quality_check: false),
        cells_per_job: 3,
        output: "/tmp/hexbake-odd-out",
    )"#;
    let plan = parse_manifest_str(text, Path::new("odd.ron")).unwrap();
    let d = format::manifest::BakeParams::default();
    let b = &plan.bake;
    // Each field differs from its default, so a writer that drops one fails below.
    assert_ne!(b.image_res, d.image_res);
    assert_ne!(b.self_occluding_tolerance_px, d.self_occluding_tolerance_px);
    assert_ne!(b.edge_length_tolerance_px, d.edge_length_tolerance_px);
    assert_ne!(b.t_c0, d.t_c0);
    assert_ne!(b.t_c1, d.t_c1);
    assert_ne!(b.clustering, d.clustering);
    assert_ne!(b.occlusion_culling, d.occlusion_culling);
    assert_ne!(b.max_deviation_px, d.max_deviation_px);
    assert_ne!(b.far_field, d.far_field);
    assert_ne!(b.quality, Some(format::manifest::QualityFloor::default()));
    assert_ne!(b.quality_check, d.quality_check);
    assert_ne!(plan.cells_per_job, format::manifest::DEFAULT_CELLS_PER_JOB);

    let listed_text = scene::build::instances_manifest(&plan).unwrap();
    let listed = parse_manifest_str(&listed_text, Path::new("odd-instances.ron")).unwrap();
    assert!(!listed.bake.quality_check, "{listed_text}");
    assert_eq!(listed.bake, plan.bake, "{listed_text}");
    assert_eq!(listed.cells, plan.cells);
    assert_eq!(listed.cells_per_job, plan.cells_per_job);
    assert_eq!(listed.ground, plan.ground);
    assert_eq!(listed.name, plan.name);
    assert_eq!(listed.output, plan.output);
    assert_eq!(listed.scene, plan.scene);

    // The demo (a park) with the check off keeps it off too.
    let demo = std::fs::read_to_string(repo_root().join("manifests/demo.ron")).unwrap();
    let off = demo.replacen("bake: (", "bake: (quality_check: false, ", 1);
    let plan = parse_manifest_str(&off, &repo_root().join("manifests/demo.ron")).unwrap();
    assert!(!plan.bake.quality_check);
    let listed = scene::build::instances_manifest(&plan).unwrap();
    let listed = parse_manifest_str(&listed, Path::new("demo-instances.ron")).unwrap();
    assert_eq!(listed.bake, plan.bake);
}

/// A park with `placed` objects (issue 16, the demo's showcase): they come after the
/// generated instances, which stay exactly where the park alone puts them, and
/// `--as-instances` lists them with the rest.
#[test]
fn placed_objects_follow_the_park_and_move_nothing() {
    let path = repo_root().join("manifests/demo.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    let with = parse_manifest_str(&text, &path).unwrap();
    let format::manifest::SceneSpec::Park(park) = &with.scene else {
        panic!("the demo is a park")
    };
    assert_eq!(park.placed.len(), 14);
    let mut alone = with.clone();
    if let format::manifest::SceneSpec::Park(p) = &mut alone.scene {
        p.placed.clear();
    }
    let (a, w) = (
        scene::build_scene(&alone).unwrap(),
        scene::build_scene(&with).unwrap(),
    );
    assert_eq!(w.instances[..a.instances.len()], a.instances[..]);
    let placed = &w.instances[a.instances.len()..];
    assert_eq!(placed.len(), 14);
    let first = placed[0].transform.w_axis;
    assert_eq!([first.x, first.y, first.z], park.placed[0].translation);

    let listed = scene::build::instances_manifest(&with).unwrap();
    let relisted =
        scene::build_scene(&parse_manifest_str(&listed, Path::new("demo-instances.ron")).unwrap())
            .unwrap();
    assert_eq!(relisted.instances.len(), w.instances.len());
    for (x, y) in relisted.instances.iter().zip(&w.instances) {
        assert!(x.transform.abs_diff_eq(y.transform, 1e-4), "{x:?} vs {y:?}");
    }
}

/// A placed object on a generated statue is refused with both named; a bad field
/// of a placed object names its path, line and column.
#[test]
fn placed_objects_are_validated() {
    let path = repo_root().join("manifests/demo.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    let scene = demo_scene();
    // The first generated statue's position.
    let p = scene.instances[0].transform.w_axis;
    let on_statue = text.replacen(
        "translation: (240.0, 0.0, 40.0)",
        &format!("translation: ({:?}, 0.0, {:?})", p.x, p.z),
        1,
    );
    let err = scene::build_scene(&parse_manifest_str(&on_statue, &path).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("scene.placed[0]")
            && err.contains("overlaps the park's generated instance 0")
            && err.contains("procedural:torus_knot"),
        "{err}"
    );
    let negative = text.replacen("target_height: 0.3,", "target_height: -0.3,", 1);
    let err = parse_manifest_str(&negative, &path)
        .unwrap_err()
        .to_string();
    assert!(err.contains("scene.placed[8].target_height"), "{err}");
    let line = text
        .lines()
        .position(|l| l.contains("target_height: 0.3,"))
        .unwrap()
        + 1;
    assert!(err.contains(&format!("demo.ron:{line}:")), "{err}");
}

/// Issue 27: a tiled world's centre tile is the base scene shifted by whole grid
/// periods — every base cell's prism and every base instance's box reappear shifted
/// by the same vector, so the world's centre cell has exactly the neighbourhood of
/// the base's cell inside its tile, and per-cell figures compare 1:1.
#[test]
fn tiled_world_centre_tile_is_the_base_shifted_by_whole_periods() {
    use format::grid::HexGrid;
    use format::manifest::SceneSpec;
    let base_plan = parse_manifest(&repo_root().join("manifests/demo.ron")).unwrap();
    let world_plan = parse_manifest(&repo_root().join("manifests/demo-world.ron")).unwrap();
    let SceneSpec::Tiled(spec) = &world_plan.scene else {
        panic!("demo-world.ron is a Tiled scene");
    };
    assert_eq!(spec.tiles, 3);
    let base = scene::build_scene(&base_plan).unwrap();
    let world = scene::build_scene(&world_plan).unwrap();
    assert_eq!(world.instances.len(), 9 * base.instances.len());
    assert_eq!(
        world.models.len(),
        base.models.len(),
        "tiles share the models"
    );
    let c = base_plan.cells.cell_size;
    let (bg, wg) = (HexGrid::new(base.ground, c), HexGrid::new(world.ground, c));
    let [pc, pr] = spec.period;
    assert_eq!(pc % 2, 0, "an even column period keeps the odd-q layout");
    assert_eq!(wg.n_cols(), bg.n_cols() + 2 * pc);
    assert_eq!(wg.n_rows(), bg.n_rows() + 2 * pr);
    let shift = glam::Vec2::new(pc as f32 * 1.5 * c, pr as f32 * 3f32.sqrt() * c);
    let tol = 1e-3 * c;
    for id in 0..bg.cell_count() {
        let (col, row) = bg.col_row(id);
        let w = wg
            .id(i64::from(col + pc), i64::from(row + pr))
            .expect("the centre tile's cell");
        for (a, b) in bg.corners(id).iter().zip(wg.corners(w)) {
            assert!(
                (*a + shift - b).length() < tol,
                "cell {id} → {w}: corner {a} vs {b}"
            );
        }
        // Inside the tile, the same neighbours (a border cell of the base has more
        // in the world: the next tile's).
        let mut bn: Vec<(u32, u32)> = bg.neighbours(id).iter().map(|&n| bg.col_row(n)).collect();
        let mut wn: Vec<(u32, u32)> = wg
            .neighbours(w)
            .iter()
            .map(|&n| wg.col_row(n))
            .filter(|&(c2, r2)| {
                (pc..pc + bg.n_cols()).contains(&c2) && (pr..pr + bg.n_rows()).contains(&r2)
            })
            .map(|(c2, r2)| (c2 - pc, r2 - pr))
            .collect();
        bn.sort_unstable();
        wn.sort_unstable();
        assert_eq!(bn, wn, "cell {id}: the same neighbours");
    }
    // The centre tile (1, 1) is the 5th block of instances.
    let n = base.instances.len();
    let shift3 = glam::Vec3::new(shift.x, 0.0, shift.y);
    for i in 0..n {
        let (lo, hi) = base.instance_bounds(i);
        let (wlo, whi) = world.instance_bounds(4 * n + i);
        assert!((lo + shift3 - wlo).length() < tol && (hi + shift3 - whi).length() < tol);
        assert_eq!(world.instances[4 * n + i].model, base.instances[i].model);
    }
}

/// A Tiled manifest gives no ground, tiles a manifest that is not tiled, with the
/// same cell size; each mistake is named.
#[test]
fn tiled_manifest_mistakes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let demo = repo_root().join("manifests/demo.ron");
    let write = |name: &str, text: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let tiled = |extra: &str, tiles: u32, cell: f32| {
        format!(
            "(scene: Tiled((manifest: {demo:?}, tiles: {tiles})), {extra} cells: (cell_size: {cell}, min_eye_height: 6.0, max_eye_height: 12.0))"
        )
    };
    for (text, expected) in [
        (
            tiled("ground: (min: (0.0, 0.0), max: (10.0, 10.0)),", 3, 50.0),
            "leave `ground` out",
        ),
        (tiled("", 0, 50.0), "scene.tiles"),
        (tiled("", 3, 40.0), "cells.cell_size"),
    ] {
        let e = parse_manifest(&write("w.ron", text))
            .unwrap_err()
            .to_string();
        assert!(e.contains(expected), "{e}");
    }
    let inner = write("inner.ron", tiled("", 2, 50.0));
    let outer = format!(
        "(scene: Tiled((manifest: {inner:?}, tiles: 2)), cells: (cell_size: 50.0, min_eye_height: 6.0, max_eye_height: 12.0))"
    );
    let e = parse_manifest(&write("outer.ron", outer))
        .unwrap_err()
        .to_string();
    assert!(e.contains("tiled itself"), "{e}");
}
