//! `<out>/report.json`: the report of a bake (issue 6 item 5), built from the output
//! directory by `pipeline report` (and at the end of `pipeline run`), read by the
//! benchmark tools. `report.md` and `report.png` are renderings of it (pipeline
//! `report.rs`, `heatmap.rs`).
//!
//! JSON (`serde_json::to_vec_pretty`); every struct reads with `#[serde(default)]`,
//! so a report written before a field existed still reads. Golden file:
//! `format/tests/data/schema/report.json`.

use super::plan::Partial;
use crate::manifest::{BakeParams, CellParams};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Numbers of one cell (from its job record and pack).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CellLine {
    pub cell: u32,
    /// Triangles of the original instances inside the cell.
    pub polygons_inside: f64,
    /// Triangles of the SV, MV and cluster proxies.
    pub sv_polygons: f64,
    pub mv_polygons: f64,
    pub cluster_polygons: f64,
    /// Objects outside the cell by representation.
    pub sv_objects: f64,
    pub mv_objects: f64,
    pub cluster_objects: f64,
    pub culled_objects: f64,
    /// Triangles the outside objects had before simplification.
    pub outside_original_polygons: f64,
    pub texture_bytes: f64,
    pub pack_bytes: u64,
    pub bake_ms: f64,
    /// Per-stage bake time in ms.
    pub stage_ms: BTreeMap<String, f64>,
    /// Issue 16: layered impostors (objects, quad triangles) and the outside
    /// objects the objective selection culled (below a pixel from the region).
    pub impostor_objects: f64,
    pub impostor_polygons: f64,
    pub selection_culled: f64,
    /// Issue 16, the bake's quality check: proxies measured by the objective
    /// selection (cell and its far-field group), the worst sample view's
    /// object-pixel PSNR(Y) and SSIM among them (100 dB / 1 when none), and the
    /// |ΔY| histogram over their object pixels (bins of 8 levels, last ≥ 56).
    pub measured_proxies: f64,
    pub worst_view_psnr_db: f64,
    pub worst_view_ssim: f64,
    pub error_histogram: [u64; 8],
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Storage {
    pub base_bytes: u64,
    pub index_bytes: u64,
    /// Bytes of the cells' textures (stored, i.e. after compression): the `textures`
    /// sections of cell packs (versions 1–5), or the store's files the cells name and
    /// no group does, each counted once (version 6).
    pub texture_bytes: u64,
    /// Cell-pack bytes holding everything but inline textures (proxy indices, view
    /// masks, tables, texture references).
    pub mesh_bytes: u64,
    pub cell_bytes: u64,
    /// Far-field group packs (`groups/<id>.pack`), and their textures (issue 13): the
    /// inline sections, or the store's files the groups name, each counted once.
    pub group_bytes: u64,
    pub group_texture_bytes: u64,
    /// Format version 6 (issue 27 item 3): distinct textures in the bake's store that
    /// the packs name, their file bytes (already in `texture_bytes` and
    /// `group_texture_bytes`, each counted once), how many references the packs make
    /// to them, and the file bytes of every reference counted again (what inline
    /// textures, a copy per cell, would have taken).
    /// (Absent, i.e. 0, in reports of bakes before version 6: they round-trip.)
    #[serde(skip_serializing_if = "super::compare::is_zero_u64")]
    pub store_textures: u64,
    #[serde(skip_serializing_if = "super::compare::is_zero_u64")]
    pub store_bytes: u64,
    #[serde(skip_serializing_if = "super::compare::is_zero_u64")]
    pub texture_uses: u64,
    #[serde(skip_serializing_if = "super::compare::is_zero_u64")]
    pub texture_bytes_per_use: u64,
    pub total_bytes: u64,
    /// (cell + group pack bytes + store bytes) / cells.
    pub per_cell_bytes: f64,
}

/// The far field shared by 7-cell groups (issue 13; worker `far_field.rs`): proxies
/// per level and the bytes sharing saves.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FarFieldStats {
    /// Group packs baked.
    pub groups: u64,
    /// Proxies stored in cell packs (level 0) and in group packs (level 1).
    pub cell_proxies: u64,
    pub group_proxies: u64,
    /// Objects a cell draws from its group's far field, averaged over cells.
    pub far_objects_per_cell: f64,
    /// Group-pack bytes.
    pub group_bytes: u64,
    /// What the group packs would take if each of their cells stored its own copy,
    /// beyond the one copy stored: Σ over groups of bytes × (cells − 1).
    pub bytes_shared: u64,
    /// Per level of groups (issue 27; level 1 = 7-cell groups), ascending.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub levels: Vec<FarLevelStats>,
}

/// One level of far-field groups in a report (issue 27).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FarLevelStats {
    pub level: u32,
    /// Group packs of the level baked.
    pub groups: u64,
    /// Proxies in them, and how many are merged layered impostors.
    pub proxies: u64,
    pub impostors: u64,
    /// Objects they draw.
    pub objects: u64,
    /// Their packs' bytes and bake time (stages summed).
    pub bytes: u64,
    pub bake_s: f64,
}

/// Per-cell averages, the rows of the paper's Tables 3–8.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PaperTable {
    pub polygons_inside_a_cell: f64,
    pub sv_single_percent: f64,
    pub sv_clustered_percent: f64,
    pub mv_percent: f64,
    pub culled_percent: f64,
    pub polygons_sv_and_mv: f64,
    pub polygons_for_a_cell: f64,
    /// Simplified : original, as "1 : x".
    pub simplified_to_original: f64,
    pub texture_kb: f64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Report {
    pub scene: String,
    /// Cells baked (with a done job record).
    pub cells: usize,
    /// Cells of the grid; more than `cells` for a partial (`--cells`) bake.
    pub grid_cells: usize,
    /// Set when the bake is partial (`<out>/partial.json`).
    pub partial: Option<Partial>,
    /// `--set` overrides of the manifest's parameters.
    pub overrides: Vec<String>,
    /// Bake and cell parameters in effect (absent for plans written before they were
    /// recorded).
    pub bake: Option<BakeParams>,
    pub cell_params: Option<CellParams>,
    pub jobs: usize,
    /// Jobs with a valid done record (the same test as `pipeline status`).
    pub jobs_done: usize,
    /// Jobs whose last attempt failed (an error file, no done record).
    pub jobs_failed: Vec<u32>,
    /// Jobs neither done nor failed: not run yet, running, or outside a `--cells`
    /// selection.
    pub jobs_pending: Vec<u32>,
    pub instances: usize,
    pub scene_triangles: u64,
    /// Sum over jobs of their wall time (s): the bake's cost on one worker.
    pub job_wall_s: f64,
    /// Sum over jobs of their CPU time (s); `None` when a job shared its process with
    /// other jobs (local executor with several threads: no job has a CPU time of its
    /// own; the stage times, per cell and per thread, stand in).
    #[serde(default)]
    pub job_cpu_s: Option<f64>,
    /// Per-stage bake time summed over cells (s).
    pub stage_s: BTreeMap<String, f64>,
    /// Proxies of the baked cells, and how many of them were taken by content key
    /// from an earlier bake of the output instead of derived (issue 13).
    pub proxies: u64,
    pub proxies_reused: u64,
    /// `None` when the bake has no far field (`bake.far_field` off, or older).
    pub far_field: Option<FarFieldStats>,
    pub storage: Storage,
    /// Averages over the baked cells; `None` when no cell is baked (there is nothing
    /// to average).
    pub per_cell: Option<PaperTable>,
    pub cell_lines: Vec<CellLine>,
    /// Issue 16: the cells whose worst sample view has the lowest object-pixel
    /// PSNR(Y), worst first (at most [`WORST_CELLS`]), and the share of the outside
    /// objects of the baked cells per representation.
    pub worst_cells: Vec<(u32, f64)>,
    pub representation_share: BTreeMap<String, f64>,
}

/// Cells listed in [`Report::worst_cells`].
pub const WORST_CELLS: usize = 10;

impl Report {
    /// The per-cell averages, or NaN for every statistic when no cell is baked (what
    /// tables show as "–").
    pub fn averages(&self) -> PaperTable {
        self.per_cell.clone().unwrap_or(PaperTable {
            polygons_inside_a_cell: f64::NAN,
            sv_single_percent: f64::NAN,
            sv_clustered_percent: f64::NAN,
            mv_percent: f64::NAN,
            culled_percent: f64::NAN,
            polygons_sv_and_mv: f64::NAN,
            polygons_for_a_cell: f64::NAN,
            simplified_to_original: f64::NAN,
            texture_kb: f64::NAN,
        })
    }

    /// Whether some job is failed or pending.
    pub fn incomplete(&self) -> bool {
        !self.jobs_failed.is_empty() || !self.jobs_pending.is_empty()
    }

    /// One plain sentence on the jobs of an unfinished bake, e.g. "3 of 5 jobs done;
    /// 1 failed (job 2); 1 pending (job 4)"; `None` when every job is done.
    pub fn jobs_line(&self) -> Option<String> {
        if !self.incomplete() {
            return None;
        }
        let list = |v: &[u32]| {
            let shown: Vec<String> = v.iter().take(20).map(|j| j.to_string()).collect();
            let more = if v.len() > 20 { " …" } else { "" };
            let noun = if v.len() == 1 { "job" } else { "jobs" };
            format!("{noun} {}{more}", shown.join(", "))
        };
        let mut line = format!("{} of {} jobs done", self.jobs_done, self.jobs);
        if !self.jobs_failed.is_empty() {
            line += &format!(
                "; {} failed ({})",
                self.jobs_failed.len(),
                list(&self.jobs_failed)
            );
        }
        if !self.jobs_pending.is_empty() {
            line += &format!(
                "; {} pending ({})",
                self.jobs_pending.len(),
                list(&self.jobs_pending)
            );
        }
        Some(line)
    }
}
