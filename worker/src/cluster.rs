//! Greedy object clustering of SV objects (paper 000 §3.1.6).
//!
//! The paper's terms, measured here on world boxes seen from the cell centre:
//!
//! - **Texture size** of an object or cluster: the pixel count `width · height` of its
//!   tight capture from the centre ([`View::tight_around`] of its world box at
//!   `image_res` pixels per 60°) — the texture its SVMesh would carry.
//! - **Cluster-able**: M is cluster-able with cluster C when the texture size of
//!   M ∪ C is less than the sum of theirs and self-occluding-error(M ∪ C) < T_s
//!   ([`object_self_occluding_error`] of the union box).
//! - **Projected area** of an object: its texture size (the area of its projected
//!   box's bounding rectangle).
//! - **Overlapping size** of M and C: the area, in pixels, of the intersection of
//!   their projected box rectangles in the tight view of M ∪ C.
//!
//! The greedy approach, as the paper writes it: SV objects sorted by decreasing
//! projected area (ties: lower instance first); no cluster at first; for each object
//! M taken from the list, the clusters it is cluster-able with are ordered by
//! decreasing overlapping size (ties: the cluster whose first member is lower), and M
//! is merged with each in turn *if the merged result is still cluster-able with it*
//! (Fig. 8: M ∪ C₁ may no longer be cluster-able with C₂ but still with C₃); the
//! result is a new cluster (M alone if nothing was cluster-able).
//!
//! Clusters are returned with sorted members, ordered by their first member, so the
//! output does not depend on anything but the input.

use crate::raster::View;
use crate::selfocc::object_self_occluding_error;
use glam::Vec3;

/// One SV object offered to clustering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterCandidate {
    pub instance: u32,
    pub aabb_min: Vec3,
    pub aabb_max: Vec3,
}

/// What clustering needs to know about the cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterSettings {
    /// The cell centre (mid eye height).
    pub centre: Vec3,
    pub cell_size: f32,
    pub image_res: u32,
    /// T_s in pixels.
    pub self_occluding_tolerance_px: f32,
}

#[derive(Clone, Debug)]
struct Group {
    members: Vec<u32>,
    lo: Vec3,
    hi: Vec3,
    texture: u64,
}

/// Texture size (pixels) of the tight capture of `[lo, hi]` from the centre;
/// `u64::MAX` when no capture view can be made (never cluster-able).
pub fn texture_size(settings: &ClusterSettings, lo: Vec3, hi: Vec3) -> u64 {
    match View::tight_around(settings.centre, lo, hi, settings.image_res) {
        Ok(v) => v.width as u64 * v.height as u64,
        Err(_) => u64::MAX,
    }
}

fn cluster_able(settings: &ClusterSettings, m: &Group, c: &Group) -> Option<Group> {
    let lo = m.lo.min(c.lo);
    let hi = m.hi.max(c.hi);
    let texture = texture_size(settings, lo, hi);
    if texture >= m.texture.saturating_add(c.texture) {
        return None;
    }
    let error = object_self_occluding_error(
        settings.cell_size,
        settings.image_res,
        settings.centre,
        lo,
        hi,
    );
    if error.is_nan() || error >= settings.self_occluding_tolerance_px {
        return None;
    }
    let mut members = m.members.clone();
    members.extend_from_slice(&c.members);
    members.sort_unstable();
    Some(Group {
        members,
        lo,
        hi,
        texture,
    })
}

/// Pixel rectangle `(x0, y0, x1, y1)` of the projection of a box's corners in `view`
/// (corners behind the eye are skipped).
fn projected_rect(view: &View, lo: Vec3, hi: Vec3) -> Option<(f32, f32, f32, f32)> {
    let mut r = (
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    );
    let mut any = false;
    for p in crate::view::box_corners(lo, hi) {
        if let Some((px, _)) = view.project(p) {
            r = (r.0.min(px.x), r.1.min(px.y), r.2.max(px.x), r.3.max(px.y));
            any = true;
        }
    }
    any.then_some(r)
}

/// Overlapping size (pixels²) of `m` and `c` in the tight view of their union.
fn overlapping_size(settings: &ClusterSettings, m: &Group, c: &Group) -> f64 {
    let Ok(view) = View::tight_around(
        settings.centre,
        m.lo.min(c.lo),
        m.hi.max(c.hi),
        settings.image_res,
    ) else {
        return 0.0;
    };
    match (
        projected_rect(&view, m.lo, m.hi),
        projected_rect(&view, c.lo, c.hi),
    ) {
        (Some(a), Some(b)) => {
            let w = (a.2.min(b.2) - a.0.max(b.0)).max(0.0) as f64;
            let h = (a.3.min(b.3) - a.1.max(b.1)).max(0.0) as f64;
            w * h
        }
        _ => 0.0,
    }
}

/// Greedy clustering of the SV objects `candidates` (module docs). Every candidate
/// ends in exactly one cluster; singletons are clusters of one.
pub fn greedy_clusters(
    candidates: &[ClusterCandidate],
    settings: &ClusterSettings,
) -> Vec<Vec<u32>> {
    // Step 1: sort by decreasing projected area.
    let mut order: Vec<(u64, u32, Group)> = candidates
        .iter()
        .map(|c| {
            let (lo, hi) = (c.aabb_min.min(c.aabb_max), c.aabb_min.max(c.aabb_max));
            let texture = texture_size(settings, lo, hi);
            (
                texture,
                c.instance,
                Group {
                    members: vec![c.instance],
                    lo,
                    hi,
                    texture,
                },
            )
        })
        .collect();
    order.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));

    // Step 2: take each object in turn.
    let mut clusters: Vec<Group> = Vec::new();
    for (_, _, m) in order {
        let mut able: Vec<(f64, u32, usize)> = clusters
            .iter()
            .enumerate()
            .filter(|(_, c)| cluster_able(settings, &m, c).is_some())
            .map(|(k, c)| (overlapping_size(settings, &m, c), c.members[0], k))
            .collect();
        able.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut current = m;
        let mut merged = Vec::new();
        for &(_, _, k) in &able {
            if let Some(union) = cluster_able(settings, &current, &clusters[k]) {
                current = union;
                merged.push(k);
            }
        }
        merged.sort_unstable();
        for k in merged.into_iter().rev() {
            clusters.remove(k);
        }
        clusters.push(current);
    }
    let mut out: Vec<Vec<u32>> = clusters.into_iter().map(|c| c.members).collect();
    out.sort_unstable_by_key(|m| m[0]);
    out
}
