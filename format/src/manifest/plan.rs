//! The validated plan a manifest resolves to ([`Plan`]): the types every stage
//! after parsing reads (bake and cell parameters, the scene's specification), with
//! their defaults.

use super::*;

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
    /// Objects wider than two cells are split into one chunk per cell at import
    /// (`scene::chunk`, issue 29 item 2); manifest `split_wide_objects`, default true.
    pub split_wide_objects: bool,
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
