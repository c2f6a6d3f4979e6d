//! Cross-fades at cell borders (issue 31 item 2): near the edge of its cell, a
//! frame blends the representations of the cells whose hexagons lie within a band
//! of the eye, so that walking across the edge changes nothing at once.
//!
//! Paper 000 §3.2 draws the current cell's representation only; the swap at a
//! crossing (outgoing proxies, clusters and impostors replaced by the incoming
//! cell's, originals becoming proxies and back) is the pop its Fig. 14 era accepted.
//! Here the weights are a function of the eye's position alone, not of which cell is
//! current:
//!
//! - every cell `c` whose closed hexagon lies within `band` of the eye has weight
//!   `w_c = 1 − d_c / band` (`d_c`: distance from the eye (x, z) to the hexagon, 0
//!   inside it), so the cell the eye is in has 1 and a neighbour fades in linearly
//!   over the band before its edge; on an edge the two cells weigh 1 each, at a
//!   corner three do;
//! - each cell gets the share `w_c / Σ w` of the 64 levels of an 8 × 8 Bayer matrix
//!   ([`bayer8`]), cells in id order ([`ranges`]), and its draw list keeps exactly
//!   the pixels whose level lies in its range (`gpu::Renderer::render_blend`, the
//!   `DITHER` pipelines). Every list is a complete image of the scene (each cell's
//!   representation alone is), so each pixel shows one cell's image: no object is
//!   drawn twice opaque and none leaves a gap (a screen-door cross-fade, as engines
//!   dither LOD transitions).
//!
//! Because the weights and the order depend on the position only, the frame before
//! and the frame after a crossing draw the same cells with the same ranges: the
//! pop becomes a fade spread over the band. With `band` at most the hexagon's
//! edge length, every cell within the band of an eye in cell `i` is `i` or one of
//! its neighbours, so evaluating them from `i` loses none ([`weights`]).

use format::grid::HexGrid;
use glam::Vec2;

/// Levels of the dither matrix: a list's range is a sub-range of `0..LEVELS`.
pub const LEVELS: u32 = 64;

/// Most cells a frame blends: the three that meet at a hexagon corner.
pub const MAX_CELLS: usize = 3;

/// The level (0..64) of pixel (x, y) in the 8 × 8 Bayer matrix: the bit-reversed
/// interleave of `x ^ y` and `y` (shader.wgsl `bayer8`, the one the GPU uses).
/// Each 8 × 8 tile holds every level once, and any run of levels `lo..hi` is spread
/// evenly over the tile.
pub fn bayer8(x: u32, y: u32) -> u32 {
    let y = y & 7;
    let z = (x & 7) ^ y;
    ((z & 1) << 5)
        | ((y & 1) << 4)
        | ((z & 2) << 2)
        | ((y & 2) << 1)
        | ((z & 4) >> 1)
        | ((y & 4) >> 2)
}

/// The band of a fade: `fade` × the hexagon's apothem (√3/2 × `cell_size`),
/// `fade` clamped to [0, 1] (then the band is at most the edge length, as
/// [`weights`] needs). 0: no fade.
pub fn band(grid: &HexGrid, fade: f32) -> f32 {
    let apothem = 3f32.sqrt() / 2.0 * grid.cell_size();
    fade.clamp(0.0, 1.0) * apothem
}

/// The distance from `p` (x, z) to cell `id`'s closed hexagon: 0 inside.
pub fn distance_to_hexagon(grid: &HexGrid, id: u32, p: Vec2) -> f32 {
    if grid.in_hexagon(id, p) {
        return 0.0;
    }
    let c = grid.corners(id);
    (0..6)
        .map(|k| {
            let (a, b) = (c[k], c[(k + 1) % 6]);
            let ab = b - a;
            let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            p.distance(a + t * ab)
        })
        .fold(f32::INFINITY, f32::min)
}

/// The cells a frame at `p` blends and their weights (module docs), sorted by id:
/// `current` (the cell `p` is in) with weight 1 when `p` is in its hexagon, and
/// each neighbour within `band`; at most [`MAX_CELLS`], the lightest dropped.
/// Only `current` when `band` is 0.
pub fn weights(grid: &HexGrid, current: u32, p: Vec2, band: f32) -> Vec<(u32, f32)> {
    let weight = |id: u32| {
        if band <= 0.0 {
            return f32::from(id == current);
        }
        (1.0 - distance_to_hexagon(grid, id, p) / band).max(0.0)
    };
    let mut out: Vec<(u32, f32)> = std::iter::once(current)
        .chain(grid.neighbours(current))
        .map(|id| (id, weight(id)))
        .filter(|&(id, w)| w > 0.0 || id == current)
        .collect();
    // The current cell stays even in a border notch (outside every hexagon).
    if let Some(c) = out.iter_mut().find(|(id, _)| *id == current) {
        c.1 = c.1.max(f32::MIN_POSITIVE);
    }
    out.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    out.truncate(MAX_CELLS);
    out.sort_by_key(|&(id, _)| id);
    out
}

/// Each weighted cell's dither range `lo..hi` (levels of [`bayer8`]): the cells in
/// the order given (by id, [`weights`]) share `0..LEVELS` in proportion to their
/// weights, the boundaries rounded to whole levels; cells left with an empty range
/// are dropped. The ranges partition `0..LEVELS` whenever a weight is positive.
pub fn ranges(weights: &[(u32, f32)]) -> Vec<(u32, u32, u32)> {
    let total: f32 = weights.iter().map(|w| w.1.max(0.0)).sum();
    if total <= 0.0 {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(weights.len());
    let (mut acc, mut lo) = (0.0f32, 0u32);
    for (k, &(id, w)) in weights.iter().enumerate() {
        acc += w.max(0.0);
        let hi = if k + 1 == weights.len() {
            LEVELS
        } else {
            ((acc / total) * LEVELS as f32).round().min(LEVELS as f32) as u32
        };
        if hi > lo {
            out.push((id, lo, hi));
            lo = hi;
        }
    }
    // Rounding may leave the last cells empty: the last range ends at LEVELS.
    if let Some(last) = out.last_mut() {
        last.2 = LEVELS;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use format::scene::Ground;
    use proptest::prelude::*;

    fn grid() -> HexGrid {
        HexGrid::new(
            Ground {
                min: [-40.0, -40.0],
                max: [40.0, 40.0],
            },
            5.0,
        )
    }

    /// The Bayer matrix holds every level once per 8 × 8 tile and repeats.
    #[test]
    fn bayer_levels_are_a_permutation_per_tile() {
        let mut seen = [false; 64];
        for y in 0..8 {
            for x in 0..8 {
                let v = bayer8(x, y) as usize;
                assert!(!seen[v], "level {v} twice");
                seen[v] = true;
                assert_eq!(bayer8(x + 8, y + 16), v as u32);
            }
        }
        // The 2 × 2 corner is the classic [[0, 2], [3, 1]] × 16.
        assert_eq!(
            [bayer8(0, 0), bayer8(1, 0), bayer8(0, 1), bayer8(1, 1)],
            [0, 32, 48, 16]
        );
    }

    /// A neighbour's weight rises from 0 at the band's edge to 1 on the shared
    /// edge; the eye's cell weighs 1 inside its hexagon.
    #[test]
    fn weights_ramp_over_the_band() {
        let g = grid();
        let id = g.cell_at(Vec2::ZERO).unwrap();
        let c = g.centre(id);
        let apothem = 3f32.sqrt() / 2.0 * g.cell_size();
        let up = Vec2::new(0.0, 1.0); // a flat-top hexagon has an edge above
        let band = 1.0;
        assert_eq!(weights(&g, id, c, band), vec![(id, 1.0)]);
        let near = c + up * (apothem - 0.25);
        let w = weights(&g, id, near, band);
        assert_eq!(w.len(), 2, "{w:?}");
        let other = w.iter().find(|x| x.0 != id).unwrap();
        assert!((other.1 - 0.75).abs() < 1e-4, "{w:?}");
        assert!(w.iter().any(|x| x.0 == id && x.1 == 1.0));
        assert_eq!(weights(&g, id, near, 0.0), vec![(id, 1.0)]);
    }

    proptest! {
        /// Ranges partition the levels, in the order given, sized by weight
        /// within one level of rounding.
        #[test]
        fn ranges_partition_the_levels(ws in prop::collection::vec(0.0f32..1.0, 1..4)) {
            let weighted: Vec<(u32, f32)> = ws.iter().enumerate().map(|(k, &w)| (k as u32, w)).collect();
            let total: f32 = ws.iter().sum();
            let r = ranges(&weighted);
            if total <= 0.0 {
                prop_assert!(r.is_empty());
            } else {
                prop_assert_eq!(r[0].1, 0);
                prop_assert_eq!(r.last().unwrap().2, LEVELS);
                for pair in r.windows(2) {
                    prop_assert_eq!(pair[0].2, pair[1].1);
                    prop_assert!(pair[0].0 < pair[1].0);
                }
                for &(id, lo, hi) in &r {
                    prop_assert!(lo < hi);
                    let share = ws[id as usize] / total * LEVELS as f32;
                    prop_assert!(((hi - lo) as f32 - share).abs() <= 2.0, "{:?} {:?}", r, ws);
                }
            }
        }

        /// The weights depend on the position only: an eye near an edge gets the
        /// same cells and weights evaluated from either cell of the edge (what
        /// makes the frames before and after a crossing alike).
        #[test]
        fn weights_do_not_depend_on_the_current_cell(x in -30.0f32..30.0, z in -30.0f32..30.0, fade in 0.05f32..1.0) {
            let g = grid();
            let p = Vec2::new(x, z);
            let Some(i) = g.cell_at(p) else { return Ok(()); };
            prop_assume!(g.in_hexagon(i, p));
            let b = band(&g, fade);
            let from_i = weights(&g, i, p, b);
            for &(j, _) in from_i.iter().filter(|w| g.in_hexagon(w.0, p)) {
                let from_j = weights(&g, j, p, b);
                prop_assert_eq!(&from_i, &from_j);
            }
            // Every cell within the band is found from the eye's cell.
            for id in 0..g.cell_count() {
                let d = distance_to_hexagon(&g, id, p);
                if d < b * 0.999 && from_i.len() < MAX_CELLS {
                    prop_assert!(from_i.iter().any(|w| w.0 == id), "{} at {} missing", id, d);
                }
            }
        }
    }
}
