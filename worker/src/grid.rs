//! Hexagonal view-cell grid (DESIGN.md "Hex grid"; paper 000 §3.1.1 "Hexagonal
//! spatial subdivision").
//!
//! The layout lives in [`format::grid`], the one home the player's current-cell
//! lookup shares; this module re-exports it so the worker's stages keep naming
//! `crate::grid::HexGrid`.

pub use format::grid::{GridError, HexGrid, Prism};
use format::manifest::CellParams;
use glam::Vec3;

/// The cell centre at mid eye height.
pub fn cell_eye(grid: &HexGrid, cell: u32, cells: &CellParams) -> Vec3 {
    let c = grid.centre(cell);
    Vec3::new(
        c.x,
        0.5 * (cells.min_eye_height + cells.max_eye_height),
        c.y,
    )
}

/// The split's rule ([`crate::bake`]'s module docs, step 1; issue 29): an object whose world box
/// `[lo, hi]` has a footprint overlapping the region's hexagon is drawn by the
/// region as an original — it stands in, lies under, spans over or encloses part of
/// the region's prism. Everything else is outside: its box misses the column over
/// the hexagon, so the region's centre (the capture eye) is outside the box. The far
/// field's groups ([`crate::far_field`]) apply the same rule to their prisms, so an
/// object is never far for a group whose region it overlaps either.
pub fn draws_as_original(prism: &Prism, lo: Vec3, hi: Vec3) -> bool {
    prism.footprint_overlaps_aabb(lo, hi)
}

/// A chunk of a split object whose footprint comes within this many cell sizes (c)
/// of a region's hexagon is drawn by the region as an original
/// ([`instance_draws_as_original`]; issue 29).
pub const CHUNK_MARGIN_CELLS: f32 = 0.5;

/// The split's rule for an instance whose world box is `[lo, hi]`:
/// [`draws_as_original`], and for a chunk of a split object
/// (`format::Model::chunk_cell`) the same with its box grown by `chunk_margin`
/// (world units: [`CHUNK_MARGIN_CELLS`] × the grid's c) in x and z.
///
/// Why chunks get a margin: a chunk holds the triangles whose centroids lie in its
/// cell, so its footprint may stop a sliver short of a neighbour's hexagon (the
/// terrain example's chunks stop 0.64 units short of the next row's cells), and
/// the neighbour drew the ground at its feet as an MV proxy, captured from cell
/// centres 30 or more units away and smeared at the viewer's grazing angle
/// (frame 240 of the terrain walk: 20.0 dB object PSNR(Y)). With half a cell's
/// margin, every cell draws the chunks of its own and its six neighbours' cells as
/// originals, so the nearest proxied ground lies about a cell away. Measured on
/// the terrain walk (`player compare --reference-ss 1`, llvmpipe): no margin 30.58
/// dB object PSNR(Y) (worst frame 20.05 dB), 2,184 triangles per frame, 13.7 MB
/// of packs; 0.5 c 32.83 dB (worst 25.90 dB, frame 240 43.15 dB), 2,233
/// triangles, 11.1 MB; 1 c 34.15 dB, 2,828 triangles, 9.0 MB. Half a cell takes
/// the neighbours at the cost of 2 % more triangles; a whole cell starts on the
/// second ring (30 % more). Scenes without chunks are not affected.
pub fn instance_draws_as_original(
    prism: &Prism,
    lo: Vec3,
    hi: Vec3,
    chunk: bool,
    chunk_margin: f32,
) -> bool {
    if !chunk {
        return draws_as_original(prism, lo, hi);
    }
    let grow = Vec3::new(chunk_margin, 0.0, chunk_margin);
    draws_as_original(prism, lo - grow, hi + grow)
}
