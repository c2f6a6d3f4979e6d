//! Self-occluding error test: SvMesh or MvMesh (paper 000 §3.1.2; 003 §4.1.3).
//!
//! An SvMesh keeps only what is front-facing to the cell's centre `V`; seen from
//! another point of the cell, surfaces it lacks can show as holes. Fig. 2 of the paper
//! bounds their projected size by looking from the farthest point `V'` of the cell
//! (`|VV'| = c`, the cell size, centre-to-corner) at an object whose near point `O` is
//! at distance `d = |VO|` and whose far point `P` lies `l = |OP|` behind it along the
//! line of sight:
//!
//! ```text
//! s = √3 · c · l / (2 d (d + l)) · image_res        (pixels)
//! ```
//!
//! The object is an SvMesh when `s < T_s`, otherwise an MvMesh.
//!
//! # How d and l are measured
//!
//! `s` falls with `d` and grows with `l`, so under-estimating `d` and over-estimating
//! `l` keeps the test conservative (never SV when the paper's exact figure would say
//! MV). From an axis-aligned world box around the object:
//! - `d` = distance from the cell centre to the nearest point of the box (0 when the
//!   centre is inside it, which gives `s = ∞`, i.e. MV);
//! - `l` = the box's extent along the unit direction `u` from the cell centre to the
//!   box centre, `Σ_k |u_k| · (max_k − min_k)` — the length of the box's shadow on
//!   the line of sight, which bounds the object's depth along it.
//!
//! The paper derives `s` "based on those polygons that are front-facing w.r.t. the
//! cell", so callers may pass the box of the triangles that survive regional back-face
//! culling ([`crate::backface`]) instead of the whole instance's; both are valid.

use glam::{Mat4, Vec3};

/// Which view-dependent LOD mesh represents an outside object (000 §3.1.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Representation {
    /// Single-view mesh: self-occluding error below the tolerance.
    Sv,
    /// Multi-view mesh: self-occluding error at or above the tolerance.
    Mv,
}

/// The paper's `s` in pixels for cell size `c`, object distance `d`, object depth `l`
/// and capture resolution `image_res` (pixels across a side face). `d ≤ 0` (the
/// centre touches the object) gives `+∞`; `l ≤ 0` gives 0.
pub fn self_occluding_error(cell_size: f32, d: f32, l: f32, image_res: u32) -> f32 {
    if d.is_nan() || l.is_nan() || cell_size.is_nan() {
        return f32::INFINITY;
    }
    if d <= 0.0 {
        return f32::INFINITY;
    }
    if l <= 0.0 {
        return 0.0;
    }
    let (c, d, l) = (cell_size as f64, d as f64, l as f64);
    let s = 3f64.sqrt() * c * l / (2.0 * d * (d + l)) * image_res as f64;
    s as f32
}

/// `(d, l)` of an object with world box `[aabb_min, aabb_max]` seen from `cell_centre`
/// (module docs, "How d and l are measured").
pub fn object_distance_and_depth(cell_centre: Vec3, aabb_min: Vec3, aabb_max: Vec3) -> (f32, f32) {
    let (lo, hi) = (aabb_min.min(aabb_max), aabb_min.max(aabb_max));
    let nearest = cell_centre.clamp(lo, hi);
    let d = cell_centre.distance(nearest);
    let direction = ((lo + hi) * 0.5 - cell_centre).normalize_or_zero();
    let l = direction.abs().dot(hi - lo);
    (d, l)
}

/// The self-occluding error of an object with world box `[aabb_min, aabb_max]` for the
/// cell of size `cell_size` centred at `cell_centre` (module docs).
pub fn object_self_occluding_error(
    cell_size: f32,
    image_res: u32,
    cell_centre: Vec3,
    aabb_min: Vec3,
    aabb_max: Vec3,
) -> f32 {
    let (d, l) = object_distance_and_depth(cell_centre, aabb_min, aabb_max);
    self_occluding_error(cell_size, d, l, image_res)
}

/// SV when `s < t_s` (pixels), else MV; a NaN error is MV.
pub fn choose_representation(self_occluding_error_px: f32, t_s: f32) -> Representation {
    if self_occluding_error_px < t_s {
        Representation::Sv
    } else {
        Representation::Mv
    }
}

/// The world box of a local box `[min, max]` placed by `transform` (the box of its 8
/// transformed corners).
pub fn transformed_aabb(min: Vec3, max: Vec3, transform: Mat4) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in crate::view::box_corners(min, max) {
        let q = transform.transform_point3(p);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    (lo, hi)
}
