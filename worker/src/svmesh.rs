//! SVMesh derivation (paper 000 §3.1.3; 003 §4.1.4), also for clusters (§3.1.6).
//!
//! Steps, for one object (or the members of a cluster, treated as one object):
//!
//! 1. The polygons front-facing to the cell's centre ([`crate::backface::front_facing_from`]), tidied
//!    ([`tidy_selection_sized`]): on a scanned mesh the front-facing set is ragged
//!    near the rim, with specks of a few front-facing triangles beyond it (each would
//!    survive the collapse as its own piece) and back-facing specks inside it (holes
//!    whose boundaries block collapses). Pieces of at most [`SPECK_TRIANGLES`]
//!    triangles are flipped; both are near edge-on and sub-pixel at proxy distances.
//!    A front-facing piece covering [`SPECK_AREA_PX`] or more on screen is kept
//!    whatever its triangle count (a large flat face of a coarse chain level).
//! 2. Capture the object(s) alone from the centre ([`crate::capture`]).
//! 3. Classify the capture's pixels (§3.1.3.1, [`classify_objects`], thresholds on
//!    the paper's window depth with the near plane at the side face,
//!    [`WindowDepth::paper`]) and weight the vertices (§3.1.3.2, [`vertex_states_captured`]).
//! 4. Cluster only: drop a member's triangle that no pixel of the cluster capture
//!    shows (triangle-ID buffer) and none of whose vertices is visible — surfaces
//!    "occluded by others in the cluster" (§3.1.6). The paper lets the low weights of
//!    invisible vertices (0.05) collapse them; a hidden triangle can still survive
//!    when it borders visible ones, and a single SV object keeps all its front-facing
//!    triangles (dropping sub-pixel ones there would only open boundaries that block
//!    collapses).
//! 5. Weighted edge collapse with l from the centre ([`ProjectedLength::FromPoint`]),
//!    per member (half-edge collapses never join different meshes).
//! 6. The texture is the centre capture (its covered rectangle) with its world →
//!    texture matrix.

use crate::backface::front_facing_of;
use crate::capture::{capture_objects, capture_objects_in, CaptureError};
use crate::capture_memo::{CaptureKey, CaptureSettings, Captured};
use crate::classify::{classify_objects, WindowDepth};
use crate::grid::Prism;
use crate::lod_chain::{LodChains, START_FRACTION, UNBOUNDED_START_PX};
use crate::raster::{DrawItem, ProjectedTexture, BACKGROUND_ID};
use crate::simplify::{
    locked_mask, pixels_per_radian, simplify_seeded, DeviationBound, ProjectedLength, Simplified,
    SimplifyError, SimplifyInput, SimplifyParams,
};
use crate::visibility::DepthTolerance;
use crate::weights::{
    vertex_states_captured, vertex_states_if_front, with_front_facing, VertexState,
};
use format::manifest::BakeParams;
use format::Scene;
use glam::{Mat3, Mat4, Vec3};
use std::time::Instant;
use thiserror::Error;

/// Parameters shared by SVMesh and MVMesh derivation.
#[derive(Clone, Debug, PartialEq)]
pub struct ProxySettings {
    /// Pixels per 60° of the captures (DESIGN.md).
    pub image_res: u32,
    /// T_l (pixels).
    pub edge_length_tolerance_px: f32,
    pub t_c0: f32,
    pub t_c1: f32,
    /// Cell size c (the window-depth range of the class thresholds).
    pub cell_size: f32,
    pub depth_tolerance: DepthTolerance,
    /// Pieces of at most this many triangles are tidied away from the selection
    /// before simplifying ([`tidy_selection`]; 0 = off).
    pub speck_triangles: usize,
    /// The collapse's deviation bound (`None`: the paper's algorithm as written).
    pub deviation: Option<DeviationBound>,
    /// The region the proxy serves, for choosing the LOD chain level a collapse
    /// starts from ([`crate::lod_chain`]); `None`: always from the full mesh.
    pub lod_region: Option<Prism>,
}

impl ProxySettings {
    pub fn new(params: &BakeParams, cell_size: f32) -> ProxySettings {
        ProxySettings {
            image_res: params.image_res,
            edge_length_tolerance_px: params.edge_length_tolerance_px,
            t_c0: params.t_c0,
            t_c1: params.t_c1,
            cell_size,
            depth_tolerance: DepthTolerance::default(),
            speck_triangles: SPECK_TRIANGLES,
            deviation: None,
            lod_region: None,
        }
    }

    /// [`ProxySettings::new`] plus the bake's deviation bound over the cell's prism
    /// (`bake.max_deviation_px`, read by [`BakeParams::deviation_bound_px`]: exactly
    /// 0 = none; a negative or non-finite value, which only a hand-built
    /// `BakeParams` can hold, is passed on, and [`crate::simplify`] refuses it with
    /// [`SimplifyError::BadDeviation`]).
    pub fn for_cell(params: &BakeParams, cell_size: f32, prism: Prism) -> ProxySettings {
        ProxySettings {
            deviation: params.deviation_bound_px().map(|max_px| DeviationBound {
                max_px,
                region: prism,
            }),
            lod_region: Some(prism),
            ..ProxySettings::new(params, cell_size)
        }
    }
}

/// Why a proxy cannot be derived.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ProxyError {
    #[error("instance {instance}: model {model} does not exist")]
    NoModel { instance: u32, model: u32 },
    #[error("instance {instance} does not exist")]
    NoInstance { instance: u32 },
    #[error("capture of instances {instances:?}: {source}")]
    Capture {
        instances: Vec<u32>,
        #[source]
        source: CaptureError,
    },
    #[error("simplifying instance {instance}: {source}")]
    Simplify {
        instance: u32,
        #[source]
        source: SimplifyError,
    },
}

/// The mesh a member's collapse starts from: the coarsest level of its model's LOD
/// chain that the region allows ([`crate::lod_chain::LodChain::start_for`]), or the model itself.
pub(crate) struct StartMesh<'a> {
    /// The model's vertices (its whole mesh).
    pub mesh: &'a format::Mesh,
    /// The start's triangles over them: a chain level's, or the model's own.
    pub triangles: &'a [[u32; 3]],
    /// Per triangle of `mesh`, the original vertices it carries (chain levels only).
    pub carried: Option<&'a [Vec<u32>]>,
    /// The model's locked vertices as [`SimplifyInput::locked`] (a chunk's cut
    /// border, issue 29); `None` for other models.
    pub locked: Option<Vec<bool>>,
}

impl<'a> StartMesh<'a> {
    pub(crate) fn of(
        scene: &Scene,
        chains: &'a LodChains,
        item: &DrawItem<'a>,
        settings: &ProxySettings,
    ) -> StartMesh<'a> {
        let level = settings.lod_region.as_ref().and_then(|region| {
            let model = scene.instances.get(item.object_id as usize)?.model;
            let budget_px = settings
                .deviation
                .map_or(UNBOUNDED_START_PX, |d| d.max_px * START_FRACTION);
            chains.get(model)?.start_for(
                item.transform,
                scene.instance_bounds(item.object_id as usize),
                region,
                budget_px,
                pixels_per_radian(settings.image_res),
            )
        });
        let locked = scene
            .instances
            .get(item.object_id as usize)
            .and_then(|inst| scene.models.get(inst.model as usize))
            .and_then(|model| locked_mask(item.mesh.positions.len(), &model.locked_vertices));
        match level {
            Some(l) => StartMesh {
                mesh: item.mesh,
                triangles: &l.triangles,
                carried: Some(&l.carried),
                locked,
            },
            None => StartMesh {
                mesh: item.mesh,
                triangles: &item.mesh.triangles,
                carried: None,
                locked,
            },
        }
    }

    /// What a derivation reads from the capture of `item` alone from `eye`: its
    /// texture and covered pixels, from the run's memo ([`crate::capture_memo`]) or
    /// computed and kept there, and this start mesh's vertex states in it (equal to
    /// [`StartMesh::vertex_states`]). `aabb` is the item's box
    /// ([`crate::capture::items_aabb`]); the capture and class times are added to
    /// `times` when computed.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn captured(
        &self,
        scene: &Scene,
        chains: &LodChains,
        item: &DrawItem,
        aabb: Option<(Vec3, Vec3)>,
        eye: Vec3,
        settings: &ProxySettings,
        times: &mut StageTimes,
    ) -> Result<(std::sync::Arc<Captured>, Vec<VertexState>), CaptureError> {
        let compute = |times: &mut StageTimes| {
            let t = Instant::now();
            let capture =
                capture_objects_in(eye, std::slice::from_ref(item), aabb, settings.image_res);
            times.capture_ms += ms_since(t);
            let capture = capture?;
            let t = Instant::now();
            let classes = classify_objects(
                &capture.capture,
                &[item.object_id],
                settings.t_c0,
                settings.t_c1,
                WindowDepth::paper(settings.cell_size),
            );
            let if_front = vertex_states_if_front(
                item.mesh,
                item.transform,
                &capture.capture,
                &classes,
                item.object_id,
                settings.depth_tolerance,
            );
            times.weights_ms += ms_since(t);
            Ok(Captured {
                if_front,
                texture: capture.texture,
                covered_pixels: capture.covered_pixels,
            })
        };
        let model_hash = scene
            .instances
            .get(item.object_id as usize)
            .and_then(|inst| scene.models.get(inst.model as usize))
            .map(|m| m.content_hash);
        let key = model_hash.and_then(|hash| {
            CaptureKey::new(
                hash,
                item,
                eye,
                &CaptureSettings {
                    image_res: settings.image_res,
                    t_c0: settings.t_c0,
                    t_c1: settings.t_c1,
                    cell_size: settings.cell_size,
                    footprint_px: settings.depth_tolerance.footprint_px,
                    neighbourhood_px: settings.depth_tolerance.neighbourhood_px,
                },
            )
        });
        let captured = match key {
            Some(key) => chains.captures().get_or_compute(key, || compute(times))?,
            None => std::sync::Arc::new(compute(times)?),
        };
        let t = Instant::now();
        let states = with_front_facing(
            &captured.if_front,
            self.mesh,
            self.triangles,
            item.transform,
            eye,
        );
        times.weights_ms += ms_since(t);
        Ok((captured, states))
    }

    /// The selected triangles and their carried lists, in mesh order.
    /// The state of every vertex in `capture`, a capture of `item` (the full model
    /// drawn as `object_id`): [`vertex_states_captured`] of this start mesh against
    /// the captured mesh's triangles.
    pub(crate) fn vertex_states(
        &self,
        item: &DrawItem,
        capture: &crate::raster::Capture,
        classes: &[crate::classify::PixelClass],
        object_id: u32,
        tolerance: DepthTolerance,
    ) -> Vec<VertexState> {
        vertex_states_captured(
            self.mesh,
            self.triangles,
            &item.mesh.triangles,
            item.transform,
            capture,
            classes,
            object_id,
            tolerance,
        )
    }

    pub(crate) fn select(&self, selected: &[bool]) -> (Vec<[u32; 3]>, Option<Vec<Vec<u32>>>) {
        let picked = || (0..self.triangles.len()).filter(|&t| selected[t]);
        let triangles = picked().map(|t| self.triangles[t]).collect();
        let carried = self
            .carried
            .map(|c| picked().map(|t| c[t].clone()).collect());
        (triangles, carried)
    }
}

/// Time spent per stage, in milliseconds (never written to packs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    pub capture_ms: f64,
    pub weights_ms: f64,
    pub simplify_ms: f64,
}

impl StageTimes {
    pub fn add(&mut self, other: &StageTimes) {
        self.capture_ms += other.capture_ms;
        self.weights_ms += other.weights_ms;
        self.simplify_ms += other.simplify_ms;
    }
}

pub(crate) fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// One instance's simplified triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct MemberMesh {
    pub instance: u32,
    /// Triangles given to the simplifier (after culling / front-facing selection).
    pub input_triangles: Vec<[u32; 3]>,
    pub simplified: Simplified,
}

/// An SVMesh: one object or a cluster, one capture from the cell centre.
#[derive(Clone, Debug, PartialEq)]
pub struct SvMesh {
    pub members: Vec<MemberMesh>,
    pub view: ProjectedTexture,
    pub covered_pixels: usize,
    pub times: StageTimes,
}

/// World positions and unit normals of an instance's vertices.
/// Per triangle of `mesh` placed by `transform`, the largest area in pixels (at
/// `image_res` per 60°) it covers seen from one of `eyes`: its area vector's
/// component along the line of sight over the distance cubed (a solid angle),
/// times the pixels per steradian.
pub fn projected_areas_px(
    mesh: &format::Mesh,
    triangles: &[[u32; 3]],
    transform: Mat4,
    eyes: &[Vec3],
    image_res: u32,
) -> Vec<f32> {
    let ppr = pixels_per_radian(image_res);
    let p: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&v| transform.transform_point3(Vec3::from_array(v)))
        .collect();
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let area = 0.5 * (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            eyes.iter()
                .map(|&e| {
                    let v = e - centroid;
                    let d2 = v.length_squared().max(1e-12);
                    area.dot(v).abs() / (d2 * d2.sqrt()) * ppr * ppr
                })
                .fold(0.0, f32::max)
        })
        .collect()
}

pub(crate) fn world_vertices(mesh: &format::Mesh, transform: Mat4) -> (Vec<Vec3>, Vec<Vec3>) {
    let positions: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&p| transform.transform_point3(Vec3::from_array(p)))
        .collect();
    let linear = Mat3::from_mat4(transform);
    let normal_matrix = if linear.determinant().abs() > 1e-30 {
        linear.inverse().transpose()
    } else {
        linear
    };
    let normals = (0..positions.len())
        .map(|v| {
            let n = mesh
                .normals
                .get(v)
                .map_or(Vec3::ZERO, |&n| Vec3::from_array(n));
            let n = (normal_matrix * n).normalize_or_zero();
            if n.is_finite() && n != Vec3::ZERO {
                n
            } else {
                Vec3::Y
            }
        })
        .collect();
    (positions, normals)
}

pub(crate) fn draw_item(scene: &Scene, instance: u32) -> Result<DrawItem<'_>, ProxyError> {
    let inst = scene
        .instances
        .get(instance as usize)
        .ok_or(ProxyError::NoInstance { instance })?;
    if scene.models.get(inst.model as usize).is_none() {
        return Err(ProxyError::NoModel {
            instance,
            model: inst.model,
        });
    }
    Ok(DrawItem::instance(scene, instance))
}

/// The centre capture of an SVMesh: one object's, from the run's memo, or a
/// cluster's with the classes of its pixels.
enum Shot {
    /// The memo's capture and the start mesh's states in it.
    One(std::sync::Arc<Captured>, Vec<VertexState>),
    Cluster(
        Box<(
            crate::capture::ObjectCapture,
            Vec<crate::classify::PixelClass>,
        )>,
    ),
}

/// Derives the SVMesh of `instances` (one object, or a cluster) seen from the cell
/// centre `centre` (module docs). Members come out in the order given.
pub fn derive_svmesh(
    scene: &Scene,
    chains: &LodChains,
    instances: &[u32],
    centre: Vec3,
    settings: &ProxySettings,
) -> Result<SvMesh, ProxyError> {
    let mut times = StageTimes::default();
    let items = instances
        .iter()
        .map(|&i| draw_item(scene, i))
        .collect::<Result<Vec<_>, _>>()?;

    // Steps 2–3: the capture of the object(s) alone from the centre and the classes
    // of its pixels. One object: from the run's memo (crate::capture_memo), shared
    // with the MVMeshes of the neighbouring cells that capture it from this centre.
    let capture_error = |source| ProxyError::Capture {
        instances: instances.to_vec(),
        source,
    };
    let shot = match items.as_slice() {
        [item] => {
            let start = StartMesh::of(scene, chains, item, settings);
            let aabb = crate::capture::items_aabb(&items);
            let (captured, states) = start
                .captured(scene, chains, item, aabb, centre, settings, &mut times)
                .map_err(capture_error)?;
            Shot::One(captured, states)
        }
        _ => {
            let t = Instant::now();
            let capture =
                capture_objects(centre, &items, settings.image_res).map_err(capture_error)?;
            times.capture_ms += ms_since(t);
            let t = Instant::now();
            let classes = classify_objects(
                &capture.capture,
                instances,
                settings.t_c0,
                settings.t_c1,
                WindowDepth::paper(settings.cell_size),
            );
            times.weights_ms += ms_since(t);
            Shot::Cluster(Box::new((capture, classes)))
        }
    };

    let length = ProjectedLength::FromPoint {
        eye: centre,
        pixels_per_radian: pixels_per_radian(settings.image_res),
    };
    let mut members = Vec::with_capacity(items.len());
    for item in &items {
        let t = Instant::now();
        let start = StartMesh::of(scene, chains, item, settings);
        let mesh = start.mesh;
        let states = match &shot {
            Shot::One(_, states) => states.clone(),
            Shot::Cluster(shot) => start.vertex_states(
                item,
                &shot.0.capture,
                &shot.1,
                item.object_id,
                settings.depth_tolerance,
            ),
        };
        let weights: Vec<f32> = states.iter().map(|s| s.weight()).collect();
        // Step 1 (and 4 for clusters): the triangles to simplify.
        let mut front = front_facing_of(mesh, start.triangles, item.transform, centre);
        // On welded vertices: a UV-seamed model's faces are not specks (issue 18).
        let welded = crate::simplify::welded_triangles(&mesh.positions, start.triangles);
        let areas = projected_areas_px(
            mesh,
            start.triangles,
            item.transform,
            &[centre],
            settings.image_res,
        );
        tidy_selection_sized(&welded, &mut front, settings.speck_triangles, Some(&areas));
        let cluster_capture = match &shot {
            Shot::Cluster(shot) => Some(&shot.0),
            Shot::One(..) => None,
        };
        let seen = cluster_capture.map(|capture| {
            let seen = seen_triangles(&capture.capture, item);
            if start.carried.is_none() {
                return seen;
            }
            // A chain level: a level triangle counts as shown when one of its
            // vertices belongs to a shown original triangle.
            let mut shown = vec![false; mesh.positions.len()];
            for (tri, _) in item.mesh.triangles.iter().zip(&seen).filter(|(_, &s)| s) {
                for &v in tri {
                    shown[v as usize] = true;
                }
            }
            start
                .triangles
                .iter()
                .map(|tri| tri.iter().any(|&v| shown[v as usize]))
                .collect()
        });
        let selected: Vec<bool> = start
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                front[t]
                    && seen.as_ref().is_none_or(|seen| {
                        seen[t]
                            || tri.iter().any(|&v| {
                                matches!(states.get(v as usize), Some(VertexState::Visible(_)))
                            })
                    })
            })
            .collect();
        let (input_triangles, carried) = start.select(&selected);
        times.weights_ms += ms_since(t);

        // Step 5: weighted edge collapse.
        let t = Instant::now();
        let (positions, normals) = world_vertices(mesh, item.transform);
        let simplified = simplify_seeded(
            &SimplifyInput {
                positions: &positions,
                normals: &normals,
                triangles: &input_triangles,
                weights: &weights,
                view_sets: None,
                locked: start.locked.as_deref(),
            },
            &SimplifyParams {
                edge_length_tolerance_px: settings.edge_length_tolerance_px,
                length: length.clone(),
                deviation: settings.deviation,
            },
            carried,
        )
        .map_err(|source| ProxyError::Simplify {
            instance: item.object_id,
            source,
        })?;
        times.simplify_ms += ms_since(t);
        members.push(MemberMesh {
            instance: item.object_id,
            input_triangles,
            simplified,
        });
    }
    let (view, covered_pixels) = match shot {
        Shot::One(captured, _) => (captured.texture.clone(), captured.covered_pixels),
        Shot::Cluster(shot) => {
            let (capture, _) = *shot;
            (capture.texture, capture.covered_pixels)
        }
    };
    Ok(SvMesh {
        members,
        view,
        covered_pixels,
        times,
    })
}

/// Per triangle of `item`'s mesh: some pixel of `capture` shows it.
pub(crate) fn seen_triangles(capture: &crate::raster::Capture, item: &DrawItem) -> Vec<bool> {
    let mut seen = vec![false; item.mesh.triangles.len()];
    for (&id, &tri) in capture.object_id.iter().zip(&capture.triangle_id) {
        if id == item.object_id && tri != BACKGROUND_ID {
            if let Some(s) = seen.get_mut(tri as usize) {
                *s = true;
            }
        }
    }
    seen
}

/// Default most triangles of a "speck" piece of a triangle selection
/// ([`tidy_selection`]). Measured on the bunny at the paper's size (tests/bake.rs,
/// MV at 1–6 cells / SV at 7–9 cells, paper 1,605 … 306 / 259 … 239): without tidying
/// 3,632 / 1,591 / 1,310 / 1,217 / 1,214 / 1,110 and 830 / 791 / 806 (rim specks
/// each survive as their own piece); speck 1: 3,220 … 802 / 546 … 528; speck 4:
/// 2,905 / 816 / 587 / 492 / 476 / 443 and 137 / 128 / 127; speck 8: … 382 / 79 …;
/// speck 16: … 370 / 60 / 61 / 55. 4 is the only setting within a factor 2 of every
/// figure of the paper.
pub const SPECK_TRIANGLES: usize = 4;

/// Tidies a per-triangle selection (front-facing to the centre, or not regionally
/// back-facing) of a scanned mesh before simplification: connected pieces (through
/// shared edges) of *unselected* triangles with at most `max_triangles` triangles are
/// selected (back-facing specks inside the front-facing region: on noisy scans they
/// punch holes whose boundaries block edge collapses), then pieces of *selected*
/// triangles with at most `max_triangles` are unselected (front-facing specks beyond
/// the rim: each would survive as its own piece). Both kinds are sub-pixel, near
/// edge-on, at proxy distances. Returns how many triangles changed.
pub fn tidy_selection(
    triangles: &[[u32; 3]],
    selected: &mut [bool],
    max_triangles: usize,
) -> usize {
    tidy_selection_sized(triangles, selected, max_triangles, None)
}

/// The area in pixels (at `image_res` per 60°) from which a connected piece of a
/// selection is never a speck ([`tidy_selection_sized`]): 4 × 4 pixels.
pub const SPECK_AREA_PX: f32 = 16.0;

/// [`tidy_selection`] that spares a selected piece covering [`SPECK_AREA_PX`] or
/// more on screen (`areas_px`, per triangle, [`projected_areas_px`]): a speck is
/// small in triangles *and* on screen. A collapse that starts from a coarse level
/// of a model's LOD chain ([`crate::lod_chain`]) sees a large flat face as two
/// triangles; counted in triangles alone, a cell seeing two faces of a 40-unit
/// block took them for a speck and its proxy lost every triangle.
pub fn tidy_selection_sized(
    triangles: &[[u32; 3]],
    selected: &mut [bool],
    max_triangles: usize,
    areas_px: Option<&[f32]>,
) -> usize {
    let n = triangles.len().min(selected.len());
    // Edge adjacency by sorting (a, b, triangle).
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(n * 3);
    for (t, tri) in triangles[..n].iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), t as u32));
        }
    }
    edges.sort_unstable();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    let mut changed = 0;
    for pass in [false, true] {
        // Components of triangles whose selection equals `pass`.
        for (k, p) in parent.iter_mut().enumerate() {
            *p = k as u32;
        }
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
                j += 1;
            }
            for a in i..j {
                for b in a + 1..j {
                    let (ta, tb) = (edges[a].2, edges[b].2);
                    if selected[ta as usize] == pass && selected[tb as usize] == pass {
                        let (ra, rb) = (find(&mut parent, ta), find(&mut parent, tb));
                        if ra != rb {
                            parent[ra.max(rb) as usize] = ra.min(rb);
                        }
                    }
                }
            }
            i = j;
        }
        let mut size = vec![0usize; n];
        let mut area = vec![0f32; n];
        for t in 0..n as u32 {
            if selected[t as usize] == pass {
                let r = find(&mut parent, t);
                size[r as usize] += 1;
                area[r as usize] += areas_px
                    .and_then(|a| a.get(t as usize))
                    .copied()
                    .unwrap_or(0.0);
            }
        }
        for t in 0..n as u32 {
            if selected[t as usize] == pass {
                let r = find(&mut parent, t);
                // Unselected pieces (holes) are filled by count alone, as before.
                let small_on_screen = !pass || area[r as usize] < SPECK_AREA_PX;
                if size[r as usize] <= max_triangles && small_on_screen {
                    selected[t as usize] = !pass;
                    changed += 1;
                }
            }
        }
    }
    changed
}
