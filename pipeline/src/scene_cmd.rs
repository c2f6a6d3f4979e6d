//! `pipeline scene <manifest> [--json]`: what a manifest resolves to — models
//! (name, triangles, vertices, bounds), instances, total triangles, the hex grid.

use format::manifest::Plan;
use format::Scene;
use serde::Serialize;
use worker::grid::HexGrid;

#[derive(Serialize)]
pub struct ModelSummary {
    pub name: String,
    pub source: String,
    pub triangles: usize,
    pub vertices: usize,
    /// Instances of this model in the scene.
    pub instances: usize,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
}

/// JSON keys are a contract (issue 2): `instances`, `triangles`, `models`,
/// `grid` (`[N, M]`), `cells`.
#[derive(Serialize)]
pub struct SceneSummary {
    pub name: String,
    pub instances: usize,
    pub triangles: u64,
    pub models: Vec<ModelSummary>,
    pub grid: [u32; 2],
    pub cells: u32,
    pub cell_size: f32,
    pub ground_min: [f32; 2],
    pub ground_max: [f32; 2],
    /// Far-field groups per level (issue 27; empty with `bake.far_field` off):
    /// `levels[k]` is the number of groups of level k + 1.
    pub far_levels: Vec<u32>,
    /// Objects wider than two cells split into per-cell chunks (issue 29 item 2;
    /// `split_wide_objects`): how many, into how many chunks.
    pub chunks: scene::chunk::ChunkStats,
    /// A `Tiled` scene: tiles per side, the base manifest and the grid period.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tiled: Option<TiledSummary>,
}

#[derive(Serialize)]
pub struct TiledSummary {
    pub tiles: u32,
    pub manifest: String,
    /// Columns and rows between tiles.
    pub period: [u32; 2],
}

pub fn summarize(plan: &Plan, scene: &Scene, chunks: scene::chunk::ChunkStats) -> SceneSummary {
    let grid = HexGrid::new(scene.ground, plan.cells.cell_size);
    let models = scene
        .models
        .iter()
        .enumerate()
        .map(|(m, model)| {
            let (lo, hi) = model.mesh.bounds().unwrap_or(([0.0; 3], [0.0; 3]));
            ModelSummary {
                name: model.name.clone(),
                source: model.source.clone(),
                triangles: model.mesh.triangle_count(),
                vertices: model.mesh.vertex_count(),
                instances: scene
                    .instances
                    .iter()
                    .filter(|i| i.model as usize == m)
                    .count(),
                bounds_min: lo,
                bounds_max: hi,
            }
        })
        .collect();
    let groups = worker::far_field::CellGroups::for_params(&grid, &plan.bake);
    let mut far_levels = Vec::new();
    if plan.bake.far_field {
        for g in 0..groups.len() {
            let l = groups.level(g) as usize;
            far_levels.resize(far_levels.len().max(l), 0);
            far_levels[l - 1] += 1;
        }
    }
    let tiled = match &plan.scene {
        format::manifest::SceneSpec::Tiled(t) => Some(TiledSummary {
            tiles: t.tiles,
            manifest: t.manifest.display().to_string(),
            period: t.period,
        }),
        _ => None,
    };
    SceneSummary {
        far_levels,
        tiled,
        chunks,
        name: plan.name.clone(),
        instances: scene.instances.len(),
        triangles: scene.triangle_count(),
        models,
        grid: [grid.n_cols(), grid.n_rows()],
        cells: grid.cell_count(),
        cell_size: plan.cells.cell_size,
        ground_min: scene.ground.min,
        ground_max: scene.ground.max,
    }
}

pub fn render_text(s: &SceneSummary) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(out, "scene {}", s.name);
    let _ = writeln!(
        out,
        "{:<22} {:>10} {:>10} {:>5}  {:>24}",
        "model", "triangles", "vertices", "inst", "size (x × y × z)"
    );
    for m in &s.models {
        let size: Vec<String> = (0..3)
            .map(|k| format!("{:.1}", m.bounds_max[k] - m.bounds_min[k]))
            .collect();
        let _ = writeln!(
            out,
            "{:<22} {:>10} {:>10} {:>5}  {:>24}",
            m.name,
            m.triangles,
            m.vertices,
            m.instances,
            size.join(" × ")
        );
    }
    let _ = writeln!(out, "instances  {}", s.instances);
    let _ = writeln!(out, "triangles  {}", s.triangles);
    let _ = writeln!(
        out,
        "ground     {} × {}",
        s.ground_max[0] - s.ground_min[0],
        s.ground_max[1] - s.ground_min[1]
    );
    let _ = writeln!(
        out,
        "grid       {} × {} cells of size {} ({} cells)",
        s.grid[0], s.grid[1], s.cell_size, s.cells
    );
    if s.chunks.split_objects > 0 {
        let _ = writeln!(
            out,
            "chunks     {} objects wider than two cells split into {} chunks (one per cell)",
            s.chunks.split_objects, s.chunks.chunks
        );
    }
    if !s.far_levels.is_empty() {
        let per: Vec<String> = s.far_levels.iter().map(|n| n.to_string()).collect();
        let _ = writeln!(
            out,
            "far field  {} levels of groups (7, 49, 343 … cells): {} groups",
            s.far_levels.len(),
            per.join(" / ")
        );
    }
    if let Some(t) = &s.tiled {
        let _ = writeln!(
            out,
            "tiled      {} × {} tiles of {}, {} columns × {} rows apart",
            t.tiles, t.tiles, t.manifest, t.period[0], t.period[1]
        );
    }
    out
}
