//! Run-time patch selection for the objects a cell draws as originals (issue 17):
//! per instance and frame, the union of the nearest spherical samples' patch
//! bitfields (paper 002 §3.3) and the per-patch normal-cone back-face test (003
//! §4.1; Zhang & Hoff's normal masks at patch granularity), both from
//! [`format::patch_visibility::select_patches`], turn into a few index ranges of the
//! model's patch-ordered index buffer.
//!
//! Switches for measurements (environment, read once per process):
//! `HEXBAKE_PATCH_BITFIELDS=0` turns the bitfields off, `HEXBAKE_PATCH_BACKFACE=0` the
//! back-face test; with both off the originals are drawn whole as before.

use crate::gpu::{DrawList, PatchedDraw};
use crate::vertex::InstanceRaw;
use format::pack::BasePack;
use format::patch_visibility::{
    select_patches, ModelPatchView, PatchBounds, PatchTests, SamplingSphere,
};
use glam::{Mat4, Vec3};

/// Which tests the environment leaves on (both unless set to `0`).
pub fn tests_from_env() -> PatchTests {
    let on = |name: &str| std::env::var(name).map_or(true, |v| v.trim() != "0");
    PatchTests {
        bitfields: on("HEXBAKE_PATCH_BITFIELDS"),
        backface: on("HEXBAKE_PATCH_BACKFACE"),
    }
}

/// One model's patch data in the form the per-frame test wants.
pub struct ModelRuntime {
    centre: Vec3,
    radius: f32,
    bounds: Vec<PatchBounds>,
    samples: Vec<u32>,
    /// Per patch its first index in the patch-ordered index buffer, plus the end.
    pub index_first: Vec<u32>,
}

/// The patch data of a bake (from `base.pack`'s optional sections).
pub struct PatchRuntime {
    sphere: SamplingSphere,
    shells: Vec<f32>,
    words: usize,
    pub models: Vec<ModelRuntime>,
    /// Per instance: world → object transform, and whether it mirrors (then the
    /// back-face test is skipped: the winding flips).
    inverse: Vec<(Mat4, bool)>,
    pub tests: PatchTests,
}

impl PatchRuntime {
    /// `None` when the base pack has no patch data or both tests are off.
    pub fn new(base: &BasePack, tests: PatchTests) -> Option<PatchRuntime> {
        let set = base.patches.as_ref()?;
        if !tests.bitfields && !tests.backface {
            return None;
        }
        let models = set
            .models
            .iter()
            .map(|m| {
                let mut index_first = Vec::with_capacity(m.patches.len() + 1);
                let mut first = 0u32;
                for p in &m.patches {
                    index_first.push(first);
                    first += 3 * p.triangle_count;
                }
                index_first.push(first);
                ModelRuntime {
                    centre: Vec3::from(m.centre),
                    radius: m.radius,
                    bounds: m.patches.iter().map(|p| p.bounds).collect(),
                    samples: m
                        .patches
                        .iter()
                        .flat_map(|p| p.samples.iter().copied())
                        .collect(),
                    index_first,
                }
            })
            .collect();
        let inverse = base
            .instances
            .iter()
            .map(|i| {
                let t = Mat4::from_cols_array(&i.transform);
                (t.inverse(), t.determinant() < 0.0)
            })
            .collect();
        Some(PatchRuntime {
            sphere: SamplingSphere::new(set.sample_level),
            shells: set.shell_radius.clone(),
            words: set.words_per_patch(),
            models,
            inverse,
            tests,
        })
    }

    /// The index ranges of instance `instance` (of model `model`) to draw from `eye`
    /// (world), merged where patches are adjacent; and the triangles they hold.
    pub fn ranges(
        &self,
        model: u32,
        instance: u32,
        eye: Vec3,
        keep: &mut Vec<bool>,
    ) -> Option<(Vec<(u32, u32)>, u64)> {
        let m = self.models.get(model as usize)?;
        let &(inv, mirrored) = self.inverse.get(instance as usize)?;
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
        let mut ranges: Vec<(u32, u32)> = Vec::new();
        let mut indices = 0u64;
        for (p, &k) in keep.iter().enumerate() {
            if !k {
                continue;
            }
            let (a, b) = (m.index_first[p], m.index_first[p + 1]);
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

/// Moves every original of `list` whose model has patch data into
/// `list.patched`, with the ranges its visible patches make from `eye`. Instances
/// with nothing left to draw are dropped.
pub fn apply(
    runtime: &PatchRuntime,
    base: &BasePack,
    ids: &[u32],
    eye: Vec3,
    instances: &[InstanceRaw],
    list: &mut DrawList<'_>,
) {
    let mut keep = Vec::new();
    let mut moved: std::collections::BTreeSet<u32> = std::collections::BTreeSet::new();
    for &i in ids {
        let Some(inst) = base.instances.get(i as usize) else {
            continue;
        };
        let Some((ranges, triangles)) = runtime.ranges(inst.model, i, eye, &mut keep) else {
            continue;
        };
        moved.insert(i);
        if !ranges.is_empty() {
            list.patched.push(PatchedDraw {
                model: inst.model,
                instance: instances[i as usize],
                ranges,
                triangles,
            });
        }
    }
    if moved.is_empty() {
        return;
    }
    // Grouped by model like the full-geometry reference's instanced draws (instances
    // in id order within a model): the same draw order, the same depth ties.
    list.patched.sort_by_key(|p| p.model);
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
    list.originals = by_model.into_iter().collect();
}

/// A run of a proxy's (de-indexed, world-space) triangles in one normal cluster, with
/// the bounds of [`format::patch_visibility::patch_backfacing`] (issue 17 item 4
/// applied to proxies too: 003 §4.1's normal clusters, formed at load time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProxyCluster {
    pub bounds: PatchBounds,
    /// First vertex and vertex count in the proxy's vertex buffer.
    pub first: u32,
    pub count: u32,
}

/// Whether the per-cluster back-face test of proxies is on (`HEXBAKE_PATCH_BACKFACE`,
/// read once).
pub fn proxy_backface_on() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| tests_from_env().backface)
}

/// The cluster (Zhang & Hoff's cube-face partition, 24 clusters) of a geometric
/// normal; the same partition as the bake's patches (worker `patches.rs`).
fn cluster_of(n: Vec3) -> u8 {
    let a = n.abs();
    let (axis, u, v) = if a.x >= a.y && a.x >= a.z {
        (0u8, n.y, n.z)
    } else if a.y >= a.z {
        (1, n.z, n.x)
    } else {
        (2, n.x, n.y)
    };
    let major = u8::from(n.to_array()[axis as usize] < 0.0);
    ((axis * 2 + major) << 2) | (u8::from(u < 0.0) << 1) | u8::from(v < 0.0)
}

/// Reorders a proxy's triangles by normal cluster (stable within a cluster) and
/// returns the clusters with their normal cones. Every mode draws the reordered
/// buffer, so switching the test off changes nothing but the culling.
pub fn cluster_proxy_vertices(
    vertices: &[crate::vertex::ProxyVertex],
) -> (Vec<crate::vertex::ProxyVertex>, Vec<ProxyCluster>) {
    let tris = vertices.len() / 3;
    let normal = |t: usize| {
        let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(vertices[3 * t + k].pos).as_dvec3());
        (b - a).cross(c - a)
    };
    let mut order: Vec<(u8, usize)> = (0..tris)
        .map(|t| (cluster_of(normal(t).as_vec3()), t))
        .collect();
    order.sort_unstable();
    let mut out = Vec::with_capacity(vertices.len());
    let mut clusters = Vec::new();
    let mut k = 0;
    while k < order.len() {
        let mut j = k;
        while j < order.len() && order[j].0 == order[k].0 {
            j += 1;
        }
        let first = out.len() as u32;
        for &(_, t) in &order[k..j] {
            out.extend_from_slice(&vertices[3 * t..3 * t + 3]);
        }
        clusters.push(ProxyCluster {
            bounds: cone_of(&out[first as usize..]),
            first,
            count: out.len() as u32 - first,
        });
        k = j;
    }
    out.extend_from_slice(&vertices[3 * tris..]);
    (out, clusters)
}

/// Normal cone, box centre and plane offset of a run of triangles, as the bake
/// computes them for patches ([`PatchBounds::of_triangles`]).
fn cone_of(v: &[crate::vertex::ProxyVertex]) -> PatchBounds {
    PatchBounds::of_triangles(
        v.chunks_exact(3)
            .map(|t| [0, 1, 2].map(|k| Vec3::from(t[k].pos).as_dvec3())),
    )
}

/// The vertex ranges of a proxy to draw from `eye` (world): its clusters that are
/// not wholly back-facing, adjacent ones merged; everything without clusters.
pub fn proxy_ranges(
    clusters: &[ProxyCluster],
    vertex_count: u32,
    eye: Option<Vec3>,
) -> Vec<(u32, u32)> {
    let (Some(eye), true) = (eye, proxy_backface_on() && !clusters.is_empty()) else {
        return vec![(0, vertex_count)];
    };
    let mut ranges: Vec<(u32, u32)> = Vec::new();
    for c in clusters {
        let eps = 1e-5 * (1.0 + Vec3::from(c.bounds.centre).length());
        if format::patch_visibility::patch_backfacing(&c.bounds, eye, eps) {
            continue;
        }
        let (a, b) = (c.first, c.first + c.count);
        match ranges.last_mut() {
            Some(last) if last.1 == a => last.1 = b,
            _ => ranges.push((a, b)),
        }
    }
    ranges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vertex::ProxyVertex;
    use bytemuck::Zeroable;

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
        let (ordered, clusters) = cluster_proxy_vertices(&v);
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
            let ranges = proxy_ranges(&clusters, ordered.len() as u32, Some(eye));
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
