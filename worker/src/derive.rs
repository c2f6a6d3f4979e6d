//! Steps 4–5 of a region's bake (paper 000 §3.1.3–§3.1.6; [`crate::bake`]'s module
//! docs): the clustering of the SV candidates, then the derivation of every
//! SvMesh / Cluster / MvMesh of a cell's or a group's region, in parallel over
//! proxies and collected in order; with objective selection (`bake.quality`, paper
//! 004, issue 16) each object's candidates are measured and the cheapest one that
//! meets the floor is kept ([`crate::select`]).

use crate::cluster::{greedy_clusters, ClusterCandidate, ClusterSettings};
use crate::error::BakeError;
use crate::grid::Prism;
use crate::impostor::{build_layered_impostor, LayeredImpostor};
use crate::lod_chain::LodChains;
use crate::mesh_order::cache_order;
use crate::mvmesh::derive_mvmesh;
use crate::proxy::*;
use crate::raster::DrawItem;
use crate::select::{self, sample_viewpoints, subpixel_from_region, Candidate, Measured};
use crate::svmesh::{derive_svmesh, ms_since, ProxySettings, StageTimes};
use format::manifest::QualityFloor;
use format::manifest::{BakeParams, CellParams};
use format::pack::ProxyKind;
use format::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

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

enum Job {
    Sv(Vec<u32>),
    Mv(u32),
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
                    reused_texture_bytes: None,
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
                    reused_texture_bytes: None,
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
