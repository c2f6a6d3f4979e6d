//! What one frame draws in each configuration of the paper's evaluation (000 §4.1):
//! A = all original geometry (`full`), B = original geometry with view-frustum culling
//! per instance (`frustum`), C = the hybrid representation of the current cell with
//! view-frustum culling per instance and per proxy (`hybrid`, §3.2); and the
//! distance-LOD baseline (`lod`, issue 8: every instance frustum-culled and drawn at
//! the coarsest level of its model's meshoptimizer chain under a projected pixel
//! error, [`crate::lod`]); and Nanite-style cluster LOD (`cluster-lod`, issue 30:
//! every instance frustum-culled and drawn as the cut of its model's cluster DAG,
//! [`crate::clusterlod`]).

use crate::bake::Bake;
use crate::camera::{Aabb, Camera, Frustum};
use crate::gpu::{DrawList, GpuModels, GpuProxy};
/// The configurations (their home is `mode.rs`, plain data; re-exported here, where
/// each one's draw list is built).
pub use crate::mode::Mode;
use crate::occlusion::OcclusionMap;
use crate::stream::{CurrentCell, Far, PendingDraw, ResidentCell};
use crate::vertex::InstanceRaw;
use std::collections::BTreeMap;

fn group(bake: &Bake, ids: impl Iterator<Item = u32>) -> Vec<(u32, Vec<InstanceRaw>)> {
    let mut by_model: BTreeMap<u32, Vec<InstanceRaw>> = BTreeMap::new();
    for i in ids {
        if let Some(inst) = bake.base.instances.get(i as usize) {
            by_model
                .entry(inst.model)
                .or_default()
                .push(bake.instances[i as usize]);
        }
    }
    by_model.into_iter().collect()
}

fn visible<'a>(
    bake: &'a Bake,
    frustum: &'a Frustum,
    ids: impl Iterator<Item = u32> + 'a,
) -> impl Iterator<Item = u32> + 'a {
    ids.filter(move |&i| {
        bake.instance_bounds
            .get(i as usize)
            .is_some_and(|b| frustum.intersects(b))
    })
}

/// The draw list of configuration A or B, or of C's fallback (no usable pack).
/// With `cull` (B, C's fallback): instances frustum-culled whole, then the tiles of
/// their patches by the bake's exact per-tile tests ([`Bake::exact_patches`]).
pub fn originals_list<'a>(bake: &Bake, camera: &Camera, cull: bool) -> DrawList<'a> {
    let n = bake.base.instances.len() as u32;
    if !cull {
        return DrawList {
            originals: group(bake, 0..n),
            ..Default::default()
        };
    }
    let f = camera.frustum();
    let shown: Vec<u32> = visible(bake, &f, 0..n).collect();
    let mut list = DrawList {
        originals: group(bake, shown.iter().copied()),
        ..Default::default()
    };
    // Issue 30 item 2, fair culling: the per-tile normal-cone and frustum tests the
    // hybrid's originals get (exact: no pixel changes; not the patch bitfields).
    if let Some(runtime) = &bake.exact_patches {
        patch_originals(&mut list, runtime, bake, &shown, camera, &f);
    }
    list
}

/// Replaces `list`'s originals of the `shown` instances by their patches that pass
/// `runtime`'s tests from `camera` (bitfields and normal cones, or the exact tests
/// alone; `patches::apply`).
fn patch_originals(
    list: &mut DrawList<'_>,
    runtime: &crate::patches::PatchRuntime,
    bake: &Bake,
    shown: &[u32],
    camera: &Camera,
    f: &Frustum,
) {
    list.patched = crate::patches::apply(
        runtime,
        &bake.base,
        shown,
        (camera.eye, f),
        &bake.instances,
        &mut list.originals,
    );
}

/// The draw list of the LOD baseline.
pub fn lod_list<'a>(
    bake: &Bake,
    set: &crate::lod::LodSet,
    camera: &Camera,
    threshold_px: f32,
) -> DrawList<'a> {
    DrawList {
        levels: crate::lod::lod_groups(bake, set, camera, threshold_px),
        ..Default::default()
    }
}

/// The draw list of cluster LOD (issue 30): every instance frustum-culled and drawn
/// as its model's DAG cut at `tau_px`, each selected cluster tested with the
/// hybrid originals' per-tile cone and frustum tests (the bake's [`crate::DrawOptions`]).
pub fn cluster_list<'a>(
    bake: &Bake,
    set: &crate::clusterlod::ClusterSet,
    camera: &Camera,
    tau_px: f32,
) -> DrawList<'a> {
    let cull = crate::patches::CullView::new(camera.eye, camera.frustum(), &bake.options);
    DrawList {
        clusters: crate::clusterlod::cluster_draws(bake, set, camera, tau_px, Some(&cull)),
        ..Default::default()
    }
}

/// The hybrid draw list for the current cell (config C).
pub fn hybrid_list<'a>(
    bake: &Bake,
    camera: &Camera,
    current: &CurrentCell<'a>,
    pending: PendingDraw,
) -> DrawList<'a> {
    match current {
        CurrentCell::Originals => originals_list(bake, camera, true),
        CurrentCell::Pack(cell, far, stand_ins) => {
            cell_list(bake, camera, cell, far, stand_ins, pending)
        }
    }
}

/// The cell's inside objects as originals, its ready proxies and those of its
/// far-field group, and — while a proxy's textures are still in the upload queue —
/// a stand-in for it (a ready proxy of the packs drawn before the crossing that
/// shows only objects waiting so, [`stand_ins_for`]) or its member objects as
/// originals (never a hole; [`ResidentCell::fallback_instances`]) or, with
/// [`PendingDraw::Lit`], the proxy lit without textures. Without its group's pack
/// ([`Far::Unavailable`]) every object the cell has neither as original nor as
/// proxy is drawn as original.
fn cell_list<'a>(
    bake: &Bake,
    camera: &Camera,
    cell: &'a ResidentCell,
    far: &Far<'a>,
    stand_ins: &[&'a ResidentCell],
    pending: PendingDraw,
) -> DrawList<'a> {
    let f = camera.frustum();
    let packs: Vec<&'a ResidentCell> = match far {
        Far::Packs(groups) => std::iter::once(cell)
            .chain(groups.iter().copied())
            .collect(),
        Far::None | Far::Unavailable => vec![cell],
    };
    let mut ids: std::collections::BTreeSet<u32> = cell.originals.iter().copied().collect();
    let mut standing_in = Vec::new();
    if pending != PendingDraw::Lit {
        let mut waiting: std::collections::BTreeSet<u32> =
            packs.iter().flat_map(|p| p.fallback_instances()).collect();
        if pending == PendingDraw::StandIns && !matches!(far, Far::Unavailable) {
            standing_in = stand_ins_for(stand_ins, &mut waiting);
        }
        ids.extend(waiting);
    }
    if let Far::Unavailable = far {
        let proxied: std::collections::BTreeSet<u32> = cell
            .member_objects
            .iter()
            .flatten()
            .flatten()
            .copied()
            .collect();
        ids.extend((0..bake.base.instances.len() as u32).filter(|i| !proxied.contains(i)));
    }
    let shown: Vec<u32> = visible(bake, &f, ids.into_iter()).collect();
    let originals = group(bake, shown.iter().copied());
    let in_view = || {
        packs
            .iter()
            .flat_map(|p| p.proxies.iter().zip(&p.bounds))
            .filter(|(_, b)| f.intersects(b))
            .map(|(p, _)| p)
    };
    let ready: Vec<&GpuProxy> = in_view().filter(|p| p.is_ready()).collect();
    let mut proxy_only: Vec<Option<Vec<(u32, u32)>>> = vec![None; ready.len()];
    let mut proxies = ready;
    for (p, _, only) in standing_in.into_iter().filter(|(_, b, _)| f.intersects(b)) {
        proxies.push(p);
        proxy_only.push(only);
    }
    let lit_proxies = match pending {
        PendingDraw::StandIns | PendingDraw::Originals => Vec::new(),
        PendingDraw::Lit => in_view().filter(|p| !p.is_ready()).collect(),
    };
    let mut list = DrawList {
        originals,
        levels: Vec::new(),
        proxies,
        proxy_only,
        lit_proxies,
        patched: Vec::new(),
        cull: Some(crate::patches::CullView::new(camera.eye, f, &bake.options)),
        ..Default::default()
    };
    // Issue 17: the originals' visible patches only (bitfields and normal cones).
    if let Some(runtime) = &bake.patches {
        patch_originals(&mut list, runtime, bake, &shown, camera, &f);
    }
    // 000 §3.2 step (3): proxy tiles hidden behind what the originals draw.
    if bake.options.occlusion {
        list.occlusion = Some(occluders(bake, camera, &list));
    }
    list
}

/// The occlusion map of a draw list's originals (instanced groups and patched
/// draws, only the tiles the list keeps) from `camera`, nearest instances first so
/// that tiles keep the nearest bounds.
fn occluders(bake: &Bake, camera: &Camera, list: &DrawList<'_>) -> OcclusionMap {
    let mut map = OcclusionMap::new(camera);
    // (distance², model, object → world, kept index ranges of the tile order).
    type Occluder<'a> = (f32, u32, glam::Mat4, Option<&'a [(u32, u32)]>);
    let mut occluders: Vec<Occluder<'_>> = Vec::new();
    let place = |raw: &crate::vertex::InstanceRaw| {
        let m = glam::Mat4::from_cols_array_2d(&raw.model);
        (m.w_axis.truncate().distance_squared(camera.eye), m)
    };
    for (model, instances) in &list.originals {
        for raw in instances {
            let (d, m) = place(raw);
            occluders.push((d, *model, m, None));
        }
    }
    for p in &list.patched {
        let (d, m) = place(&p.instance);
        occluders.push((d, p.model, m, Some(&p.ranges)));
    }
    occluders.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (_, model, m, ranges) in occluders {
        let Some(mesh) = bake.base.models.get(model as usize).map(|x| &x.mesh) else {
            continue;
        };
        match ranges {
            None => map.add_mesh(&m, &mesh.positions, mesh.triangles.iter()),
            Some(ranges) => {
                // Index ranges of the model's tile-ordered index buffer.
                let order = bake.draw_order.as_ref().and_then(|o| o.get(model as usize));
                let Some(order) = order else { continue };
                let tris = ranges
                    .iter()
                    .flat_map(|&(s, e)| order.get(s as usize / 3..e as usize / 3))
                    .flatten()
                    .filter_map(|&t| mesh.triangles.get(t as usize));
                map.add_mesh(&m, &mesh.positions, tris);
            }
        }
    }
    map
}

/// A proxy standing in, its bounds and the vertex ranges of the members drawn
/// (`None`: all of it).
type StandIn<'a> = (&'a GpuProxy, &'a Aabb, Option<Vec<(u32, u32)>>);

/// The ready proxies of `stand_ins` (the packs drawn before the last crossing)
/// that show objects waiting in `waiting` (objects of proxies still waiting for
/// their textures), first come first served, with their bounds: a lone proxy whose
/// members all wait, and of a batch each member proxy whose objects all wait (the
/// vertex ranges of those members, `GpuProxy::member_spans`; `None` when every
/// member is). Their objects leave `waiting`. A member with an object that is
/// drawn otherwise now (inside the cell, or by a ready proxy) never stands in, so
/// no object is drawn twice.
fn stand_ins_for<'a>(
    stand_ins: &[&'a ResidentCell],
    waiting: &mut std::collections::BTreeSet<u32>,
) -> Vec<StandIn<'a>> {
    let mut chosen = Vec::new();
    for pack in stand_ins {
        for ((proxy, bounds), objects) in pack
            .proxies
            .iter()
            .zip(&pack.bounds)
            .zip(&pack.member_objects)
        {
            if !proxy.is_ready() {
                continue;
            }
            let mut spans = Vec::new();
            for (member, span) in objects.iter().zip(&proxy.member_spans) {
                if !member.is_empty() && member.iter().all(|m| waiting.contains(m)) {
                    for m in member {
                        waiting.remove(m);
                    }
                    spans.push(*span);
                }
            }
            if spans.is_empty() {
                continue;
            }
            let whole = spans.len() == proxy.member_spans.len();
            chosen.push((proxy, bounds, (!whole).then_some(spans)));
        }
    }
    chosen
}

/// What a draw list submits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ListStats {
    pub triangles: u64,
    /// Texture bytes of the proxies drawn.
    pub texture_bytes: u64,
    pub draw_calls: u64,
    /// Clusters drawn (`cluster-lod`; 0 in the other modes).
    pub clusters: u64,
}

impl std::ops::Add for ListStats {
    type Output = ListStats;
    /// What two lists drawn in one frame submit (a cross-fade's, issue 31).
    fn add(self, o: ListStats) -> ListStats {
        ListStats {
            triangles: self.triangles + o.triangles,
            texture_bytes: self.texture_bytes + o.texture_bytes,
            draw_calls: self.draw_calls + o.draw_calls,
            clusters: self.clusters + o.clusters,
        }
    }
}

/// Triangles, texture bytes and draw calls a draw list submits.
pub fn list_stats(list: &DrawList<'_>, models: &GpuModels) -> ListStats {
    ListStats {
        triangles: list.triangle_count(models),
        texture_bytes: list.proxies.iter().map(|p| p.texture_bytes).sum(),
        draw_calls: list.draw_calls(models),
        clusters: list.cluster_count(),
    }
}

/// What a hybrid frame draws for `cells`, each with its dither range (`None`: one
/// cell drawn whole): each cell's [`hybrid_list`], and for a cross-fade
/// ([`crate::transition`]) those lists as [`blend_lists`] rearranges them; for
/// `Renderer::render_blend`.
pub fn blend_frame<'a>(
    bake: &Bake,
    camera: &Camera,
    cells: Vec<(CurrentCell<'a>, Option<(u32, u32)>)>,
    pending: PendingDraw,
) -> Vec<(DrawList<'a>, Option<(u32, u32)>)> {
    let lists = cells
        .into_iter()
        .map(|(cell, range)| (hybrid_list(bake, camera, &cell, pending), range));
    match lists.len() {
        1 => lists.map(|(l, _)| (l, None)).collect(),
        _ => blend_lists(
            lists
                .map(|(l, r)| (l, r.unwrap_or((0, crate::transition::LEVELS))))
                .collect(),
        ),
    }
}

/// The lists of a cross-fade (issue 31 item 2, [`crate::transition`]): each cell's
/// hybrid list with its dither range, rearranged so that what every list draws
/// alike is drawn once and whole. Returns first that shared list (no range: the
/// plain pipelines, early depth test), then each list without it (its range).
///
/// Shared: an instanced original drawn by every list (same model and instance
/// data), a patched original drawn by every list (drawn with the union of their
/// patch ranges) and a proxy drawn by every list (the same GPU proxy, a far-field
/// group's pack both cells use; drawn with the union of their tile ranges). A tile
/// or patch one list leaves out is one its tests found back-facing, outside the
/// frustum or hidden behind nearer surfaces (run-time occlusion), or a patch its
/// cell's visibility bitfield drops: where those tests are conservative, drawing it
/// changes no pixel that list owns, so every pixel shows the nearest surface of its
/// owner's list, as [`crate::gpu::Renderer::render_blend`] promises (the bitfields
/// come from sampling, paper 002: a patch one cell's sampling missed is drawn if the
/// other cell's found it).
pub fn blend_lists<'a>(
    lists: Vec<(DrawList<'a>, (u32, u32))>,
) -> Vec<(DrawList<'a>, Option<(u32, u32)>)> {
    use std::collections::BTreeMap;
    if lists.len() < 2 {
        return lists.into_iter().map(|(l, r)| (l, Some(r))).collect();
    }
    let n = lists.len();
    let key = |i: &InstanceRaw| {
        let mut k = [0u8; std::mem::size_of::<InstanceRaw>()];
        k.copy_from_slice(bytemuck::bytes_of(i));
        k
    };
    // Instanced originals: (model, instance bytes) → lists drawing it.
    let mut seen: BTreeMap<DrawKey, usize> = BTreeMap::new();
    for (l, _) in &lists {
        for (m, v) in &l.originals {
            let mut unique: Vec<_> = v.iter().map(key).collect();
            unique.sort();
            unique.dedup();
            for k in unique {
                *seen.entry((*m, k)).or_default() += 1;
            }
        }
    }
    // Patched originals: (model, instance bytes) → (count, union of ranges).
    let mut patched: BTreeMap<DrawKey, (usize, Ranges)> = BTreeMap::new();
    for (l, _) in &lists {
        for p in &l.patched {
            let e = patched.entry((p.model, key(&p.instance))).or_default();
            e.0 += 1;
            e.1 = union_ranges(&e.1, &p.ranges);
        }
    }
    // Proxies (ready ones; lit ones stay in their list): pointer → (count, union).
    let ptr = |p: &GpuProxy| p as *const GpuProxy as usize;
    let mut proxies: BTreeMap<usize, (usize, Ranges)> = BTreeMap::new();
    for (l, _) in &lists {
        let ranges = l.proxy_ranges();
        for (k, &p) in l.proxies.iter().enumerate() {
            let e = proxies.entry(ptr(p)).or_default();
            e.0 += 1;
            e.1 = union_ranges(&e.1, &ranges[k]);
        }
    }
    let mut common = DrawList::default();
    let mut common_ranges: Vec<Ranges> = Vec::new();
    let mut shared_originals: BTreeMap<u32, Vec<InstanceRaw>> = BTreeMap::new();
    let mut out = Vec::with_capacity(n + 1);
    for (k, (l, range)) in lists.into_iter().enumerate() {
        let ranges = l.proxy_ranges().to_vec();
        let mut own = DrawList {
            cull: None,
            occlusion: None,
            ..Default::default()
        };
        for (m, v) in l.originals {
            let (both, alone): (Vec<InstanceRaw>, Vec<InstanceRaw>) = v
                .into_iter()
                .partition(|i| seen.get(&(m, key(i))) == Some(&n));
            if k == 0 && !both.is_empty() {
                shared_originals.entry(m).or_default().extend(both);
            }
            if !alone.is_empty() {
                own.originals.push((m, alone));
            }
        }
        for p in l.patched {
            let (count, union) = &patched[&(p.model, key(&p.instance))];
            if *count == n {
                if k == 0 {
                    let triangles = union.iter().map(|r| u64::from(r.1 - r.0) / 3).sum();
                    common.patched.push(crate::patches::PatchedDraw {
                        ranges: union.clone(),
                        triangles,
                        ..p
                    });
                }
            } else {
                own.patched.push(p);
            }
        }
        let mut own_ranges = Vec::new();
        for (i, &p) in l.proxies.iter().enumerate() {
            let (count, union) = &proxies[&ptr(p)];
            if *count == n {
                if k == 0 {
                    common.proxies.push(p);
                    common.proxy_only.push(None);
                    common_ranges.push(union.clone());
                }
            } else {
                own.proxies.push(p);
                own.proxy_only.push(None);
                own_ranges.push(ranges[i].clone());
            }
        }
        // Lit proxies keep their list's ranges (after the ready ones').
        own_ranges.extend(ranges[l.proxies.len()..].iter().cloned());
        own.lit_proxies = l.lit_proxies;
        let _ = own.ranges.set(own_ranges);
        out.push((own, Some(range)));
    }
    common.originals = shared_originals.into_iter().collect();
    let _ = common.ranges.set(common_ranges);
    out.insert(0, (common, None));
    out
}

/// Sorted, disjoint [start, end) ranges of an index or vertex buffer.
type Ranges = Vec<(u32, u32)>;
/// An original in a draw list: its model and its instance data's bytes.
type DrawKey = (u32, [u8; std::mem::size_of::<InstanceRaw>()]);

/// The union of two sorted, disjoint range lists, sorted, touching ranges merged.
fn union_ranges(a: &[(u32, u32)], b: &[(u32, u32)]) -> Vec<(u32, u32)> {
    let mut all: Vec<(u32, u32)> = a.iter().chain(b).copied().collect();
    all.sort_unstable();
    let mut out: Vec<(u32, u32)> = Vec::with_capacity(all.len());
    for (s, e) in all {
        match out.last_mut() {
            Some(last) if s <= last.1 => last.1 = last.1.max(e),
            _ => out.push((s, e)),
        }
    }
    out
}
