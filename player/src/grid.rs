//! The current view cell from the camera (paper 000 §3.2: the player finds the cell the
//! viewer is in and draws that cell's representation).
//!
//! The player does not link the worker, so this replicates `worker::grid::HexGrid`'s
//! layout exactly from the base pack's [`GridParams`] (DESIGN.md "Hex grid"): flat-top
//! hexagons of centre-to-corner size `c`, columns spaced `1.5·c` in x and centred on the
//! ground, rows spaced `√3·c` in z starting on the ground's min edge, odd columns
//! shifted by `+√3·c/2`, cell id = row·N + col. A point's cell is the grid cell with
//! the nearest centre (exact ties: lower (row, col)); ground points in the zig-zag
//! border notches get the nearest border cell.

use format::pack::GridParams;
use glam::Vec2;

const SQRT3: f32 = 1.732_050_8;

/// The hexagonal cell layout of a bake.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellGrid {
    params: GridParams,
    /// Centre of cell (col 0, row 0).
    origin: Vec2,
}

impl CellGrid {
    pub fn new(params: GridParams) -> CellGrid {
        let c = params.cell_size as f64;
        let w = (params.ground_max[0] - params.ground_min[0]) as f64;
        let strip_width = (params.n_cols.max(1) - 1) as f64 * 1.5 * c;
        let origin_x = params.ground_min[0] as f64 + (w - strip_width) / 2.0;
        CellGrid {
            params,
            origin: Vec2::new(origin_x as f32, params.ground_min[1]),
        }
    }

    pub fn params(&self) -> &GridParams {
        &self.params
    }

    pub fn cell_count(&self) -> u32 {
        self.params.n_cols * self.params.n_rows
    }

    /// `(col, row)` of a cell id.
    pub fn col_row(&self, id: u32) -> (u32, u32) {
        (id % self.params.n_cols, id / self.params.n_cols)
    }

    fn id(&self, col: i64, row: i64) -> Option<u32> {
        let (n, m) = (self.params.n_cols as i64, self.params.n_rows as i64);
        if col < 0 || row < 0 || col >= n || row >= m {
            return None;
        }
        Some(row as u32 * self.params.n_cols + col as u32)
    }

    fn lattice_centre(&self, col: i64, row: i64) -> Vec2 {
        let c = self.params.cell_size;
        let odd = col.rem_euclid(2) == 1;
        Vec2::new(
            self.origin.x + col as f32 * 1.5 * c,
            self.origin.y + row as f32 * SQRT3 * c + if odd { SQRT3 * c / 2.0 } else { 0.0 },
        )
    }

    /// Centre (x, z) of a cell.
    pub fn centre(&self, id: u32) -> Vec2 {
        let (col, row) = self.col_row(id);
        self.lattice_centre(col as i64, row as i64)
    }

    /// Nearest lattice position (maybe outside the grid); `clamp` restricts the
    /// search to the grid's own cells.
    fn nearest(&self, p: Vec2, clamp: bool) -> (i64, i64) {
        let c = self.params.cell_size;
        let (n, m) = (self.params.n_cols as i64, self.params.n_rows as i64);
        let col_guess = ((p.x - self.origin.x) / (1.5 * c)).floor() as i64;
        let (mut lo, mut hi) = (col_guess - 1, col_guess + 2);
        if clamp {
            lo = lo.clamp(0, n - 1);
            hi = hi.clamp(0, n - 1);
        }
        let mut best = (i64::MAX, i64::MAX);
        let mut best_d = f32::INFINITY;
        for col in lo..=hi {
            let off = if col.rem_euclid(2) == 1 {
                SQRT3 * c / 2.0
            } else {
                0.0
            };
            let row_guess = ((p.y - self.origin.y - off) / (SQRT3 * c)).round() as i64;
            let (mut rlo, mut rhi) = (row_guess - 1, row_guess + 1);
            if clamp {
                rlo = rlo.clamp(0, m - 1);
                rhi = rhi.clamp(0, m - 1);
            }
            for row in rlo..=rhi {
                let d = self.lattice_centre(col, row).distance_squared(p);
                if d < best_d || (d == best_d && (row, col) < (best.1, best.0)) {
                    best_d = d;
                    best = (col, row);
                }
            }
        }
        best
    }

    fn ground_contains(&self, p: Vec2) -> bool {
        let g = &self.params;
        p.x >= g.ground_min[0]
            && p.x <= g.ground_max[0]
            && p.y >= g.ground_min[1]
            && p.y <= g.ground_max[1]
    }

    /// The cell of a point (x, z), as `worker::grid::HexGrid::cell_at`: the grid cell
    /// with the nearest centre; `None` off the grid and off the ground.
    pub fn cell_at(&self, p: Vec2) -> Option<u32> {
        if !p.is_finite() || self.cell_count() == 0 {
            return None;
        }
        let (col, row) = self.nearest(p, false);
        if let Some(id) = self.id(col, row) {
            return Some(id);
        }
        if self.ground_contains(p) {
            let (col, row) = self.nearest(p, true);
            return self.id(col, row);
        }
        None
    }

    /// The grid cell with the nearest centre, also for points off the ground (the
    /// player keeps drawing the border cell when the viewer walks off the grid).
    pub fn nearest_cell(&self, p: Vec2) -> Option<u32> {
        if !p.is_finite() || self.cell_count() == 0 {
            return None;
        }
        self.cell_at(p).or_else(|| {
            let (col, row) = self.nearest(p, true);
            self.id(col, row)
        })
    }
}
