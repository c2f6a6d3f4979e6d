//! Run-time patch selection for the objects a cell draws as originals (issue 17):
//! per instance and frame, the union of the nearest spherical samples' patch
//! bitfields (paper 002 §3.3) and the per-patch normal-cone back-face test (003
//! §4.1; Zhang & Hoff's normal masks at patch granularity), both from
//! [`format::patch_visibility::select_patches`], turn into a few index ranges of the
//! model's patch-ordered index buffer. At load time each patch is further split
//! into spatial tiles of at most [`DrawOptions::tile_triangles`] ([`refine_patches`]; the index
//! buffer is uploaded in that order), and a tile is drawn only when its own normal
//! cone is not wholly back-facing and its object-space box meets the view frustum
//! carried into the instance's object space (000's run-time step (3), view-frustum
//! culling, at tile rather than object granularity). The cone and frustum tests are
//! conservative; only the bitfields are not (002 §4).
//!
//! Switches for measurements ([`DrawOptions`], passed in; `player` flags):
//! `patch_bitfields` (`--no-patch-bitfields`), `backface` (`--no-backface`, originals
//! and proxies), `frustum` (`--no-frustum`, the per-tile test; instances and proxies
//! are still culled whole) and `tile_triangles` (`--tile-triangles N`); with the
//! three tests off the originals are drawn whole.

use crate::camera::{Aabb, Frustum};
use crate::vertex::InstanceRaw;
use crate::DrawOptions;
use format::pack::BasePack;
use format::patch_visibility::{
    normal_cluster, patch_backfacing, select_patches, ModelPatchView, PatchBounds, PatchTests,
    SamplingSphere,
};
use glam::{Mat4, Vec3};

/// Which of the bake-data tests `options` leave on.
pub fn patch_tests(options: &DrawOptions) -> PatchTests {
    PatchTests {
        bitfields: options.patch_bitfields,
        backface: options.backface,
    }
}

/// One model's patch data in the form the per-frame test wants.
pub struct ModelRuntime {
    centre: Vec3,
    radius: f32,
    bounds: Vec<PatchBounds>,
    samples: Vec<u32>,
    /// The patches' spatial tiles in index-buffer order.
    tiles: Vec<Tile>,
}

/// A run of a patch's triangles in the model's refined index buffer
/// ([`refine_patches`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    pub patch: u32,
    /// First index and end in the index buffer.
    pub first: u32,
    pub end: u32,
    /// Normal cone and plane offset of the tile's triangles (object space).
    pub bounds: PatchBounds,
    /// Object-space box of the tile's corners.
    pub aabb: Aabb,
}

/// The patch data of a bake (from `base.pack`'s optional sections).
pub struct PatchRuntime {
    sphere: SamplingSphere,
    shells: Vec<f32>,
    words: usize,
    pub models: Vec<ModelRuntime>,
    /// Per instance: object → world and world → object transforms, and whether it
    /// mirrors (then the back-face test is skipped: the winding flips).
    placement: Vec<(Mat4, Mat4, bool)>,
    pub tests: PatchTests,
    /// Whether patches outside the view frustum are dropped.
    pub frustum_test: bool,
}

impl PatchRuntime {
    /// `None` when the base pack has no patch data or every test of `options` is
    /// off. `tiles`: per model, the tiles [`refine_patches`] made of its patches.
    pub fn new(
        base: &BasePack,
        tiles: Vec<Vec<Tile>>,
        options: &DrawOptions,
    ) -> Option<PatchRuntime> {
        let (tests, frustum_test) = (patch_tests(options), options.frustum);
        let set = base.patches.as_ref()?;
        if !tests.bitfields && !tests.backface && !frustum_test {
            return None;
        }
        let models = set
            .models
            .iter()
            .zip(tiles)
            .map(|(m, tiles)| ModelRuntime {
                centre: Vec3::from(m.centre),
                radius: m.radius,
                bounds: m.patches.iter().map(|p| p.bounds).collect(),
                samples: m
                    .patches
                    .iter()
                    .flat_map(|p| p.samples.iter().copied())
                    .collect(),
                tiles,
            })
            .collect();
        let placement = base
            .instances
            .iter()
            .map(|i| {
                let t = Mat4::from_cols_array(&i.transform);
                (t, t.inverse(), t.determinant() < 0.0)
            })
            .collect();
        Some(PatchRuntime {
            sphere: SamplingSphere::new(set.sample_level),
            shells: set.shell_radius.clone(),
            words: set.words_per_patch(),
            models,
            placement,
            tests,
            frustum_test,
        })
    }

    /// The index ranges of instance `instance` (of model `model`) to draw from `eye`
    /// (world) with view frustum `frustum` (world), merged where patches are
    /// adjacent; and the triangles they hold.
    pub fn ranges(
        &self,
        model: u32,
        instance: u32,
        eye: Vec3,
        frustum: &Frustum,
        keep: &mut Vec<bool>,
    ) -> Option<(Vec<(u32, u32)>, u64)> {
        let m = self.models.get(model as usize)?;
        let &(fwd, inv, mirrored) = self.placement.get(instance as usize)?;
        let eye_obj = inv.transform_point3(eye);
        let tests = PatchTests {
            backface: self.tests.backface && !mirrored,
            ..self.tests
        };
        let view = ModelPatchView {
            centre: m.centre,
            radius: m.radius,
            patches: &m.bounds,
            samples: &m.samples,
            words: self.words,
        };
        select_patches(&view, &self.sphere, &self.shells, eye_obj, tests, keep);
        let f = self.frustum_test.then(|| frustum.in_object_space(&fwd));
        let eps = 1e-4 * m.radius;
        let mut ranges: Vec<(u32, u32)> = Vec::new();
        let mut indices = 0u64;
        for t in &m.tiles {
            if !keep.get(t.patch as usize).copied().unwrap_or(true)
                || (tests.backface && patch_backfacing(&t.bounds, eye_obj, eps))
                || f.as_ref().is_some_and(|f| !f.intersects(&t.aabb))
            {
                continue;
            }
            let (a, b) = (t.first, t.end);
            if a == b {
                continue;
            }
            indices += (b - a) as u64;
            match ranges.last_mut() {
                Some(last) if last.1 == a => last.1 = b,
                _ => ranges.push((a, b)),
            }
        }
        Some((ranges, indices / 3))
    }
}

/// The model's triangle order for upload (patch by patch as the bake wrote them,
/// each patch's triangles reordered into spatial tiles by [`split_spatially`]) and
/// the tiles of at most `tile` triangles. `mesh` is the model the patches
/// partition; triangle or vertex indices out of range are skipped, so a bad pack
/// cannot panic here (the reader has checked them already). Computed once per bake
/// (`Bake::open`): the upload takes the order, [`PatchRuntime`] the tiles.
pub fn refine_patches(
    m: &format::pack::patches::ModelPatches,
    mesh: &format::Mesh,
    tile: usize,
) -> (Vec<u32>, Vec<Tile>) {
    let corners = |t: u32| -> Option<[Vec3; 3]> {
        let tri = mesh.triangles.get(t as usize)?;
        let mut c = [Vec3::ZERO; 3];
        for (k, &v) in tri.iter().enumerate() {
            c[k] = Vec3::from(*mesh.positions.get(v as usize)?);
        }
        Some(c)
    };
    let mut order = Vec::with_capacity(m.triangle_order.len());
    let mut tiles = Vec::new();
    let mut rest = &m.triangle_order[..];
    for (patch, p) in m.patches.iter().enumerate() {
        let (mine, tail) = rest.split_at((p.triangle_count as usize).min(rest.len()));
        rest = tail;
        let mut members: Vec<(usize, Vec3)> = mine
            .iter()
            .filter_map(|&t| corners(t).map(|c| (t as usize, (c[0] + c[1] + c[2]) / 3.0)))
            .collect();
        for run in spatial_runs(&mut members, tile) {
            let first = 3 * order.len() as u32;
            order.extend(run.iter().map(|&(t, _)| t as u32));
            let (bounds, aabb) = run_bounds(
                run.iter()
                    .map(|&(t, _)| corners(t as u32).unwrap_or([Vec3::ZERO; 3])),
            );
            tiles.push(Tile {
                patch: patch as u32,
                first,
                end: 3 * order.len() as u32,
                bounds,
                aabb,
            });
        }
    }
    (order, tiles)
}

/// One original drawn as the index ranges of its visible patches.
#[derive(Clone, Debug)]
pub struct PatchedDraw {
    pub model: u32,
    pub instance: InstanceRaw,
    /// Ranges of the model's patch-ordered index buffer.
    pub ranges: Vec<(u32, u32)>,
    pub triangles: u64,
}

/// Takes every original of `ids` whose model has patch data out of `originals`
/// (the draw list's instanced groups, rebuilt from `ids` without them) and returns
/// them as patched draws, with the ranges their visible patches make from `eye`
/// within `frustum`, grouped by model. Instances with nothing left to draw are
/// dropped.
pub fn apply(
    runtime: &PatchRuntime,
    base: &BasePack,
    ids: &[u32],
    (eye, frustum): (Vec3, &Frustum),
    instances: &[InstanceRaw],
    originals: &mut Vec<(u32, Vec<InstanceRaw>)>,
) -> Vec<PatchedDraw> {
    let mut patched = Vec::new();
    let mut keep = Vec::new();
    let mut moved: std::collections::BTreeSet<u32> = std::collections::BTreeSet::new();
    for &i in ids {
        let Some(inst) = base.instances.get(i as usize) else {
            continue;
        };
        let Some((ranges, triangles)) = runtime.ranges(inst.model, i, eye, frustum, &mut keep)
        else {
            continue;
        };
        moved.insert(i);
        if !ranges.is_empty() {
            patched.push(PatchedDraw {
                model: inst.model,
                instance: instances[i as usize],
                ranges,
                triangles,
            });
        }
    }
    if moved.is_empty() {
        return patched;
    }
    // Grouped by model like the full-geometry reference's instanced draws (instances
    // in id order within a model): the same draw order, the same depth ties.
    patched.sort_by_key(|p| p.model);
    // Rebuild the grouped originals without the moved instances.
    let mut by_model: std::collections::BTreeMap<u32, Vec<InstanceRaw>> = Default::default();
    for &i in ids {
        if moved.contains(&i) {
            continue;
        }
        if let Some(inst) = base.instances.get(i as usize) {
            by_model
                .entry(inst.model)
                .or_default()
                .push(instances[i as usize]);
        }
    }
    *originals = by_model.into_iter().collect();
    patched
}

/// A run of a proxy's (de-indexed, world-space) triangles in one normal cluster and
/// one spatial tile of it, with the bounds of
/// [`format::patch_visibility::patch_backfacing`] (issue 17 item 4 applied to proxies
/// too: 003 §4.1's normal clusters, formed at load time) and its box for the
/// per-cluster frustum test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProxyCluster {
    pub bounds: PatchBounds,
    /// World box of the run's vertices.
    pub aabb: Aabb,
    /// First vertex and vertex count in the proxy's vertex buffer.
    pub first: u32,
    pub count: u32,
}

/// Most triangles in one proxy cluster or original tile (default): a normal cluster
/// (or a bake patch) with more is split in halves at the median centroid along its
/// longest axis until every piece holds at most this many. Smaller pieces cull more
/// (tighter boxes and plane offsets); the draw calls do not grow with their number
/// (a proxy's or an original's kept tiles are gathered into one index buffer per
/// frame, `gpu::FrameIndices`), the CPU time of the tests does. Park-4m's walk
/// (BENCHMARKS.md, "Per-tile culling"): each halving from 256 down to 8 removes
/// about 2 % of the triangles; the tests and gathering take 0.19 ms per frame with
/// whole patches, 0.22 ms at 32, 0.24 ms at 16, 0.30 ms at 8 on the 2-core VM. 16 is
/// a judgement, said plainly: it is the largest size at which that walk meets issue
/// 16's triangle line (32 misses it by 0.07 %), for 0.05 ms of CPU per frame over
/// whole patches. [`DrawOptions::tile_triangles`] (`--tile-triangles N`) sets
/// another; its default is this.
pub const CLUSTER_TRIANGLES: usize = format::schema::frames::DEFAULT_TILE_TRIANGLES as usize;

/// Splits `tris` (triangle ids with their centroids) in place into runs of at most
/// `tile` (at least 1), median-splitting along the longest centroid axis
/// (ties by id, so the order is deterministic); returns the run lengths in order.
fn split_spatially(tris: &mut [(usize, Vec3)], tile: usize, out: &mut Vec<usize>) {
    if tris.len() <= tile.max(1) {
        out.push(tris.len());
        return;
    }
    let mut b = Aabb::EMPTY;
    for &(_, c) in tris.iter() {
        b.add(c);
    }
    let ext = b.max - b.min;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    tris.sort_unstable_by(|a, b| a.1[axis].total_cmp(&b.1[axis]).then(a.0.cmp(&b.0)));
    let (lo, hi) = tris.split_at_mut(tris.len() / 2);
    split_spatially(lo, tile, out);
    split_spatially(hi, tile, out);
}

/// `tris` reordered by [`split_spatially`] into runs of at most `tile` and cut into
/// them, in order.
fn spatial_runs(tris: &mut [(usize, Vec3)], tile: usize) -> Vec<&[(usize, Vec3)]> {
    let mut lengths = Vec::new();
    split_spatially(tris, tile, &mut lengths);
    let mut rest: &[(usize, Vec3)] = tris;
    lengths
        .into_iter()
        .map(|len| {
            let (run, tail) = rest.split_at(len);
            rest = tail;
            run
        })
        .collect()
}

/// Reorders a proxy's triangles by normal cluster and, within one, by spatial tile
/// of at most `tile` triangles ([`split_spatially`]), and returns the clusters with
/// their normal cones and boxes. Every mode draws the reordered buffer, so switching
/// the tests off changes nothing but the culling.
pub fn cluster_proxy_vertices(
    vertices: &[crate::vertex::ProxyVertex],
    tile: usize,
) -> (Vec<crate::vertex::ProxyVertex>, Vec<ProxyCluster>) {
    let tris = vertices.len() / 3;
    let normal = |t: usize| {
        let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(vertices[3 * t + k].pos).as_dvec3());
        (b - a).cross(c - a)
    };
    let centroid =
        |t: usize| (0..3).fold(Vec3::ZERO, |s, k| s + Vec3::from(vertices[3 * t + k].pos)) / 3.0;
    let mut order: Vec<(u8, usize)> = (0..tris).map(|t| (normal_cluster(normal(t)), t)).collect();
    order.sort_unstable();
    let mut out = Vec::with_capacity(vertices.len());
    let mut clusters = Vec::new();
    let mut k = 0;
    while k < order.len() {
        let mut j = k;
        while j < order.len() && order[j].0 == order[k].0 {
            j += 1;
        }
        let mut members: Vec<(usize, Vec3)> =
            order[k..j].iter().map(|&(_, t)| (t, centroid(t))).collect();
        for run in spatial_runs(&mut members, tile) {
            let first = out.len() as u32;
            for &(t, _) in run {
                out.extend_from_slice(&vertices[3 * t..3 * t + 3]);
            }
            let (bounds, aabb) = run_bounds(
                out[first as usize..]
                    .chunks_exact(3)
                    .map(|t| [0, 1, 2].map(|k| Vec3::from(t[k].pos))),
            );
            clusters.push(ProxyCluster {
                bounds,
                aabb,
                first,
                count: out.len() as u32 - first,
            });
        }
        k = j;
    }
    out.extend_from_slice(&vertices[3 * tris..]);
    (out, clusters)
}

/// Normal cone, box centre and plane offset of a run of triangles, as the bake
/// computes them for patches ([`PatchBounds::of_triangles`]), and the run's box.
pub(crate) fn run_bounds(triangles: impl Iterator<Item = [Vec3; 3]>) -> (PatchBounds, Aabb) {
    let mut aabb = Aabb::EMPTY;
    let corners: Vec<[glam::DVec3; 3]> = triangles
        .map(|t| {
            for q in t {
                aabb.add(q);
            }
            t.map(|q| q.as_dvec3())
        })
        .collect();
    (PatchBounds::of_triangles(corners.into_iter()), aabb)
}

/// The view the proxies' clusters are tested against: the eye (back faces) and the
/// frustum (world), and which of the two tests are on
/// ([`DrawOptions::backface`], [`DrawOptions::frustum`]).
#[derive(Clone, Copy, Debug)]
pub struct CullView {
    pub eye: Vec3,
    pub frustum: Frustum,
    pub backface_test: bool,
    pub frustum_test: bool,
}

impl CullView {
    /// Whether proxy cluster `c` passes the tests that are on: not wholly
    /// back-facing to the eye, its box not outside the frustum.
    pub fn keeps(&self, c: &ProxyCluster) -> bool {
        let eps = 1e-5 * (1.0 + Vec3::from(c.bounds.centre).length());
        let back = self.backface_test
            && format::patch_visibility::patch_backfacing(&c.bounds, self.eye, eps);
        let outside = self.frustum_test && !self.frustum.intersects(&c.aabb);
        !(back || outside)
    }

    /// The view from `eye` within `frustum` with the tests `options` leave on.
    pub fn new(eye: Vec3, frustum: Frustum, options: &DrawOptions) -> CullView {
        CullView {
            eye,
            frustum,
            backface_test: options.backface,
            frustum_test: options.frustum,
        }
    }
}

/// The vertex ranges of a proxy to draw from `view`: its clusters that are neither
/// wholly back-facing nor outside the frustum, adjacent ones merged; everything
/// without clusters or without a view.
pub fn proxy_ranges(
    clusters: &[ProxyCluster],
    vertex_count: u32,
    view: Option<&CullView>,
) -> Vec<(u32, u32)> {
    let Some(view) = view else {
        return vec![(0, vertex_count)];
    };
    if !(view.backface_test || view.frustum_test) || clusters.is_empty() {
        return vec![(0, vertex_count)];
    }
    let mut ranges: Vec<(u32, u32)> = Vec::new();
    for c in clusters.iter().filter(|c| view.keeps(c)) {
        push_range(&mut ranges, (c.first, c.first + c.count));
    }
    ranges
}

/// Appends [a, b) to sorted `ranges`, merged with the last one when adjacent.
pub fn push_range(ranges: &mut Vec<(u32, u32)>, (a, b): (u32, u32)) {
    match ranges.last_mut() {
        Some(last) if last.1 == a => last.1 = b,
        _ => ranges.push((a, b)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vertex::ProxyVertex;
    use bytemuck::Zeroable;
    use glam::Mat4;

    /// A frustum holding the box [-1000, 1000]³.
    fn everything() -> Frustum {
        Frustum::from_clip_gl(Mat4::from_scale(Vec3::splat(1e-3)))
    }

    /// A seeded generator of floats in [lo, hi).
    fn rng(seed: u64) -> impl FnMut(f32, f32) -> f32 {
        let mut s = seed;
        move |lo, hi| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((s >> 40) as f32 / (1u64 << 24) as f32)
        }
    }

    /// A bumpy n × n height field (2n² triangles) on [0, 10]², as a model mesh.
    fn terrain(n: u32) -> format::Mesh {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (10.0 * i as f32 / n as f32, 10.0 * j as f32 / n as f32);
                positions.push([x, y, (x * 1.3).sin() * (y * 0.7).cos()]);
            }
        }
        let v = |i: u32, j: u32| j * (n + 1) + i;
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        format::Mesh {
            normals: vec![[0.0, 0.0, 1.0]; positions.len()],
            albedo: vec![[200; 4]; positions.len()],
            positions,
            triangles,
        }
    }

    /// Patches of 700, 33 and the rest of `mesh`'s triangles in reversed order.
    fn uneven_patches(mesh: &format::Mesh) -> format::pack::patches::ModelPatches {
        let n = mesh.triangles.len() as u32;
        let patch = |count: u32| format::pack::patches::ModelPatch {
            triangle_count: count,
            bounds: PatchBounds {
                cone_axis: [0.0, 0.0, 1.0],
                cone_cos: -1.0,
                centre: [5.0, 5.0, 0.0],
                offset: 0.0,
            },
            samples: Vec::new(),
        };
        format::pack::patches::ModelPatches {
            centre: [5.0, 5.0, 0.0],
            radius: 8.0,
            patches: vec![patch(700), patch(33), patch(n - 733)],
            triangle_order: (0..n).rev().collect(),
        }
    }

    #[test]
    fn tiles_split_each_patch_into_small_runs_of_its_own_triangles() {
        let mesh = terrain(30);
        let m = uneven_patches(&mesh);
        let (order, tiles) = refine_patches(&m, &mesh, CLUSTER_TRIANGLES);
        // The order is a permutation that keeps every patch's triangles together.
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..mesh.triangles.len() as u32).collect::<Vec<_>>());
        let mut start = 0usize;
        for (p, patch) in m.patches.iter().enumerate() {
            let end = start + patch.triangle_count as usize;
            let mut a: Vec<u32> = order[start..end].to_vec();
            let mut b: Vec<u32> = m.triangle_order[start..end].to_vec();
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b, "patch {p}");
            // Its tiles cover exactly its index range, each within the size.
            let mine: Vec<&Tile> = tiles.iter().filter(|t| t.patch == p as u32).collect();
            assert_eq!(mine.first().unwrap().first, 3 * start as u32);
            assert_eq!(mine.last().unwrap().end, 3 * end as u32);
            for w in mine.windows(2) {
                assert_eq!(w[0].end, w[1].first);
            }
            for t in &mine {
                assert!(t.end > t.first && (t.end - t.first) as usize <= 3 * CLUSTER_TRIANGLES);
                for &tri in &order[t.first as usize / 3..t.end as usize / 3] {
                    for &v in &mesh.triangles[tri as usize] {
                        let q = Vec3::from(mesh.positions[v as usize]);
                        assert!(q.cmpge(t.aabb.min).all() && q.cmple(t.aabb.max).all());
                    }
                }
            }
            start = end;
        }
        // Deterministic: a bake's models upload in the same order on every run.
        assert_eq!(refine_patches(&m, &mesh, CLUSTER_TRIANGLES), (order, tiles));
    }

    #[test]
    fn object_space_frustum_keeps_every_tile_with_a_corner_in_view() {
        let mesh = terrain(24);
        let m = uneven_patches(&mesh);
        let (order, tiles) = refine_patches(&m, &mesh, CLUSTER_TRIANGLES);
        let mut r = rng(17);
        let (mut culled, mut total) = (0usize, 0usize);
        for _ in 0..200 {
            let place = Mat4::from_scale_rotation_translation(
                Vec3::new(r(0.5, 3.0), r(0.5, 3.0), r(0.5, 3.0)),
                glam::Quat::from_euler(
                    glam::EulerRot::XYZ,
                    r(-3.0, 3.0),
                    r(-3.0, 3.0),
                    r(-3.0, 3.0),
                ),
                Vec3::new(r(-20.0, 20.0), r(-20.0, 20.0), r(-5.0, 5.0)),
            );
            let cam = crate::camera::Camera {
                eye: Vec3::new(r(-30.0, 30.0), r(-30.0, 30.0), r(-10.0, 10.0)),
                dir: Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-0.5, 0.5)).normalize_or(Vec3::X),
                fov_y_deg: r(30.0, 90.0),
                width: 64,
                height: 48,
                near: 0.25,
                far: r(5.0, 100.0),
            };
            let world = cam.frustum();
            let object = world.in_object_space(&place);
            for t in &tiles {
                total += 1;
                if object.intersects(&t.aabb) {
                    continue;
                }
                culled += 1;
                for &tri in &order[t.first as usize / 3..t.end as usize / 3] {
                    for &v in &mesh.triangles[tri as usize] {
                        let q = place.transform_point3(Vec3::from(mesh.positions[v as usize]));
                        let inside = world.contains_point(q);
                        assert!(!inside, "tile {t:?} culled with corner {q:?} in view");
                    }
                }
            }
        }
        // The test culls something, and not everything.
        assert!(culled > total / 10 && culled < total, "{culled} of {total}");
    }

    /// A closed box of 12 triangles as proxy vertices.
    fn box_vertices() -> Vec<ProxyVertex> {
        let mesh = format::Mesh::cuboid([0.0, 0.0, 0.0], [2.0, 3.0, 4.0], [200; 4]);
        let mut out = Vec::new();
        for t in &mesh.triangles {
            for &v in t {
                out.push(ProxyVertex {
                    pos: mesh.positions[v as usize],
                    ..ProxyVertex::zeroed()
                });
            }
        }
        out
    }

    #[test]
    fn clustering_keeps_every_triangle_and_culls_only_back_faces() {
        let v = box_vertices();
        let (ordered, clusters) = cluster_proxy_vertices(&v, CLUSTER_TRIANGLES);
        assert_eq!(ordered.len(), v.len());
        let key = |t: &[ProxyVertex]| {
            t.iter()
                .map(|x| x.pos.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        let mut a: Vec<_> = v.chunks(3).map(key).collect();
        let mut b: Vec<_> = ordered.chunks(3).map(key).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
        assert_eq!(
            clusters.iter().map(|c| c.count).sum::<u32>() as usize,
            v.len()
        );
        let mut seed = 5u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f32 / (1u64 << 31) as f32) * 20.0 - 10.0
        };
        for _ in 0..500 {
            let eye = Vec3::new(rnd(), rnd(), rnd());
            let view = CullView::new(eye, everything(), &DrawOptions::default());
            let ranges = proxy_ranges(&clusters, ordered.len() as u32, Some(&view));
            let kept = |t: usize| {
                ranges
                    .iter()
                    .any(|&(a, b)| (a as usize..b as usize).contains(&(3 * t)))
            };
            for t in 0..ordered.len() / 3 {
                let [p, q, r] = [0, 1, 2].map(|k| Vec3::from(ordered[3 * t + k].pos));
                let n = (q - p).cross(r - p);
                if n.dot(eye - p) > 1e-4 * n.length() {
                    assert!(kept(t), "front-facing triangle {t} culled from {eye:?}");
                }
            }
            // A box seen from outside: at least one face is culled.
            let inside = eye.cmpge(Vec3::ZERO).all() && eye.cmple(Vec3::new(2.0, 3.0, 4.0)).all();
            if !inside {
                let drawn: u32 = ranges.iter().map(|(a, b)| b - a).sum();
                assert!(drawn < ordered.len() as u32, "{eye:?}");
            }
        }
    }
}
