//! The distance-LOD baseline (issue 8, item 2): what a user would do without hexbake.
//! Every instance of the base pack is drawn from a per-model chain of simplified
//! meshes, the level chosen per frame by its projected error — no cells, no packs, no
//! textures. It is the yardstick for the hybrid rendering of paper 000 (§3.2 run
//! time, §4 evaluation: configuration C against the plain geometry of A and B).
//!
//! - **Chain** ([`build_chain`]): level 0 is the original triangle list (error 0);
//!   level k asks meshoptimizer's `meshopt_simplify` (quadric-error edge collapse,
//!   Garland–Heckbert, through the `meshopt` crate) for 1/2^k of the original index
//!   count, k = 1..=[`MAX_LEVELS`] (down to 1/256), with no error limit, no locks and
//!   no options, always simplifying the original. The chain stops at the first level
//!   that does not shrink (meshoptimizer reached its topological limit) or is empty.
//!   Each level keeps meshoptimizer's result error, relative to the model's extent
//!   (`meshopt_simplifyScale`, the largest side of the bounding box); the chain
//!   stores the running maximum so that errors never decrease along it (a coarser
//!   level never claims to be more exact than a finer one).
//! - **Shared vertices**: `meshopt_simplify` returns indices into the original vertex
//!   buffer, so a level is an index list only; the GPU draws it with the model's
//!   vertex buffer (DESIGN.md shading from the original vertex colours and normals).
//! - **Selection** ([`select_level`]): per visible instance (frustum culling as in
//!   `frustum` mode) the coarsest level whose projected error
//!   `error × extent × instance scale / distance × pixels per radian` is below the
//!   threshold (`--lod-pixel-error`, default 1 px). The distance is from the eye to
//!   the nearest point of the instance's world bounds (conservative: never smaller
//!   than the distance to any of its triangles), the instance scale the largest
//!   column norm of its transform's linear part, pixels per radian the frame height
//!   over the vertical field of view.
//!
//! Deterministic: meshoptimizer is; models are simplified independently (in parallel
//! on scoped threads) and gathered in model order.

use crate::bake::Bake;
use crate::camera::{distance_to_box, Camera};
use crate::vertex::InstanceRaw;
use format::pack::BasePack;
use format::Mesh;
use glam::Mat4;
use std::collections::BTreeMap;
use std::time::Instant;

/// Most simplified levels per chain (level k targets 1/2^k of the triangles).
pub const MAX_LEVELS: usize = 8;

/// Default `--lod-pixel-error`.
pub const DEFAULT_PIXEL_ERROR: f32 = 1.0;

/// One level of detail: triangles indexing the model's original vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct LodLevel {
    /// Triangle list (3 indices per triangle) into the original vertex buffer.
    pub indices: Vec<u32>,
    /// Geometric error relative to the model's extent (meshoptimizer's result
    /// error, running maximum along the chain); 0 for level 0.
    pub error: f32,
}

impl LodLevel {
    pub fn triangle_count(&self) -> u64 {
        self.indices.len() as u64 / 3
    }
}

/// A model's chain of levels, finest (the original) first.
#[derive(Clone, Debug, PartialEq)]
pub struct LodChain {
    pub levels: Vec<LodLevel>,
    /// meshoptimizer's error scale: the model's extent in model units.
    pub extent: f32,
}

impl LodChain {
    /// The absolute error of level `level`, in model units.
    pub fn error_model_units(&self, level: usize) -> f32 {
        self.levels
            .get(level)
            .map_or(0.0, |l| l.error * self.extent)
    }

    pub fn triangle_count(&self, level: usize) -> u64 {
        self.levels.get(level).map_or(0, LodLevel::triangle_count)
    }
}

/// Builds a model's LOD chain (see the module docs).
pub fn build_chain(mesh: &Mesh) -> LodChain {
    // 1. Level 0: the original triangles.
    let original: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let mut levels = vec![LodLevel {
        indices: original.clone(),
        error: 0.0,
    }];
    let n_vertices = mesh.positions.len();
    let in_range = original.iter().all(|&i| (i as usize) < n_vertices);
    if original.is_empty() || !in_range {
        // Nothing to simplify (or indices meshoptimizer must not see): one level.
        return LodChain {
            levels,
            extent: 0.0,
        };
    }
    let bytes: &[u8] = bytemuck::cast_slice(&mesh.positions);
    let stride = std::mem::size_of::<[f32; 3]>();
    let Ok(adapter) = meshopt::VertexDataAdapter::new(bytes, stride, 0) else {
        return LodChain {
            levels,
            extent: 0.0,
        };
    };
    let extent = meshopt::simplify_scale(&adapter);
    // 2. Levels 1..: halve the target each time, from the original.
    for k in 1..=MAX_LEVELS {
        let target_triangles = (mesh.triangles.len() >> k).max(1);
        let mut error = 0f32;
        let indices = meshopt::simplify(
            &original,
            &adapter,
            target_triangles * 3,
            f32::MAX,
            meshopt::SimplifyOptions::None,
            Some(&mut error),
        );
        let prev = levels.last().expect("level 0 exists");
        // 3. Stop when meshoptimizer cannot go further.
        if indices.is_empty() || indices.len() >= prev.indices.len() {
            break;
        }
        let error = if error.is_finite() { error } else { 1.0 };
        levels.push(LodLevel {
            error: error.max(prev.error),
            indices,
        });
        if target_triangles == 1 {
            break;
        }
    }
    LodChain { levels, extent }
}

/// The LOD chains of a bake's models and per-instance scales.
#[derive(Clone, Debug, PartialEq)]
pub struct LodSet {
    /// One chain per model of the base pack.
    pub chains: Vec<LodChain>,
    /// Per instance: the largest column norm of the transform's linear part.
    pub instance_scale: Vec<f32>,
    /// Wall time of [`LodSet::build`], milliseconds.
    pub build_ms: f64,
}

impl LodSet {
    /// Builds every model's chain (scoped threads over models; the result does not
    /// depend on the thread count).
    pub fn build(base: &BasePack) -> LodSet {
        let t0 = Instant::now();
        let meshes: Vec<&Mesh> = base.models.iter().map(|m| &m.mesh).collect();
        let threads = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .clamp(1, meshes.len().max(1));
        let chunk = meshes.len().div_ceil(threads).max(1);
        let chains: Vec<LodChain> = std::thread::scope(|s| {
            let handles: Vec<_> = meshes
                .chunks(chunk)
                .map(|part| {
                    s.spawn(move || {
                        part.iter()
                            .map(|m| build_chain(m))
                            .collect::<Vec<LodChain>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| {
                    h.join()
                        .unwrap_or_else(|e| std::panic::resume_unwind(e))
                        .into_iter()
                })
                .collect::<Vec<LodChain>>()
        });
        let instance_scale = base
            .instances
            .iter()
            .map(|i| instance_scale(&Mat4::from_cols_array(&i.transform)))
            .collect();
        LodSet {
            chains,
            instance_scale,
            build_ms: t0.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// Levels over all chains (simplified ones, not counting level 0).
    pub fn simplified_levels(&self) -> usize {
        self.chains.iter().map(|c| c.levels.len() - 1).sum()
    }

    /// Triangles stored in simplified levels.
    pub fn simplified_triangles(&self) -> u64 {
        self.chains
            .iter()
            .flat_map(|c| c.levels.iter().skip(1))
            .map(LodLevel::triangle_count)
            .sum()
    }
}

/// The largest column norm of a transform's linear part (how much it magnifies
/// lengths at most, for uniform and mildly non-uniform scales).
pub fn instance_scale(m: &Mat4) -> f32 {
    [m.x_axis, m.y_axis, m.z_axis]
        .iter()
        .map(|c| c.truncate().length())
        .fold(0.0, f32::max)
}

/// Pixels per radian of a frame: its height over the vertical field of view.
pub fn pixels_per_radian(camera: &Camera) -> f32 {
    camera.height as f32 / camera.fov_y_deg.to_radians().max(1e-6)
}

/// The coarsest level of `chain` whose projected error is below `threshold_px`;
/// `px_per_model_unit` = instance scale / distance × pixels per radian. Level 0 (the
/// original) when no simplified level qualifies.
pub fn select_level(chain: &LodChain, px_per_model_unit: f32, threshold_px: f32) -> usize {
    let mut chosen = 0;
    for k in 1..chain.levels.len() {
        let px = chain.error_model_units(k) * px_per_model_unit;
        if px < threshold_px {
            chosen = k;
        } else {
            break; // errors never decrease along the chain
        }
    }
    chosen
}

/// What an LOD frame draws: visible instances grouped by (model, level).
pub type LodGroups = Vec<((u32, u32), Vec<InstanceRaw>)>;

/// Frustum-culls every instance of the bake and picks each one's level.
pub fn lod_groups(bake: &Bake, set: &LodSet, camera: &Camera, threshold_px: f32) -> LodGroups {
    let frustum = camera.frustum();
    let ppr = pixels_per_radian(camera);
    let mut groups: BTreeMap<(u32, u32), Vec<InstanceRaw>> = BTreeMap::new();
    for (i, inst) in bake.base.instances.iter().enumerate() {
        let Some(bounds) = bake.instance_bounds.get(i) else {
            continue;
        };
        if !frustum.intersects(bounds) {
            continue;
        }
        let Some(chain) = set.chains.get(inst.model as usize) else {
            continue;
        };
        let distance = distance_to_box(camera.eye, bounds).max(camera.near.max(1e-6));
        let scale = set.instance_scale.get(i).copied().unwrap_or(1.0);
        let level = select_level(chain, scale / distance * ppr, threshold_px);
        groups
            .entry((inst.model, level as u32))
            .or_default()
            .push(bake.instances[i]);
    }
    groups.into_iter().collect()
}

/// Triangles an LOD frame draws.
pub fn lod_triangles(set: &LodSet, groups: &LodGroups) -> u64 {
    groups
        .iter()
        .map(|((m, l), inst)| {
            set.chains
                .get(*m as usize)
                .map_or(0, |c| c.triangle_count(*l as usize))
                * inst.len() as u64
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn grid_mesh(n: u32) -> Mesh {
        // An n × n bumpy height field (distinct errors per level).
        let mut m = Mesh::default();
        for z in 0..=n {
            for x in 0..=n {
                let (fx, fz) = (x as f32 / n as f32, z as f32 / n as f32);
                let y = 0.1 * (fx * 9.0).sin() * (fz * 7.0).cos();
                m.positions.push([fx, y, fz]);
                m.normals.push([0.0, 1.0, 0.0]);
                m.albedo.push([200, 200, 200, 255]);
            }
        }
        let v = |x: u32, z: u32| z * (n + 1) + x;
        for z in 0..n {
            for x in 0..n {
                m.triangles.push([v(x, z), v(x, z + 1), v(x + 1, z)]);
                m.triangles
                    .push([v(x + 1, z), v(x, z + 1), v(x + 1, z + 1)]);
            }
        }
        m
    }

    #[test]
    fn select_level_picks_the_coarsest_level_under_the_threshold() {
        let chain = LodChain {
            extent: 10.0,
            levels: [0.0, 0.01, 0.05, 0.2]
                .iter()
                .map(|&error| LodLevel {
                    indices: vec![0; 3],
                    error,
                })
                .collect(),
        };
        // Absolute errors 0, 0.1, 0.5, 2 model units.
        assert_eq!(select_level(&chain, 1.0, 0.05), 0);
        assert_eq!(select_level(&chain, 1.0, 0.2), 1);
        assert_eq!(select_level(&chain, 1.0, 1.0), 2);
        assert_eq!(select_level(&chain, 1.0, 2.0), 2, "strictly below");
        assert_eq!(select_level(&chain, 0.1, 1.0), 3);
        assert_eq!(select_level(&chain, 1.0, 0.0), 0);
    }

    #[test]
    fn empty_mesh_has_one_level() {
        let c = build_chain(&Mesh::default());
        assert_eq!(c.levels.len(), 1);
        assert_eq!(c.triangle_count(0), 0);
    }

    #[test]
    fn grid_chain_shrinks_by_halves() {
        let m = grid_mesh(32);
        let c = build_chain(&m);
        assert!(c.levels.len() >= 4, "{} levels", c.levels.len());
        assert!((c.extent - 1.0).abs() < 1e-3, "extent {}", c.extent);
        for w in c.levels.windows(2) {
            assert!(w[1].triangle_count() < w[0].triangle_count());
            assert!(w[1].error >= w[0].error);
        }
        // Level 1 hits its target (meshoptimizer may stop a few triangles above it).
        let t1 = c.triangle_count(1);
        assert!(t1 <= m.triangles.len() as u64 / 2 + 16, "{t1}");
        assert!(c.levels[1].error > 0.0);
    }

    #[test]
    fn instance_scale_is_the_largest_axis_scale() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 3.0, 1.5),
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(5.0, 0.0, 1.0),
        );
        assert!((instance_scale(&m) - 3.0).abs() < 1e-5);
    }
}
