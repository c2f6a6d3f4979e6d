//! Manifest parsing: the two stages (ron → raw → validated plan) and their errors,
//! which must name file:line:column and the field (issue 2, item 2).

use format::manifest::{parse_manifest, parse_manifest_str, ManifestError, ModelSource, SceneSpec};
use std::path::{Path, PathBuf};

const GOOD: &str = r#"(
    name: "demo",
    ground: (min: (0.0, 0.0), max: (300.0, 260.0)),
    scene: Park((
        seed: 7,
        models: [
            (model: Procedural("torus_knot"), count: 4, target_height: 20.0),
            (model: File("models/a.obj"), count: 7, target_height: 43.2, pre_rotation_deg: (-90.0, 0.0, 0.0)),
        ],
        tint_min: (0.7, 0.7, 0.7),
        tint_max: (1.0, 1.0, 1.0),
    )),
    cells: (cell_size: 50.0, min_eye_height: 6.0, max_eye_height: 12.0),
    bake: (image_res: 256, clustering: false),
    cells_per_job: 2,
    output: "../out/demo",
)
"#;

/// A temp dir holding `manifests/m.ron` (contents `text`) and an (empty) model file
/// `manifests/models/a.obj`; the path only needs to exist for validation.
fn write_manifest(text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let manifests = dir.path().join("manifests");
    std::fs::create_dir_all(manifests.join("models")).unwrap();
    std::fs::write(manifests.join("models/a.obj"), "v 0 0 0\n").unwrap();
    let path = manifests.join("m.ron");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn parse_err(text: &str) -> (ManifestError, String) {
    let (_dir, path) = write_manifest(text);
    let err = parse_manifest(&path).expect_err("manifest should be rejected");
    let shown = err.to_string();
    let rel = shown.replace(&path.display().to_string(), "m.ron");
    (err, rel)
}

/// 1-based (line, column) of the first occurrence of `needle` in `text`.
fn position_of(text: &str, needle: &str) -> (usize, usize) {
    let offset = text.find(needle).expect("needle in text");
    let line = text[..offset].matches('\n').count() + 1;
    let line_start = text[..offset].rfind('\n').map_or(0, |k| k + 1);
    (line, text[line_start..offset].chars().count() + 1)
}

#[test]
fn good_manifest_resolves_paths_and_defaults() {
    let (dir, path) = write_manifest(GOOD);
    let plan = parse_manifest(&path).unwrap();
    assert_eq!(plan.name, "demo");
    assert_eq!(plan.cells.cell_size, 50.0);
    assert_eq!(plan.cells_per_job, 2);
    assert_eq!(plan.bake.image_res, 256);
    assert!(!plan.bake.clustering);
    // Unspecified bake fields keep the paper's defaults.
    assert_eq!(plan.bake.self_occluding_tolerance_px, 5.0);
    assert_eq!(plan.bake.t_c0, 3.4e-4);
    assert_eq!(plan.output, dir.path().join("out/demo"));
    let SceneSpec::Park(park) = &plan.scene else {
        panic!("expected a park")
    };
    assert_eq!(park.seed, 7);
    assert_eq!(park.models.len(), 2);
    assert_eq!(
        park.models[0].model,
        ModelSource::Procedural("torus_knot".into())
    );
    assert_eq!(park.models[0].pre_rotation_deg, [0.0; 3]);
    assert_eq!(park.models[1].pre_rotation_deg, [-90.0, 0.0, 0.0]);
    // Relative file paths resolve against the manifest's folder, not the cwd.
    assert_eq!(
        park.models[1].model,
        ModelSource::File(dir.path().join("manifests/models/a.obj"))
    );
    assert!(matches!(&park.models[1].model, ModelSource::File(p) if p.is_file()));
    assert_eq!(park.tint_min, [0.7; 3]);
}

#[test]
fn optional_fields_take_defaults() {
    let text = r#"(
        ground: (min: (0.0, 0.0), max: (10.0, 10.0)),
        scene: Instances([
            (model: Procedural("box"), target_height: 2.0, translation: (5.0, 0.0, 5.0), rotation_y_deg: 30.0),
        ]),
        cells: (cell_size: 5.0, min_eye_height: 1.0, max_eye_height: 2.0),
    )"#;
    let plan = parse_manifest_str(text, Path::new("some/dir/small.ron")).unwrap();
    assert_eq!(plan.name, "small");
    assert_eq!(plan.bake, format::manifest::BakeParams::default());
    assert_eq!(plan.cells_per_job, 4);
    assert_eq!(plan.output, Path::new("some/out/small"));
    let SceneSpec::Instances(list) = &plan.scene else {
        panic!("expected instances")
    };
    assert_eq!(list[0].scale, 1.0);
    assert_eq!(list[0].tint, [1.0; 3]);
    assert_eq!(list[0].rotation_y_deg, 30.0);
}

#[test]
fn misspelled_field_names_line_column_and_field() {
    let text = GOOD.replace("(cell_size: 50.0", "(cel_size: 50.0");
    let (err, shown) = parse_err(&text);
    let (line, col) = position_of(&text, "cel_size");
    assert_eq!(err.line_column(), Some((line, col)), "{shown}");
    assert!(
        shown.starts_with(&format!("m.ron:{line}:{col}: unknown field `cel_size`")),
        "{shown}"
    );
    assert!(shown.contains("expected one of `cell_size`"), "{shown}");
    assert_eq!(err.field(), Some("cells.cel_size"));
}

#[test]
fn misspelled_nested_field_in_list() {
    let text = GOOD.replace("count: 7", "cuont: 7");
    let (err, shown) = parse_err(&text);
    let (line, col) = position_of(&text, "cuont");
    assert_eq!(err.line_column(), Some((line, col)), "{shown}");
    assert!(shown.contains("unknown field `cuont`"), "{shown}");
    assert_eq!(err.field(), Some("scene.models[1].cuont"));
}

#[test]
fn missing_field_is_named() {
    let text = GOOD.replace("min_eye_height: 6.0, ", "");
    let (err, shown) = parse_err(&text);
    assert!(shown.contains("missing field `min_eye_height`"), "{shown}");
    let (line, _) = position_of(&text, "cells:");
    assert_eq!(err.line_column().unwrap().0, line, "{shown}");
    assert_eq!(err.field(), Some("cells.min_eye_height"));
}

#[test]
fn wrong_type_is_named() {
    let text = GOOD.replace("cell_size: 50.0", "cell_size: \"fifty\"");
    let (err, shown) = parse_err(&text);
    let (line, _) = position_of(&text, "\"fifty\"");
    assert_eq!(err.line_column().unwrap().0, line, "{shown}");
    assert_eq!(err.field(), Some("cells.cell_size"), "{shown}");
    assert!(shown.contains("cells.cell_size"), "{shown}");
}

#[test]
fn syntax_error_has_position() {
    let text = GOOD.replace("seed: 7,", "seed: 7,,");
    let (err, shown) = parse_err(&text);
    let (line, _) = position_of(&text, "7,,");
    assert_eq!(err.line_column().unwrap().0, line, "{shown}");
}

#[test]
fn negative_cell_size_is_out_of_range() {
    let text = GOOD.replace("cell_size: 50.0", "cell_size: -5.0");
    let (err, shown) = parse_err(&text);
    let (line, col) = position_of(&text, "cell_size");
    assert_eq!(err.line_column(), Some((line, col)), "{shown}");
    assert_eq!(err.field(), Some("cells.cell_size"));
    assert!(
        shown.contains("`cells.cell_size` must be > 0, found -5"),
        "{shown}"
    );
}

#[test]
fn min_eye_above_max_eye_is_rejected() {
    let text = GOOD.replace("min_eye_height: 6.0", "min_eye_height: 16.0");
    let (err, shown) = parse_err(&text);
    let (line, col) = position_of(&text, "max_eye_height");
    assert_eq!(err.line_column(), Some((line, col)), "{shown}");
    assert_eq!(err.field(), Some("cells.max_eye_height"));
}

#[test]
fn out_of_range_values_name_their_field() {
    let cases = [
        (
            "target_height: 43.2",
            "target_height: 0.0",
            "scene.models[1].target_height",
        ),
        ("image_res: 256", "image_res: 3", "bake.image_res"),
        (
            "clustering: false",
            "clustering: false, max_deviation_px: -0.5",
            "bake.max_deviation_px",
        ),
        ("cells_per_job: 2", "cells_per_job: 0", "cells_per_job"),
        ("max: (300.0, 260.0)", "max: (300.0, -1.0)", "ground.max"),
        (
            "tint_max: (1.0, 1.0, 1.0)",
            "tint_max: (1.0, 0.5, 1.0)",
            "scene.tint_max",
        ),
        (
            "\"models/a.obj\"",
            "\"models/missing.obj\"",
            "scene.models[1].model",
        ),
        (
            "\"models/a.obj\"",
            "\"models/a.fbx\"",
            "scene.models[1].model",
        ),
        (
            "Procedural(\"torus_knot\")",
            "Procedural(\"teapot\")",
            "scene.models[0].model",
        ),
        (
            "pre_rotation_deg: (-90.0, 0.0, 0.0)",
            "pre_rotation_deg: (-90.0, inf, 0.0)",
            "scene.models[1].pre_rotation_deg",
        ),
        // Issue 19: values that parse but cannot be baked.
        ("cell_size: 50.0", "cell_size: 0.001", "cells.cell_size"),
        ("cell_size: 50.0", "cell_size: 1e30", "cells.cell_size"),
        (
            "max_eye_height: 12.0",
            "max_eye_height: 1e30",
            "cells.max_eye_height",
        ),
        ("max: (300.0, 260.0)", "max: (300.0, 1e7)", "ground.max"),
        ("min: (0.0, 0.0)", "min: (-3e38, 0.0)", "ground.min"),
        (
            "target_height: 43.2",
            "target_height: 1e30",
            "scene.models[1].target_height",
        ),
        (
            "target_height: 43.2",
            "target_height: 1e-9",
            "scene.models[1].target_height",
        ),
        (
            "tint_max: (1.0, 1.0, 1.0)",
            "tint_max: (1.0, 1e38, 1.0)",
            "scene.tint_max",
        ),
    ];
    for (from, to, field) in cases {
        let text = GOOD.replace(from, to);
        assert_ne!(text, GOOD, "{from}");
        let (err, shown) = parse_err(&text);
        assert_eq!(err.field(), Some(field), "{shown}");
        let key = field.rsplit('.').next().unwrap();
        let (line, col) = position_of(&text[..], &format!("{key}:")[..]);
        // The key's first occurrence may belong to an earlier element: check the line
        // names the field.
        let (eline, ecol) = err.line_column().unwrap();
        let line_text = text.lines().nth(eline - 1).unwrap();
        assert!(
            line_text[..].contains(key),
            "{shown}: line {eline} is {line_text:?}"
        );
        assert!(eline >= line && (eline > line || ecol >= col), "{shown}");
        assert!(shown.contains(&format!("`{field}`")), "{shown}");
    }
}

/// An `Instances` scene of one instance: `{FIELDS}` stands for extra fields.
const INSTANCES: &str = r#"(
    ground: (min: (0.0, 0.0), max: (300.0, 260.0)),
    scene: Instances([
        (model: Procedural("box"), target_height: 10.0, translation: (5.0, 0.0, 7.0),
         rotation_y_deg: 30.0{FIELDS}),
    ]),
    cells: (cell_size: 50.0, min_eye_height: 6.0, max_eye_height: 12.0),
)
"#;

/// Issue 19: an instance placed or sized beyond what f32 rasterising handles is
/// refused at its field, with the manifest's line and column.
#[test]
fn instances_beyond_the_coordinate_limit_are_refused_at_their_field() {
    let good = INSTANCES.replace("{FIELDS}", "");
    parse_manifest_str(&good, Path::new("i.ron")).unwrap();
    for (from, to, field, key, says) in [
        (
            "translation: (5.0, 0.0, 7.0)",
            "translation: (5.0, 0.0, 1e38)",
            "scene[0].translation",
            "translation:",
            "within ±1000000",
        ),
        (
            "translation: (5.0, 0.0, 7.0)",
            "translation: (-2e6, 0.0, 7.0)",
            "scene[0].translation",
            "translation:",
            "within ±1000000",
        ),
        (
            "{FIELDS}",
            ", scale: 1e30",
            "scene[0].scale",
            "scale:",
            "units tall",
        ),
        (
            "{FIELDS}",
            ", scale: 1e-7",
            "scene[0].scale",
            "scale:",
            "units tall",
        ),
        (
            "target_height: 10.0",
            "target_height: 2e6",
            "scene[0].target_height",
            "target_height:",
            "1000000",
        ),
        (
            "{FIELDS}",
            ", tint: (1.0, inf, 1.0)",
            "scene[0].tint",
            "tint:",
            "components in 0..=100",
        ),
    ] {
        let text = INSTANCES.replace(from, to).replace("{FIELDS}", "");
        let err = parse_manifest_str(&text, Path::new("i.ron")).unwrap_err();
        assert_eq!(err.field(), Some(field), "{err}");
        assert_eq!(err.line_column(), Some(position_of(&text, key)), "{err}");
        let shown = err.to_string();
        assert!(shown.starts_with("i.ron:"), "{shown}");
        assert!(shown.contains(says), "{to}: {shown}");
    }
}

/// Issue 19: `cell_size: 0.001` on the demo's ground (a 200,000 × 150,000 grid)
/// panicked in the worker's grid; it is refused at the field, naming the limit.
#[test]
fn a_grid_too_large_for_the_ground_is_refused_at_the_cell_size() {
    let text = GOOD.replace("cell_size: 50.0", "cell_size: 0.001");
    let (err, shown) = parse_err(&text);
    assert_eq!(err.field(), Some("cells.cell_size"));
    assert_eq!(err.line_column(), Some(position_of(&text, "cell_size")));
    assert!(shown.contains("more than 1000000"), "{shown}");
    // The rule is one function, which `pipeline run --set` also calls.
    let ground = format::Ground {
        min: [0.0, 0.0],
        max: [300.0, 260.0],
    };
    let mut cells = format::manifest::CellParams {
        cell_size: 0.001,
        min_eye_height: 6.0,
        max_eye_height: 12.0,
    };
    let v = format::manifest::check_cells(&ground, &cells).unwrap_err();
    assert_eq!(v.field, "cells.cell_size");
    // A grid under the limit is accepted: 1000 × 752 cells.
    cells.cell_size = 0.2;
    assert_eq!(ground.hex_grid_dims(0.2), Some([1000, 752]));
    format::manifest::check_cells(&ground, &cells).unwrap();
}

/// Issue 19: 100,000 `[` exhausted memory in the field scan before ron parsed a
/// thing; it is refused at the first bracket nested too deep.
#[test]
fn deep_nesting_is_refused_with_its_position() {
    let mut text = "(\n  name: ".to_string();
    text.push_str(&"[".repeat(100_000));
    let err = parse_manifest_str(&text, Path::new("deep.ron")).unwrap_err();
    let depth = format::manifest::MAX_NESTING;
    // `(` is the first level; the `[` at column 9 + depth − 1 is one too many.
    assert_eq!(err.line_column(), Some((2, 9 + depth - 1)), "{err}");
    assert!(
        err.to_string().contains("nested more than 64 deep"),
        "{err}"
    );
}

/// A manifest file larger than the limit is refused before it is read whole.
#[test]
fn a_huge_manifest_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.ron");
    let file = std::fs::File::create(&path).unwrap();
    file.set_len(format::manifest::MAX_MANIFEST_BYTES + 1)
        .unwrap();
    let err = parse_manifest(&path).unwrap_err();
    assert!(matches!(err, ManifestError::Read { .. }), "{err}");
    assert!(err.to_string().contains("larger than"), "{err}");
}

#[test]
fn empty_park_is_rejected() {
    let text = r#"(
        ground: (min: (0.0, 0.0), max: (10.0, 10.0)),
        scene: Park((seed: 1, models: [])),
        cells: (cell_size: 5.0, min_eye_height: 1.0, max_eye_height: 2.0),
    )"#;
    let err = parse_manifest_str(text, Path::new("e.ron")).unwrap_err();
    assert_eq!(err.field(), Some("scene.models"));
    assert_eq!(err.line_column(), Some((3, 31)), "{err}");
    assert!(err.to_string().starts_with("e.ron:3:31: "), "{err}");
}

#[test]
fn unknown_scene_variant_lists_the_choices() {
    let text = GOOD.replace("scene: Park((", "scene: Parc((");
    let (_err, shown) = parse_err(&text);
    assert!(
        shown.contains("`Park`") && shown.contains("`Instances`"),
        "{shown}"
    );
}

#[test]
fn unreadable_manifest_names_the_path() {
    let err = parse_manifest(Path::new("/nonexistent/dir/m.ron")).unwrap_err();
    assert!(
        err.to_string().starts_with("/nonexistent/dir/m.ron: "),
        "{err}"
    );
    assert_eq!(err.line_column(), None);
}

#[test]
fn integers_are_accepted_for_float_fields() {
    let text = GOOD
        .replace("cell_size: 50.0", "cell_size: 50")
        .replace("target_height: 20.0", "target_height: 20");
    let (_dir, path) = write_manifest(&text);
    let plan = parse_manifest(&path).unwrap();
    assert_eq!(plan.cells.cell_size, 50.0);
}

#[test]
fn demo_manifest_parses() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../manifests/demo.ron");
    let plan = parse_manifest(&path).unwrap();
    assert_eq!(plan.name, "demo");
    assert_eq!(plan.bake.image_res, 256);
    assert_eq!(plan.cells.cell_size, 50.0);
    assert_eq!(
        plan.output,
        format::manifest::lexically_normal(&path.join("../../out/demo"))
    );
}

mod hostile {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        /// Random edits of a good manifest give a plan or a positioned error, never a
        /// panic; every error's line lies within the text.
        #[test]
        fn edited_manifests_give_errors_not_panics(
            edits in prop::collection::vec((any::<prop::sample::Index>(), "[ -~\n]{0,3}"), 1..5),
        ) {
            let mut text = GOOD.to_string();
            for (at, insert) in edits {
                let mut i = at.index(text.len());
                while !text.is_char_boundary(i) {
                    i -= 1;
                }
                let end = (i + insert.len().min(2)).min(text.len());
                let end = (end..=text.len()).find(|&e| text.is_char_boundary(e)).unwrap();
                text.replace_range(i..end, &insert);
            }
            if let Err(ManifestError::At { line, column, .. }) =
                parse_manifest_str(&text, Path::new("/nonexistent/m.ron"))
            {
                prop_assert!(line >= 1 && line <= text.lines().count() + 1);
                prop_assert!(column >= 1);
            }
        }
    }
}

// ---------------------------------------------------------------------------------
// Issue 14 item 4: one validator for the file and `--set`, units in names.

/// `GOOD` with `bake` replaced by `bake_fields` (the inside of `bake: (...)`).
fn with_bake(bake_fields: &str) -> String {
    GOOD.replace(
        "bake: (image_res: 256, clustering: false),",
        &format!("bake: ({bake_fields}),"),
    )
}

fn overrides(sets: &[&str]) -> Vec<format::manifest::Override> {
    sets.iter()
        .map(|s| format::manifest::parse_override(s).unwrap())
        .collect()
}

/// The old name of a renamed parameter is refused at its line and column with a
/// message that names the new one; so is the old key of `--set`.
#[test]
fn old_parameter_names_are_refused_naming_the_new_one() {
    let text = with_bake("image_res: 256, edge_length_tolerance: 4.5");
    let (err, shown) = parse_err(&text);
    let (line, column) = position_of(&text, "edge_length_tolerance");
    assert_eq!(err.line_column(), Some((line, column)), "{shown}");
    assert_eq!(err.field(), Some("bake.edge_length_tolerance"));
    assert_eq!(
        shown,
        format!(
            "m.ron:{line}:{column}: `bake.edge_length_tolerance` was renamed \
             `bake.edge_length_tolerance_px` (pixels)"
        )
    );
    let e = format::manifest::parse_override("bake.edge_length_tolerance=4.5").unwrap_err();
    assert_eq!(
        e.to_string(),
        "--set bake.edge_length_tolerance: `bake.edge_length_tolerance` was renamed \
         `bake.edge_length_tolerance_px` (pixels)"
    );
    // The new name and the paper's short name work.
    let (_dir, path) = write_manifest(&with_bake("edge_length_tolerance_px: 6.0"));
    assert_eq!(
        parse_manifest(&path).unwrap().bake.edge_length_tolerance_px,
        6.0
    );
    for key in ["T_l", "tl", "bake.edge_length_tolerance_px"] {
        let o = format::manifest::parse_override(&format!("{key}=6")).unwrap();
        assert_eq!(o.key, "bake.edge_length_tolerance_px");
    }
}

/// A value set by `--set` and the same value written in the manifest give the
/// identical plan, for every kind of parameter.
#[test]
fn an_override_and_the_same_value_in_the_manifest_give_the_identical_plan() {
    use format::manifest::parse_manifest_str_with;
    let (_dir, path) = write_manifest(GOOD);
    let cases: &[(&str, &str, &str)] = &[
        // (bake fields in the file, the same through --set, bake fields for the --set run)
        (
            "image_res: 512, clustering: false",
            "bake.image_res=512",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: false, edge_length_tolerance_px: 6.0",
            "T_l=6.0",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: false, self_occluding_tolerance_px: 3",
            "T_s=3",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: false, max_deviation_px: 0.0",
            "deviation=0",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: true",
            "bake.clustering=on",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: false, quality: (min_psnr_db: 35.0)",
            "min_psnr_db=35",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: false, quality: ()",
            "bake.quality=on",
            "image_res: 256, clustering: false",
        ),
        (
            "image_res: 256, clustering: false, far_field: false",
            "bake.far_field=false",
            "image_res: 256, clustering: false",
        ),
    ];
    for (in_file, set, base) in cases {
        let a = parse_manifest_str_with(&with_bake(in_file), &path, &[]).unwrap();
        let b = parse_manifest_str_with(&with_bake(base), &path, &overrides(&[set])).unwrap();
        assert_eq!(a, b, "{set}");
    }
    // Cells and cells_per_job.
    let a = parse_manifest_str_with(
        &GOOD
            .replace("cell_size: 50.0", "cell_size: 100.0")
            .replace("cells_per_job: 2", "cells_per_job: 1"),
        &path,
        &[],
    )
    .unwrap();
    let b = parse_manifest_str_with(
        GOOD,
        &path,
        &overrides(&["cell_size=100", "cells_per_job=1"]),
    )
    .unwrap();
    assert_eq!(a, b);
}

/// An out-of-range value gives the same message through `--set` as in the file;
/// only the location differs (the override instead of file:line:column).
#[test]
fn out_of_range_values_give_the_same_message_in_the_file_and_through_set() {
    use format::manifest::parse_manifest_str_with;
    let (_dir, path) = write_manifest(GOOD);
    let cases: &[(&str, &str, &str)] = &[
        (
            "bake: (image_res: 256, clustering: false)",
            "bake: (image_res: 8, clustering: false)",
            "bake.image_res=8",
        ),
        (
            "bake: (image_res: 256, clustering: false)",
            "bake: (image_res: 256, clustering: false, self_occluding_tolerance_px: -1)",
            "T_s=-1",
        ),
        (
            "bake: (image_res: 256, clustering: false)",
            "bake: (image_res: 256, clustering: false, edge_length_tolerance_px: 0)",
            "T_l=0",
        ),
        (
            "bake: (image_res: 256, clustering: false)",
            "bake: (image_res: 256, clustering: false, max_deviation_px: -0.5)",
            "deviation=-0.5",
        ),
        (
            "bake: (image_res: 256, clustering: false)",
            "bake: (image_res: 256, clustering: false, quality: (min_ssim: 1.5))",
            "bake.quality.min_ssim=1.5",
        ),
        (
            "cell_size: 50.0",
            "cell_size: 0.001",
            "cells.cell_size=0.001",
        ),
        ("cell_size: 50.0", "cell_size: 1e30", "cell_size=1e30"),
        (
            "max_eye_height: 12.0",
            "max_eye_height: 1e30",
            "cells.max_eye_height=1e30",
        ),
        (
            "min_eye_height: 6.0",
            "min_eye_height: -1",
            "cells.min_eye_height=-1",
        ),
        ("cells_per_job: 2", "cells_per_job: 0", "cells_per_job=0"),
    ];
    for (from, to, set) in cases {
        let in_file = parse_manifest_str_with(&GOOD.replace(from, to), &path, &[]).unwrap_err();
        let through_set = parse_manifest_str_with(GOOD, &path, &overrides(&[set])).unwrap_err();
        assert_eq!(in_file.message(), through_set.message(), "{set}");
        assert_eq!(in_file.field(), through_set.field(), "{set}");
        assert!(in_file.line_column().is_some(), "{set}");
        let canonical = format::manifest::parse_override(set).unwrap().to_string();
        assert_eq!(
            through_set.to_string(),
            format!(
                "{}: --set {canonical}: {}",
                path.display(),
                in_file.message()
            ),
        );
    }
}

/// One default per parameter: a manifest that leaves `bake` out, a `--set` that
/// does not touch it and a serialised plan without the field all give
/// `BakeParams::default()` (0.5 px for the deviation bound).
#[test]
fn every_parameter_has_one_default() {
    let (_dir, path) =
        write_manifest(&GOOD.replace("    bake: (image_res: 256, clustering: false),\n", ""));
    let plan = parse_manifest(&path).unwrap();
    let d = format::manifest::BakeParams::default();
    assert_eq!(plan.bake, d);
    assert_eq!(
        plan.bake.max_deviation_px,
        format::manifest::DEFAULT_MAX_DEVIATION_PX
    );
    let from_json: format::manifest::BakeParams = serde_json::from_str("{}").unwrap();
    assert_eq!(from_json, d);
}
