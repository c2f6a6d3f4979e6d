//! Far-field groups of every level (issue 13, issue 27; [`crate::far_field`],
//! [`crate::levels`]): a group's bake — the same steps 4–5 as a cell's SV proxies
//! from the group centre over the group prism, or merged layered impostors from
//! `bake.merge_level` on — and everything the hybrid draws from a cell, its own
//! proxies with those of its whole chain of groups appended. Split from `bake.rs`
//! (issue 28: one file per role).

use crate::bake::{bake_cell_with, finish, Assignment, CellBake};
use crate::derive::{derive_region, selection_culled, CellTimes, Region};
use crate::error::BakeError;
use crate::far_field::{served_instances, CellGroups, FarField};
use crate::grid::{HexGrid, Prism};
use crate::lod_chain::LodChains;
use crate::proxy::{proxy_key, BakedProxy, ProxyReuse};
use crate::select::subpixel_from_region;
use crate::svmesh::{ms_since, StageTimes};
use format::manifest::{BakeParams, CellParams};
use format::pack::ProxyKind;
use format::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Bakes the far field of group `group` ([`crate::far_field`]): the group's far
/// objects, clustered (step 4, when `params.clustering`) and derived (step 5) as
/// single-view proxies from the group centre over the group prism. The result's
/// `cell` is the group id; it has no originals; every instance that is not far is
/// [`Assignment::Culled`] in its assignment (not drawn from this pack).
#[allow(clippy::too_many_arguments)]
pub fn bake_group(
    scene: &Scene,
    chains: &LodChains,
    reuse: &ProxyReuse,
    grid: &HexGrid,
    groups: &CellGroups,
    group: u32,
    cells: &CellParams,
    params: &BakeParams,
) -> Result<CellBake, BakeError> {
    let start = Instant::now();
    if group >= groups.len() {
        return Err(BakeError::NoGroup {
            group,
            groups: groups.len(),
        });
    }
    let mut times = CellTimes::default();
    let t = Instant::now();
    let prism = groups.prism(grid, group, cells);
    let far = served_instances(scene, grid, groups, group, cells, params);
    times.split_ms = ms_since(t);
    let served: Vec<u32> = (0..far.len() as u32).filter(|&i| far[i as usize]).collect();
    let (proxies, stage, culled) = if groups.level(group) >= params.merge_level {
        // From `bake.merge_level` on: merged layered impostors (`levels.rs`).
        let (proxies, dropped) = merged_level(
            scene, reuse, group, &prism, &served, cells, params, &mut times,
        )?;
        // The impostors' captures are the level's capture stage (`finish` takes
        // the capture time from the stage times).
        let stage = StageTimes {
            capture_ms: times.capture_ms,
            ..StageTimes::default()
        };
        (proxies, stage, dropped)
    } else {
        // Step 2b on the group's prism: far objects under a pixel from all of it.
        let (sv, small): (Vec<u32>, Vec<u32>) = served.iter().partition(|&&i| {
            let (lo, hi) = scene.instance_bounds(i as usize);
            params.quality.is_none() || !subpixel_from_region(lo, hi, &prism, params.image_res)
        });
        let region = Region {
            id: group,
            prism,
            eyes: vec![prism.centre3()],
            size: prism.cell_size,
        };
        let (proxies, stage) = derive_region(
            scene,
            chains,
            reuse,
            &region,
            &sv,
            &[],
            cells,
            params,
            &mut times,
        )?;
        let culled = small.len() as u32 + selection_culled(sv.len(), &proxies);
        (proxies, stage, culled)
    };
    let mut assignment = vec![Assignment::Culled; scene.instances.len()];
    for (k, p) in proxies.iter().enumerate() {
        for m in &p.members {
            assignment[m.instance as usize] = Assignment::Proxy(k as u32);
        }
    }
    let mut bake = finish(
        scene,
        group,
        assignment,
        Vec::new(),
        proxies,
        stage,
        times,
        start,
    );
    bake.far_group = groups.parent(group);
    bake.stats.far_objects = groups.cells(group).len() as u32;
    bake.stats.selection_culled = culled;
    Ok(bake)
}

/// The proxies of a group of level ≥ 2 ([`crate::levels`]): one merged layered
/// impostor per sector and depth band of the objects it serves, each reused by key
/// when an earlier bake has it; also the count of objects dropped as under a pixel.
#[allow(clippy::too_many_arguments)]
fn merged_level(
    scene: &Scene,
    reuse: &ProxyReuse,
    group: u32,
    prism: &Prism,
    served: &[u32],
    cells: &CellParams,
    params: &BakeParams,
    times: &mut CellTimes,
) -> Result<(Vec<BakedProxy>, u32), BakeError> {
    let t = Instant::now();
    let (bands, dropped) = crate::levels::bands(scene, prism, served, params.image_res);
    times.cluster_ms += ms_since(t);
    let t = Instant::now();
    let params_fp = format::fingerprint::params_fingerprint(params, cells);
    let centre = prism.centre3();
    let built: Vec<Result<Option<BakedProxy>, BakeError>> = bands
        .par_iter()
        .map(|band| {
            let kind = ProxyKind::LayeredImpostor;
            let key = proxy_key(scene, &params_fp, kind, &band.members, prism, &[centre]);
            if let Some(packed) = reuse.get(&key) {
                return Ok(Some(BakedProxy::reused(packed, key)));
            }
            crate::levels::merged_impostor(scene, prism, band, params.image_res, key).map_err(|e| {
                BakeError::Texture {
                    cell: group,
                    instance: band.members[0],
                    what: format!(
                        "merged layered impostor of {} objects: {e}",
                        band.members.len()
                    ),
                }
            })
        })
        .collect();
    let mut proxies = Vec::with_capacity(built.len());
    let mut empty = 0u32;
    for (band, b) in bands.iter().zip(built) {
        match b? {
            Some(p) => proxies.push(p),
            None => empty += band.members.len() as u32,
        }
    }
    times.capture_ms += ms_since(t);
    Ok((proxies, dropped.len() as u32 + empty))
}

/// Everything the hybrid draws from `cell` (for `worker check` and CPU renders):
/// the cell's bake ([`bake_cell_with`]) with, when `params.far_field` is on, the
/// far-field proxies of every group of its chain ([`bake_group`], level 1 first)
/// appended and its [`Assignment::Far`]
/// objects pointing at them. Stats are the cell's own plus the group proxies'
/// counts, polygons and texture bytes.
#[allow(clippy::too_many_arguments)]
pub fn bake_cell_hybrid(
    scene: &Scene,
    chains: &LodChains,
    grid: &HexGrid,
    groups: &CellGroups,
    cell: u32,
    cells: &CellParams,
    params: &BakeParams,
) -> Result<CellBake, BakeError> {
    let far = FarField::of_cell(scene, grid, groups, cell, cells, params);
    let none = ProxyReuse::new();
    let mut bake = bake_cell_with(
        scene,
        chains,
        &none,
        grid,
        cell,
        cells,
        params,
        far.as_ref(),
    )?;
    let Some(far) = far else {
        return Ok(bake);
    };
    // Every level of the cell's chain: level 1, then each parent.
    for g in groups.ancestors_and_self(far.group) {
        let group = bake_group(scene, chains, &none, grid, groups, g, cells, params)?;
        append_group(&mut bake, group);
    }
    // Far objects that no group drew (under a pixel from all of a group's prism).
    for a in bake.assignment.iter_mut() {
        if *a == Assignment::Far {
            *a = Assignment::Culled;
            bake.stats.culled += 1;
        }
    }
    Ok(bake)
}

/// Appends a group's proxies to a cell's bake: its [`Assignment::Far`] objects that
/// the group draws point at them, and the stats add up.
fn append_group(bake: &mut CellBake, group: CellBake) {
    let offset = bake.proxies.len() as u32;
    for (i, a) in group.assignment.iter().enumerate() {
        if let (Assignment::Proxy(k), Assignment::Far) = (*a, bake.assignment[i]) {
            bake.assignment[i] = Assignment::Proxy(offset + k)
        }
    }
    let (s, g) = (&mut bake.stats, &group.stats);
    s.sv_count += g.sv_count;
    s.sv_polygons += g.sv_polygons;
    s.cluster_count += g.cluster_count;
    s.cluster_members += g.cluster_members;
    s.cluster_polygons += g.cluster_polygons;
    s.proxied_original_polygons += g.proxied_original_polygons;
    s.impostor_count += g.impostor_count;
    s.impostor_members += g.impostor_members;
    s.impostor_polygons += g.impostor_polygons;
    s.texture_bytes += g.texture_bytes;
    s.views += g.views;
    for t in [
        (&mut s.times.capture_ms, g.times.capture_ms),
        (&mut s.times.weights_ms, g.times.weights_ms),
        (&mut s.times.simplify_ms, g.times.simplify_ms),
    ] {
        *t.0 += t.1;
    }
    bake.proxies.extend(group.proxies);
}
