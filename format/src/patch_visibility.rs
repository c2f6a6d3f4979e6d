//! Run-time side of the per-model patch data shared by the bake and the player:
//! the sampling sphere of paper 002 §3.2.1 (an octahedron whose faces are split into
//! four, level by level, vertices pushed onto the unit sphere), the lookup of the
//! sphere face a view direction passes through (002 §3.3: descend the face hierarchy,
//! at most four tests per level), and the choice of patches to draw from one eye
//! position (002 §3.3: inclusive OR of the bitfields of the face's three corner
//! samples; 003 §4.1 / Zhang & Hoff's normal clusters: a patch whose every triangle
//! faces away from the eye is not drawn).
//!
//! One home for both renderers (STYLE.md habit 15): the worker's error measurement
//! and the player call [`select_patches`].
//!
//! What is conservative and what is not:
//! - **Back-face test** ([`patch_backfacing`]): exact-conservative. With `c` the
//!   patch centre, `δ = max_t n_t·(c − q_t)` over its triangles (plane offsets from
//!   `c`) and all unit normals `n_t` in the cone (axis `a`, half-angle `α`), every
//!   triangle satisfies `n_t·(e − q_t) ≤ max_{n ∈ cone} n·(e − c) + δ`; the maximum
//!   over the cone is `|e − c|·cos(max(θ − α, 0))` with `θ = ∠(a, e − c)`. When that
//!   bound is below `−ε`, every triangle is back-facing and the GPU would cull each of
//!   them anyway: dropping the patch changes no pixel.
//! - **Visibility bitfields**: not conservative (002 §2 says so); a patch seen from
//!   no sample near the eye is dropped. For every triangle, front-facing-ness along a
//!   ray from the model centre is linear in the distance, so a triangle that faces the
//!   eye faces one of the two bracketing shells' samples in that direction; what the
//!   samples can miss is a patch hidden by the model itself at the samples and not at
//!   the eye. The bake measures that error (worker `patches.rs`, 002 §4's
//!   image comparison) and the player can switch the bitfields off.
//!   Eyes nearer than the innermost shell draw every patch that passes the back-face
//!   test (002 §4: "switch to the full model" when closer than the samples).

use glam::Vec3;
use std::collections::BTreeMap;

/// The deepest sphere subdivision level a pack may use (002 §4 found 1,026 samples,
/// level 4, enough; level 6 has 16,386 directions).
pub const MAX_SAMPLE_LEVEL: u32 = 6;
/// Most distance shells per pack.
pub const MAX_SHELLS: usize = 4;

/// The sampling sphere of one subdivision level: unit directions (those of coarser
/// levels first, so a level's directions are a prefix of the next level's) and the
/// face hierarchy (faces of level k + 1 at `4i..4i + 4` are the children of face `i`
/// of level k).
#[derive(Clone, Debug, PartialEq)]
pub struct SamplingSphere {
    pub level: u32,
    pub directions: Vec<Vec3>,
    /// Per level 0..=level: faces as direction indices, counter-clockwise seen from
    /// outside the sphere.
    pub faces: Vec<Vec<[u32; 3]>>,
}

/// Number of directions of a level: 4·4^level + 2 (6, 18, 66, 258, 1026, ...).
pub fn direction_count(level: u32) -> usize {
    4 * 4usize.pow(level) + 2
}

fn det(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    a.dot(b.cross(c))
}

impl SamplingSphere {
    /// 002 §3.2.1: start from the octahedron, split each face into four, push the new
    /// vertices onto the sphere. Deterministic (midpoints are numbered in face order).
    pub fn new(level: u32) -> SamplingSphere {
        let level = level.min(MAX_SAMPLE_LEVEL);
        let mut directions = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let mut top = Vec::with_capacity(8);
        for sx in [0u32, 1] {
            for sy in [2u32, 3] {
                for sz in [4u32, 5] {
                    let (a, b, c) = (sx, sy, sz);
                    let d = det(
                        directions[a as usize],
                        directions[b as usize],
                        directions[c as usize],
                    );
                    top.push(if d > 0.0 { [a, b, c] } else { [a, c, b] });
                }
            }
        }
        let mut faces = vec![top];
        for _ in 0..level {
            let parent = faces.last().expect("level 0 exists");
            let mut midpoints: BTreeMap<(u32, u32), u32> = BTreeMap::new();
            let mut children = Vec::with_capacity(parent.len() * 4);
            for &[a, b, c] in parent {
                let mut mid = |i: u32, j: u32| {
                    *midpoints.entry((i.min(j), i.max(j))).or_insert_with(|| {
                        let m = (directions[i as usize] + directions[j as usize]).normalize();
                        directions.push(m);
                        directions.len() as u32 - 1
                    })
                };
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                children.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            faces.push(children);
        }
        SamplingSphere {
            level,
            directions,
            faces,
        }
    }

    /// How far inside face `f` of `level` the direction `d` is: the smallest of the
    /// three edge determinants (≥ 0 inside).
    fn inside(&self, face: [u32; 3], d: Vec3) -> f32 {
        let [a, b, c] = face.map(|i| self.directions[i as usize]);
        det(a, b, d).min(det(b, c, d)).min(det(c, a, d))
    }

    /// The finest face the direction `d` (any length > 0) passes through, found by
    /// descending the hierarchy (002 §3.3); its three corners are the nearest samples.
    /// On an edge the first face in order wins; a direction that rounding leaves
    /// outside all four children takes the child it is least outside of.
    pub fn face_of(&self, d: Vec3) -> [u32; 3] {
        let best = |candidates: std::ops::Range<usize>, level: usize| -> usize {
            let mut best = (candidates.start, f32::NEG_INFINITY);
            for i in candidates {
                let s = self.inside(self.faces[level][i], d);
                if s > best.1 {
                    best = (i, s);
                }
            }
            best.0
        };
        let mut f = best(0..8, 0);
        for level in 1..self.faces.len() {
            f = best(4 * f..4 * f + 4, level);
        }
        self.faces[self.faces.len() - 1][f]
    }
}

/// One patch as the run-time tests need it (model space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchBounds {
    /// Unit axis of the cone of the triangles' geometric normals.
    pub cone_axis: [f32; 3],
    /// cos of the cone's half-angle; −1 means "normals in every direction".
    pub cone_cos: f32,
    /// Centre of the patch's bounding box.
    pub centre: [f32; 3],
    /// max over the patch's triangles of n·(centre − q), q on the triangle.
    pub offset: f32,
}

impl PatchBounds {
    /// The normal cone, box centre and plane offset of a set of triangles (corner
    /// positions; computed in f64 and rounded outward so the f32 test
    /// [`patch_backfacing`] stays conservative). Degenerate triangles cover no pixel
    /// and constrain nothing; triangles whose normals span every direction give the
    /// "never back-facing" cone (`cone_cos` −1). The bake's patches (worker
    /// `patches::normal_cone`) and the player's proxy clusters use this one rule.
    pub fn of_triangles(triangles: impl Iterator<Item = [glam::DVec3; 3]>) -> PatchBounds {
        use glam::DVec3;
        let mut normals = Vec::new();
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let mut sum = DVec3::ZERO;
        for [a, b, c] in triangles {
            lo = lo.min(a).min(b).min(c);
            hi = hi.max(a).max(b).max(c);
            let cross = (b - a).cross(c - a);
            let len = cross.length();
            if len > 1e-12 && len.is_finite() {
                normals.push((cross / len, a));
                sum += cross;
            }
        }
        let centre = if lo.x.is_finite() {
            (lo + hi) * 0.5
        } else {
            DVec3::ZERO
        };
        let everything = PatchBounds {
            cone_axis: [0.0, 0.0, 1.0],
            cone_cos: -1.0,
            centre: centre.as_vec3().to_array(),
            offset: 0.0,
        };
        if normals.is_empty() || sum.length() < 1e-9 {
            return everything;
        }
        let axis = sum.normalize();
        let cos = normals
            .iter()
            .map(|(n, _)| n.dot(axis))
            .fold(1.0f64, f64::min);
        let offset = normals
            .iter()
            .map(|(n, q)| n.dot(centre - *q))
            .fold(f64::NEG_INFINITY, f64::max);
        // Round outward so the f32 test stays conservative.
        let cos = (cos - 1e-6).max(-1.0);
        if cos <= -1.0 {
            return everything;
        }
        PatchBounds {
            cone_axis: axis.as_vec3().normalize().to_array(),
            cone_cos: cos as f32,
            centre: centre.as_vec3().to_array(),
            offset: (offset + 1e-6 * (hi - lo).length()) as f32,
        }
    }
}

/// True when every triangle of the patch faces away from `eye` (model space), so the
/// GPU's back-face culling would drop all of them (module docs; 003 §4.1 normal
/// clusters). `eps` absorbs rounding (model units).
pub fn patch_backfacing(p: &PatchBounds, eye: Vec3, eps: f32) -> bool {
    if p.cone_cos <= -1.0 {
        return false;
    }
    let v = eye - Vec3::from(p.centre);
    let len = v.length();
    if len <= 0.0 || !len.is_finite() {
        return false;
    }
    let cos_theta = (Vec3::from(p.cone_axis).dot(v) / len).clamp(-1.0, 1.0);
    let cos_alpha = p.cone_cos.clamp(-1.0, 1.0);
    // θ < α: the eye direction is inside the cone, some normal points at it.
    if cos_theta > cos_alpha {
        return false;
    }
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    // cos(θ − α), θ − α in [0, π].
    let cos_diff = cos_theta * cos_alpha + sin_theta * sin_alpha;
    len * cos_diff + p.offset < -eps
}

/// Which run-time tests pick the patches (the player's switches).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatchTests {
    /// Union of the nearest samples' bitfields (002).
    pub bitfields: bool,
    /// Per-patch normal-cone back-face test (003, Zhang & Hoff).
    pub backface: bool,
}

/// What [`select_patches`] needs of one model's patch data.
pub struct ModelPatchView<'a> {
    /// Bounding sphere of the model (model space).
    pub centre: Vec3,
    pub radius: f32,
    pub patches: &'a [PatchBounds],
    /// Per patch: `words` u32 of sample bits (bit s = direction + shell · directions).
    pub samples: &'a [u32],
    pub words: usize,
}

/// For one eye position (model space), `keep[p]` = draw patch `p`. `shells` are the
/// shell radii as multiples of the model's radius (increasing); `sphere` must be the
/// pack's sampling sphere.
pub fn select_patches(
    model: &ModelPatchView<'_>,
    sphere: &SamplingSphere,
    shells: &[f32],
    eye: Vec3,
    tests: PatchTests,
    keep: &mut Vec<bool>,
) {
    keep.clear();
    keep.resize(model.patches.len(), true);
    // 1. The samples whose bitfields are united: the three corners of the sphere face
    //    the eye direction passes through, on the two shells that bracket its
    //    distance (only the outermost beyond it; none inside the innermost).
    let mut samples: [usize; 6] = [usize::MAX; 6];
    let v = eye - model.centre;
    let r = v.length() / model.radius.max(f32::MIN_POSITIVE);
    let n_dirs = sphere.directions.len();
    let use_bits =
        tests.bitfields && model.words > 0 && !shells.is_empty() && r.is_finite() && r >= shells[0];
    if use_bits {
        let face = sphere.face_of(v);
        let k = shells.iter().rposition(|&s| s <= r).unwrap_or(0);
        let mut n = 0;
        for shell in [k, k + 1] {
            if shell < shells.len() {
                for d in face {
                    samples[n] = d as usize + shell * n_dirs;
                    n += 1;
                }
            }
        }
    }
    for (p, keep) in keep.iter_mut().enumerate() {
        if use_bits {
            let words = &model.samples[p * model.words..(p + 1) * model.words];
            let seen = samples
                .iter()
                .filter(|&&s| s != usize::MAX)
                .any(|&s| words.get(s / 32).is_some_and(|w| w >> (s % 32) & 1 == 1));
            if !seen {
                *keep = false;
                continue;
            }
        }
        if tests.backface && patch_backfacing(&model.patches[p], eye, 1e-4 * model.radius) {
            *keep = false;
        }
    }
}

/// The normal cluster of a geometric normal: the cube face its largest component
/// points at (6) times the signs of the other two components (4), 24 in all
/// (Zhang & Hoff's normal-space partition, coarse). Degenerate normals: cluster 0.
/// One home for the bake's patches (worker `patches.rs`) and the player's proxy
/// tiles (player `patches.rs`), both computing the normal in f64.
pub fn normal_cluster(n: glam::DVec3) -> u8 {
    let a = n.abs();
    let (axis, u, v) = if a.x >= a.y && a.x >= a.z {
        (0, n.y, n.z)
    } else if a.y >= a.z {
        (1, n.z, n.x)
    } else {
        (2, n.x, n.y)
    };
    let sign = |x: f64| u8::from(x < 0.0);
    let major = if [n.x, n.y, n.z][axis] < 0.0 { 1 } else { 0 };
    ((axis as u8 * 2 + major) << 2) | (sign(u) << 1) | sign(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_clusters_are_24_cube_face_quadrants() {
        // Each of the 24 (face, quadrant) directions lands in its own cluster, and
        // scaling a normal (f32 rounding of the same direction) never changes it.
        let mut seen = std::collections::BTreeSet::new();
        for axis in 0..3 {
            for major in [1.0, -1.0] {
                for (su, sv) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                    let mut n = [0.0f64; 3];
                    n[axis] = major;
                    n[(axis + 1) % 3] = 0.3 * su;
                    n[(axis + 2) % 3] = 0.2 * sv;
                    let c = normal_cluster(glam::DVec3::from(n));
                    assert!(c < 24);
                    assert_eq!(c, normal_cluster(glam::DVec3::from(n) * 1e-3));
                    seen.insert(c);
                }
            }
        }
        assert_eq!(seen.len(), 24);
        assert_eq!(normal_cluster(glam::DVec3::ZERO), 0);
    }

    #[test]
    fn sphere_counts_match_the_paper() {
        // 002 Figure 2: 6, 18, 66, 258 and 1026 viewpoints.
        for (level, n) in [(0, 6), (1, 18), (2, 66), (3, 258), (4, 1026)] {
            let s = SamplingSphere::new(level);
            assert_eq!(s.directions.len(), n);
            assert_eq!(direction_count(level), n);
            assert_eq!(s.faces[level as usize].len(), 8 * 4usize.pow(level));
            for d in &s.directions {
                assert!((d.length() - 1.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn face_of_contains_the_direction() {
        let s = SamplingSphere::new(3);
        let mut x = 12345u32;
        let mut rnd = || {
            x = x.wrapping_mul(1664525).wrapping_add(1013904223);
            (x >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let d = Vec3::new(rnd(), rnd(), rnd());
            if d.length() < 1e-3 {
                continue;
            }
            let f = s.face_of(d);
            assert!(s.inside(f, d.normalize()) > -1e-5, "{d:?} not in {f:?}");
            // The face's corners are near d: no direction is nearer than the farthest corner
            // by more than the face size.
            let dn = d.normalize();
            let worst = f
                .iter()
                .map(|&i| s.directions[i as usize].dot(dn))
                .fold(1.0f32, f32::min);
            assert!(worst > 0.9, "{worst}");
        }
    }

    #[test]
    fn backfacing_cone() {
        // A patch of one triangle in the plane z = 0 facing +z.
        let p = PatchBounds {
            cone_axis: [0.0, 0.0, 1.0],
            cone_cos: 1.0,
            centre: [0.0, 0.0, 0.0],
            offset: 0.0,
        };
        assert!(!patch_backfacing(&p, Vec3::new(0.0, 0.0, 1.0), 1e-6));
        assert!(patch_backfacing(&p, Vec3::new(0.0, 0.0, -1.0), 1e-6));
        assert!(patch_backfacing(&p, Vec3::new(5.0, 3.0, -0.1), 1e-6));
        // A half-angle of 60°: from (1, 0, -0.2) a normal tilted towards +x sees the eye.
        let wide = PatchBounds { cone_cos: 0.5, ..p };
        assert!(!patch_backfacing(&wide, Vec3::new(1.0, 0.0, -0.2), 1e-6));
        assert!(patch_backfacing(&wide, Vec3::new(0.1, 0.0, -1.0), 1e-6));
        let all = PatchBounds {
            cone_cos: -1.0,
            ..p
        };
        assert!(!patch_backfacing(&all, Vec3::new(0.0, 0.0, -1.0), 1e-6));
    }
}
