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
pub use overrides::{parse_override, Override, OverrideError};

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

/// Bake parameters with the paper's names and defaults (000 §3.1, §4.1.2).
///
/// One shape and one default per parameter: the manifest's raw layer, `--set`
/// overrides and the serialised form (`plan.json`, `report.json`) all take the
/// defaults of [`BakeParams::default`] for a missing field. (Plans and reports
/// written before a parameter existed therefore read with today's default, not the
/// value they were baked with; their jobs' fingerprints hash [`crate::fingerprint::BAKE_REVISION`],
/// so such outputs are rebaked anyway.)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BakeParams {
    /// Capture resolution: pixels across one 60° side face (DESIGN.md). Default 1024.
    pub image_res: u32,
    /// Self-occluding error tolerance T_s in pixels. Default 5.
    pub self_occluding_tolerance_px: f32,
    /// Projected edge-length tolerance T_l in pixels (000 §3.1.3.3). Default 4.5.
    /// Named `edge_length_tolerance` before issue 14: plans and reports written then
    /// still read (the alias); a manifest or `--set` using the old name is refused
    /// with a message naming this one ([`RENAMED`]).
    #[serde(alias = "edge_length_tolerance")]
    pub edge_length_tolerance_px: f32,
    /// Interior-silhouette (C0) depth-jump threshold T_C0. Default 3.4e-4.
    pub t_c0: f32,
    /// Sharp-edge (C1) depth-slope-change threshold T_C1. Default 1.28e-4.
    pub t_c1: f32,
    /// Greedy clustering of SV objects (000 §3.1.6). Default on.
    pub clustering: bool,
    /// Regional occlusion culling. Default off.
    pub occlusion_culling: bool,
    /// Deviation bound of the edge collapse in pixels (not in the paper; worker
    /// `simplify.rs`, "Deviation bound"): no collapse may move the surface farther
    /// than this, seen from anywhere in the cell. 0 = off (the paper's algorithm as
    /// written). Default [`DEFAULT_MAX_DEVIATION_PX`] (0.5), in a manifest, an
    /// override and a serialised plan alike; [`BakeParams::deviation_bound_px`] is
    /// the one reading of "0 = off".
    pub max_deviation_px: f32,
    /// The far field shared by 7-cell groups (issue 13; worker `far_field.rs`): an
    /// outside object that is a single-view object for the whole group's region gets
    /// one proxy for the group, stored once in `groups/<id>.pack`. Default on;
    /// `false` gives every cell its own proxy of every object (the paper's layout).
    pub far_field: bool,
    /// Levels of far-field groups (issue 27; worker `far_field.rs`, "Levels"): level 1
    /// the 7-cell groups, level k+1 the 7-groups of level k (49, 343, … cells); a
    /// level beyond the first draws its far objects as merged layered impostors
    /// (one per sector and depth band), so what a cell draws from all levels does not
    /// grow with the world. 0 (default) = every level the grid needs (until one
    /// group covers it); 1 = the one-level far field of bake revision 6–14.
    /// Written into plans and reports only when not the default.
    #[serde(skip_serializing_if = "is_default_far_levels")]
    pub far_levels: u32,
    /// The first level of far-field groups whose objects are merged into layered
    /// impostors (issue 27; worker `levels.rs`); the levels below it give every far
    /// object its own SvMesh or cluster proxy. Default 1: the 7-cell groups' objects
    /// are merged too. Chosen by measurement (BENCHMARKS.md "Scale") on parks, a
    /// city and their 3 × 3 worlds: against 2 (DESIGN.md's "beyond the first level"),
    /// park-2m and city-2m cells are unchanged (±2 % triangles, −8 % draw calls on
    /// the city, same PSNR), and world-18m's cell draws 32 % fewer triangles and 60 %
    /// fewer draw calls for 0.4 dB of object-pixel PSNR.
    /// Written into plans and reports only when not the default.
    #[serde(skip_serializing_if = "is_default_merge_level")]
    pub merge_level: u32,
    /// Objective selection of representations (paper 004; issue 16; worker
    /// `select.rs`): each outside object gets the cheapest candidate — culled when it
    /// covers under a pixel from the whole region, a layered impostor, a coarser
    /// mesh — that reaches this floor on its own pixels from every sample viewpoint
    /// of its region, or, in a view where the paper's mesh proxy itself falls short
    /// of the floor, is no worse than that mesh. When no candidate does, the mesh
    /// proxy is kept whatever its figures: the floor decides what may replace the
    /// mesh proxy, it is not a quality every proxy is guaranteed to meet (the
    /// report's worst figures can lie below it). Opt-in: absent = `None` (every outside object a mesh proxy, as in the
    /// paper); `quality: ()` selects with [`QualityFloor::default`]. Not on by default
    /// because it does not pay yet: with impostors and meshes under 2× and 4× the
    /// deviation bound as candidates, two park-4m cells lose 4 % of their proxy
    /// triangles for about 3× the bake CPU (BENCHMARKS.md, issue 16).
    pub quality: Option<QualityFloor>,
    /// The quality check of every bake (issue 16 item 3; worker `select.rs`): without
    /// `quality`, each derived mesh proxy is measured against its originals from the
    /// sample viewpoint farthest from its capture, for the report's per-cell worst
    /// view, error histogram and heat map. Default on; it adds about a quarter to
    /// the proxy derivation's time (BENCHMARKS.md, issue 16), which `false` saves.
    /// Changes no pack byte and is not in the fingerprints: switching it rebakes
    /// nothing (a job keeps the figures of the bake that made it).
    pub quality_check: bool,
}

fn is_default_far_levels(v: &u32) -> bool {
    *v == BakeParams::default().far_levels
}

fn is_default_merge_level(v: &u32) -> bool {
    *v == BakeParams::default().merge_level
}

impl BakeParams {
    /// The deviation bound of the edge collapse in pixels, `None` when off
    /// (`max_deviation_px` = 0). A validated plan has no other value below or at 0.
    pub fn deviation_bound_px(&self) -> Option<f32> {
        (self.max_deviation_px != 0.0).then_some(self.max_deviation_px)
    }
}

/// The quality floor of the objective selection (`bake.quality`, paper 004 §3–4):
/// a candidate representation cheaper than an object's mesh proxy is acceptable
/// when, in each sample view of the region, its PSNR on luminance and its SSIM over
/// the object's pixels (where the object or the candidate is drawn) reach these, or
/// the mesh proxy's own figures in that view where those are lower. The mesh proxy
/// is kept when no candidate is acceptable, whatever its figures: nothing enforces
/// the floor on it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct QualityFloor {
    /// Default 30 dB: an RMS error of 8 levels of Y (3 %) over the object's pixels,
    /// the usual threshold of acceptable lossy image coding, and 004's finding that
    /// PSNR differences above ~30 dB are hardly visible on objects.
    pub min_psnr_db: f64,
    /// Default 0.9: Wang et al.'s SSIM for "good" quality; catches structural errors
    /// (shifted edges, holes) that PSNR averages away on small objects.
    pub min_ssim: f64,
}

impl Default for QualityFloor {
    fn default() -> Self {
        QualityFloor {
            min_psnr_db: 30.0,
            min_ssim: 0.9,
        }
    }
}

/// The rules of `bake.quality` (also for `pipeline run --set`): the field that
/// breaks them and why.
pub fn check_quality(min_psnr_db: f64, min_ssim: f64) -> Result<(), (&'static str, String)> {
    if !(0.0..=crate::metrics::PSNR_CAP).contains(&min_psnr_db) {
        return Err((
            "min_psnr_db",
            format!("must be in 0..=100 dB, found {min_psnr_db}"),
        ));
    }
    if !(0.0..=1.0).contains(&min_ssim) {
        return Err(("min_ssim", format!("must be in 0..=1, found {min_ssim}")));
    }
    Ok(())
}

/// Default of [`BakeParams::max_deviation_px`].
pub const DEFAULT_MAX_DEVIATION_PX: f32 = 0.5;

impl Default for BakeParams {
    fn default() -> Self {
        BakeParams {
            image_res: 1024,
            self_occluding_tolerance_px: 5.0,
            edge_length_tolerance_px: 4.5,
            t_c0: 3.4e-4,
            t_c1: 1.28e-4,
            clustering: true,
            occlusion_culling: false,
            max_deviation_px: DEFAULT_MAX_DEVIATION_PX,
            far_field: true,
            far_levels: 0,
            merge_level: 1,
            quality: None,
            quality_check: true,
        }
    }
}

/// View-cell parameters (DESIGN.md "Hex grid").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellParams {
    /// Centre-to-corner distance of the flat-top hexagon (the paper's |VV'|).
    pub cell_size: f32,
    pub min_eye_height: f32,
    pub max_eye_height: f32,
}

/// The validated, resolved manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The manifest file this plan came from.
    pub manifest_path: PathBuf,
    /// Scene name (manifest's `name`, else the file stem).
    pub name: String,
    pub scene: SceneSpec,
    pub ground: Ground,
    pub cells: CellParams,
    pub bake: BakeParams,
    pub cells_per_job: u32,
    /// Output directory, resolved against the manifest's folder.
    pub output: PathBuf,
}

/// Where a model comes from.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum ModelSource {
    /// A file, resolved against the manifest's folder.
    File(PathBuf),
    /// A procedural model built in code (`procedural::build`).
    Procedural(String),
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum SceneSpec {
    Instances(Vec<InstanceSpec>),
    Park(ParkSpec),
    City(CitySpec),
    /// A glTF file read as a whole scene (issue 18; `load::load_gltf_scene`): every
    /// node with a mesh is placed with its composed transform, in the file's units.
    Gltf(GltfSpec),
    /// Another manifest's scene repeated k × k times on whole grid periods (issue 27,
    /// "Worlds"; [`TiledSpec`]).
    Tiled(TiledSpec),
}

/// `scene: Tiled((manifest: "park-2m.ron", tiles: 3))`: the scene of another
/// manifest (any kind but `Tiled`, the same cell size) repeated `tiles` × `tiles`
/// times. Tiles are shifted by whole periods of the hex grid — `N` columns rounded
/// up to even (the odd-q layout repeats every 2 columns) and `M` rows, for the
/// base's `N × M` grid — and the world's ground is chosen so that its grid has the
/// base's origin: cell (col + i·N′, row + j·M) of the world sees the objects of tile
/// (i, j) exactly where cell (col, row) of the base scene sees the base's. The
/// manifest gives no `ground` (it is the tiles'); models are shared by every tile
/// (one model, many instances).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TiledSpec {
    /// The base manifest, resolved against this manifest's folder.
    pub manifest: PathBuf,
    /// Tiles per side (1..=[`MAX_TILES`]).
    pub tiles: u32,
    /// The base grid's period in columns (even) and rows: tile (i, j) is shifted by
    /// `(i·period[0]·1.5·c, j·period[1]·√3·c)`.
    pub period: [u32; 2],
}

/// A glTF scene file (`scene: Gltf("file.glb")`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GltfSpec {
    /// The `.gltf` or `.glb` file, resolved against the manifest's folder.
    pub file: PathBuf,
    /// Which mesh nodes form one object of the bake (`load::GltfObjects`; default
    /// `Hierarchy`: each top-level node's subtree, when no wider than a cell).
    #[serde(default)]
    pub objects: crate::model_source::GltfObjects,
}

/// A generated city (`city.rs`): blocks of buildings, streets, props on the pavements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CitySpec {
    pub seed: u64,
    pub block_size: f32,
    pub street_width: f32,
    pub buildings_per_block: u32,
    pub min_height: f32,
    pub max_height: f32,
    pub floor_height: f32,
    pub variants: u32,
    /// Statues and props from model files, placed on the pavements.
    pub props: Vec<ParkModel>,
    pub tint_min: [f32; 3],
    pub tint_max: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstanceSpec {
    pub model: ModelSource,
    /// Euler rotation (x, y, z degrees, applied x first) before normalising.
    pub pre_rotation_deg: [f32; 3],
    pub target_height: f32,
    pub translation: [f32; 3],
    /// Rotation about +y, degrees.
    pub rotation_y_deg: f32,
    pub scale: f32,
    pub tint: [f32; 3],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParkSpec {
    pub seed: u64,
    pub models: Vec<ParkModel>,
    pub tint_min: [f32; 3],
    pub tint_max: [f32; 3],
    /// Hand-placed objects, listed after the generated ones (`scene_build`): a
    /// park's hero pieces, or the demo's showcase of every representation. Never
    /// part of the slot placement, so adding one moves no generated instance.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub placed: Vec<InstanceSpec>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParkModel {
    pub model: ModelSource,
    /// Euler rotation (x, y, z degrees, applied x first) before normalising.
    pub pre_rotation_deg: [f32; 3],
    pub count: u32,
    pub target_height: f32,
}

impl ModelSource {
    /// `path` for a file, `procedural:<name>` for a procedural model.
    pub fn describe(&self) -> String {
        match self {
            ModelSource::File(p) => p.display().to_string(),
            ModelSource::Procedural(name) => format!("procedural:{name}"),
        }
    }
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

// ---------------------------------------------------------------------------------
// Stage 1: the raw mirror of the file.

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    name: Option<String>,
    /// Required, except for a `Tiled` scene (whose ground is its tiles').
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    ground: Option<RawGround>,
    scene: RawScene,
    cells: RawCells,
    #[serde(default)]
    bake: RawBake,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    cells_per_job: Option<u32>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    output: Option<String>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawGround {
    min: [f32; 2],
    max: [f32; 2],
}

#[derive(Deserialize, Serialize)]
enum RawScene {
    Park(RawPark),
    Instances(Vec<RawInstance>),
    City(RawCity),
    Gltf(RawGltf),
    Tiled(RawTiled),
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawTiled {
    manifest: String,
    tiles: u32,
}

/// `Gltf("file.glb")` or `Gltf((file: "file.glb", objects: Parents))`.
#[derive(Serialize)]
#[serde(untagged)]
enum RawGltf {
    File(String),
    Spec(RawGltfSpec),
}

/// A string is a file, a struct a [`RawGltfSpec`]. Written out rather than
/// `#[serde(untagged)]`: an untagged enum buffers its input, and a buffered RON
/// enum variant (`objects: Nodes`) reads as a unit, i.e. as no value at all.
impl<'de> Deserialize<'de> for RawGltf {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Either;
        impl<'de> serde::de::Visitor<'de> for Either {
            type Value = RawGltf;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a glTF file name, or (file: \"…\", objects: …)")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<RawGltf, E> {
                Ok(RawGltf::File(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<RawGltf, A::Error> {
                RawGltfSpec::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(RawGltf::Spec)
            }
        }
        d.deserialize_any(Either)
    }
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawGltfSpec {
    file: String,
    /// Kept for issue 18's manifests: `true` is `objects: Parents`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    group_by_parent: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    objects: Option<crate::model_source::GltfObjects>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCity {
    seed: u64,
    block_size: f32,
    street_width: f32,
    #[serde(default = "default_buildings_per_block")]
    buildings_per_block: u32,
    min_height: f32,
    max_height: f32,
    #[serde(default = "default_floor_height")]
    floor_height: f32,
    #[serde(default = "default_variants")]
    variants: u32,
    #[serde(default)]
    props: Vec<RawParkModel>,
    #[serde(default = "unit_tint")]
    tint_min: [f32; 3],
    #[serde(default = "unit_tint")]
    tint_max: [f32; 3],
}

fn default_buildings_per_block() -> u32 {
    2
}

fn default_floor_height() -> f32 {
    3.5
}

fn default_variants() -> u32 {
    16
}

#[derive(Deserialize, Serialize)]
enum RawModelSource {
    File(String),
    Procedural(String),
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawPark {
    seed: u64,
    models: Vec<RawParkModel>,
    #[serde(default = "unit_tint")]
    tint_min: [f32; 3],
    #[serde(default = "unit_tint")]
    tint_max: [f32; 3],
    #[serde(default)]
    placed: Vec<RawInstance>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawParkModel {
    model: RawModelSource,
    count: u32,
    target_height: f32,
    #[serde(default)]
    pre_rotation_deg: [f32; 3],
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawInstance {
    model: RawModelSource,
    target_height: f32,
    translation: [f32; 3],
    rotation_y_deg: f32,
    #[serde(default = "unit_scale")]
    scale: f32,
    #[serde(default = "unit_tint")]
    tint: [f32; 3],
    #[serde(default)]
    pre_rotation_deg: [f32; 3],
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawCells {
    cell_size: f32,
    min_eye_height: f32,
    max_eye_height: f32,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
struct RawBake {
    image_res: u32,
    self_occluding_tolerance_px: f32,
    edge_length_tolerance_px: f32,
    t_c0: f32,
    t_c1: f32,
    clustering: bool,
    occlusion_culling: bool,
    max_deviation_px: f32,
    far_field: bool,
    far_levels: u32,
    merge_level: u32,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "bare")]
    quality: Option<RawQuality>,
    quality_check: bool,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
struct RawQuality {
    min_psnr_db: f64,
    min_ssim: f64,
}

impl Default for RawQuality {
    fn default() -> Self {
        let d = QualityFloor::default();
        RawQuality {
            min_psnr_db: d.min_psnr_db,
            min_ssim: d.min_ssim,
        }
    }
}

impl Default for RawBake {
    fn default() -> Self {
        let d = BakeParams::default();
        RawBake {
            image_res: d.image_res,
            self_occluding_tolerance_px: d.self_occluding_tolerance_px,
            edge_length_tolerance_px: d.edge_length_tolerance_px,
            t_c0: d.t_c0,
            t_c1: d.t_c1,
            clustering: d.clustering,
            occlusion_culling: d.occlusion_culling,
            max_deviation_px: d.max_deviation_px,
            far_field: d.far_field,
            far_levels: d.far_levels,
            merge_level: d.merge_level,
            quality: None,
            quality_check: d.quality_check,
        }
    }
}

fn unit_tint() -> [f32; 3] {
    [1.0; 3]
}

fn unit_scale() -> f32 {
    1.0
}

/// Writes an `Option` field as its bare value: the parser reads with
/// `implicit_some`, and `skip_serializing_if` leaves out a `None`.
fn bare<T: Serialize, S: serde::Serializer>(v: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(v) => v.serialize(s),
        None => s.serialize_none(),
    }
}

impl From<&BakeParams> for RawBake {
    /// Every bake parameter (the destructuring names each field, so a new one cannot
    /// be forgotten by the manifest writer).
    fn from(b: &BakeParams) -> RawBake {
        let BakeParams {
            image_res,
            self_occluding_tolerance_px,
            edge_length_tolerance_px,
            t_c0,
            t_c1,
            clustering,
            occlusion_culling,
            max_deviation_px,
            far_field,
            far_levels,
            merge_level,
            quality,
            quality_check,
        } = *b;
        RawBake {
            image_res,
            self_occluding_tolerance_px,
            edge_length_tolerance_px,
            t_c0,
            t_c1,
            clustering,
            occlusion_culling,
            max_deviation_px,
            far_field,
            far_levels,
            merge_level,
            quality: quality.map(
                |QualityFloor {
                     min_psnr_db,
                     min_ssim,
                 }| RawQuality {
                    min_psnr_db,
                    min_ssim,
                },
            ),
            quality_check,
        }
    }
}

/// A path as the manifest writes it: absolute, so the text works wherever it is put.
fn absolute_text(p: &Path) -> String {
    std::path::absolute(p)
        .unwrap_or_else(|_| p.to_path_buf())
        .display()
        .to_string()
}

impl From<&InstanceSpec> for RawInstance {
    fn from(i: &InstanceSpec) -> RawInstance {
        let InstanceSpec {
            model,
            pre_rotation_deg,
            target_height,
            translation,
            rotation_y_deg,
            scale,
            tint,
        } = i;
        RawInstance {
            model: match model {
                ModelSource::File(p) => RawModelSource::File(absolute_text(p)),
                ModelSource::Procedural(n) => RawModelSource::Procedural(n.clone()),
            },
            target_height: *target_height,
            translation: *translation,
            rotation_y_deg: *rotation_y_deg,
            scale: *scale,
            tint: *tint,
            pre_rotation_deg: *pre_rotation_deg,
        }
    }
}

/// The manifest text of `plan` with its scene replaced by `instances` (`pipeline
/// scene --as-instances`): written by serde from the raw types the parser reads, so
/// parsing the text gives back every parameter of `plan` — name, ground, cells,
/// bake (`quality_check` and `quality` included), cells per job, output (absolute)
/// — and the instances. `comment` becomes the first line(s), each prefixed `// `.
/// Numbers are written in Rust's shortest round-trip form, paths absolute.
pub fn write_instances_manifest(plan: &Plan, instances: &[InstanceSpec], comment: &str) -> String {
    let Plan {
        manifest_path: _,
        name,
        scene: _,
        ground,
        cells,
        bake,
        cells_per_job,
        output,
    } = plan;
    let CellParams {
        cell_size,
        min_eye_height,
        max_eye_height,
    } = *cells;
    let raw = RawManifest {
        name: Some(name.clone()),
        ground: Some(RawGround {
            min: ground.min,
            max: ground.max,
        }),
        scene: RawScene::Instances(instances.iter().map(RawInstance::from).collect()),
        cells: RawCells {
            cell_size,
            min_eye_height,
            max_eye_height,
        },
        bake: RawBake::from(bake),
        cells_per_job: Some(*cells_per_job),
        output: Some(absolute_text(output)),
    };
    // Depth 2: each instance, and `quality`, on one line; every other field on its own.
    let config = ron::ser::PrettyConfig::new()
        .depth_limit(2)
        .indentor("    ".to_string());
    let body = ron::ser::to_string_pretty(&raw, config).expect("a manifest serialises");
    let mut text: String = comment.lines().map(|l| format!("// {l}\n")).collect();
    text += &body;
    text.push('\n');
    text
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

// ---------------------------------------------------------------------------------
// Stage 2: validation and resolution.

struct Validator<'a> {
    path: &'a Path,
    positions: &'a FieldPositions,
    /// The `--set` overrides applied to the raw manifest: an error at a field one of
    /// them set names the override instead of a place in the file.
    overrides: &'a [Override],
}

impl Validator<'_> {
    /// An error at the field `field` (dotted path): at the last override that set
    /// it, else at its place in the file.
    fn error(&self, field: &str, message: String) -> ManifestError {
        match self.overrides.iter().rev().find(|o| o.key == field) {
            Some(o) => self.override_error(o, field, message),
            None => {
                let at = self.positions.nearest_position(field);
                ManifestError::At {
                    path: self.path.to_path_buf(),
                    line: at.line,
                    column: at.column,
                    field: field.to_string(),
                    message: format!("`{field}` {message}"),
                }
            }
        }
    }

    fn override_error(&self, o: &Override, field: &str, message: String) -> ManifestError {
        ManifestError::Override {
            path: self.path.to_path_buf(),
            set: o.to_string(),
            field: field.to_string(),
            message: format!("`{field}` {message}"),
        }
    }

    /// A [`Violation`] of a shared rule, at its field.
    fn violation(&self, v: Violation) -> ManifestError {
        self.error(&v.field, v.message)
    }

    /// A [`Violation`] of the cell rule: at the override that set its field, else at
    /// the last cell override (eye heights out of order name the max, but setting
    /// the min may be what broke them), else at its place in the file.
    fn cell_violation(&self, v: Violation) -> ManifestError {
        let set_field = self.overrides.iter().any(|o| o.key == v.field);
        match self
            .overrides
            .iter()
            .rev()
            .find(|o| o.key.starts_with("cells."))
        {
            Some(o) if !set_field => self.override_error(o, &v.field, v.message),
            _ => self.violation(v),
        }
    }

    /// An object height: > 0, at least [`MIN_LENGTH`], at most [`MAX_COORDINATE`].
    fn height(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        let v = self.positive(field, v)?;
        if !(MIN_LENGTH..=MAX_COORDINATE).contains(&v) {
            return Err(self.error(
                field,
                format!("must be in {MIN_LENGTH}..={MAX_COORDINATE} units, found {v}"),
            ));
        }
        Ok(v)
    }

    /// A position: finite components within ±[`MAX_COORDINATE`].
    fn coordinates3(&self, field: &str, v: [f32; 3]) -> Result<[f32; 3], ManifestError> {
        for x in v {
            check_coordinate(field, x).map_err(|e| self.violation(e))?;
        }
        Ok(v)
    }

    fn finite(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error(field, format!("must be a finite number, found {v}")))
        }
    }

    fn positive(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.error(field, format!("must be > 0, found {v}")))
        }
    }

    fn non_negative(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.error(field, format!("must be >= 0, found {v}")))
        }
    }

    fn finite3(&self, field: &str, v: [f32; 3]) -> Result<[f32; 3], ManifestError> {
        for x in v {
            self.finite(field, x)?;
        }
        Ok(v)
    }

    fn tint(&self, field: &str, v: [f32; 3]) -> Result<[f32; 3], ManifestError> {
        if v.iter()
            .all(|x| x.is_finite() && (0.0..=MAX_TINT).contains(x))
        {
            Ok(v)
        } else {
            Err(self.error(
                field,
                format!("must have components in 0..={MAX_TINT}, found {v:?}"),
            ))
        }
    }

    /// The manifest's folder, against which relative paths resolve.
    fn base_dir(&self) -> PathBuf {
        match self.path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    }

    /// One `Instances` entry (or a park's `placed` one) at `at` (`scene[3]`).
    fn instance(&self, at: &str, inst: RawInstance) -> Result<InstanceSpec, ManifestError> {
        let f = |name: &str| format!("{at}.{name}");
        let spec = InstanceSpec {
            model: self.model(&f("model"), inst.model)?,
            pre_rotation_deg: self.finite3(&f("pre_rotation_deg"), inst.pre_rotation_deg)?,
            target_height: self.height(&f("target_height"), inst.target_height)?,
            translation: self.coordinates3(&f("translation"), inst.translation)?,
            rotation_y_deg: self.finite(&f("rotation_y_deg"), inst.rotation_y_deg)?,
            scale: self.positive(&f("scale"), inst.scale)?,
            tint: self.tint(&f("tint"), inst.tint)?,
        };
        // The placed object's height, in f64 so the product cannot overflow.
        let height = f64::from(spec.target_height) * f64::from(spec.scale);
        if !(f64::from(MIN_LENGTH)..=f64::from(MAX_COORDINATE)).contains(&height) {
            return Err(self.error(
                &f("scale"),
                format!(
                    "makes the object {height} units tall (target_height {} × \
                     scale {}), outside {MIN_LENGTH}..={MAX_COORDINATE}",
                    spec.target_height, spec.scale
                ),
            ));
        }
        Ok(spec)
    }

    fn model(&self, field: &str, raw: RawModelSource) -> Result<ModelSource, ManifestError> {
        match raw {
            RawModelSource::File(file) => {
                if file.is_empty() {
                    return Err(self.error(field, "names an empty file path".into()));
                }
                let resolved = self.base_dir().join(&file);
                let supported = crate::model_source::ModelFormat::from_path(&resolved).is_some();
                if !supported {
                    return Err(self.error(
                        field,
                        format!(
                            "names `{file}`, an unsupported model format (expected one of {})",
                            crate::model_source::SUPPORTED_EXTENSIONS.join(", ")
                        ),
                    ));
                }
                if !resolved.is_file() {
                    return Err(self.error(
                        field,
                        format!(
                            "names `{file}`, which does not exist (resolved: {})",
                            resolved.display()
                        ),
                    ));
                }
                Ok(ModelSource::File(resolved))
            }
            RawModelSource::Procedural(name) => {
                if crate::model_source::PROCEDURAL_NAMES.contains(&name.as_str()) {
                    Ok(ModelSource::Procedural(name))
                } else {
                    Err(self.error(
                        field,
                        format!(
                            "names an unknown procedural model `{name}`, expected one of {}",
                            crate::model_source::PROCEDURAL_NAMES.join(", ")
                        ),
                    ))
                }
            }
        }
    }

    /// `bake.quality` (issue 16): PSNR in 0..=100 dB, SSIM in 0..=1.
    fn quality(&self, q: RawQuality) -> Result<QualityFloor, ManifestError> {
        check_quality(q.min_psnr_db, q.min_ssim)
            .map_err(|(field, what)| self.error(&format!("bake.quality.{field}"), what))?;
        Ok(QualityFloor {
            min_psnr_db: q.min_psnr_db,
            min_ssim: q.min_ssim,
        })
    }

    /// A glTF scene file: a `.gltf` or `.glb` that exists.
    fn gltf(
        &self,
        file: String,
        group_by_parent: bool,
        objects: Option<crate::model_source::GltfObjects>,
    ) -> Result<SceneSpec, ManifestError> {
        use crate::model_source::GltfObjects;
        let objects = match (group_by_parent, objects) {
            (false, objects) => objects.unwrap_or_default(),
            (true, None | Some(GltfObjects::Parents)) => GltfObjects::Parents,
            (true, Some(other)) => {
                return Err(self.error(
                    "scene",
                    format!(
                        "says both `group_by_parent: true` and `objects: {other:?}`; \
                         `group_by_parent: true` is `objects: Parents`: keep one"
                    ),
                ))
            }
        };
        if file.is_empty() {
            return Err(self.error("scene", "names an empty file path".into()));
        }
        let resolved = self.base_dir().join(&file);
        if crate::model_source::ModelFormat::from_path(&resolved)
            != Some(crate::model_source::ModelFormat::Gltf)
        {
            return Err(self.error(
                "scene",
                format!("names `{file}`; a glTF scene must be a .gltf or .glb file"),
            ));
        }
        if !resolved.is_file() {
            return Err(self.error(
                "scene",
                format!(
                    "names `{file}`, which does not exist (resolved: {})",
                    resolved.display()
                ),
            ));
        }
        Ok(SceneSpec::Gltf(GltfSpec {
            file: resolved,
            objects,
        }))
    }

    /// A prop list (park models on the pavements), fields under `scene.props[i]`.
    fn props(&self, raw: Vec<RawParkModel>) -> Result<Vec<ParkModel>, ManifestError> {
        let mut models = Vec::with_capacity(raw.len());
        for (i, m) in raw.into_iter().enumerate() {
            let f = |name: &str| format!("scene.props[{i}].{name}");
            models.push(ParkModel {
                model: self.model(&f("model"), m.model)?,
                pre_rotation_deg: self.finite3(&f("pre_rotation_deg"), m.pre_rotation_deg)?,
                count: m.count,
                target_height: self.height(&f("target_height"), m.target_height)?,
            });
        }
        Ok(models)
    }

    /// A `Tiled` scene ([`TiledSpec`]): the base manifest parses, is not tiled
    /// itself, has cell size `cell_size`; and the world's ground.
    fn tiled(&self, raw: &RawTiled, cell_size: f32) -> Result<(TiledSpec, Ground), ManifestError> {
        if !(1..=MAX_TILES).contains(&raw.tiles) {
            return Err(self.error(
                "scene.tiles",
                format!("must be in 1..={MAX_TILES}, found {}", raw.tiles),
            ));
        }
        if raw.manifest.is_empty() {
            return Err(self.error("scene.manifest", "names an empty file path".into()));
        }
        let path = self.base_dir().join(&raw.manifest);
        let base = parse_manifest(&path)
            .map_err(|e| self.error("scene.manifest", format!("`{}`: {e}", raw.manifest)))?;
        if matches!(base.scene, SceneSpec::Tiled(_)) {
            return Err(self.error(
                "scene.manifest",
                format!("`{}` is tiled itself; tile its base manifest", raw.manifest),
            ));
        }
        if base.cells.cell_size != cell_size {
            return Err(self.error(
                "cells.cell_size",
                format!(
                    "must equal the tiled manifest's ({}) so that tiles fall on whole grid periods, found {cell_size}",
                    base.cells.cell_size
                ),
            ));
        }
        let invalid = |what: String| self.error("scene", what);
        let [n, m] = base
            .ground
            .hex_grid_dims(cell_size)
            .ok_or_else(|| invalid("the base manifest's ground makes no grid".into()))?;
        let period = [n + n % 2, m];
        let k = u64::from(raw.tiles) - 1;
        let dims = [n + k * period[0], m + k * period[1]];
        let c = f64::from(cell_size);
        let [w, h] = base.ground.size();
        let min = base.ground.min;
        // Same origin (format::grid: the column strip is centred on the ground).
        let w = f64::from(w) + (dims[0] - n) as f64 * 1.5 * c;
        let h = f64::from(h) + (dims[1] - m) as f64 * 3f64.sqrt() * c;
        let ground = Ground {
            min,
            max: [
                (f64::from(min[0]) + w) as f32,
                (f64::from(min[1]) + h) as f32,
            ],
        };
        if ground.hex_grid_dims(cell_size) != Some(dims) {
            return Err(invalid(format!(
                "{} tiles of a {n} × {m} grid make no whole {} × {} grid (rounding); try another count",
                raw.tiles, dims[0], dims[1]
            )));
        }
        let period = [period[0] as u32, period[1] as u32];
        Ok((
            TiledSpec {
                manifest: path,
                tiles: raw.tiles,
                period,
            },
            ground,
        ))
    }

    /// A `City` scene: lengths positive and within the limits, heights ordered,
    /// whole floors, a bounded number of buildings per block and variants.
    fn city(&self, c: RawCity) -> Result<SceneSpec, ManifestError> {
        let block_size = self.height("scene.block_size", c.block_size)?;
        let street_width = self.height("scene.street_width", c.street_width)?;
        if !(1..=16).contains(&c.buildings_per_block) {
            return Err(self.error(
                "scene.buildings_per_block",
                format!("must be in 1..=16, found {}", c.buildings_per_block),
            ));
        }
        if !(1..=256).contains(&c.variants) {
            return Err(self.error(
                "scene.variants",
                format!("must be in 1..=256, found {}", c.variants),
            ));
        }
        let min_height = self.height("scene.min_height", c.min_height)?;
        let max_height = self.height("scene.max_height", c.max_height)?;
        if max_height < min_height {
            return Err(self.error(
                "scene.max_height",
                format!("must be >= `min_height` ({min_height}), found {max_height}"),
            ));
        }
        let floor_height = self.height("scene.floor_height", c.floor_height)?;
        // Floors and windows are geometry: bound them so a building stays a mesh.
        let floors = f64::from(max_height) / f64::from(floor_height);
        let columns = f64::from(block_size) / f64::from(floor_height);
        if floor_height > min_height
            || floors * columns > crate::limits::MAX_WINDOWS_PER_FACADE as f64
        {
            return Err(self.error(
                "scene.floor_height",
                format!(
                    "must be at most `min_height` ({min_height}) and leave at most {} windows \
                     on a façade ({floors:.0} floors × {columns:.0} columns), found {floor_height}",
                    crate::limits::MAX_WINDOWS_PER_FACADE
                ),
            ));
        }
        let props = self.props(c.props)?;
        let tint_min = self.tint("scene.tint_min", c.tint_min)?;
        let tint_max = self.tint("scene.tint_max", c.tint_max)?;
        if (0..3).any(|k| tint_min[k] > tint_max[k]) {
            return Err(self.error(
                "scene.tint_max",
                format!(
                    "must be >= `tint_min` per channel, found min {tint_min:?} max {tint_max:?}"
                ),
            ));
        }
        Ok(SceneSpec::City(CitySpec {
            seed: c.seed,
            block_size,
            street_width,
            buildings_per_block: c.buildings_per_block,
            min_height,
            max_height,
            floor_height,
            variants: c.variants,
            props,
            tint_min,
            tint_max,
        }))
    }

    fn plan(&self, raw: RawManifest) -> Result<Plan, ManifestError> {
        // Name: given, else the file stem.
        let name = match raw.name {
            Some(n) if n.trim().is_empty() => {
                return Err(self.error("name", "must not be empty".into()))
            }
            Some(n) => n,
            None => self
                .path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .filter(|s| !s.is_empty())
                .unwrap_or_else(|| "scene".into()),
        };

        // Ground rectangle: given, or a `Tiled` scene's tiles'.
        let tiled = match &raw.scene {
            RawScene::Tiled(t) => Some(self.tiled(t, raw.cells.cell_size)?),
            _ => None,
        };
        let ground = match (&raw.ground, &tiled) {
            (Some(_), Some(_)) => {
                return Err(self.error(
                    "ground",
                    "a Tiled scene's ground is its tiles': leave `ground` out".into(),
                ))
            }
            (None, None) => return Err(self.error("ground", "missing".into())),
            (Some(g), None) => Ground {
                min: g.min,
                max: g.max,
            },
            (None, Some((_, g))) => *g,
        };
        check_ground(&ground).map_err(|e| self.violation(e))?;

        // Scene.
        let scene = match raw.scene {
            RawScene::Park(park) => {
                if park.models.is_empty() {
                    return Err(self.error("scene.models", "must list at least one model".into()));
                }
                let mut models = Vec::with_capacity(park.models.len());
                for (i, m) in park.models.into_iter().enumerate() {
                    let f = |name: &str| format!("scene.models[{i}].{name}");
                    models.push(ParkModel {
                        model: self.model(&f("model"), m.model)?,
                        pre_rotation_deg: self
                            .finite3(&f("pre_rotation_deg"), m.pre_rotation_deg)?,
                        count: m.count,
                        target_height: self.height(&f("target_height"), m.target_height)?,
                    });
                }
                if models.iter().all(|m| m.count == 0) {
                    return Err(self.error(
                        "scene.models",
                        "places no instance: every `count` is 0".into(),
                    ));
                }
                let tint_min = self.tint("scene.tint_min", park.tint_min)?;
                let tint_max = self.tint("scene.tint_max", park.tint_max)?;
                if (0..3).any(|k| tint_min[k] > tint_max[k]) {
                    return Err(self.error(
                        "scene.tint_max",
                        format!("must be >= `tint_min` per channel, found min {tint_min:?} max {tint_max:?}"),
                    ));
                }
                let mut placed = Vec::with_capacity(park.placed.len());
                for (i, inst) in park.placed.into_iter().enumerate() {
                    placed.push(self.instance(&format!("scene.placed[{i}]"), inst)?);
                }
                SceneSpec::Park(ParkSpec {
                    seed: park.seed,
                    models,
                    tint_min,
                    tint_max,
                    placed,
                })
            }
            RawScene::City(city) => self.city(city)?,
            RawScene::Gltf(RawGltf::File(file)) => self.gltf(file, false, None)?,
            RawScene::Gltf(RawGltf::Spec(spec)) => {
                self.gltf(spec.file, spec.group_by_parent, spec.objects)?
            }
            RawScene::Tiled(_) => {
                let (spec, _) = tiled.expect("parsed above");
                SceneSpec::Tiled(spec)
            }
            RawScene::Instances(list) => {
                if list.is_empty() {
                    return Err(self.error("scene", "lists no instance".into()));
                }
                let mut instances = Vec::with_capacity(list.len());
                for (i, inst) in list.into_iter().enumerate() {
                    instances.push(self.instance(&format!("scene[{i}]"), inst)?);
                }
                SceneSpec::Instances(instances)
            }
        };

        // Cells: the grid on the ground, eye heights.
        let cells = CellParams {
            cell_size: raw.cells.cell_size,
            min_eye_height: raw.cells.min_eye_height,
            max_eye_height: raw.cells.max_eye_height,
        };
        check_cells(&ground, &cells).map_err(|e| self.cell_violation(e))?;

        // Bake parameters.
        let b = raw.bake;
        if !(16..=16384).contains(&b.image_res) {
            return Err(self.error(
                "bake.image_res",
                format!("must be in 16..=16384, found {}", b.image_res),
            ));
        }
        let bake = BakeParams {
            image_res: b.image_res,
            self_occluding_tolerance_px: self.positive(
                "bake.self_occluding_tolerance_px",
                b.self_occluding_tolerance_px,
            )?,
            edge_length_tolerance_px: self
                .positive("bake.edge_length_tolerance_px", b.edge_length_tolerance_px)?,
            t_c0: self.positive("bake.t_c0", b.t_c0)?,
            t_c1: self.positive("bake.t_c1", b.t_c1)?,
            clustering: b.clustering,
            occlusion_culling: b.occlusion_culling,
            max_deviation_px: self.non_negative("bake.max_deviation_px", b.max_deviation_px)?,
            far_field: b.far_field,
            far_levels: if b.far_levels <= MAX_FAR_LEVELS {
                b.far_levels
            } else {
                return Err(self.error(
                    "bake.far_levels",
                    format!("must be in 0..={MAX_FAR_LEVELS} (0 = every level the grid needs), found {}", b.far_levels),
                ));
            },
            merge_level: if (1..=MAX_FAR_LEVELS + 1).contains(&b.merge_level) {
                b.merge_level
            } else {
                return Err(self.error(
                    "bake.merge_level",
                    format!(
                        "must be in 1..={} ({} = never merge), found {}",
                        MAX_FAR_LEVELS + 1,
                        MAX_FAR_LEVELS + 1,
                        b.merge_level
                    ),
                ));
            },
            quality: b.quality.map(|q| self.quality(q)).transpose()?,
            quality_check: b.quality_check,
        };

        let cells_per_job = raw.cells_per_job.unwrap_or(DEFAULT_CELLS_PER_JOB);
        if cells_per_job == 0 {
            return Err(self.error("cells_per_job", "must be >= 1, found 0".into()));
        }

        let output = match raw.output {
            Some(o) if o.is_empty() => return Err(self.error("output", "must not be empty".into())),
            Some(o) => lexically_normal(&self.base_dir().join(o)),
            None => lexically_normal(&self.base_dir().join("..").join("out").join(&name)),
        };

        Ok(Plan {
            manifest_path: self.path.to_path_buf(),
            name,
            scene,
            ground,
            cells,
            bake,
            cells_per_job,
            output,
        })
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
