//! Per-model LOD chains: the starting points of every cell's weighted edge collapse
//! (DESIGN.md "Cost structure: work and bytes follow what a cell needs"; issue 13).
//!
//! The paper (000 §3.1.3.3, §3.1.4) simplifies each outside object per cell from its
//! full-resolution mesh. Most of those collapses do not depend on the cell at all:
//! a far object loses most of its vertices before any view-dependent weight matters.
//! So each model is prepared once per bake:
//!
//! - **Levels.** Level k (k = 1 … [`CHAIN_LEVELS`]) is the model simplified by our own
//!   half-edge collapse ([`crate::simplify::collapse_within`]: the same topology and
//!   geometry rules as the paper's collapse, uniform weights, cost
//!   `(1.5 − n_i·n_j)² · |e|`) under a plain object-space tolerance
//!   `ε_k = √2^(k−1) · diag / 4096` (diag = the model's bounding-box diagonal), so
//!   ε runs from diag/4096 to diag/91 in steps of √2 (a cell's start level is then
//!   never more than √2 finer than its budget allows). Each level continues from the previous one,
//!   so the chain is nested. Half-edge collapses keep original vertices: every level
//!   indexes the model's own vertex ids.
//!   A model's locked vertices (a chunk's cut border, issue 29) stay in every level.
//! - **Conservative error.** Every removed original vertex is carried by the
//!   surviving triangle nearest to it and re-assigned on every collapse that touches
//!   that triangle (the deviation bookkeeping of `simplify.rs`); a collapse is
//!   refused unless every carried vertex stays within ε_k. The level stores its
//!   carriers and `max_error`, the largest such distance: no original vertex lies
//!   farther than `max_error` from the level's surface.
//! - **Choice per (cell, object).** [`LodChain::start_for`]: the coarsest level whose
//!   `max_error`, scaled by the instance transform's largest stretch and seen from
//!   the nearest point of the region the proxy serves (the cell's prism: distance
//!   between the prism's box and the instance's world box, a lower bound of the true
//!   distance), stays below [`START_FRACTION`] of `bake.max_deviation_px`. Without a
//!   deviation bound (the paper's algorithm as written) the budget is
//!   [`UNBOUNDED_START_PX`]. The cell's collapse then starts from that level's
//!   triangles with its carriers ([`crate::simplify::simplify_seeded`]), so the
//!   deviation bound is checked against every original vertex under the selected
//!   triangles, end to end, exactly as if it had started from the full mesh.
//!
//! Why our own collapse and not meshoptimizer's simplifier: meshopt reports a
//! quadric-based error estimate, not a bound on the distance of every original
//! vertex, and gives no carriers to continue the bound from; ours gives both and
//! shares every safeguard (link condition, fold-over, manifold fans) with the
//! per-cell collapse that continues from it.
//!
//! Chains are cached in `<out>/lod/<model content hash>.lod` ([`format::lod`]) and
//! reused by every job, process and rerun; in one process they are built once
//! ([`LodChains::prepare`]) and shared by all cells. A cached chain is used only if
//! it is a chain of the model it names, checked level by level against the model
//! ([`LodChain::from_file`], issue 32 item 2); any other is rebuilt.

use crate::capture_memo::CaptureMemo;
use crate::grid::Prism;
use crate::simplify::{collapse_within, locked_mask, SimplifyError, SimplifyInput};
use format::lod::{LodChainFile, LodLevelData};
use format::{Mesh, Model, Scene};
use glam::{Mat3, Mat4, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Revision of the chain builder: part of every chain file; bump it with any change
/// to the levels' bytes.
pub const CHAIN_REVISION: u32 = 2;
/// Levels above the original.
pub const CHAIN_LEVELS: u32 = 12;
/// ε_1 = this × the model's bounding diagonal.
pub const FINEST_BOUND_FRACTION: f32 = 1.0 / 4096.0;
/// A cell's collapse starts from a level whose error projects below this fraction of
/// `bake.max_deviation_px`: the rest of the budget is left to the view-dependent
/// collapses of the cell (which re-check the whole bound anyway).
pub const START_FRACTION: f32 = 0.5;
/// The start level's projected error without a deviation bound (pixels).
pub const UNBOUNDED_START_PX: f32 = 0.25;

/// One level of a chain.
#[derive(Clone, Debug, PartialEq)]
pub struct LodLevel {
    /// ε of the level (object space).
    pub bound: f32,
    /// Largest distance of a removed original vertex from the level's surface.
    pub max_error: f32,
    /// The level's triangles, indexing the model's own vertices (a level keeps no
    /// copy of them: with 12 levels per model, copies were most of a park bake's
    /// chain memory).
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle of `mesh`, the removed original vertices it carries.
    pub carried: Vec<Vec<u32>>,
}

/// The chain of one model: levels 1 … n, finest first (level 0 is the model).
#[derive(Clone, Debug, PartialEq)]
pub struct LodChain {
    pub model_hash: [u8; 32],
    pub levels: Vec<LodLevel>,
}

/// Why a chain cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ChainError {
    #[error("model {model}: {source}")]
    Simplify {
        model: String,
        #[source]
        source: SimplifyError,
    },
}

/// Object-space positions and unit normals of a model (missing or broken normals
/// become +y, as in `svmesh::world_vertices`).
fn object_vertices(mesh: &Mesh) -> (Vec<Vec3>, Vec<Vec3>) {
    let positions: Vec<Vec3> = mesh.positions.iter().map(|&p| Vec3::from(p)).collect();
    let normals = (0..positions.len())
        .map(|v| {
            let n = mesh
                .normals
                .get(v)
                .map_or(Vec3::ZERO, |&n| Vec3::from(n))
                .normalize_or_zero();
            if n.is_finite() && n != Vec3::ZERO {
                n
            } else {
                Vec3::Y
            }
        })
        .collect();
    (positions, normals)
}

fn diagonal(mesh: &Mesh) -> f32 {
    mesh.bounds()
        .map_or(0.0, |(lo, hi)| (Vec3::from(hi) - Vec3::from(lo)).length())
}

impl LodChain {
    /// Builds the chain of `model` (module docs). Deterministic: single-threaded,
    /// index-based.
    pub fn build(model: &Model) -> Result<LodChain, ChainError> {
        let mesh = &model.mesh;
        let (positions, normals) = object_vertices(mesh);
        let weights = vec![1.0f32; positions.len()];
        // A chunk's cut border stays in every level (issue 29, simplify.rs).
        let locked = locked_mask(positions.len(), &model.locked_vertices);
        let diag = diagonal(mesh);
        let mut levels: Vec<LodLevel> = Vec::new();
        let mut triangles = mesh.triangles.clone();
        let mut carried: Vec<Vec<u32>> = vec![Vec::new(); triangles.len()];
        if !(diag.is_finite() && diag > 0.0) || triangles.is_empty() {
            return Ok(LodChain {
                model_hash: model.content_hash,
                levels,
            });
        }
        for k in 0..CHAIN_LEVELS {
            let bound = level_bound(diag, k);
            let input = SimplifyInput {
                positions: &positions,
                normals: &normals,
                triangles: &triangles,
                weights: &weights,
                view_sets: None,
                locked: locked.as_deref(),
            };
            let length = |a: u32, b: u32| positions[a as usize].distance(positions[b as usize]);
            let tracked = collapse_within(
                &input,
                length,
                vec![bound; positions.len()],
                Some(std::mem::take(&mut carried)),
            )
            .map_err(|source| ChainError::Simplify {
                model: model.name.clone(),
                source,
            })?;
            triangles = tracked.simplified.triangles;
            carried = tracked.carried;
            let max_error = max_carried_distance(&positions, &triangles, &carried);
            levels.push(LodLevel {
                bound,
                max_error,
                triangles: triangles.clone(),
                carried: carried.clone(),
            });
        }
        Ok(LodChain {
            model_hash: model.content_hash,
            levels,
        })
    }

    /// The coarsest level whose error, scaled by `transform` and seen from the
    /// nearest point of `region` to the instance's world box `(lo, hi)`, stays below
    /// `budget_px` pixels at `pixels_per_radian` (module docs); `None`: start from
    /// the original mesh.
    pub fn start_for(
        &self,
        transform: Mat4,
        world_box: (Vec3, Vec3),
        region: &Prism,
        budget_px: f32,
        pixels_per_radian: f32,
    ) -> Option<&LodLevel> {
        let distance = box_distance(world_box, prism_box(region));
        let allowed = budget_px / pixels_per_radian * distance / max_stretch(transform);
        if !(allowed.is_finite() && allowed > 0.0) {
            return None;
        }
        self.levels.iter().rev().find(|l| l.max_error <= allowed)
    }

    pub fn to_file(&self, vertices: u32) -> LodChainFile {
        LodChainFile {
            revision: CHAIN_REVISION,
            model_hash: self.model_hash,
            vertices,
            levels: self
                .levels
                .iter()
                .map(|l| LodLevelData {
                    bound: l.bound,
                    max_error: l.max_error,
                    triangles: l.triangles.clone(),
                    carried: l.carried.clone(),
                })
                .collect(),
        }
    }

    /// The chain of `model` from a decoded file, if the file is a chain of this model
    /// by this revision of the builder (issue 32 item 2: a chain file is a cache, and
    /// its seal only says that its bytes are whole, not that they are the model's
    /// chain). Beyond the revision, the model's content hash and vertex count, every
    /// level is checked against the model, as [`LodChain::build`] makes it:
    ///
    /// 1. [`CHAIN_LEVELS`] levels (none for a model without triangles or extent),
    ///    level k's bound exactly [`level_bound`]`(diag, k)`;
    /// 2. a simplification of the finer level, the model for level 1
    ///    ([`crate::simplify::validate`]: only vertices the finer level uses, no
    ///    degenerate or repeated triangle, manifold wherever the finer level is,
    ///    consistently wound there), with no more triangles than it;
    /// 3. every vertex the model's triangles use either on the level or carried by
    ///    exactly one of its triangles, and no other vertex carried;
    /// 4. `max_error` exactly the largest distance of a carried vertex from its
    ///    carrying triangle, recomputed ([`max_carried_distance`]).
    ///
    /// A chain rewritten with other valid vertex ids breaks one of them; the caller
    /// then rebuilds it. Costs a sort of each level's edges: on the demo's 11 models
    /// (218k triangles, 2 threads) loading takes 0.3–0.45 s instead of 0.07 s, a
    /// build 3.8–4.3 s.
    pub fn from_file(file: LodChainFile, model: &Model) -> Result<LodChain, ChainMismatch> {
        let mesh = &model.mesh;
        if file.revision != CHAIN_REVISION {
            return Err(ChainMismatch::Revision {
                found: file.revision,
            });
        }
        if file.model_hash != model.content_hash {
            return Err(ChainMismatch::Model {
                expected: format::fingerprint::to_hex(&model.content_hash),
                found: format::fingerprint::to_hex(&file.model_hash),
            });
        }
        if file.vertices as usize != mesh.positions.len() {
            return Err(ChainMismatch::Vertices {
                expected: mesh.positions.len(),
                found: file.vertices,
            });
        }
        check_levels(&file.levels, mesh)?;
        Ok(LodChain {
            model_hash: file.model_hash,
            levels: file
                .levels
                .into_iter()
                .map(|l| LodLevel {
                    bound: l.bound,
                    max_error: l.max_error,
                    triangles: l.triangles,
                    carried: l.carried,
                })
                .collect(),
        })
    }
}

/// Why a chain file is not the chain of the model it names ([`LodChain::from_file`]):
/// it is rebuilt, never used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ChainMismatch {
    #[error("made by chain builder revision {found}, this is revision {CHAIN_REVISION}")]
    Revision { found: u32 },
    #[error("made for the model of content hash {found}, not this one ({expected})")]
    Model { expected: String, found: String },
    #[error("made for {found} vertices, the model has {expected}")]
    Vertices { expected: usize, found: u32 },
    #[error("{found} levels, the model's chain has {expected}")]
    LevelCount { expected: usize, found: usize },
    /// Level `level` (1 = the finest above the model) breaks a rule of the chain.
    #[error("level {level}: {what}")]
    Level { level: usize, what: String },
}

/// Steps 1–4 of [`LodChain::from_file`]: `levels` against the model's `mesh`.
fn check_levels(levels: &[LodLevelData], mesh: &Mesh) -> Result<(), ChainMismatch> {
    let (positions, _) = object_vertices(mesh);
    let n = positions.len();
    let diag = diagonal(mesh);
    // 1. How many levels the builder makes for this model.
    let expected = if !(diag.is_finite() && diag > 0.0) || mesh.triangles.is_empty() {
        0
    } else {
        CHAIN_LEVELS as usize
    };
    if levels.len() != expected {
        return Err(ChainMismatch::LevelCount {
            expected,
            found: levels.len(),
        });
    }
    let mut used = vec![false; n];
    for &v in mesh.triangles.iter().flatten() {
        if let Some(u) = used.get_mut(v as usize) {
            *u = true;
        }
    }
    // Level 0 is the model.
    let mut on_finer = used.clone();
    let mut finer: &[[u32; 3]] = &mesh.triangles;
    for (k, level) in levels.iter().enumerate() {
        let bad = |what: String| ChainMismatch::Level { level: k + 1, what };
        let bound = level_bound(diag, k as u32);
        if level.bound.to_bits() != bound.to_bits() {
            return Err(bad(format!(
                "bound {}, the builder's ε of this level for this model is {bound}",
                level.bound
            )));
        }
        // 2. A nested simplification of the model.
        if level.triangles.len() > finer.len() {
            return Err(bad(format!(
                "{} triangles, more than the {} of the finer level",
                level.triangles.len(),
                finer.len()
            )));
        }
        // Against the finer level, the input of its collapse (each level is
        // validated against the one it continues: cheaper than the model 12 times,
        // and the same rules hold from the model down).
        let simplified = crate::simplify::Simplified {
            triangles: level.triangles.clone(),
            ..Default::default()
        };
        crate::simplify::validate(n, finer, &simplified).map_err(|e| {
            bad(format!(
                "not a simplification of the finer level (or the model): {e}"
            ))
        })?;
        let mut on = vec![false; n];
        for &v in level.triangles.iter().flatten() {
            if !on_finer[v as usize] {
                return Err(bad(format!(
                    "vertex {v} is on the level but not on the finer one (levels are nested)"
                )));
            }
            on[v as usize] = true;
        }
        // 3. Every vertex the model uses on the level or carried once, nothing else.
        if level.carried.len() != level.triangles.len() {
            return Err(bad(format!(
                "{} carried lists for {} triangles",
                level.carried.len(),
                level.triangles.len()
            )));
        }
        let mut carried = vec![false; n];
        for &v in level.carried.iter().flatten() {
            let v = v as usize;
            if on[v] || carried[v] || !used[v] {
                return Err(bad(format!(
                    "vertex {v} is carried, but it is {}",
                    if on[v] {
                        "on the level"
                    } else if carried[v] {
                        "carried twice"
                    } else {
                        "used by no triangle of the model"
                    }
                )));
            }
            carried[v] = true;
        }
        if let Some(v) = (0..n).find(|&v| used[v] && !on[v] && !carried[v]) {
            return Err(bad(format!(
                "vertex {v} of the model is neither on the level nor carried"
            )));
        }
        // 4. The recorded error is the carried vertices' distance.
        let max_error = max_carried_distance(&positions, &level.triangles, &level.carried);
        if max_error.to_bits() != level.max_error.to_bits() {
            return Err(bad(format!(
                "max_error {} recorded, its carried vertices lie up to {max_error} from \
                 their triangles",
                level.max_error
            )));
        }
        on_finer = on;
        finer = &level.triangles;
    }
    Ok(())
}

/// ε of level k + 1 (k = 0 … CHAIN_LEVELS − 1) of a model with bounding diagonal
/// `diag`: `diag · FINEST_BOUND_FRACTION · √2^k`.
pub fn level_bound(diag: f32, k: u32) -> f32 {
    diag * FINEST_BOUND_FRACTION * 2f32.powf(k as f32 / 2.0)
}

/// The largest distance of a carried vertex from its carrying triangle.
pub fn max_carried_distance(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    carried: &[Vec<u32>],
) -> f32 {
    let mut worst: f32 = 0.0;
    for (tri, points) in triangles.iter().zip(carried) {
        let [a, b, c] = tri.map(|v| positions[v as usize]);
        for &p in points {
            let d2 =
                crate::simplify::point_triangle_distance_squared(positions[p as usize], a, b, c);
            worst = worst.max(d2.sqrt());
        }
    }
    worst
}

/// The largest factor by which `transform` stretches a length: the spectral norm of
/// its linear part (the square root of the largest eigenvalue of MᵀM, closed form
/// for a symmetric 3 × 3), rounded up by a relative 1e-4 so float error never makes
/// it smaller than the true value.
pub fn max_stretch(transform: Mat4) -> f32 {
    let m = Mat3::from_mat4(transform).as_dmat3();
    let a = m.transpose() * m;
    let (a00, a11, a22) = (a.x_axis.x, a.y_axis.y, a.z_axis.z);
    let (a01, a02, a12) = (a.y_axis.x, a.z_axis.x, a.z_axis.y);
    let p1 = a01 * a01 + a02 * a02 + a12 * a12;
    let largest = if p1 <= 1e-300 {
        a00.max(a11).max(a22)
    } else {
        let q = (a00 + a11 + a22) / 3.0;
        let p2 = (a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * p1;
        let p = (p2 / 6.0).sqrt();
        let b = (a - glam::DMat3::from_diagonal(glam::DVec3::splat(q))) * (1.0 / p);
        let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
        let phi = r.acos() / 3.0;
        q + 2.0 * p * phi.cos()
    };
    (largest.max(0.0).sqrt() * (1.0 + 1e-4)) as f32
}

/// The axis-aligned box of a prism.
fn prism_box(prism: &Prism) -> (Vec3, Vec3) {
    let hex = prism.hexagon();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for c in hex {
        lo = lo.min(Vec3::new(c.x, prism.min_y, c.y));
        hi = hi.max(Vec3::new(c.x, prism.max_y, c.y));
    }
    (lo, hi)
}

/// Distance between two axis-aligned boxes (0 when they overlap).
fn box_distance(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> f32 {
    let gap = (b.0 - a.1).max(a.0 - b.1).max(Vec3::ZERO);
    gap.length()
}

/// The chains of a scene's models, by model index (`None`: the model has no chain,
/// cells start from its full mesh), and the memo of single-object captures that
/// every cell and group baked with them shares ([`crate::capture_memo`]): both are
/// what the cells of a run share about one scene's models.
#[derive(Clone, Debug, Default)]
pub struct LodChains {
    chains: Vec<Option<Arc<LodChain>>>,
    captures: Arc<CaptureMemo>,
}

/// What [`LodChains::prepare`] did, for the run's report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PrepareStats {
    pub built: u32,
    pub loaded: u32,
    /// Of `built`: chains whose cached file was there but did not decode or did not
    /// match its model ([`LodChain::from_file`]).
    pub refused: u32,
}

impl LodChains {
    /// No chains: every cell starts from the full meshes (the paper as written).
    pub fn none() -> LodChains {
        LodChains::default()
    }

    pub fn get(&self, model: u32) -> Option<&LodChain> {
        self.chains.get(model as usize)?.as_deref()
    }

    /// The run's memo of single-object captures.
    pub fn captures(&self) -> &CaptureMemo {
        &self.captures
    }

    /// Chains of every model of `scene`, in parallel over models: loaded from
    /// `cache` (`<out>/lod/`) when a file there decodes and matches the model
    /// ([`LodChain::from_file`]), else built and, with a cache, written atomically
    /// (a failed write only costs a rebuild next time).
    pub fn prepare(
        scene: &Scene,
        cache: Option<&Path>,
    ) -> Result<(LodChains, PrepareStats), ChainError> {
        let results: Vec<Result<(LodChain, Source), ChainError>> = scene
            .models
            .par_iter()
            .map(|model| {
                let path = cache.map(|dir| chain_path(dir, &model.content_hash));
                let source = match path.as_deref().map(|p| load(p, model)) {
                    Some(Cached::Loaded(chain)) => return Ok((*chain, Source::Loaded)),
                    Some(Cached::Refused) => Source::Rebuilt,
                    Some(Cached::Missing) | None => Source::Built,
                };
                let chain = LodChain::build(model)?;
                if let Some(path) = &path {
                    let bytes = chain.to_file(model.mesh.positions.len() as u32).encode();
                    let _ = std::fs::create_dir_all(path.parent().expect("in a directory"));
                    let _ = format::pack::write_atomic(path, &bytes);
                }
                Ok((chain, source))
            })
            .collect();
        let mut stats = PrepareStats::default();
        let mut chains = Vec::with_capacity(results.len());
        for r in results {
            let (chain, source) = r?;
            match source {
                Source::Loaded => stats.loaded += 1,
                Source::Built => stats.built += 1,
                Source::Rebuilt => {
                    stats.built += 1;
                    stats.refused += 1;
                }
            }
            chains.push(Some(Arc::new(chain)));
        }
        Ok((
            LodChains {
                chains,
                captures: Arc::default(),
            },
            stats,
        ))
    }
}

/// `<cache>/<hex of the model's content hash>.lod`.
pub fn chain_path(cache: &Path, model_hash: &[u8; 32]) -> PathBuf {
    cache.join(format!("{}.lod", format::fingerprint::to_hex(model_hash)))
}

/// Where a prepared chain came from.
enum Source {
    Loaded,
    Built,
    /// Built because the cached file did not decode or match its model.
    Rebuilt,
}

/// What the cache holds for a model.
enum Cached {
    Missing,
    Refused,
    Loaded(Box<LodChain>),
}

fn load(path: &Path, model: &Model) -> Cached {
    let Ok(bytes) = std::fs::read(path) else {
        return Cached::Missing;
    };
    match LodChainFile::decode(&bytes).map(|file| LodChain::from_file(file, model)) {
        Ok(Ok(chain)) => Cached::Loaded(Box::new(chain)),
        _ => Cached::Refused,
    }
}
