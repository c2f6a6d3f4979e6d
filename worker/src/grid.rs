//! Hexagonal view-cell grid (DESIGN.md "Hex grid"; paper 000 §3.1.1 "Hexagonal
//! spatial subdivision").
//!
//! The layout lives in [`format::grid`], the one home the player's current-cell
//! lookup shares; this module re-exports it so the worker's stages keep naming
//! `crate::grid::HexGrid`.

pub use format::grid::{GridError, HexGrid, Prism};
