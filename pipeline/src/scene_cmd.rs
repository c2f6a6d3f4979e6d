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
}

pub fn summarize(plan: &Plan, scene: &Scene) -> SceneSummary {
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
    SceneSummary {
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
    out
}
