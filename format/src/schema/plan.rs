//! `<out>/plan.json` (what a run planned: written by `pipeline run`, read by
//! `pipeline status`, `pipeline report` and Slurm tasks) and `<out>/partial.json`
//! (what a `pipeline run --cells` left unbaked).
//!
//! JSON (`serde_json::to_vec_pretty`). Fields added after the first plans carry
//! `#[serde(default)]`, so older plans still read. Golden files:
//! `format/tests/data/schema/plan.json`, `partial.json`.

use super::job::Job;
use crate::manifest::{BakeParams, CellParams};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// `<out>/plan.json`: what the run planned, for `pipeline status` and Slurm tasks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanFile {
    pub manifest: PathBuf,
    pub name: String,
    pub jobs: Vec<Job>,
    /// `--set` overrides the run applied to the manifest (`KEY=VALUE`, canonical keys).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<String>,
    /// The bake and cell parameters in effect (after overrides); absent in plans
    /// written before they were recorded.
    #[serde(default)]
    pub bake: Option<BakeParams>,
    #[serde(default)]
    pub cell_params: Option<CellParams>,
}

/// `<out>/plan.json`.
pub fn plan_path(out: &Path) -> PathBuf {
    out.join("plan.json")
}

/// `<out>/partial.json`: written by a `--cells` run that leaves cells unbaked, removed
/// by any run after which every cell is baked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Partial {
    /// The `--cells` spec as given.
    pub spec: String,
    /// The cells the spec resolved to.
    pub requested_cells: Vec<u32>,
    /// Cells with a done pack (requested or not: jobs are baked whole).
    pub baked_cells: usize,
    /// Cells of the grid.
    pub grid_cells: usize,
    /// Cells not baked: not in the index, drawn as original geometry by the player.
    pub not_baked_cells: Vec<u32>,
    /// Requested cells that are not baked (their job failed); empty on success.
    pub requested_not_baked: Vec<u32>,
}

impl Partial {
    /// One line for people, e.g. `partial: 84 of 528 cells baked (62 requested: all baked)`.
    pub fn line(&self) -> String {
        let requested = if self.requested_not_baked.is_empty() {
            "all baked".to_string()
        } else {
            format!("{} NOT baked", self.requested_not_baked.len())
        };
        format!(
            "partial: {} of {} cells baked ({} requested by --cells {:?}: {}); cells not in the index are drawn as original geometry",
            self.baked_cells,
            self.grid_cells,
            self.requested_cells.len(),
            self.spec,
            requested
        )
    }
}

/// `<out>/partial.json`.
pub fn partial_path(out: &Path) -> PathBuf {
    out.join("partial.json")
}

/// Reads `<out>/partial.json`, if the bake is partial (and the file reads).
pub fn read_partial(out: &Path) -> Option<Partial> {
    serde_json::from_slice(&std::fs::read(partial_path(out)).ok()?).ok()
}
