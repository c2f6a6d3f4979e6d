//! Manifest schema: `manifest.ron` parsed in two stages (STYLE.md habit 8).
//!
//! Stage 1 (`RawManifest`) is a plain serde mirror of the file with
//! `deny_unknown_fields`, read by `ron`: unknown fields, missing fields, wrong types
//! and syntax errors come back from ron with their line and column. Stage 2 (`Plan`)
//! is the validated, resolved form the rest of hexbake reads: relative paths resolved
//! against the manifest's folder, ranges checked, defaults applied (the paper's
//! values, 000 §4.1.2). Validation errors find the offending field's line and column
//! in the text through a structural scan of the text (`field_positions.rs`).
//!
//! The syntax (every field not marked optional is required):
//!
//! ```ron
//! (
//!     name: "demo",                                    // optional, default: file stem
//!     ground: (min: (0.0, 0.0), max: (300.0, 260.0)),  // x–z rectangle on y = 0
//!     scene: Park((
//!         seed: 7,
//!         models: [
//!             // File("path") or Procedural("name"); pre_rotation_deg optional
//!             // (x, y, z Euler degrees, applied x first, before normalising)
//!             (model: Procedural("torus_knot"), count: 4, target_height: 20.0),
//!             (model: File("../models/bunny.obj"), count: 7, target_height: 43.2,
//!              pre_rotation_deg: (0.0, 0.0, 0.0)),
//!         ],
//!         tint_min: (0.7, 0.7, 0.7),                   // optional, default (1, 1, 1)
//!         tint_max: (1.0, 1.0, 1.0),                   // optional, default (1, 1, 1)
//!         // optional: hand-placed objects added after the generated ones, each
//!         // written as an `Instances` entry below; they must not overlap a generated
//!         // one (the scene build names the pair), but may touch each other
//!         placed: [(model: Procedural("sphere"), target_height: 6.0,
//!                   translation: (240.0, 0.0, 40.0), rotation_y_deg: 0.0)],
//!     )),
//!     // or: scene: City((seed: 17, block_size: 64.0, street_width: 20.0,
//!     //        min_height: 12.0, max_height: 60.0,
//!     //        buildings_per_block: 2 /* optional */, floor_height: 3.5 /* optional */,
//!     //        variants: 16 /* optional */, props: [ /* as park models */ ] /* optional */,
//!     //        tint_min: (..), tint_max: (..) /* optional */)),
//!     // or: scene: Gltf("scene.glb")  (a .gltf or .glb read as a whole scene: every
//!     //        node with a mesh placed with its composed transform, in the file's
//!     //        units; base-colour textures read; `load::load_gltf_scene`)
//!     // or: scene: Gltf((file: "scene.glb", objects: Hierarchy))  (the same; which
//!     //        mesh nodes form one object: `Hierarchy` (default) each top-level
//!     //        node with its subtree, when no wider than a cell — a truck and its
//!     //        wheels; `Parents` the mesh children of one node (also written
//!     //        `group_by_parent: true`); `Nodes` every mesh node; `load::GltfObjects`)
//!     // or: scene: Instances([(model: File("a.obj"), target_height: 10.0,
//!     //        translation: (5.0, 0.0, 7.0), rotation_y_deg: 30.0,
//!     //        scale: 1.0 /* optional */, tint: (1.0, 0.9, 0.8) /* optional */,
//!     //        pre_rotation_deg: (0.0, 0.0, 0.0) /* optional */), ...]),
//!     cells: (cell_size: 50.0, min_eye_height: 6.0, max_eye_height: 12.0),
//!     bake: (image_res: 1024, clustering: true),       // optional, every field optional
//!     //    quality: (min_psnr_db: 30.0, min_ssim: 0.9) /* opt-in objective selection, issue 16:
//!     //        the floor a cheaper candidate must reach to replace a mesh proxy (not a
//!     //        guarantee on the mesh proxy); `quality: ()` for the defaults */
//!     cells_per_job: 4,                                // optional, default 4
//!     split_wide_objects: true,                        // optional, default true: objects
//!     //   wider than two cells become one chunk per cell (scene::chunk, issue 29)
//!     output: "../out/demo",                           // optional, default ../out/<name>
//! )
//! ```
//!
//! **Limits** (issue 19, "Trust nothing read from disk"). A manifest that validates
//! can be baked: besides types and ranges, the validator refuses values that f32
//! rasterising, the hex grid or memory cannot handle, each with file:line:column of
//! the field.
//!
//! | what | limit |
//! |---|---|
//! | the file | at most [`MAX_MANIFEST_BYTES`] (16 MiB) and brackets nested at most [`MAX_NESTING`] (64) deep |
//! | every coordinate: `ground.min`/`max`, an instance's `translation` | \|x\| ≤ [`MAX_COORDINATE`] (10⁶ units) |
//! | lengths: `target_height` (× `scale` for an instance), `cells.cell_size`, eye heights | ≤ [`MAX_COORDINATE`]; object heights ≥ [`MIN_LENGTH`] (10⁻³ units) |
//! | the grid: `cells.cell_size` on the ground | at most [`MAX_CELLS`] (1,000,000) cells |
//! | tints | components in 0..=[`MAX_TINT`] (100) |
//!
//! 10⁶ units keep f32 precise to 0.06 units or better anywhere in a scene (its spacing
//! at 10⁶ is 2⁻⁴), and squared distances far from overflow; a million cells is 40
//! times the paper's largest park grid (22 × 24) and bounds the plan, the job
//! journal and the index.
//!
//! **Overrides** (`pipeline run --set KEY=VALUE`, [`overrides`]) replace values of
//! the raw manifest before stage 2, so there is one validator: an overridden value
//! is refused with the same message as the same value in the file, located at the
//! override instead of file:line:column ([`ManifestError::Override`]).
//!
//! **Renamed parameters** ([`RENAMED`]): a name that changed to carry its unit
//! (`bake.edge_length_tolerance` → `bake.edge_length_tolerance_px`) is refused with
//! a message naming the new one, at its line and column.

use crate::field_positions::{FieldPositions, TextPosition};
use crate::scene::Ground;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub mod overrides;
mod plan;
mod raw;
mod validate;

pub use overrides::{parse_override, Override, OverrideError};
pub use plan::*;
pub use raw::write_instances_manifest;
use raw::*;
use validate::*;

/// A parameter renamed to say its unit: the old dotted name, the new one and the
/// unit. A manifest or `--set` using the old name is refused with a message that
/// names the new one ([`renamed_message`]); serialised plans and reports with the
/// old key still read (a serde alias).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Renamed {
    pub old: &'static str,
    pub new: &'static str,
    pub unit: &'static str,
}

/// The renamed manifest parameters (issue 14: units in names).
pub const RENAMED: &[Renamed] = &[Renamed {
    old: "bake.edge_length_tolerance",
    new: "bake.edge_length_tolerance_px",
    unit: "pixels",
}];

/// "`bake.edge_length_tolerance` was renamed `bake.edge_length_tolerance_px`
/// (pixels)" for an old name, `None` for any other.
pub fn renamed_message(field: &str) -> Option<String> {
    RENAMED
        .iter()
        .find(|r| r.old == field)
        .map(|r| format!("`{}` was renamed `{}` ({})", r.old, r.new, r.unit))
}

/// A manifest that cannot be read, parsed or validated.
///
/// Display reads `manifests/x.ron:12:5: unknown field `cel_size`, expected one of ...`.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    #[error("{}: cannot read manifest: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A syntax, unknown-field, missing-field or wrong-type error reported by ron, or a
    /// value that fails validation. `field` is the dotted path of the field involved
    /// (`scene.models[1].count`), empty when none applies.
    #[error("{}:{line}:{column}: {message}", path.display())]
    At {
        path: PathBuf,
        line: usize,
        column: usize,
        field: String,
        message: String,
    },
    /// A `--set` override ([`overrides`]) whose value the validator refuses (the
    /// same `message` as for the value in the file) or that does not parse as the
    /// field's type. `set` is the override as `KEY=VALUE` with its canonical key.
    #[error("{}: --set {set}: {message}", path.display())]
    Override {
        path: PathBuf,
        set: String,
        field: String,
        message: String,
    },
}

impl ManifestError {
    /// `(line, column)` of the error, 1-based; `None` for a read error.
    pub fn line_column(&self) -> Option<(usize, usize)> {
        match self {
            ManifestError::Read { .. } | ManifestError::Override { .. } => None,
            ManifestError::At { line, column, .. } => Some((*line, *column)),
        }
    }

    /// The message without its location (file:line:column, or the override): the
    /// same text for a value refused in the file and through `--set`.
    pub fn message(&self) -> String {
        match self {
            ManifestError::Read { source, .. } => format!("cannot read manifest: {source}"),
            ManifestError::At { message, .. } | ManifestError::Override { message, .. } => {
                message.clone()
            }
        }
    }

    /// Dotted path of the field involved; `None` for a read error or when unknown.
    pub fn field(&self) -> Option<&str> {
        match self {
            ManifestError::At { field, .. } | ManifestError::Override { field, .. }
                if !field.is_empty() =>
            {
                Some(field)
            }
            _ => None,
        }
    }
}

/// Reads, parses and validates the manifest at `path`.
pub fn parse_manifest(path: &Path) -> Result<Plan, ManifestError> {
    parse_manifest_with(path, &[])
}

/// [`parse_manifest`] with `--set` overrides applied, in order, to the raw manifest
/// before validation: an overridden value is checked by the same rules as the
/// file's ([`overrides`]).
pub fn parse_manifest_with(path: &Path, overrides: &[Override]) -> Result<Plan, ManifestError> {
    use std::io::Read;
    let read_error = |source| ManifestError::Read {
        path: path.to_path_buf(),
        source,
    };
    // Read at most one byte past the limit, so a huge file is refused, not read.
    let file = std::fs::File::open(path).map_err(read_error)?;
    let mut text = String::new();
    file.take(MAX_MANIFEST_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(read_error)?;
    if text.len() as u64 > MAX_MANIFEST_BYTES {
        return Err(read_error(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("the file is larger than the manifest limit of {MAX_MANIFEST_BYTES} bytes"),
        )));
    }
    parse_manifest_str_with(&text, path, overrides)
}

/// Parses and validates manifest `text`; `path` names it in messages and anchors
/// relative paths (its folder), so it need not exist.
pub fn parse_manifest_str(text: &str, path: &Path) -> Result<Plan, ManifestError> {
    parse_manifest_str_with(text, path, &[])
}

/// [`parse_manifest_str`] with `--set` overrides (see [`parse_manifest_with`]).
pub fn parse_manifest_str_with(
    text: &str,
    path: &Path,
    overrides: &[Override],
) -> Result<Plan, ManifestError> {
    // Stage 1: ron → raw structs; ron's errors carry a position.
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let positions = FieldPositions::scan(text);
    if let Some(at) = positions.too_deep() {
        // Refused before ron sees it: deep nesting is what exhausts parsers.
        return Err(ManifestError::At {
            path: path.to_path_buf(),
            line: at.line,
            column: at.column,
            field: positions.path_at(at).unwrap_or_default(),
            message: format!("brackets nested more than {MAX_NESTING} deep"),
        });
    }
    let mut raw: RawManifest = options
        .from_str(text)
        .map_err(|e| ron_error(path, &positions, e))?;
    // Stage 1½: the overrides replace raw values (only their type is checked here).
    for o in overrides {
        overrides::apply(&mut raw, o).map_err(|message| ManifestError::Override {
            path: path.to_path_buf(),
            set: o.to_string(),
            field: o.key.to_string(),
            message,
        })?;
    }
    // Stage 2: validate and resolve.
    Validator {
        path,
        positions: &positions,
        overrides,
    }
    .plan(raw)
}

pub use crate::limits::{
    MAX_CELLS, MAX_COORDINATE, MAX_FAR_LEVELS, MAX_MANIFEST_BYTES, MAX_TILES, MAX_TINT, MIN_LENGTH,
};

/// Default number of cells baked by one job.
pub const DEFAULT_CELLS_PER_JOB: u32 = 4;

/// Deepest bracket nesting a manifest may have (a real one nests about 5 deep).
pub const MAX_NESTING: usize = crate::field_positions::MAX_NESTING;

/// A value outside the manifest's rules: the dotted path of the field and what is
/// wrong with it. The manifest validator turns it into a positioned
/// [`ManifestError`]; `pipeline run --set` into an override error.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{field}` {message}")]
pub struct Violation {
    pub field: String,
    pub message: String,
}

impl Violation {
    fn new(field: &str, message: String) -> Violation {
        Violation {
            field: field.to_string(),
            message,
        }
    }
}

/// Checks the ground rectangle: finite, within ±[`MAX_COORDINATE`], `min < max` on
/// both axes.
pub fn check_ground(ground: &Ground) -> Result<(), Violation> {
    for (field, v) in [("ground.min", ground.min), ("ground.max", ground.max)] {
        for x in v {
            check_coordinate(field, x)?;
        }
    }
    if !(ground.min[0] < ground.max[0] && ground.min[1] < ground.max[1]) {
        return Err(Violation::new(
            "ground.max",
            format!(
                "must exceed `ground.min` on both axes, found min {:?} max {:?}",
                ground.min, ground.max
            ),
        ));
    }
    Ok(())
}

/// Checks the cell parameters on a (checked) ground: a cell size > 0 and at most
/// [`MAX_COORDINATE`] whose grid has at most [`MAX_CELLS`] cells, and eye heights with
/// `0 <= min_eye_height <= max_eye_height <= MAX_COORDINATE`.
pub fn check_cells(ground: &Ground, cells: &CellParams) -> Result<(), Violation> {
    let c = cells.cell_size;
    if !(c.is_finite() && c > 0.0) {
        return Err(Violation::new(
            "cells.cell_size",
            format!("must be > 0, found {c}"),
        ));
    }
    if c > MAX_COORDINATE {
        return Err(Violation::new(
            "cells.cell_size",
            format!("must be at most {MAX_COORDINATE} units, found {c}"),
        ));
    }
    match ground.hex_grid_dims(c) {
        Some([n_cols, n_rows]) if n_cols.saturating_mul(n_rows) <= MAX_CELLS => {}
        dims => {
            let found = dims.map_or("too many".to_string(), |[n, m]| {
                format!("{n} × {m} = {}", n.saturating_mul(m))
            });
            return Err(Violation::new(
                "cells.cell_size",
                format!(
                    "is too small for the ground ({:?} to {:?}): its grid would have \
                     {found} cells, more than {MAX_CELLS}",
                    ground.min, ground.max
                ),
            ));
        }
    }
    let (min, max) = (cells.min_eye_height, cells.max_eye_height);
    for (field, v) in [("cells.min_eye_height", min), ("cells.max_eye_height", max)] {
        if !v.is_finite() {
            return Err(Violation::new(
                field,
                format!("must be a finite number, found {v}"),
            ));
        }
        if v > MAX_COORDINATE {
            return Err(Violation::new(
                field,
                format!("must be at most {MAX_COORDINATE} units, found {v}"),
            ));
        }
    }
    if min < 0.0 {
        return Err(Violation::new(
            "cells.min_eye_height",
            format!("must be >= 0 (eyes above the ground), found {min}"),
        ));
    }
    if min > max {
        return Err(Violation::new(
            "cells.max_eye_height",
            format!("must be >= `min_eye_height` ({min}), found {max}"),
        ));
    }
    Ok(())
}

/// A coordinate: finite and within ±[`MAX_COORDINATE`].
fn check_coordinate(field: &str, v: f32) -> Result<f32, Violation> {
    if !v.is_finite() {
        return Err(Violation::new(
            field,
            format!("must be a finite number, found {v}"),
        ));
    }
    if v.abs() > MAX_COORDINATE {
        return Err(Violation::new(
            field,
            format!("must be within ±{MAX_COORDINATE} units, found {v}"),
        ));
    }
    Ok(v)
}

/// Turns a ron error into a [`ManifestError`] naming the field involved.
fn ron_error(
    path: &Path,
    positions: &FieldPositions,
    e: ron::error::SpannedError,
) -> ManifestError {
    use ron::error::Error as E;
    let mut at = TextPosition {
        line: e.position.line,
        column: e.position.col,
    };
    let enclosing = positions.path_at(at).unwrap_or_default();
    let one_of = |alts: &[&str]| {
        alts.iter()
            .map(|a| format!("`{a}`"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let within = |field: &str| {
        if field.is_empty() {
            String::new()
        } else {
            format!(" in `{field}`")
        }
    };
    let (field, message) = match &e.code {
        E::NoSuchStructField {
            expected, found, ..
        } => {
            // Point at the misspelled key itself rather than past it.
            if let Some(key) = positions.key_before(at, found) {
                at = key;
            }
            let field = positions.path_at(at).unwrap_or_else(|| found.clone());
            let message = renamed_message(&field).unwrap_or_else(|| {
                format!(
                    "unknown field `{found}`, expected one of {}",
                    one_of(expected)
                )
            });
            (field, message)
        }
        E::MissingStructField { field, .. } => {
            let enclosing = positions.struct_at(at).unwrap_or_default();
            let full = if enclosing.is_empty() {
                field.to_string()
            } else {
                format!("{enclosing}.{field}")
            };
            (
                full,
                format!("missing field `{field}`{}", within(&enclosing)),
            )
        }
        E::DuplicateStructField { field, .. } => (
            enclosing.clone(),
            format!("duplicate field `{field}`{}", within(&enclosing)),
        ),
        E::NoSuchEnumVariant {
            expected, found, ..
        } => (
            enclosing.clone(),
            format!(
                "unknown variant `{found}`{}, expected one of {}",
                within(&enclosing),
                one_of(expected)
            ),
        ),
        other => {
            let mut text = other.to_string();
            if let Some(first) = text.get(..1) {
                text = first.to_lowercase() + &text[1..];
            }
            let message = if enclosing.is_empty() {
                text
            } else {
                format!("`{enclosing}`: {text}")
            };
            (enclosing.clone(), message)
        }
    };
    ManifestError::At {
        path: path.to_path_buf(),
        line: at.line,
        column: at.column,
        field,
        message,
    }
}

/// `path` with `.` components dropped and `name/..` pairs folded, without touching the
/// file system (so `manifests/../out/demo` prints as `out/demo`). A `..` that follows
/// no normal component is kept; an empty result is `.`.
pub fn lexically_normal(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut parts: Vec<Component> = Vec::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match parts.last() {
                Some(Component::Normal(_)) => {
                    parts.pop();
                }
                Some(Component::RootDir) | Some(Component::Prefix(_)) => {}
                _ => parts.push(c),
            },
            _ => parts.push(c),
        }
    }
    if parts.is_empty() {
        return PathBuf::from(".");
    }
    parts.iter().collect()
}

#[cfg(test)]
mod lexical_tests {
    use super::lexically_normal;
    use std::path::Path;

    #[test]
    fn folds_dot_and_dot_dot() {
        let n = |s: &str| lexically_normal(Path::new(s)).display().to_string();
        assert_eq!(n("manifests/../out/demo"), "out/demo");
        assert_eq!(n("./manifests/./x.ron"), "manifests/x.ron");
        assert_eq!(n("../out/demo"), "../out/demo");
        assert_eq!(n("./../out"), "../out");
        assert_eq!(n("/a/../../b"), "/b");
        assert_eq!(n("a/.."), ".");
    }
}

#[cfg(test)]
mod bake_params_tests {
    use super::{BakeParams, DEFAULT_MAX_DEVIATION_PX};

    /// One default per parameter (issue 14): a serialised plan missing a field reads
    /// it at [`BakeParams::default`], as a manifest does; the old key of a renamed
    /// field still reads; new ones round-trip.
    #[test]
    fn serialised_bake_params_read_with_the_one_default_and_old_keys() {
        let old = r#"{"image_res":1024,"self_occluding_tolerance_px":5.0,
            "edge_length_tolerance":6.0,"t_c0":0.00034,"t_c1":0.000128,
            "clustering":true,"occlusion_culling":false}"#;
        let p: BakeParams = serde_json::from_str(old).unwrap();
        assert_eq!(p.edge_length_tolerance_px, 6.0);
        assert_eq!(p.max_deviation_px, DEFAULT_MAX_DEVIATION_PX);
        assert_eq!(p.deviation_bound_px(), Some(DEFAULT_MAX_DEVIATION_PX));
        assert!(p.far_field);
        assert_eq!(
            BakeParams {
                edge_length_tolerance_px: 4.5,
                ..p
            },
            BakeParams::default()
        );
        let d = BakeParams::default();
        assert_eq!(d.max_deviation_px, DEFAULT_MAX_DEVIATION_PX);
        let back: BakeParams = serde_json::from_str(&serde_json::to_string(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        let off = BakeParams {
            max_deviation_px: 0.0,
            ..d
        };
        assert_eq!(off.deviation_bound_px(), None);
    }
}
