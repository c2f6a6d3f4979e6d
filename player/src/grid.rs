//! The current view cell from the camera (paper 000 §3.2: the player finds the cell the
//! viewer is in and draws that cell's representation).
//!
//! The layout is [`format::grid::HexGrid`], the very type the worker bakes on
//! (DESIGN.md "Hex grid"); [`CellGrid`] adds the base pack's [`GridParams`] (eye
//! heights) and dereferences to it, so `cell_at`, `nearest_cell`, `centre`,
//! `neighbours`, `corners` are the worker's.

use format::grid::HexGrid;
use format::pack::GridParams;
use std::ops::Deref;

/// The hexagonal cell layout of a bake: its [`HexGrid`] and the parameters it was
/// built from.
#[derive(Clone, Debug, PartialEq)]
pub struct CellGrid {
    params: GridParams,
    hex: HexGrid,
}

impl CellGrid {
    /// The grid of a base pack's parameters.
    ///
    /// # Panics
    /// When `params` do not make a grid; a base pack's are validated on reading
    /// (`GridParams::validate`), which rules that out.
    pub fn new(params: GridParams) -> CellGrid {
        let hex = HexGrid::from_params(&params)
            .unwrap_or_else(|e| panic!("CellGrid::new: unvalidated grid parameters: {e}"));
        debug_assert_eq!((hex.n_cols(), hex.n_rows()), (params.n_cols, params.n_rows));
        CellGrid { params, hex }
    }

    pub fn params(&self) -> &GridParams {
        &self.params
    }

    /// The shared layout.
    pub fn hex(&self) -> &HexGrid {
        &self.hex
    }
}

impl Deref for CellGrid {
    type Target = HexGrid;

    fn deref(&self) -> &HexGrid {
        &self.hex
    }
}
