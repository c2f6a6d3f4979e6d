//! Pictures of one object's capture from a cell centre, for people (issue 3 item 6):
//! colour, depth, pixel classes (000 §3.1.3.1) and vertex weights (§3.1.3.2).
//!
//! The capture follows DESIGN.md: the eye is the cell centre at mid eye height, the
//! frustum is tight around the object at `image_res` pixels per 60°, and only the
//! object itself is drawn (its classes and weights do not depend on other objects).

use crate::classify::{classify_objects, ClassCounts, PixelClass, WindowDepth};
use crate::grid::HexGrid;
use crate::picture::{ramp, write_rgba, PictureError};
use crate::raster::{render, Capture, CullMode, DrawItem, View};
use crate::visibility::DepthTolerance;
use crate::weights::{vertex_states, VertexState};
use format::manifest::Plan;
use format::Scene;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Colours of the class map (legend in the docs).
pub fn class_colour(class: PixelClass) -> [u8; 4] {
    match class {
        PixelClass::Background => [24, 24, 24, 255],
        PixelClass::ExteriorSilhouette => [255, 64, 64, 255],
        PixelClass::InteriorSilhouette => [255, 200, 40, 255],
        PixelClass::SharpEdge => [60, 200, 255, 255],
        PixelClass::Interior => [90, 90, 150, 255],
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DiagnosticsError {
    #[error("cell {cell} is not on the grid ({cells} cells)")]
    NoSuchCell { cell: u32, cells: u32 },
    #[error("instance {instance} does not exist ({instances} instances)")]
    NoSuchInstance { instance: u32, instances: usize },
    #[error("cannot capture instance {instance} from cell {cell}: {message}")]
    View {
        instance: u32,
        cell: u32,
        message: String,
    },
    #[error(transparent)]
    Picture(#[from] PictureError),
}

/// What `capture_pictures` measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CaptureSummary {
    pub cell: u32,
    pub instance: u32,
    pub model: String,
    pub eye: [f32; 3],
    /// Centre of the instance's bounding box.
    pub object_centre: [f32; 3],
    pub width: u32,
    pub height: u32,
    /// Percent of the object's pixels per class: exterior silhouette, interior
    /// silhouette, sharp edge, interior.
    pub class_percent: [f64; 4],
    /// Vertices per state: back-facing, visible, invisible.
    pub vertex_states: [usize; 3],
    pub files: Vec<PathBuf>,
}

/// The cell centre at mid eye height: the eye of the cell's SVMesh captures.
pub fn cell_eye(plan: &Plan, grid: &HexGrid, cell: u32) -> Vec3 {
    let c = grid.centre(cell);
    let h = 0.5 * (plan.cells.min_eye_height + plan.cells.max_eye_height);
    Vec3::new(c.x, h, c.y)
}

/// Captures `instance` from the centre of `cell` and writes `colour.png`,
/// `depth.png`, `classes.png`, `weights.png` and `sheet.png` (the three side by side)
/// into `out`.
pub fn capture_pictures(
    plan: &Plan,
    scene: &Scene,
    cell: u32,
    instance: u32,
    out: &Path,
) -> Result<CaptureSummary, DiagnosticsError> {
    // 1. The eye and a tight frustum around the instance.
    let grid = HexGrid::new(scene.ground, plan.cells.cell_size);
    if cell >= grid.cell_count() {
        return Err(DiagnosticsError::NoSuchCell {
            cell,
            cells: grid.cell_count(),
        });
    }
    let inst = scene
        .instances
        .get(instance as usize)
        .ok_or(DiagnosticsError::NoSuchInstance {
            instance,
            instances: scene.instances.len(),
        })?;
    let model = &scene.models[inst.model as usize];
    let eye = cell_eye(plan, &grid, cell);
    let (lo, hi) = scene.instance_bounds(instance as usize);
    let view = View::tight_around(eye, lo, hi, plan.bake.image_res).map_err(|e| {
        DiagnosticsError::View {
            instance,
            cell,
            message: e.to_string(),
        }
    })?;

    // 2. Render the object alone, classify its pixels, weight its vertices.
    let item = DrawItem::instance(scene, instance);
    let capture = render(&view, &[item], CullMode::Back);
    // The thresholds are on window depth with the near plane at the cell's side face
    // (the paper's capture window), not on the tight frustum's own near/far.
    let classes = classify_objects(
        &capture,
        &[instance],
        plan.bake.t_c0,
        plan.bake.t_c1,
        WindowDepth::paper(plan.cells.cell_size),
    );
    let states = vertex_states(
        &model.mesh,
        inst.transform,
        &capture,
        &classes,
        instance,
        DepthTolerance::default(),
    );

    // 3. Pictures.
    std::fs::create_dir_all(out).map_err(|source| PictureError::Io {
        path: out.display().to_string(),
        source,
    })?;
    let (w, h) = (capture.view.width, capture.view.height);
    let colour = capture.color.clone();
    let depth = depth_picture(&capture);
    let class_map: Vec<[u8; 4]> = classes.iter().map(|&c| class_colour(c)).collect();
    let weight_map = weight_picture(&capture, &model.mesh, inst.transform, &states);
    let sheet = side_by_side(w, h, &[&colour, &class_map, &weight_map]);
    let mut files = Vec::new();
    for (name, pixels, width) in [
        ("colour.png", &colour, w),
        ("depth.png", &depth, w),
        ("classes.png", &class_map, w),
        ("weights.png", &weight_map, w),
        ("sheet.png", &sheet, 3 * w + 2 * SHEET_GAP),
    ] {
        let path = out.join(name);
        write_rgba(&path, width, h, pixels)?;
        files.push(path);
    }

    // 4. Numbers.
    let counts = ClassCounts::of(&classes);
    let class_percent = [
        PixelClass::ExteriorSilhouette,
        PixelClass::InteriorSilhouette,
        PixelClass::SharpEdge,
        PixelClass::Interior,
    ]
    .map(|c| counts.percent_of_object(c));
    let mut vertex_counts = [0usize; 3];
    for s in &states {
        vertex_counts[match s {
            VertexState::BackFacing => 0,
            VertexState::Visible(_) => 1,
            VertexState::Invisible => 2,
        }] += 1;
    }
    Ok(CaptureSummary {
        cell,
        instance,
        model: model.name.clone(),
        eye: eye.to_array(),
        object_centre: (0.5 * (lo + hi)).to_array(),
        width: w,
        height: h,
        class_percent,
        vertex_states: vertex_counts,
        files,
    })
}

const SHEET_GAP: u32 = 4;

fn side_by_side(w: u32, h: u32, images: &[&Vec<[u8; 4]>]) -> Vec<[u8; 4]> {
    let total_w = images.len() as u32 * w + (images.len() as u32 - 1) * SHEET_GAP;
    let mut out = vec![[255, 255, 255, 255]; (total_w * h) as usize];
    for (k, img) in images.iter().enumerate() {
        let x0 = k as u32 * (w + SHEET_GAP);
        for y in 0..h {
            for x in 0..w {
                out[(y * total_w + x0 + x) as usize] = img[(y * w + x) as usize];
            }
        }
    }
    out
}

/// Eye depth over the object's range: near = bright, far = dark, background black.
fn depth_picture(capture: &Capture) -> Vec<[u8; 4]> {
    let finite = capture.depth.iter().copied().filter(|d| d.is_finite());
    let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| {
        (lo.min(d), hi.max(d))
    });
    let span = (hi - lo).max(1e-12);
    capture
        .depth
        .iter()
        .map(|&d| {
            if d.is_finite() {
                let v = (255.0 * (1.0 - 0.85 * (d - lo) / span)).round() as u8;
                [v, v, v, 255]
            } else {
                [0, 0, 0, 255]
            }
        })
        .collect()
}

/// Each front-facing vertex as a dot at its pixel, coloured by its weight on the
/// ramp (0.05 hidden … 0.5 exterior silhouette); back-facing vertices (all 0.5) are
/// left out so the visible surface stays readable, hidden ones are drawn first.
fn weight_picture(
    capture: &Capture,
    mesh: &format::Mesh,
    transform: glam::Mat4,
    states: &[VertexState],
) -> Vec<[u8; 4]> {
    let (w, h) = (capture.view.width, capture.view.height);
    let mut out = vec![[16, 16, 16, 255]; (w * h) as usize];
    let mut order: Vec<usize> = (0..states.len())
        .filter(|&i| states[i] != VertexState::BackFacing)
        .collect();
    order.sort_by_key(|&i| matches!(states[i], VertexState::Visible(_)));
    for i in order {
        let p = transform.transform_point3(Vec3::from(mesh.positions[i]));
        if let Some((px, _)) = capture.view.project(p) {
            let (x, y) = (px.x.floor(), px.y.floor());
            if x >= 0.0 && y >= 0.0 && (x as u32) < w && (y as u32) < h {
                let t = (states[i].weight() - 0.05) / 0.45;
                out[(y as u32 * w + x as u32) as usize] = ramp(t);
            }
        }
    }
    out
}
