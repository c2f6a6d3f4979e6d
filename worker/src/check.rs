//! Proxy quality check of a baked cell (paper 000 §4.2 image quality; DESIGN.md
//! "Quality"): the same CPU rasterizer renders the original geometry and the cell's
//! hybrid representation (Originals as lit models, proxies with projective texturing,
//! [`Shading::Projective`]) from viewpoints spread over the cell's prism, and compares
//! them by PSNR on luminance `Y = 0.299 R + 0.587 G + 0.114 B` of the sRGB8 values.
//!
//! Layered impostors (issue 16) are drawn by [`crate::impostor::composite_impostors`]
//! into the hybrid frame after the meshes, depth-tested.
//!
//! Viewpoints (deterministic): view k of n sits at `prism.sample(u, v, w)` with
//! `(u, v, w)` the Halton point k + 1 in bases 2, 3, 5, and looks horizontally in the
//! direction of azimuth `2π (k + ½) / n`, 60° vertical field of view, square image.
//! Identical frames give an infinite PSNR; it is capped at [`MAX_PSNR_DB`] so means
//! stay finite.

use crate::bake::CellBake;
use crate::grid::HexGrid;
use crate::raster::{
    render, render_with, Capture, CullMode, DrawItem, ProjectiveSurface, ProjectiveTextures,
    Shading, View,
};
use format::manifest::{BakeParams, CellParams};
use format::{Mesh, Scene};
use glam::Vec3;
use thiserror::Error;

/// The image metrics are [`format::metrics`]' (shared with the player's compare);
/// the check reports PSNR capped at [`MAX_PSNR_DB`].
pub use format::metrics::{
    capped_psnr_of_mse as psnr_of_mse, luminance, mse_y, PSNR_CAP as MAX_PSNR_DB,
};

/// Why a check cannot run.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CheckError {
    #[error("cell {cell} does not exist (the grid has {cells} cells)")]
    NoCell { cell: u32, cells: u32 },
    #[error("the bake is of cell {baked}, not {asked}")]
    WrongCell { baked: u32, asked: u32 },
    #[error("bad check parameters: {what}")]
    BadParameters { what: String },
}

/// Images of one check view, RGBA8 row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckImages {
    pub view: usize,
    pub width: u32,
    pub height: u32,
    pub reference: Vec<[u8; 4]>,
    pub proxy: Vec<[u8; 4]>,
    /// |ΔY| × 8, grey, opaque.
    pub diff: Vec<[u8; 4]>,
}

/// Result of [`check_cell`].
#[derive(Clone, Debug, PartialEq)]
pub struct CheckReport {
    pub eyes: Vec<Vec3>,
    pub per_view_psnr_y: Vec<f64>,
    /// Arithmetic mean of `per_view_psnr_y` (views showing no geometry count as
    /// [`MAX_PSNR_DB`]).
    pub mean: f64,
    /// PSNR of the mean squared error over all views' pixels (robust to empty views).
    pub pooled_psnr_y: f64,
    /// Views whose reference frame shows no geometry at all (sky only).
    pub empty_views: usize,
    pub worst_view: usize,
    pub worst: CheckImages,
}

fn halton(mut i: u32, base: u32) -> f32 {
    let mut f = 1.0f64;
    let mut r = 0.0f64;
    while i > 0 {
        f /= base as f64;
        r += f * (i % base) as f64;
        i /= base;
    }
    r as f32
}

/// The check viewpoints of a cell: eyes and look directions (module docs).
pub fn check_views(
    grid: &HexGrid,
    cell: u32,
    cells: &CellParams,
    views: usize,
) -> Vec<(Vec3, Vec3)> {
    let prism = grid.prism(cell, cells.min_eye_height, cells.max_eye_height);
    (0..views)
        .map(|k| {
            let i = k as u32 + 1;
            let eye = prism.sample(halton(i, 2), halton(i, 3), halton(i, 5));
            let a = std::f32::consts::TAU * (k as f32 + 0.5) / views as f32;
            (eye, Vec3::new(a.cos(), 0.0, a.sin()))
        })
        .collect()
}

/// PSNR (dB) on luminance between two images of equal size, capped at
/// [`MAX_PSNR_DB`]; 0 for images of different or zero size.
pub fn psnr_y(a: &[[u8; 4]], b: &[[u8; 4]]) -> f64 {
    mse_y(a, b).map_or(0.0, psnr_of_mse)
}

/// The proxy meshes of a bake as standalone meshes (model vertices, simplified
/// triangles) with their projective surfaces, in proxy/member order.
struct ProxyScene {
    meshes: Vec<(u32, Mesh)>,
    surfaces: Vec<Option<ProjectiveSurface>>,
}

fn proxy_scene(scene: &Scene, bake: &CellBake) -> ProxyScene {
    let mut meshes = Vec::new();
    let mut surfaces = Vec::new();
    for proxy in &bake.proxies {
        for m in &proxy.members {
            let inst = &scene.instances[m.instance as usize];
            let model = &scene.models[inst.model as usize].mesh;
            let mesh = Mesh {
                positions: model.positions.clone(),
                normals: model.normals.clone(),
                albedo: model.albedo.clone(),
                triangles: m.triangles.clone(),
            };
            surfaces.push(Some(ProjectiveSurface {
                views: proxy.views.clone(),
                triangle_masks: (!m.view_masks.is_empty()).then(|| m.view_masks.clone()),
            }));
            meshes.push((m.instance, mesh));
        }
    }
    ProxyScene { meshes, surfaces }
}

/// Renders the original geometry and the baked cell from `views` viewpoints over the
/// cell's prism at `res × res` (module docs) and compares them.
#[allow(clippy::too_many_arguments)]
pub fn check_cell(
    scene: &Scene,
    grid: &HexGrid,
    cell: u32,
    cells: &CellParams,
    _params: &BakeParams,
    bake: &CellBake,
    views: usize,
    res: u32,
) -> Result<CheckReport, CheckError> {
    if cell >= grid.cell_count() {
        return Err(CheckError::NoCell {
            cell,
            cells: grid.cell_count(),
        });
    }
    if bake.cell != cell {
        return Err(CheckError::WrongCell {
            baked: bake.cell,
            asked: cell,
        });
    }
    if views == 0 || res == 0 {
        return Err(CheckError::BadParameters {
            what: format!("{views} views of {res} px"),
        });
    }
    let item_of = |i: u32| DrawItem::instance(scene, i);
    // Reference: every instance as its model.
    let reference_items: Vec<DrawItem> = (0..scene.instances.len() as u32)
        .filter(|&i| {
            scene
                .models
                .get(scene.instances[i as usize].model as usize)
                .is_some()
        })
        .map(item_of)
        .collect();
    // Hybrid: Originals as models, proxies as their simplified meshes (object ids
    // past the instances index the projective surfaces).
    let proxies = proxy_scene(scene, bake);
    let base = scene.instances.len() as u32;
    let mut hybrid_items: Vec<DrawItem> = bake.originals.iter().map(|&i| item_of(i)).collect();
    for (k, (instance, mesh)) in proxies.meshes.iter().enumerate() {
        let inst = &scene.instances[*instance as usize];
        hybrid_items.push(DrawItem {
            mesh,
            transform: inst.transform,
            tint: inst.tint,
            object_id: base + k as u32,
            triangles: None,
            albedo_map: None,
        });
    }
    let mut by_object: Vec<Option<ProjectiveSurface>> = vec![None; base as usize];
    by_object.extend(proxies.surfaces.iter().cloned());
    let impostors: Vec<crate::impostor::ImpostorDraw> = bake
        .proxies
        .iter()
        .filter_map(|p| p.impostor.as_ref())
        .map(|imp| crate::impostor::ImpostorDraw {
            texture: &imp.texture,
            layers: &imp.layers,
            object_id: u32::MAX - 1,
        })
        .collect();

    let extent = {
        let g = scene.ground.size();
        (g[0] * g[0] + g[1] * g[1]).sqrt().max(1.0) * 2.0
    };
    let mut per_view = Vec::with_capacity(views);
    let mut mse_sum = 0.0;
    let mut empty_views = 0;
    let mut worst: Option<(f64, usize, Capture, Capture)> = None;
    for (k, (eye, dir)) in check_views(grid, cell, cells, views)
        .into_iter()
        .enumerate()
    {
        let view = View::look_at_fov(eye, eye + dir, Vec3::Y, 60.0, res, res, 0.05, extent)
            .map_err(|e| CheckError::BadParameters {
                what: e.to_string(),
            })?;
        let reference = render(&view, &reference_items, CullMode::Back);
        let textures = ProjectiveTextures {
            viewer: eye,
            by_object: by_object.clone(),
        };
        let mut hybrid = render_with(
            &view,
            &hybrid_items,
            CullMode::Back,
            Shading::Projective(&textures),
        );
        // Layered impostors (issue 16) composite into the depth-tested frame.
        crate::impostor::composite_impostors(&mut hybrid, &impostors);
        let mse = mse_y(&reference.color, &hybrid.color).unwrap_or(0.0);
        mse_sum += mse;
        if reference.covered_pixels() == 0 {
            empty_views += 1;
        }
        let psnr = psnr_of_mse(mse);
        per_view.push(psnr);
        if worst.as_ref().is_none_or(|w| psnr < w.0) {
            worst = Some((psnr, k, reference, hybrid));
        }
    }
    let mean = per_view.iter().sum::<f64>() / per_view.len() as f64;
    let (_, worst_view, reference, hybrid) = worst.expect("views > 0");
    let diff = reference
        .color
        .iter()
        .zip(&hybrid.color)
        .map(|(&a, &b)| {
            let d = ((luminance(a) - luminance(b)).abs() * 8.0).min(255.0) as u8;
            [d, d, d, 255]
        })
        .collect();
    Ok(CheckReport {
        eyes: check_views(grid, cell, cells, views)
            .into_iter()
            .map(|v| v.0)
            .collect(),
        per_view_psnr_y: per_view,
        mean,
        pooled_psnr_y: psnr_of_mse(mse_sum / views as f64),
        empty_views,
        worst_view,
        worst: CheckImages {
            view: worst_view,
            width: reference.view.width,
            height: reference.view.height,
            reference: reference.color,
            proxy: hybrid.color,
            diff,
        },
    })
}
