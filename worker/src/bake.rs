//! `bake_cell`: the preprocessing of one view cell (paper 000 §3.1, Fig. 3; DESIGN.md
//! "Data flow", "Representations").
//!
//! Steps:
//!
//! 1. **Split** ([`draws_as_original`], issue 29). An instance whose world box's
//!    footprint (its x–z rectangle) overlaps the cell's hexagon is inside:
//!    Original — whatever its height, so an object under the viewer's region
//!    (terrain, a ground mesh, a road), over it (a bridge, an arcade's roof) or
//!    enclosing part of it is drawn as it is, never captured from a point inside,
//!    above or below it. Every other instance is outside and gets a proxy or is
//!    Culled. The paper's view cells are regions of the ground (000 §3.1.1), and its
//!    inside objects those standing in them: this is that rule for objects of any
//!    height, of which the box–prism intersection (the rule until issue 29) is the
//!    special case of objects reaching the eye heights. An outside object's box
//!    misses the vertical column over the hexagon, so the cell centre lies outside
//!    it and a capture from there sees all of it in front of the eye
//!    ([`crate::view`]). A chunk of a split object (`scene::chunk`) is inside
//!    when its footprint comes within half a cell of the hexagon
//!    ([`instance_draws_as_original`]): the chunks of the cell's neighbours are
//!    drawn as they are, not as proxies smeared at the viewer's feet.
//! 2. **Regional back-face culling** (§3.1.5): an outside instance all of whose
//!    triangles face away from the whole prism is Culled (an instance without
//!    triangles too).
//!
//!    2b. **Culled by size** (004; issue 16): with objective selection
//!    (`bake.quality`), an outside instance that subtends less than a pixel from
//!    every point of the prism ([`select::subpixel_from_region`]) is Culled before
//!    clustering, so it neither gets a proxy nor joins a cluster.
//! 3. **Self-occluding error** (§3.1.2) of the instance's world box from the cell
//!    centre: below T_s → SV candidate, else MvMesh.
//! 4. **Clustering** (§3.1.6, when `params.clustering`) of the SV candidates; a
//!    cluster of one is a plain SvMesh.
//! 5. **Derivation** (§3.1.3, §3.1.4) of every SvMesh / Cluster / MvMesh, in parallel
//!    over proxies (rayon), collected in order of each proxy's first instance, so the
//!    result does not depend on the thread count.
//!
//! Every outside object gets a proxy, however far or small: the paper has no far
//! plane, and an object projecting below a pixel simply simplifies to the few
//! triangles the collapse constraints leave, with a 1 × 1 texture
//! ([`crate::capture`]).
//!
//! With the far field (`bake.far_field`, [`crate::far_field`]), step 1 first sets
//! aside the far objects of the cell's 7-cell group ([`Assignment::Far`]): their
//! proxies are derived once per group by [`bake_group`] — the same steps 4–5 from
//! the group centre, over the group's prism — and stored in the group's pack.
//!
//! Where each part lives: the split's rule and the cell eye in [`crate::grid`]; steps
//! 4–5 in [`crate::derive`]; proxies and their content keys in [`crate::proxy`];
//! errors in [`crate::error`]; groups and levels of the far field in
//! [`crate::groups`], [`crate::far_field`] and [`crate::levels`].
//!
//! The cell centre is the hexagon's centre at mid eye height; neighbours' centres
//! (MvMesh views) are at the same height. Stage times are measured per proxy and
//! summed (CPU time, not wall time) and are never written to packs.

use crate::backface::all_culled;
use crate::capture::pack_texture;
use crate::capture_memo::CaptureMemo;
pub use crate::derive::CellTimes;
use crate::derive::{derive_region, selection_culled, Region};
pub use crate::error::BakeError;
use crate::far_field::FarField;
use crate::grid::HexGrid;
pub use crate::grid::{cell_eye, draws_as_original, instance_draws_as_original};
use crate::lod_chain::LodChains;
pub use crate::proxy::{proxy_key, BakedMember, BakedProxy, ProxyKey, ProxyReuse};
use crate::select::subpixel_from_region;
use crate::selfocc::{choose_representation, object_self_occluding_error, Representation};
use crate::svmesh::{ms_since, StageTimes};
use format::manifest::{BakeParams, CellParams};
use format::pack::{CellPack, Proxy, ProxyKind, ProxyMember, ProxyView};
use format::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// What became of one instance in this cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Assignment {
    Original,
    Culled,
    /// Index into [`CellBake::proxies`].
    Proxy(u32),
    /// A far object of the cell's group: drawn from the group's pack.
    Far,
}

/// Per-cell statistics (DESIGN.md reports).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CellStats {
    pub instances: u32,
    pub originals: u32,
    /// Triangles of the Original instances.
    pub polygons_inside: u64,
    pub culled: u32,
    pub sv_count: u32,
    pub sv_polygons: u64,
    pub mv_count: u32,
    pub mv_polygons: u64,
    /// Clusters of two or more objects, their members and polygons.
    pub cluster_count: u32,
    pub cluster_members: u32,
    pub cluster_polygons: u64,
    /// Triangles of the full models of the proxied instances.
    pub proxied_original_polygons: u64,
    /// (SV + MV + cluster polygons) / `proxied_original_polygons`.
    pub simplified_ratio: f64,
    /// Decoded RGBA8 bytes of all proxy textures.
    pub texture_bytes: u64,
    pub views: u32,
    /// Proxies taken from an earlier bake by key instead of derived.
    pub reused_proxies: u32,
    /// Objects drawn from the group's far field (a cell) — or, for a group's bake,
    /// the number of cells sharing it.
    pub far_objects: u32,
    /// Layered impostors (issue 16), the objects they stand for and their quads'
    /// triangles (two per layer).
    pub impostor_count: u32,
    pub impostor_members: u32,
    pub impostor_polygons: u64,
    /// Outside objects the objective selection culled (below a pixel from the whole
    /// region: single objects at step 2b, whole proxies at step 6); they are also
    /// counted in `culled`.
    pub selection_culled: u32,
    /// The objective selection's measurements of the proxies it kept (issue 16).
    pub quality: CellQuality,
    pub times: CellTimes,
}

/// Quality figures of a cell's measured proxies (issue 16, [`crate::select`]): each
/// kept candidate that was measured contributes its worst sample view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellQuality {
    /// Proxies whose kept candidate was measured.
    pub measured: u32,
    /// Smallest object-pixel PSNR(Y) of a sample view over the measured proxies
    /// ([`format::metrics::PSNR_CAP`] when none was measured).
    pub worst_psnr_db: f64,
    /// Smallest object-pixel SSIM likewise (1 when none).
    pub worst_ssim: f64,
    /// |ΔY| over the object pixels of every measured view, bins of 8 levels.
    pub error_histogram: [u64; 8],
}

impl Default for CellQuality {
    fn default() -> Self {
        CellQuality {
            measured: 0,
            worst_psnr_db: format::metrics::PSNR_CAP,
            worst_ssim: 1.0,
            error_histogram: [0; 8],
        }
    }
}

/// The result of baking one cell.
#[derive(Clone, Debug, PartialEq)]
pub struct CellBake {
    /// The cell's id (the group's id for [`bake_group`]).
    pub cell: u32,
    /// The cell's far-field group, if the far field is on.
    pub far_group: Option<u32>,
    /// Per instance of the scene.
    pub assignment: Vec<Assignment>,
    /// Original instances, ascending.
    pub originals: Vec<u32>,
    /// Ordered by first member instance.
    pub proxies: Vec<BakedProxy>,
    pub stats: CellStats,
}

/// Bakes one cell (module docs) with every collapse starting from the full meshes
/// (the paper as written; [`bake_cell_with`] starts from the models' LOD chains).
pub fn bake_cell(
    scene: &Scene,
    grid: &HexGrid,
    cell: u32,
    cells: &CellParams,
    params: &BakeParams,
) -> Result<CellBake, BakeError> {
    bake_cell_with(
        scene,
        &LodChains::none(),
        &ProxyReuse::new(),
        grid,
        cell,
        cells,
        params,
        None,
    )
}

/// Bakes one cell (module docs); each proxy's collapse starts from the coarsest level
/// of its model's chain in `chains` that the cell's region allows
/// ([`crate::lod_chain`]), a proxy whose key ([`proxy_key`]) is in `reuse` is
/// taken from there instead of derived, and the far objects of `far` (the cell's
/// group, [`FarField::of_cell`]) are left to the group's pack.
#[allow(clippy::too_many_arguments)]
pub fn bake_cell_with(
    scene: &Scene,
    chains: &LodChains,
    reuse: &ProxyReuse,
    grid: &HexGrid,
    cell: u32,
    cells: &CellParams,
    params: &BakeParams,
    far: Option<&FarField>,
) -> Result<CellBake, BakeError> {
    let start = Instant::now();
    if cell >= grid.cell_count() {
        return Err(BakeError::NoCell {
            cell,
            cells: grid.cell_count(),
        });
    }
    let mut times = CellTimes::default();
    let prism = grid.prism(cell, cells.min_eye_height, cells.max_eye_height);
    let corners = prism.corners();
    let chunk_margin = crate::grid::CHUNK_MARGIN_CELLS * grid.cell_size();
    let centre = cell_eye(grid, cell, cells);

    // Steps 1–3: split, cull, self-occluding error (parallel, collected in order).
    let t = Instant::now();
    let is_far = |i: usize| far.is_some_and(|f| f.instances.get(i) == Some(&true));
    let split: Vec<(Option<Representation>, Assignment, bool)> = (0..scene.instances.len())
        .into_par_iter()
        .map(|i| {
            let culled = (None, Assignment::Culled, false);
            let inst = &scene.instances[i];
            let Some(model) = scene.models.get(inst.model as usize) else {
                return culled;
            };
            if model.mesh.triangles.is_empty() {
                return culled;
            }
            if is_far(i) {
                return (None, Assignment::Far, false);
            }
            let (lo, hi) = scene.instance_bounds(i);
            let chunk = model.chunk_cell.is_some();
            if instance_draws_as_original(&prism, lo, hi, chunk, chunk_margin) {
                return (None, Assignment::Original, false);
            }
            // Culled by size (004, issue 16): with objective selection, an object
            // under a pixel from every point of the prism is dropped here, before
            // clustering, so it neither gets a proxy nor joins a cluster (where the
            // selection could no longer drop it alone).
            if params.quality.is_some() && subpixel_from_region(lo, hi, &prism, params.image_res) {
                return (None, Assignment::Culled, true);
            }
            if all_culled(&model.mesh, inst.transform, &corners) {
                return culled;
            }
            let error =
                object_self_occluding_error(grid.cell_size(), params.image_res, centre, lo, hi);
            (
                Some(choose_representation(
                    error,
                    params.self_occluding_tolerance_px,
                )),
                Assignment::Culled,
                false,
            )
        })
        .collect();
    let size_culled = split.iter().filter(|k| k.2).count() as u32;
    let kinds: Vec<(Option<Representation>, Assignment)> =
        split.into_iter().map(|(r, a, _)| (r, a)).collect();
    times.split_ms = ms_since(t);
    // Regional occlusion culling (000 §3.1.7; `occlusion.rs`, issue 17): with
    // `bake.occlusion_culling`, an outside object hidden from every point of the
    // prism is Culled instead of getting a proxy. Its time counts as split time.
    let kinds = if params.occlusion_culling {
        let t = Instant::now();
        let candidates: Vec<u32> = (0..kinds.len() as u32)
            .filter(|&i| kinds[i as usize].0.is_some())
            .collect();
        let settings = crate::occlusion::OcclusionSettings::for_prism(&prism);
        let hidden = crate::occlusion::occluded_instances(scene, &prism, &candidates, &settings);
        let mut kinds = kinds;
        for (&i, hidden) in candidates.iter().zip(hidden) {
            if hidden {
                kinds[i as usize] = (None, Assignment::Culled);
            }
        }
        times.split_ms += ms_since(t);
        kinds
    } else {
        kinds
    };
    let mut assignment: Vec<Assignment> = kinds.iter().map(|k| k.1).collect();
    let originals: Vec<u32> = (0..scene.instances.len() as u32)
        .filter(|&i| assignment[i as usize] == Assignment::Original)
        .collect();
    let of_kind = |r: Representation| -> Vec<u32> {
        (0..kinds.len() as u32)
            .filter(|&i| kinds[i as usize].0 == Some(r))
            .collect()
    };
    let mut eyes = vec![centre];
    eyes.extend(
        grid.neighbours(cell)
            .into_iter()
            .map(|n| cell_eye(grid, n, cells)),
    );
    let region = Region {
        id: cell,
        prism,
        eyes,
        size: grid.cell_size(),
    };
    let (sv, mv) = (of_kind(Representation::Sv), of_kind(Representation::Mv));
    let (proxies, stage) = derive_region(
        scene, chains, reuse, &region, &sv, &mv, cells, params, &mut times,
    )?;
    let selection_culled = size_culled + selection_culled(sv.len() + mv.len(), &proxies);
    for (k, p) in proxies.iter().enumerate() {
        for m in &p.members {
            assignment[m.instance as usize] = Assignment::Proxy(k as u32);
        }
    }
    let mut bake = finish(
        scene, cell, assignment, originals, proxies, stage, times, start,
    );
    bake.far_group = far.map(|f| f.group);
    bake.stats.selection_culled = selection_culled;
    bake.stats.far_objects = bake
        .assignment
        .iter()
        .filter(|&&a| a == Assignment::Far)
        .count() as u32;
    Ok(bake)
}

/// Statistics and the result of a cell's (or group's) bake.
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish(
    scene: &Scene,
    cell: u32,
    assignment: Vec<Assignment>,
    originals: Vec<u32>,
    proxies: Vec<BakedProxy>,
    stage: StageTimes,
    mut times: CellTimes,
    start: Instant,
) -> CellBake {
    times.capture_ms = stage.capture_ms;
    times.weights_ms = stage.weights_ms;
    times.simplify_ms = stage.simplify_ms;
    let tris_of = |i: u32| {
        let inst = &scene.instances[i as usize];
        scene.models[inst.model as usize].mesh.triangles.len() as u64
    };
    let mut stats = CellStats {
        instances: scene.instances.len() as u32,
        originals: originals.len() as u32,
        polygons_inside: originals.iter().map(|&i| tris_of(i)).sum(),
        culled: assignment
            .iter()
            .filter(|&&a| a == Assignment::Culled)
            .count() as u32,
        ..CellStats::default()
    };
    for p in &proxies {
        let tris = p.triangle_count();
        match p.kind {
            ProxyKind::SvMesh => {
                stats.sv_count += 1;
                stats.sv_polygons += tris;
            }
            ProxyKind::MvMesh => {
                stats.mv_count += 1;
                stats.mv_polygons += tris;
            }
            ProxyKind::LayeredImpostor => {
                stats.impostor_count += 1;
                stats.impostor_members += p.members.len() as u32;
                stats.impostor_polygons += tris;
            }
            _ => {
                stats.cluster_count += 1;
                stats.cluster_members += p.members.len() as u32;
                stats.cluster_polygons += tris;
            }
        }
        stats.proxied_original_polygons +=
            p.members.iter().map(|m| tris_of(m.instance)).sum::<u64>();
        stats.views += p.view_count() as u32;
        stats.texture_bytes += p.texture_bytes();
        stats.reused_proxies += u32::from(p.packed.is_some());
        if let Some(m) = &p.quality {
            let q = &mut stats.quality;
            q.measured += 1;
            q.worst_psnr_db = q.worst_psnr_db.min(m.worst_psnr_db);
            q.worst_ssim = q.worst_ssim.min(m.worst_ssim);
            for (a, b) in q.error_histogram.iter_mut().zip(m.error_histogram) {
                *a += b;
            }
        }
    }
    let proxy_polygons =
        stats.sv_polygons + stats.mv_polygons + stats.cluster_polygons + stats.impostor_polygons;
    stats.simplified_ratio = if stats.proxied_original_polygons > 0 {
        proxy_polygons as f64 / stats.proxied_original_polygons as f64
    } else {
        0.0
    };
    times.total_ms = ms_since(start);
    stats.times = times;
    CellBake {
        cell,
        far_group: None,
        assignment,
        originals,
        proxies,
        stats,
    }
}

impl CellBake {
    /// The cell pack (no times or other run-dependent data reach it).
    pub fn to_pack(&self, fingerprint: [u8; 32]) -> Result<CellPack, BakeError> {
        self.to_pack_with(fingerprint, &CaptureMemo::default())
    }

    /// [`CellBake::to_pack`] with capture textures encoded through the run's
    /// `memo` ([`CaptureMemo::encoded`]): once per distinct image, the same bytes.
    pub fn to_pack_with(
        &self,
        fingerprint: [u8; 32],
        memo: &CaptureMemo,
    ) -> Result<CellPack, BakeError> {
        let proxies = self
            .proxies
            .iter()
            .map(|p| {
                if let Some(packed) = &p.packed {
                    return Ok(packed.clone());
                }
                if let Some(imp) = &p.impostor {
                    // Lossless: the alpha channel holds depth codes (impostor.rs).
                    let t = &imp.texture;
                    let texture =
                        format::pack::Texture::from_rgba8_smallest(t.width, t.height, &t.rgba)
                            .map_err(|what| BakeError::Texture {
                                cell: self.cell,
                                instance: p.members.first().map_or(u32::MAX, |m| m.instance),
                                what,
                            })?;
                    return Ok(Proxy {
                        kind: ProxyKind::LayeredImpostor,
                        members: p
                            .members
                            .iter()
                            .map(|m| ProxyMember {
                                instance: m.instance,
                                triangles: Vec::new(),
                                view_masks: Vec::new(),
                            })
                            .collect(),
                        views: vec![ProxyView {
                            eye: t.eye.into(),
                            matrix: crate::capture::matrix_array(&t.matrix),
                            texture,
                        }],
                        layers: Some(imp.layers.clone()),
                    });
                }
                let views = p
                    .views
                    .iter()
                    .map(|v| {
                        let (texture, matrix) =
                            pack_texture(v, memo).map_err(|what| BakeError::Texture {
                                cell: self.cell,
                                instance: p.members.first().map_or(u32::MAX, |m| m.instance),
                                what,
                            })?;
                        Ok(ProxyView {
                            eye: v.eye.into(),
                            matrix,
                            texture,
                        })
                    })
                    .collect::<Result<Vec<_>, BakeError>>()?;
                Ok(Proxy {
                    kind: p.kind,
                    members: p
                        .members
                        .iter()
                        .map(|m| ProxyMember {
                            instance: m.instance,
                            triangles: m.triangles.clone(),
                            view_masks: m.view_masks.clone(),
                        })
                        .collect(),
                    views,
                    layers: None,
                })
            })
            .collect::<Result<Vec<_>, BakeError>>()?;
        Ok(CellPack {
            cell_id: self.cell,
            fingerprint,
            far_group: self.far_group,
            originals: self.originals.clone(),
            proxies,
        })
    }
}
