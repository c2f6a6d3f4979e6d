//! Manifest schema: `manifest.ron` parsed in two stages (STYLE.md habit 8).
//!
//! Stage 1 (`RawManifest`) is a plain serde mirror of the file with
//! `deny_unknown_fields`; stage 2 (`Plan`) is the validated, resolved form the
//! rest of hexbake reads: relative paths resolved against the manifest's folder,
//! ranges checked, defaults applied (the paper's values, 000 §4.1.2).
//!
//! TODO(issue 2): raw schema, validation with file:line:column errors, Park generator.

use crate::scene::Ground;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Bake parameters with the paper's names and defaults (000 §3.1, §4.1.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakeParams {
    /// Capture resolution: pixels across one 60° side face (DESIGN.md). Default 1024.
    pub image_res: u32,
    /// Self-occluding error tolerance T_s in pixels. Default 5.
    pub self_occluding_tolerance_px: f32,
    /// Projected edge-length tolerance T_l. Default 4.5.
    pub edge_length_tolerance: f32,
    /// Interior-silhouette (C0) depth-jump threshold T_C0. Default 3.4e-4.
    pub t_c0: f32,
    /// Sharp-edge (C1) depth-slope-change threshold T_C1. Default 1.28e-4.
    pub t_c1: f32,
    /// Greedy clustering of SV objects (000 §3.1.6). Default on.
    pub clustering: bool,
    /// Regional occlusion culling. Default off.
    pub occlusion_culling: bool,
}

impl Default for BakeParams {
    fn default() -> Self {
        BakeParams {
            image_res: 1024,
            self_occluding_tolerance_px: 5.0,
            edge_length_tolerance: 4.5,
            t_c0: 3.4e-4,
            t_c1: 1.28e-4,
            clustering: true,
            occlusion_culling: false,
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
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstanceSpec {
    pub model: ModelSource,
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
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParkModel {
    pub model: ModelSource,
    pub count: u32,
    pub target_height: f32,
}
