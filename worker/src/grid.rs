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
