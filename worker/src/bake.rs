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
//!    ([`crate::view`]).
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
//! The cell centre is the hexagon's centre at mid eye height; neighbours' centres
//! (MvMesh views) are at the same height. Stage times are measured per proxy and
//! summed (CPU time, not wall time) and are never written to packs.

use crate::backface::all_culled;
use crate::capture::pack_texture;
use crate::cluster::{greedy_clusters, ClusterCandidate, ClusterSettings};
use crate::far_field::FarField;
use crate::grid::{HexGrid, Prism};
pub use crate::groups::{bake_cell_hybrid, bake_group};
use crate::impostor::{build_layered_impostor, LayeredImpostor};
use crate::lod_chain::LodChains;
use crate::mesh_order::cache_order;
use crate::mvmesh::derive_mvmesh;
use crate::raster::DrawItem;
use crate::raster::ProjectedTexture;
use crate::select::{self, sample_viewpoints, subpixel_from_region, Candidate, Measured};
use crate::selfocc::{choose_representation, object_self_occluding_error, Representation};
use crate::svmesh::{derive_svmesh, ms_since, ProxyError, ProxySettings, StageTimes};
use format::manifest::QualityFloor;
use format::manifest::{BakeParams, CellParams};
use format::pack::{CellPack, Proxy, ProxyKind, ProxyMember, ProxyView};
use format::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::time::Instant;
use thiserror::Error;

/// Why a cell cannot be baked.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BakeError {
    #[error("cell {cell} does not exist (the grid has {cells} cells)")]
    NoCell { cell: u32, cells: u32 },
    #[error("far-field group {group} does not exist (the grid has {groups} groups)")]
    NoGroup { group: u32, groups: u32 },
    #[error("cell {cell}: {source}")]
    Proxy {
        cell: u32,
        #[source]
        source: ProxyError,
    },
    #[error("cell {cell}: texture of a proxy of instance {instance}: {what}")]
    Texture {
        cell: u32,
        instance: u32,
        what: String,
    },
}

impl BakeError {
    /// The failure in the user's terms (issue 29 item 4), without the cell or group
    /// (the job names its unit): which instance failed — its glTF node or manifest
    /// entry and its model ([`Scene::describe_instance`]) —, what went wrong, and
    /// what to change in the scene or the manifest.
    pub fn explain(&self, scene: &Scene) -> String {
        use crate::capture::CaptureError;
        use crate::view::ViewError;
        let describe = |instances: &[u32]| -> String {
            let mut named: Vec<String> = instances
                .iter()
                .take(3)
                .map(|&i| scene.describe_instance(i as usize))
                .collect();
            if instances.len() > 3 {
                named.push(format!("{} more", instances.len() - 3));
            }
            named.join(", ")
        };
        let split_it = "split it into parts no wider than a cell (`cells.cell_size`), \
                        e.g. as separate nodes or meshes";
        match self {
            BakeError::NoCell { .. } | BakeError::NoGroup { .. } => self.to_string(),
            BakeError::Texture { instance, what, .. } => format!(
                "the texture of a proxy of {} cannot be stored: {what}; to change: check \
                 `bake.image_res`, and report it if the manifest is sound",
                describe(&[*instance])
            ),
            BakeError::Proxy { source, .. } => match source {
                ProxyError::NoModel { .. } | ProxyError::NoInstance { .. } => format!(
                    "the scene is inconsistent: {source}; to change: rebuild the scene \
                     (a scene loaded from a manifest never is: report it)"
                ),
                ProxyError::Capture { instances, source } => {
                    let what = describe(instances);
                    let advice = match source {
                        CaptureError::Empty => {
                            "check the model: none of its triangles has valid vertices".into()
                        }
                        CaptureError::View {
                            source: ViewError::TooLarge { .. },
                            ..
                        } => format!("lower `bake.image_res`, or {split_it}"),
                        CaptureError::View {
                            source: ViewError::BoxNotInFront { .. },
                            ..
                        } => format!(
                            "the object's box surrounds the capture point; {split_it}, or \
                             move it so that it does not enclose a cell's centre"
                        ),
                        CaptureError::View { .. } => {
                            format!("check the object's placement and size, or {split_it}")
                        }
                    };
                    format!("capture of {what} failed: {source}; to change: {advice}")
                }
                ProxyError::Simplify { instance, source } => format!(
                    "simplifying {} failed: {source}; to change: check the model's mesh \
                     (finite positions, valid triangles)",
                    describe(&[*instance])
                ),
            },
        }
    }
}

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

/// One member of a baked proxy.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedMember {
    pub instance: u32,
    /// Triangles given to the simplifier (for `simplify::validate`).
    pub input_triangles: Vec<[u32; 3]>,
    /// Simplified triangles (original vertex ids of the instance's model).
    pub triangles: Vec<[u32; 3]>,
    /// MvMesh: per triangle, bit i = `views[i]` sees it; empty otherwise.
    pub view_masks: Vec<u8>,
    /// MvMesh: per model vertex, the views it is visible in (same bits); empty
    /// otherwise (for `simplify::validate_view_masks`).
    pub vertex_view_sets: Vec<u8>,
}

/// One proxy of the cell.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedProxy {
    pub kind: ProxyKind,
    pub members: Vec<BakedMember>,
    /// The captures (empty for a proxy reused from an earlier bake: see `packed`).
    pub views: Vec<ProjectedTexture>,
    /// Content key: the hash of exactly what the proxy depends on ([`proxy_key`]).
    pub key: ProxyKey,
    /// Reused from an earlier bake of the cell (its key matched): the pack form,
    /// written as it is. Its members carry triangles and masks, no collapse inputs.
    pub packed: Option<Proxy>,
    /// LayeredImpostor (issue 16): its image and layers (`views` holds its texture
    /// too); `None` for every other kind.
    pub impostor: Option<LayeredImpostor>,
    /// The objective selection's measurement of the kept candidate
    /// ([`crate::select`]), where one was measured.
    pub quality: Option<Measured>,
}

impl BakedProxy {
    /// A layered impostor of `members` (their meshes are not drawn: no triangles).
    pub fn impostor(
        members: &[u32],
        imp: LayeredImpostor,
        key: ProxyKey,
        quality: Option<Measured>,
    ) -> BakedProxy {
        BakedProxy {
            kind: ProxyKind::LayeredImpostor,
            members: members
                .iter()
                .map(|&instance| BakedMember {
                    instance,
                    input_triangles: Vec::new(),
                    triangles: Vec::new(),
                    view_masks: Vec::new(),
                    vertex_view_sets: Vec::new(),
                })
                .collect(),
            views: vec![imp.texture.clone()],
            key,
            packed: None,
            impostor: Some(imp),
            quality,
        }
    }

    /// Triangles drawn: the members' (mesh proxies) or two per layer (impostors).
    pub fn triangle_count(&self) -> u64 {
        let layers = match (&self.impostor, &self.packed) {
            (Some(i), _) => i.layers.layers.len() as u64,
            (None, Some(p)) => p.layers.as_ref().map_or(0, |l| l.layers.len() as u64),
            (None, None) => 0,
        };
        2 * layers
            + self
                .members
                .iter()
                .map(|m| m.triangles.len() as u64)
                .sum::<u64>()
    }

    pub fn view_count(&self) -> usize {
        self.packed
            .as_ref()
            .map_or(self.views.len(), |p| p.views.len())
    }

    /// Decoded RGBA8 bytes of the proxy's textures.
    pub fn texture_bytes(&self) -> u64 {
        match &self.packed {
            Some(p) => p
                .views
                .iter()
                .map(|v| u64::from(v.texture.width) * u64::from(v.texture.height) * 4)
                .sum(),
            None => self.views.iter().map(|v| v.rgba.len() as u64).sum(),
        }
    }

    /// A proxy of an earlier bake whose key matches.
    pub(crate) fn reused(packed: &Proxy, key: ProxyKey) -> BakedProxy {
        BakedProxy {
            kind: packed.kind,
            members: packed
                .members
                .iter()
                .map(|m| BakedMember {
                    instance: m.instance,
                    input_triangles: Vec::new(),
                    triangles: m.triangles.clone(),
                    view_masks: m.view_masks.clone(),
                    vertex_view_sets: Vec::new(),
                })
                .collect(),
            views: Vec::new(),
            key,
            packed: Some(packed.clone()),
            impostor: None,
            quality: None,
        }
    }
}

/// A proxy's content key (issue 13, "per-proxy content-addressed cache").
pub type ProxyKey = [u8; 32];

/// Proxies of an earlier bake of a cell, by key: a proxy whose key is here is taken
/// as it is instead of derived again.
pub type ProxyReuse = BTreeMap<ProxyKey, Proxy>;

/// The key of a proxy: blake3 of exactly what its derivation reads — the bake and
/// cell parameters with the format version and bake revision
/// ([`format::fingerprint::params_fingerprint`]) and the LOD chain builder's revision,
/// its kind, the region it serves
/// (the prism) and the eyes it is captured from, and per member (in order) the
/// instance id, its model's content hash (which also decides the model's LOD
/// chain), transform and tint. A proxy's derivation reads nothing else: captures show
/// its members alone, and collapses see only their own meshes. So equal keys mean
/// byte-equal proxies, and a rebake after a manifest change derives only proxies
/// whose key changed.
pub fn proxy_key(
    scene: &Scene,
    params: &format::fingerprint::Fingerprint,
    kind: ProxyKind,
    members: &[u32],
    prism: &crate::grid::Prism,
    eyes: &[Vec3],
) -> ProxyKey {
    let mut h = blake3::Hasher::new();
    h.update(b"hexbake proxy v1\0");
    h.update(params);
    h.update(&crate::lod_chain::CHAIN_REVISION.to_le_bytes());
    h.update(&[kind as u8]);
    let floats = |h: &mut blake3::Hasher, values: &[f32]| {
        for v in values {
            h.update(&v.to_le_bytes());
        }
    };
    floats(
        &mut h,
        &[
            prism.centre.x,
            prism.centre.y,
            prism.cell_size,
            prism.min_y,
            prism.max_y,
        ],
    );
    h.update(&(eyes.len() as u32).to_le_bytes());
    for e in eyes {
        floats(&mut h, &e.to_array());
    }
    h.update(&(members.len() as u32).to_le_bytes());
    for &i in members {
        h.update(&i.to_le_bytes());
        if let Some(inst) = scene.instances.get(i as usize) {
            if let Some(model) = scene.models.get(inst.model as usize) {
                h.update(&model.content_hash);
            }
            floats(&mut h, &inst.transform.to_cols_array());
            floats(&mut h, &inst.tint.to_array());
        }
    }
    *h.finalize().as_bytes()
}

/// Time per stage (milliseconds; proxy stages summed over proxies).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CellTimes {
    /// Split, regional back-face culling and self-occluding error.
    pub split_ms: f64,
    pub cluster_ms: f64,
    pub capture_ms: f64,
    /// Classes, weights, view sets, triangle selection.
    pub weights_ms: f64,
    pub simplify_ms: f64,
    /// Objective selection (issue 16): building and measuring candidates; without
    /// it, the quality check of every bake (`select.rs`).
    pub select_ms: f64,
    /// Wall time of the whole `bake_cell`.
    pub total_ms: f64,
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

/// The cell centre at mid eye height.
pub fn cell_eye(grid: &HexGrid, cell: u32, cells: &CellParams) -> Vec3 {
    let c = grid.centre(cell);
    Vec3::new(
        c.x,
        0.5 * (cells.min_eye_height + cells.max_eye_height),
        c.y,
    )
}

enum Job {
    Sv(Vec<u32>),
    Mv(u32),
}

/// The split's rule (module docs, step 1; issue 29): an object whose world box
/// `[lo, hi]` has a footprint overlapping the region's hexagon is drawn by the
/// region as an original — it stands in, lies under, spans over or encloses part of
/// the region's prism. Everything else is outside: its box misses the column over
/// the hexagon, so the region's centre (the capture eye) is outside the box. The far
/// field's groups ([`crate::far_field`]) apply the same rule to their prisms, so an
/// object is never far for a group whose region it overlaps either.
pub fn draws_as_original(prism: &Prism, lo: Vec3, hi: Vec3) -> bool {
    prism.footprint_overlaps_aabb(lo, hi)
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
            if draws_as_original(&prism, lo, hi) {
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

/// Candidates (SV and MV objects) that ended in no proxy: culled by the objective
/// selection (issue 16).
pub(crate) fn selection_culled(candidates: usize, proxies: &[BakedProxy]) -> u32 {
    let kept: usize = proxies.iter().map(|p| p.members.len()).sum();
    candidates.saturating_sub(kept) as u32
}

/// The region a set of proxies serves: a cell's prism, or a group's
/// ([`crate::far_field`]).
pub(crate) struct Region {
    /// Cell or group id (for errors).
    pub(crate) id: u32,
    pub(crate) prism: Prism,
    /// The capture eyes: the centre first, then (for MvMesh) the neighbours' centres.
    pub(crate) eyes: Vec<Vec3>,
    /// The region's size c (the self-occluding error's and the clustering's |VV'|,
    /// the class thresholds' window depth).
    pub(crate) size: f32,
}

/// Steps 4–5 over a region: clustering of the SV candidates `sv`, then the
/// derivation of every SvMesh / Cluster / MvMesh (`mv`), in parallel over proxies,
/// collected in order of each proxy's first instance.
#[allow(clippy::too_many_arguments)]
pub(crate) fn derive_region(
    scene: &Scene,
    chains: &LodChains,
    reuse: &ProxyReuse,
    region: &Region,
    sv: &[u32],
    mv: &[u32],
    cells: &CellParams,
    params: &BakeParams,
    times: &mut CellTimes,
) -> Result<(Vec<BakedProxy>, StageTimes), BakeError> {
    let centre = region.eyes[0];
    let prism = region.prism;
    let settings = ProxySettings::for_cell(params, region.size, prism);

    // Step 4: clustering of the SV candidates.
    let t = Instant::now();
    let sv_groups: Vec<Vec<u32>> = if params.clustering {
        let candidates: Vec<ClusterCandidate> = sv
            .iter()
            .map(|&i| {
                let (lo, hi) = scene.instance_bounds(i as usize);
                ClusterCandidate {
                    instance: i,
                    aabb_min: lo,
                    aabb_max: hi,
                }
            })
            .collect();
        greedy_clusters(
            &candidates,
            &ClusterSettings {
                centre,
                cell_size: region.size,
                image_res: params.image_res,
                self_occluding_tolerance_px: params.self_occluding_tolerance_px,
            },
        )
    } else {
        sv.iter().map(|&i| vec![i]).collect()
    };
    times.cluster_ms = ms_since(t);

    // Step 5: derive every proxy, ordered by first instance.
    let mut jobs: Vec<(u32, Job)> = sv_groups
        .into_iter()
        .map(|g| (g[0], Job::Sv(g)))
        .chain(mv.iter().map(|&i| (i, Job::Mv(i))))
        .collect();
    jobs.sort_by_key(|j| j.0);
    let eyes = &region.eyes;
    let cell = region.id;
    let params_fp = format::fingerprint::params_fingerprint(params, cells);
    type Built = (BakedProxy, Vec<BakedProxy>, StageTimes);
    let built: Vec<Result<Built, BakeError>> = jobs
        .par_iter()
        .map(|(_, job)| {
            let wrap = |source| BakeError::Proxy { cell, source };
            // The proxy's key; an earlier bake's proxy with the same key is reused.
            let key = match job {
                Job::Sv(group) => {
                    let kind = if group.len() > 1 {
                        ProxyKind::Cluster
                    } else {
                        ProxyKind::SvMesh
                    };
                    proxy_key(scene, &params_fp, kind, group, &prism, &[centre])
                }
                Job::Mv(i) => proxy_key(scene, &params_fp, ProxyKind::MvMesh, &[*i], &prism, eyes),
            };
            if let Some(packed) = reuse.get(&key) {
                return Ok((
                    BakedProxy::reused(packed, key),
                    Vec::new(),
                    StageTimes::default(),
                ));
            }
            let (proxy, mut times) =
                derive_job(scene, chains, job, eyes, &prism, &settings, key).map_err(wrap)?;
            // Coarser mesh candidates for the objective selection (issue 16, paper
            // 004: the polygonal representation at more than one resolution): the
            // same derivation with the deviation bound multiplied.
            let mut coarser = Vec::new();
            if params.quality.is_some() {
                for factor in select::COARSER_BOUND_FACTORS {
                    let Some(bound) = settings.deviation else {
                        break;
                    };
                    let looser = ProxySettings {
                        deviation: Some(crate::simplify::DeviationBound {
                            max_px: bound.max_px * factor,
                            ..bound
                        }),
                        ..settings.clone()
                    };
                    let (c, t) =
                        derive_job(scene, chains, job, eyes, &prism, &looser, key).map_err(wrap)?;
                    times.add(&t);
                    coarser.push(c);
                }
            }
            Ok((proxy, coarser, times))
        })
        .collect();
    let mut proxies = Vec::with_capacity(built.len());
    let mut coarser = Vec::with_capacity(built.len());
    let mut stage = StageTimes::default();
    for result in built {
        let (proxy, c, t) = result?;
        stage.add(&t);
        proxies.push(proxy);
        coarser.push(c);
    }
    // Step 6 (issue 16): objective selection (paper 004, `select.rs`), or the
    // quality check of every bake.
    let t = Instant::now();
    if let Some(floor) = &params.quality {
        proxies = select_region(scene, region, proxies, coarser, params, floor)?;
    } else if params.quality_check {
        let eyes = select::check_viewpoints(&region.prism, centre);
        proxies.par_iter_mut().for_each(|proxy| {
            if proxy.packed.is_none() && proxy.impostor.is_none() {
                proxy.quality = check_mesh(scene, proxy, &eyes, centre, params.image_res);
            }
        });
    }
    times.select_ms += ms_since(t);
    Ok((proxies, stage))
}

/// The quality check of a mesh proxy (`select.rs`, "The check of every bake"): its
/// measurement against its originals from `eyes`, `None` when no view could frame
/// it.
fn check_mesh(
    scene: &Scene,
    proxy: &BakedProxy,
    eyes: &[Vec3],
    centre: Vec3,
    image_res: u32,
) -> Option<Measured> {
    let originals: Vec<DrawItem> = proxy
        .members
        .iter()
        .map(|m| DrawItem::instance(scene, m.instance))
        .collect();
    let mesh = MeshDraw::of(scene, proxy, centre);
    let items = mesh.items(&originals);
    let m = select::measure(
        &originals,
        &Candidate::Mesh {
            items: &items,
            textures: &mesh.textures,
        },
        eyes,
        centre,
        image_res,
        &QualityFloor::default(),
    );
    (m.views > 0).then_some(m)
}

/// Step 5 for one job: its SVMesh / cluster or MVMesh proxy under `settings`.
fn derive_job(
    scene: &Scene,
    chains: &LodChains,
    job: &Job,
    eyes: &[Vec3],
    prism: &Prism,
    settings: &ProxySettings,
    key: ProxyKey,
) -> Result<(BakedProxy, StageTimes), crate::svmesh::ProxyError> {
    match job {
        Job::Sv(group) => {
            let sv = derive_svmesh(scene, chains, group, eyes[0], settings)?;
            let kind = if group.len() > 1 {
                ProxyKind::Cluster
            } else {
                ProxyKind::SvMesh
            };
            let members = sv
                .members
                .into_iter()
                .map(|m| BakedMember {
                    instance: m.instance,
                    input_triangles: m.input_triangles,
                    triangles: cache_order(m.simplified.triangles, Vec::new()).0,
                    view_masks: Vec::new(),
                    vertex_view_sets: Vec::new(),
                })
                .collect();
            Ok((
                BakedProxy {
                    kind,
                    members,
                    views: vec![sv.view],
                    key,
                    packed: None,
                    impostor: None,
                    quality: None,
                },
                sv.times,
            ))
        }
        Job::Mv(i) => {
            let mv = derive_mvmesh(scene, chains, *i, eyes, prism, settings)?;
            let (triangles, view_masks) = cache_order(
                mv.member.simplified.triangles,
                mv.member.simplified.view_masks,
            );
            Ok((
                BakedProxy {
                    kind: ProxyKind::MvMesh,
                    members: vec![BakedMember {
                        instance: *i,
                        input_triangles: mv.member.input_triangles,
                        triangles,
                        view_masks,
                        vertex_view_sets: mv.vertex_view_sets,
                    }],
                    views: mv.views,
                    key,
                    packed: None,
                    impostor: None,
                    quality: None,
                },
                mv.times,
            ))
        }
    }
}

/// Step 6 (issue 16, [`crate::select`]): per derived proxy, the cheapest of Culled
/// (below a pixel from the whole region), a layered impostor at half or full
/// capture resolution, the coarser mesh proxies (`coarser`, one list per proxy:
/// the same derivation under a looser deviation bound) and the mesh proxy itself
/// that meets `floor` from the region's sample viewpoints. Culled proxies are
/// dropped (their members stay [`Assignment::Culled`]); reused proxies are kept as
/// they are. Parallel over proxies, collected in order.
fn select_region(
    scene: &Scene,
    region: &Region,
    proxies: Vec<BakedProxy>,
    coarser: Vec<Vec<BakedProxy>>,
    params: &BakeParams,
    floor: &QualityFloor,
) -> Result<Vec<BakedProxy>, BakeError> {
    let prism = region.prism;
    let centre = region.eyes[0];
    let eyes = sample_viewpoints(&prism);
    let check_eyes = select::check_viewpoints(&prism, centre);
    let max_offset = crate::impostor::max_offset(&prism, centre);
    let chosen: Vec<Result<Option<BakedProxy>, BakeError>> = proxies
        .into_par_iter()
        .zip(coarser)
        .map(|(proxy, mut coarser)| {
            if proxy.packed.is_some() {
                return Ok(Some(proxy));
            }
            let members: Vec<u32> = proxy.members.iter().map(|m| m.instance).collect();
            let originals: Vec<DrawItem> = members
                .iter()
                .map(|&i| DrawItem::instance(scene, i))
                .collect();
            // Culled: less than a pixel from the whole region.
            let Some((lo, hi)) = crate::capture::items_aabb(&originals) else {
                return Ok(Some(proxy));
            };
            if subpixel_from_region(lo, hi, &prism, params.image_res) {
                return Ok(None);
            }
            // The paper's mesh proxy as the measuring code draws it: its figures set
            // the thresholds of the cheaper candidates (select.rs, "Acceptance").
            let mesh = MeshDraw::of(scene, &proxy, centre);
            let mesh_items = mesh.items(&originals);
            let mesh_cost = mesh.cost(&proxy);
            // Candidates cheaper than the mesh proxy, cheapest first (ties: the
            // order built, coarser meshes after impostors).
            enum Cheaper {
                Impostor(LayeredImpostor),
                Coarser(usize),
            }
            let mut candidates: Vec<(u64, Cheaper)> = Vec::new();
            for res in [params.image_res / 2, params.image_res] {
                let built = build_layered_impostor(
                    centre,
                    &originals,
                    res.max(1),
                    params.image_res,
                    max_offset,
                )
                .map_err(|e| BakeError::Texture {
                    cell: region.id,
                    instance: members[0],
                    what: format!("layered impostor: {e}"),
                })?;
                if let Some(imp) = built {
                    let c = select::cost(imp.triangle_count(), imp.texels(), 1);
                    if c < mesh_cost {
                        candidates.push((c, Cheaper::Impostor(imp)));
                    }
                }
            }
            let coarse: Vec<MeshDraw> = coarser
                .iter()
                .map(|c| MeshDraw::of(scene, c, centre))
                .collect();
            let coarse_items: Vec<Vec<DrawItem>> =
                coarse.iter().map(|m| m.items(&originals)).collect();
            for (k, (c, draw)) in coarser.iter().zip(&coarse).enumerate() {
                let cost = draw.cost(c);
                if cost < mesh_cost {
                    candidates.push((cost, Cheaper::Coarser(k)));
                }
            }
            candidates.sort_by_key(|c| c.0);
            let drawn: Vec<Candidate> = candidates
                .iter()
                .map(|(_, c)| match c {
                    Cheaper::Impostor(imp) => Candidate::Impostor(imp),
                    Cheaper::Coarser(k) => Candidate::Mesh {
                        items: &coarse_items[*k],
                        textures: &coarse[*k].textures,
                    },
                })
                .collect();
            let (mesh_quality, winner) = select::select_among(
                &originals,
                &Candidate::Mesh {
                    items: &mesh_items,
                    textures: &mesh.textures,
                },
                &drawn,
                &eyes,
                centre,
                params.image_res,
                floor,
            );
            drop(drawn);
            match winner.map(|(i, m)| (candidates.swap_remove(i).1, m)) {
                Some((Cheaper::Impostor(imp), m)) => Ok(Some(BakedProxy::impostor(
                    &members,
                    imp,
                    proxy.key,
                    Some(m),
                ))),
                Some((Cheaper::Coarser(k), m)) => {
                    let mut chosen = coarser.swap_remove(k);
                    chosen.quality = Some(m);
                    Ok(Some(chosen))
                }
                None => {
                    let mut proxy = proxy;
                    proxy.quality = if mesh_quality.views > 0 {
                        Some(mesh_quality)
                    } else if !params.quality_check {
                        None
                    } else {
                        // No cheaper candidate: measured as in every bake.
                        check_mesh(scene, &proxy, &check_eyes, centre, params.image_res)
                    };
                    Ok(Some(proxy))
                }
            }
        })
        .collect();
    let mut out = Vec::new();
    for c in chosen {
        out.extend(c?);
    }
    Ok(out)
}

/// A derived mesh proxy as the selection draws it (select.rs): its members' meshes
/// (the models with the simplified triangles, untextured) and its projective
/// textures from the viewer's side.
struct MeshDraw {
    meshes: Vec<format::Mesh>,
    textures: crate::raster::ProjectiveTextures,
}

impl MeshDraw {
    fn of(scene: &Scene, proxy: &BakedProxy, centre: Vec3) -> MeshDraw {
        let meshes = proxy
            .members
            .iter()
            .map(|m| {
                let inst = &scene.instances[m.instance as usize];
                let model = &scene.models[inst.model as usize].mesh;
                format::Mesh {
                    positions: model.positions.clone(),
                    normals: model.normals.clone(),
                    albedo: model.albedo.clone(),
                    triangles: m.triangles.clone(),
                }
            })
            .collect();
        let textures = crate::raster::ProjectiveTextures {
            viewer: centre,
            by_object: proxy
                .members
                .iter()
                .map(|m| {
                    Some(crate::raster::ProjectiveSurface {
                        views: proxy.views.clone(),
                        triangle_masks: (!m.view_masks.is_empty()).then(|| m.view_masks.clone()),
                    })
                })
                .collect(),
        };
        MeshDraw { meshes, textures }
    }

    /// Draw items over `originals` (object ids index the textures).
    fn items<'a>(&'a self, originals: &[DrawItem<'a>]) -> Vec<DrawItem<'a>> {
        self.meshes
            .iter()
            .zip(originals)
            .enumerate()
            .map(|(k, (mesh, o))| DrawItem {
                mesh,
                object_id: k as u32,
                albedo_map: None,
                ..*o
            })
            .collect()
    }

    /// [`select::cost`] of `proxy` (the one this was made of).
    fn cost(&self, proxy: &BakedProxy) -> u64 {
        let texels: u64 = proxy.views.iter().map(|v| v.rgba.len() as u64 / 4).sum();
        select::cost(proxy.triangle_count(), texels, 1)
    }
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
                            pack_texture(v).map_err(|what| BakeError::Texture {
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
