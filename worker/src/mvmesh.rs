//! MVMesh derivation (paper 000 §3.1.4; 003 §4.1.4) for objects that fail the
//! self-occluding-error test (§3.1.2).
//!
//! Steps:
//!
//! 1. The polygons *not* regionally back-facing for the cell's prism (§3.1.5,
//!    [`crate::backface::regional_backface_cull`]): "front-facing with respect to the cell", tidied
//!    like the SVMesh's selection ([`crate::svmesh::tidy_selection_sized`], the
//!    on-screen areas taken from the capture eyes).
//! 2. Capture the object alone from the cell centre (view 0) and from the centres of
//!    the up to 6 neighbouring cells (views 1..), all at mid eye height. A neighbour
//!    whose centre lies inside the object's box (the object stands in that cell)
//!    gives no capture: its view set bit stays clear everywhere.
//! 3. Per view: classes and vertex states as for the SVMesh (§3.1.3.1–2). The vertex's
//!    view set has bit i when the vertex is visible in view i (depth-buffer test).
//! 4. Weight = the maximum over the views (§3.1.4), with one reading written down: a
//!    vertex's back-facing weight (0.5, §3.1.3.2) counts only when it faces away from
//!    *every* view. From a neighbour's centre most of the object's far side is
//!    back-facing; taking its 0.5 there would pin every vertex the centre sees on the
//!    far side of some neighbour, which the paper's polygon counts (Fig. 6) rule out.
//!    The back-facing weight marks the rim of what a view sees; with several views
//!    the rim of the union is where no view sees the vertex from the front.
//! 5. Weighted edge collapse with l′ = the maximum projected length over the prism's
//!    12 corners and its point nearest the edge ([`ProjectedLength::MaxOverPrism`]:
//!    "with respect to the cell") and the view-set constraint of
//!    §3.1.4 (`simplify` with `view_sets`); each triangle's view mask is the AND of its
//!    vertices' sets.
//! 6. Keep only the views some triangle's mask names, renumbering the mask bits in
//!    view order (the centre stays first when it is used).

use crate::backface::regional_backface_cull_of;
use crate::capture::{fit_texture, fitted_scale, items_aabb, CaptureError};
use crate::grid::Prism;
use crate::lod_chain::LodChains;
use crate::raster::ProjectedTexture;
use crate::simplify::{
    pixels_per_radian, simplify_seeded, ProjectedLength, SimplifyInput, SimplifyParams, CELL_VIEWS,
};
use crate::svmesh::{
    draw_item, ms_since, projected_areas_px, tidy_selection_sized, world_vertices, MemberMesh,
    ProxyError, ProxySettings, StageTimes, StartMesh,
};
use crate::weights::{VertexState, BACK_FACING_WEIGHT};
use format::Scene;
use glam::Vec3;
use std::time::Instant;

/// An MVMesh: one object, its simplified triangles with per-triangle view masks (in
/// `member.simplified.view_masks`, bits renumbered to `views`), and the captures used.
#[derive(Clone, Debug, PartialEq)]
pub struct MvMesh {
    pub member: MemberMesh,
    /// The captures some triangle uses, in the order of the eyes given.
    pub views: Vec<ProjectedTexture>,
    /// For each kept view, its index in the eyes given to [`derive_mvmesh`].
    pub view_sources: Vec<u32>,
    /// Per model vertex: the views (renumbered like the masks) it is visible in.
    pub vertex_view_sets: Vec<u8>,
    pub times: StageTimes,
}

/// Derives the MVMesh of `instance` for a cell whose view region is `prism`, with
/// captures from `eyes` (the cell centre first, then the neighbours' centres; at
/// most [`CELL_VIEWS`] are used).
pub fn derive_mvmesh(
    scene: &Scene,
    chains: &LodChains,
    instance: u32,
    eyes: &[Vec3],
    prism: &Prism,
    settings: &ProxySettings,
) -> Result<MvMesh, ProxyError> {
    let prism_corners = &prism.corners();
    let mut times = StageTimes::default();
    let item = draw_item(scene, instance)?;
    // The collapse starts from a level of the model's LOD chain (crate::lod_chain):
    // selection, states and weights are those of its vertices and triangles.
    let start = StartMesh::of(scene, chains, &item, settings);
    let mesh = start.mesh;
    let eyes = &eyes[..eyes.len().min(CELL_VIEWS as usize)];
    let aabb = items_aabb(std::slice::from_ref(&item));
    let (object_lo, object_hi) = aabb.unwrap_or_default();
    let (region_lo, region_hi) = prism_corners
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &c| {
            (lo.min(c), hi.max(c))
        });

    // Step 1: polygons not back-facing for the whole cell.
    let t = Instant::now();
    let mut kept: Vec<bool> =
        regional_backface_cull_of(mesh, start.triangles, item.transform, prism_corners)
            .into_iter()
            .map(|culled| !culled)
            .collect();
    // On welded vertices: a UV-seamed model's faces are not specks (issue 18).
    let welded = crate::simplify::welded_triangles(&mesh.positions, start.triangles);
    let areas = projected_areas_px(
        mesh,
        start.triangles,
        item.transform,
        eyes,
        settings.image_res,
    );
    tidy_selection_sized(&welded, &mut kept, settings.speck_triangles, Some(&areas));
    let (input_triangles, carried) = start.select(&kept);
    times.weights_ms += ms_since(t);

    // Steps 2–4: captures, per-view states, max weight and view sets.
    let n = mesh.positions.len();
    let mut weight = vec![f32::NEG_INFINITY; n];
    let mut back_everywhere = vec![true; n];
    let mut view_sets = vec![0u8; n];
    let mut textures = Vec::with_capacity(eyes.len());
    for (i, &eye) in eyes.iter().enumerate() {
        // The capture, classes and states from `eye`: from the run's memo when
        // another cell of the run captured this object from there
        // (crate::capture_memo), else computed and kept.
        let (captured, states) =
            match start.captured(scene, chains, &item, aabb, eye, settings, &mut times) {
                Ok(c) => c,
                // A neighbour's centre inside the object's box: no capture from there.
                Err(CaptureError::View { .. }) if i > 0 => {
                    textures.push(None);
                    continue;
                }
                Err(source) => {
                    return Err(ProxyError::Capture {
                        instances: vec![instance],
                        source,
                    })
                }
            };
        let t = Instant::now();
        for (v, state) in states.iter().enumerate() {
            match state {
                VertexState::BackFacing => {}
                VertexState::Visible(_) => {
                    back_everywhere[v] = false;
                    view_sets[v] |= 1 << i;
                    weight[v] = weight[v].max(state.weight());
                }
                VertexState::Invisible => {
                    back_everywhere[v] = false;
                    weight[v] = weight[v].max(state.weight());
                }
            }
        }
        // Texture resolution fitted to need (issue 15 item 3, `capture::fitted_scale`):
        // a neighbour's centre may stand closer to the object than any point of the
        // cell; texels finer than the cell's nearest viewer can see are dropped.
        let scale = fitted_scale(eye, object_lo, object_hi, region_lo, region_hi);
        textures.push(Some(fit_texture(captured.texture.clone(), scale)));
        times.weights_ms += ms_since(t);
    }
    for (w, &back) in weight.iter_mut().zip(&back_everywhere) {
        if back {
            *w = BACK_FACING_WEIGHT;
        }
    }

    // Step 5: weighted edge collapse with l′ and the view-set constraint.
    let t = Instant::now();
    let (positions, normals) = world_vertices(mesh, item.transform);
    let mut simplified = simplify_seeded(
        &SimplifyInput {
            positions: &positions,
            normals: &normals,
            triangles: &input_triangles,
            weights: &weight,
            view_sets: Some(&view_sets),
            locked: start.locked.as_deref(),
        },
        &SimplifyParams {
            edge_length_tolerance_px: settings.edge_length_tolerance_px,
            length: ProjectedLength::MaxOverPrism {
                prism: *prism,
                pixels_per_radian: pixels_per_radian(settings.image_res),
            },
            deviation: settings.deviation,
        },
        carried,
    )
    .map_err(|source| ProxyError::Simplify { instance, source })?;
    times.simplify_ms += ms_since(t);

    // Step 6: keep the views some triangle uses; renumber the mask bits.
    let used = simplified.view_masks.iter().fold(0u8, |a, &m| a | m);
    let mut remap = [0u8; 8];
    let mut views = Vec::new();
    let mut view_sources = Vec::new();
    for (i, texture) in textures.into_iter().enumerate() {
        if let (true, Some(texture)) = (used & (1 << i) != 0, texture) {
            remap[i] = 1 << views.len();
            views.push(texture);
            view_sources.push(i as u32);
        }
    }
    for m in &mut simplified.view_masks {
        *m = (0..8)
            .filter(|&i| *m & (1 << i) != 0)
            .fold(0, |a, i| a | remap[i]);
    }
    let vertex_view_sets = renumber_view_sets(&view_sets, &view_sources);
    Ok(MvMesh {
        vertex_view_sets,
        member: MemberMesh {
            instance,
            input_triangles,
            simplified,
        },
        views,
        view_sources,
        times,
    })
}

/// The per-vertex view sets renumbered like [`derive_mvmesh`]'s masks (for checking
/// masks against `simplify::validate_view_masks`): `sources` are the kept views'
/// original indices.
pub fn renumber_view_sets(view_sets: &[u8], sources: &[u32]) -> Vec<u8> {
    view_sets
        .iter()
        .map(|&s| {
            sources
                .iter()
                .enumerate()
                .filter(|(_, &src)| src < 8 && s & (1 << src) != 0)
                .fold(0u8, |a, (k, _)| a | (1 << k))
        })
        .collect()
}
