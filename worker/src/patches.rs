//! Patch visibility bitfields (paper 002, Meruvia Pastor: "Visibility Preprocessing
//! Using Spherical Sampling of Polygonal Patches") and per-patch normal cones for
//! run-time back-face culling (003 §4.1's normal clusters; Zhang & Hoff's normal
//! masks at patch granularity), computed once per model (DESIGN.md "Each model is
//! prepared once").
//!
//! 1. **Patch creation** (002 §3.1) within **normal clusters** (003 §4.1; Zhang &
//!    Hoff's normal masks partition normal space by the faces of a cube, each split
//!    into four): every triangle starts as a patch; the smallest patch by area is
//!    fused with the neighbour of its normal cluster that keeps the merged
//!    bounding-box diagonal smallest (the "extension"), until the target count is
//!    reached. Neighbours share an edge of the position-welded mesh; a patch without
//!    such neighbours (a separate piece) fuses with the patch of its cluster nearest
//!    in the same sense. Keeping a patch inside one cluster keeps its normal cone
//!    narrow (at most ≈ 55° from the cluster's centre), which is what lets the
//!    run-time back-face test drop whole patches; 002 alone tiles by position only.
//! 2. **Spherical sampling** (002 §3.2): ID renders of the model (back faces culled,
//!    as the player draws) from every direction of the subdivided octahedron
//!    ([`format::patch_visibility::SamplingSphere`]), looking at the centre of the
//!    bounding sphere, on each distance shell ([`PatchPreset::shell_radius`], in
//!    bounding radii; the outermost is nearly orthographic). A patch's bit for a
//!    sample is set when one of its triangles covers a pixel (002 §3.2.2).
//! 3. **Normal cones**: per patch the area-weighted mean geometric normal, the largest
//!    angle to it, the bounding-box centre and the plane offsets' maximum (the test in
//!    [`format::patch_visibility::patch_backfacing`]).
//!
//! The run-time choice (002 §3.3) and what is conservative are documented in
//! `format::patch_visibility`; [`measure_error`] is 002 §4's check: ID renders of the
//! full model and of the chosen patches from random viewpoints, pixels that differ.

use crate::raster::{render, CullMode, DrawItem, View, BACKGROUND_ID};
use format::pack::{ModelPatch, ModelPatches, PatchSet};
use format::patch_visibility::{
    select_patches, ModelPatchView, PatchBounds, PatchTests, SamplingSphere,
};
use format::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap};

/// Parameters of the patch bake (a named preset, STYLE.md: obvhs).
#[derive(Clone, Debug, PartialEq)]
pub struct PatchPreset {
    /// Target triangles per patch (002 §4: a few hundred patches per model).
    pub triangles_per_patch: u32,
    /// At most this many patches per model.
    pub max_patches: u32,
    /// Sphere subdivision level (002: 2 → 66 directions, 3 → 258).
    pub sample_level: u32,
    /// Shell radii in bounding radii, increasing.
    pub shell_radius: Vec<f32>,
    /// Side of the square ID renders in pixels.
    pub sample_res: u32,
}

impl PatchPreset {
    /// What the pipeline bakes: 66 directions × 3 shells, 256² ID renders, ~96
    /// triangles per patch, at most 256 patches.
    pub fn standard() -> PatchPreset {
        PatchPreset {
            triangles_per_patch: 96,
            max_patches: 256,
            sample_level: 2,
            shell_radius: vec![1.5, 3.0, 64.0],
            sample_res: 256,
        }
    }
}

/// The patch data of every model (in model order), models in parallel; the result
/// does not depend on the thread count.
pub fn bake_patch_set(meshes: &[&Mesh], preset: &PatchPreset) -> PatchSet {
    let sphere = SamplingSphere::new(preset.sample_level);
    let models = meshes
        .par_iter()
        .map(|m| model_patches(m, preset, &sphere))
        .collect();
    PatchSet {
        sample_level: sphere.level,
        shell_radius: preset.shell_radius.clone(),
        models,
    }
}

/// Bounding sphere of a mesh: the centre of its box and the farthest vertex.
pub fn bounding_sphere(mesh: &Mesh) -> (Vec3, f32) {
    if mesh.positions.is_empty() {
        return (Vec3::ZERO, 1.0);
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in &mesh.positions {
        lo = lo.min(Vec3::from(*p));
        hi = hi.max(Vec3::from(*p));
    }
    let c = (lo + hi) * 0.5;
    let r = mesh
        .positions
        .iter()
        .map(|p| Vec3::from(*p).distance(c))
        .fold(0.0f32, f32::max);
    (c, r.max(1e-6))
}

/// One model: tiling, cones, sampling.
pub fn model_patches(mesh: &Mesh, preset: &PatchPreset, sphere: &SamplingSphere) -> ModelPatches {
    let n = mesh.triangles.len();
    let (centre, radius) = bounding_sphere(mesh);
    let target = (n as u32)
        .div_ceil(preset.triangles_per_patch.max(1))
        .clamp(1, preset.max_patches.max(1)) as usize;
    let tiles = tile_patches(mesh, target);
    let mut patch_of = vec![0u32; n];
    for (p, tris) in tiles.iter().enumerate() {
        for &t in tris {
            patch_of[t as usize] = p as u32;
        }
    }
    let seen = sample_bits(mesh, &patch_of, tiles.len(), centre, radius, preset, sphere);
    let words = (sphere.directions.len() * preset.shell_radius.len()).div_ceil(32);
    let patches = tiles
        .iter()
        .enumerate()
        .map(|(p, tris)| ModelPatch {
            triangle_count: tris.len() as u32,
            bounds: normal_cone(mesh, tris),
            samples: seen[p * words..(p + 1) * words].to_vec(),
        })
        .collect();
    ModelPatches {
        centre: centre.to_array(),
        radius,
        patches,
        triangle_order: tiles.into_iter().flatten().collect(),
    }
}

#[derive(Clone)]
struct Tile {
    area: f64,
    lo: DVec3,
    hi: DVec3,
    members: Vec<u32>,
    neighbours: BTreeSet<u32>,
    version: u32,
    alive: bool,
}

fn merged_diagonal(a: &Tile, b: &Tile) -> f64 {
    (a.hi.max(b.hi) - a.lo.min(b.lo)).length()
}

fn corners(mesh: &Mesh, t: [u32; 3]) -> [DVec3; 3] {
    t.map(|i| {
        mesh.positions
            .get(i as usize)
            .map_or(DVec3::ZERO, |p| Vec3::from(*p).as_dvec3())
    })
}

pub use format::patch_visibility::normal_cluster;

/// 002 §3.1 patch creation inside normal clusters (module docs). Returns the
/// patches' triangle ids (each ascending), patches ordered by their first triangle.
/// There may be more than `target` patches when the model has more clusters.
pub fn tile_patches(mesh: &Mesh, target: usize) -> Vec<Vec<u32>> {
    let n = mesh.triangles.len();
    if n == 0 {
        return Vec::new();
    }
    let cluster: Vec<u8> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(mesh, *t);
            normal_cluster((b - a).cross(c - a))
        })
        .collect();
    // Weld positions (bit-equal) so that split vertices still connect.
    let mut order: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    let key = |i: u32| mesh.positions[i as usize].map(f32::to_bits);
    order.sort_by_key(|&i| (key(i), i));
    let mut weld = vec![0u32; mesh.positions.len()];
    for k in 0..order.len() {
        weld[order[k] as usize] = if k > 0 && key(order[k]) == key(order[k - 1]) {
            weld[order[k - 1] as usize]
        } else {
            order[k]
        };
    }
    // Edge adjacency.
    let mut edges: Vec<((u32, u32), u32)> = Vec::with_capacity(3 * n);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let w = tri.map(|v| weld.get(v as usize).copied().unwrap_or(v));
        for (a, b) in [(w[0], w[1]), (w[1], w[2]), (w[2], w[0])] {
            if a != b {
                edges.push(((a.min(b), a.max(b)), t as u32));
            }
        }
    }
    edges.sort_unstable();
    let mut tiles: Vec<Tile> = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let [a, b, c] = corners(mesh, *tri);
            Tile {
                area: 0.5 * (b - a).cross(c - a).length(),
                lo: a.min(b).min(c),
                hi: a.max(b).max(c),
                members: vec![t as u32],
                neighbours: BTreeSet::new(),
                version: 0,
                alive: true,
            }
        })
        .collect();
    let mut k = 0;
    while k < edges.len() {
        let mut j = k;
        while j < edges.len() && edges[j].0 == edges[k].0 {
            j += 1;
        }
        for x in k..j {
            for y in x + 1..j {
                let (a, b) = (edges[x].1, edges[y].1);
                if a != b && cluster[a as usize] == cluster[b as usize] {
                    tiles[a as usize].neighbours.insert(b);
                    tiles[b as usize].neighbours.insert(a);
                }
            }
        }
        k = j;
    }
    // Fuse the smallest patch (by area) with the neighbour of least merged extension.
    let mut heap: BinaryHeap<Reverse<(u64, u32, u32)>> = tiles
        .iter()
        .enumerate()
        .map(|(i, t)| Reverse((t.area.to_bits(), i as u32, 0)))
        .collect();
    let mut live = n;
    // Per normal cluster, its patches (ascending; compacted as patches die): a
    // separate piece searches only its own cluster's.
    let mut live_in: Vec<Vec<u32>> = Vec::new();
    for (t, &c) in cluster.iter().enumerate() {
        if live_in.len() <= c as usize {
            live_in.resize(c as usize + 1, Vec::new());
        }
        live_in[c as usize].push(t as u32);
    }
    let mut live_count: Vec<usize> = live_in.iter().map(Vec::len).collect();
    while live > target.max(1) {
        let Some(Reverse((_, p, version))) = heap.pop() else {
            break;
        };
        let pt = &tiles[p as usize];
        if !pt.alive || pt.version != version {
            continue;
        }
        let pick = |cands: &mut dyn Iterator<Item = u32>| -> Option<u32> {
            let mut best: Option<(f64, u32)> = None;
            for q in cands {
                let d = merged_diagonal(pt, &tiles[q as usize]);
                if best.is_none_or(|(bd, bq)| d < bd || (d == bd && q < bq)) {
                    best = Some((d, q));
                }
            }
            best.map(|(_, q)| q)
        };
        let q = if pt.neighbours.is_empty() {
            // A separate piece: the live patch of its cluster of least merged
            // extension.
            let ids = &live_in[cluster[pt.members[0] as usize] as usize];
            pick(
                &mut ids
                    .iter()
                    .copied()
                    .filter(|&q| q != p && tiles[q as usize].alive),
            )
        } else {
            pick(&mut pt.neighbours.iter().copied())
        };
        let Some(q) = q else {
            // Alone in its cluster: it stays a patch of its own.
            continue;
        };
        let taken = std::mem::replace(
            &mut tiles[p as usize],
            Tile {
                area: 0.0,
                lo: DVec3::ZERO,
                hi: DVec3::ZERO,
                members: Vec::new(),
                neighbours: BTreeSet::new(),
                version: 0,
                alive: false,
            },
        );
        for &x in &taken.neighbours {
            let nb = &mut tiles[x as usize].neighbours;
            nb.remove(&p);
            if x != q {
                nb.insert(q);
            }
        }
        let c = cluster[taken.members[0] as usize] as usize;
        live_count[c] -= 1;
        if live_in[c].len() > 2 * live_count[c] + 16 {
            live_in[c].retain(|&x| tiles[x as usize].alive);
        }
        let qt = &mut tiles[q as usize];
        qt.neighbours
            .extend(taken.neighbours.iter().copied().filter(|&x| x != q));
        qt.neighbours.remove(&p);
        qt.area += taken.area;
        qt.lo = qt.lo.min(taken.lo);
        qt.hi = qt.hi.max(taken.hi);
        qt.members.extend(taken.members);
        qt.version += 1;
        heap.push(Reverse((qt.area.to_bits(), q, qt.version)));
        live -= 1;
    }
    let mut out: Vec<Vec<u32>> = tiles
        .into_iter()
        .filter(|t| t.alive)
        .map(|mut t| {
            t.members.sort_unstable();
            t.members
        })
        .collect();
    out.sort_by_key(|m| m[0]);
    out
}

/// The normal cone, box centre and plane offset of a patch
/// ([`PatchBounds::of_triangles`]).
pub fn normal_cone(mesh: &Mesh, tris: &[u32]) -> PatchBounds {
    PatchBounds::of_triangles(
        tris.iter()
            .map(|&t| corners(mesh, mesh.triangles[t as usize])),
    )
}

/// The view of sample (direction, shell) around the bounding sphere.
fn sample_view(centre: Vec3, radius: f32, dir: Vec3, shell: f32, res: u32) -> View {
    let dist = radius * shell;
    let eye = centre + dir * dist;
    let half = (1.0 / shell).clamp(-1.0, 1.0).asin() * 1.02;
    let fov = (2.0 * half).to_degrees().min(170.0);
    let up = if dir.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
    let near = (dist - radius * 1.01).max(dist * 1e-3);
    let far = dist + radius * 1.01;
    View::look_at_fov(eye, centre, up, fov, res, res, near, far)
        .expect("sample views are valid by construction")
}

/// 002 §3.2.2: per patch, `words` u32 of bits over the samples.
fn sample_bits(
    mesh: &Mesh,
    patch_of: &[u32],
    patch_count: usize,
    centre: Vec3,
    radius: f32,
    preset: &PatchPreset,
    sphere: &SamplingSphere,
) -> Vec<u32> {
    let dirs = sphere.directions.len();
    let samples = dirs * preset.shell_radius.len();
    let words = samples.div_ceil(32);
    let mut bits = vec![0u32; patch_count * words];
    let item = DrawItem::whole(mesh, 0);
    for (shell_index, &shell) in preset.shell_radius.iter().enumerate() {
        for (d, dir) in sphere.directions.iter().enumerate() {
            let s = d + shell_index * dirs;
            let view = sample_view(centre, radius, *dir, shell, preset.sample_res);
            let cap = render(&view, &[item], CullMode::Back);
            let mut hit = vec![false; patch_count];
            for &t in &cap.triangle_id {
                if t != BACKGROUND_ID {
                    if let Some(&p) = patch_of.get(t as usize) {
                        hit[p as usize] = true;
                    }
                }
            }
            for (p, h) in hit.iter().enumerate() {
                if *h {
                    bits[p * words + s / 32] |= 1 << (s % 32);
                }
            }
        }
    }
    bits
}

/// 002 §4's image check for one model: from `views` random eyes at distances
/// `min_shell..max_shell` bounding radii (uniform directions), the number of pixels
/// where the ID render of the chosen patches differs from that of the full model,
/// the pixels the model covers, and the triangles drawn / of the full model.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchError {
    pub views: u32,
    pub differing_pixels: u64,
    pub covered_pixels: u64,
    /// Views with at least one differing pixel.
    pub views_with_error: u32,
    pub triangles_drawn: u64,
    pub triangles_full: u64,
}

/// See [`PatchError`]. `seed` fixes the viewpoints.
#[allow(clippy::too_many_arguments)]
pub fn measure_error(
    mesh: &Mesh,
    model: &ModelPatches,
    set: &PatchSet,
    tests: PatchTests,
    views: u32,
    res: u32,
    distance: (f32, f32),
    seed: u64,
) -> PatchError {
    let sphere = SamplingSphere::new(set.sample_level);
    let words = set.words_per_patch();
    let bounds: Vec<PatchBounds> = model.patches.iter().map(|p| p.bounds).collect();
    let samples: Vec<u32> = model
        .patches
        .iter()
        .flat_map(|p| p.samples.iter().copied())
        .collect();
    let view_data = ModelPatchView {
        centre: Vec3::from(model.centre),
        radius: model.radius,
        patches: &bounds,
        samples: &samples,
        words,
    };
    let mut rng = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut out = PatchError::default();
    let mut keep = Vec::new();
    let centre = Vec3::from(model.centre);
    for _ in 0..views {
        let z = 2.0 * next() - 1.0;
        let phi = std::f64::consts::TAU * next();
        let s = (1.0 - z * z).max(0.0).sqrt();
        let dir = DVec3::new(s * phi.cos(), z, s * phi.sin()).as_vec3();
        let r = distance.0 + (distance.1 - distance.0) * next() as f32;
        // Look at a random point of the bounding sphere's inner half, so views are
        // not all centred.
        let target = centre
            + Vec3::new(
                next() as f32 - 0.5,
                next() as f32 - 0.5,
                next() as f32 - 0.5,
            ) * model.radius;
        let eye = centre + dir * model.radius * r;
        let up = if dir.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
        let near = (model.radius * (r - 1.0)).max(model.radius * 0.01);
        let Ok(view) = View::look_at_fov(
            eye,
            target,
            up,
            60.0,
            res,
            res,
            near,
            model.radius * (r + 1.5),
        ) else {
            continue;
        };
        select_patches(
            &view_data,
            &sphere,
            &set.shell_radius,
            eye,
            tests,
            &mut keep,
        );
        let mut chosen = Vec::new();
        let mut first = 0usize;
        for (p, patch) in model.patches.iter().enumerate() {
            let end = first + patch.triangle_count as usize;
            if keep[p] {
                chosen.extend_from_slice(&model.triangle_order[first..end]);
            }
            first = end;
        }
        let full_item = DrawItem::whole(mesh, 0);
        let part_item = DrawItem {
            triangles: Some(&chosen),
            ..full_item
        };
        let full = render(&view, &[full_item], CullMode::Back);
        let part = render(&view, &[part_item], CullMode::Back);
        let diff = full
            .triangle_id
            .iter()
            .zip(&part.triangle_id)
            .filter(|(a, b)| a != b)
            .count() as u64;
        out.views += 1;
        out.differing_pixels += diff;
        out.covered_pixels += full.covered_pixels() as u64;
        out.views_with_error += u32::from(diff > 0);
        out.triangles_drawn += chosen.len() as u64;
        out.triangles_full += mesh.triangles.len() as u64;
    }
    out
}
