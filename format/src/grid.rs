//! Hexagonal view-cell grid (DESIGN.md "Hex grid"; paper 000 §3.1.1 "Hexagonal
//! spatial subdivision").
//!
//! The ground's x–z plane is divided into N × M flat-top regular hexagons of cell
//! size `c` (centre-to-corner, the paper's |VV'|). Layout (an "odd-q" offset grid):
//!
//! * columns are spaced `1.5·c` in x, rows `√3·c` in z;
//! * odd columns are shifted by `+√3·c/2` in z;
//! * `N = ceil(W / 1.5c)`, `M = ceil(H / √3c + 1/2)` for a ground of `W × H`
//!   (the paper's 1650 × 2035 park at c = 50 gives 22 × 24);
//! * the column strip is centred on the ground in x; in z the even columns start
//!   with a centre on the ground's `min` edge, so every column covers the ground's
//!   whole z range;
//! * cell id = row·N + col.
//!
//! **Border notches.** N columns of regular hexagons fully cover a width of only
//! `1.5·N·c − c/2`; with `N = ceil(W / 1.5c)` (the paper's count) the zig-zag left
//! and right borders leave triangular notches up to `(1.5·N·c + c/2 − W) / 2` deep
//! (c/4 for the paper's park) that lie on the ground but in no hexagon. Such ground
//! points belong to the border cell with the nearest centre ([`HexGrid::cell_at`]
//! and [`HexGrid::contains`] agree on that); they lie outside that cell's prism, so
//! the prism-based conservative tests (back-face culling, inside/outside split) hold
//! for them only approximately. Everywhere else a point's cell is the hexagon that
//! contains it, which is also the cell with the nearest centre.
//!
//! Corners are numbered counter-clockwise in the (x, z) plane starting at +x:
//! corner k lies at angle k·60°. Side face k joins corners k and k+1.
//!
//! This is the one implementation of the layout: the worker bakes on it
//! (`worker::grid` re-exports it) and the player finds the viewer's cell with it
//! (`player::grid::CellGrid` wraps it with the base pack's eye heights).

use crate::pack::GridParams;
use crate::Ground;
use glam::{Vec2, Vec3};
use thiserror::Error;

const SQRT3: f32 = 1.732_050_8;

/// Why a grid cannot be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GridError {
    #[error("cell size must be positive and finite, found {cell_size}")]
    BadCellSize { cell_size: f32 },
    #[error("ground must be a finite, non-empty rectangle, found min {min:?} max {max:?}")]
    BadGround { min: [f32; 2], max: [f32; 2] },
    #[error("grid of {n_cols} × {n_rows} cells is too large (more than 2^31 cells)")]
    TooManyCells { n_cols: u64, n_rows: u64 },
}

/// The hexagonal cells covering a ground rectangle.
#[derive(Clone, Debug, PartialEq)]
pub struct HexGrid {
    ground: Ground,
    cell_size: f32,
    n_cols: u32,
    n_rows: u32,
    /// Centre of cell (col 0, row 0).
    origin: Vec2,
}

impl HexGrid {
    /// Builds the grid for a validated ground and cell size.
    ///
    /// # Panics
    /// When `cell_size` is not positive and finite or the ground is empty; a validated
    /// manifest rules both out. Use [`HexGrid::try_new`] for unchecked input.
    pub fn new(ground: Ground, cell_size: f32) -> HexGrid {
        match HexGrid::try_new(ground, cell_size) {
            Ok(grid) => grid,
            Err(e) => panic!("HexGrid::new: {e}"),
        }
    }

    /// The grid a bake was made on, from its `base.pack` parameters.
    pub fn from_params(params: &GridParams) -> Result<HexGrid, GridError> {
        HexGrid::try_new(
            Ground {
                min: params.ground_min,
                max: params.ground_max,
            },
            params.cell_size,
        )
    }

    /// Builds the grid, or says why the ground / cell size cannot make one.
    pub fn try_new(ground: Ground, cell_size: f32) -> Result<HexGrid, GridError> {
        if !(cell_size.is_finite() && cell_size > 0.0) {
            return Err(GridError::BadCellSize { cell_size });
        }
        let [w, h] = ground.size();
        let finite = ground
            .min
            .iter()
            .chain(ground.max.iter())
            .all(|v| v.is_finite());
        if !(finite && w > 0.0 && h > 0.0) {
            return Err(GridError::BadGround {
                min: ground.min,
                max: ground.max,
            });
        }
        let Some([n_cols, n_rows]) = ground.hex_grid_dims(cell_size) else {
            return Err(GridError::BadGround {
                min: ground.min,
                max: ground.max,
            });
        };
        if n_cols.saturating_mul(n_rows) > (1u64 << 31) {
            return Err(GridError::TooManyCells { n_cols, n_rows });
        }
        let c = cell_size as f64;
        let strip_width = (n_cols - 1) as f64 * 1.5 * c;
        let origin_x = ground.min[0] as f64 + (w as f64 - strip_width) / 2.0;
        Ok(HexGrid {
            ground,
            cell_size,
            n_cols: n_cols as u32,
            n_rows: n_rows as u32,
            origin: Vec2::new(origin_x as f32, ground.min[1]),
        })
    }

    pub fn ground(&self) -> Ground {
        self.ground
    }

    /// Centre-to-corner distance `c`.
    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }

    /// N, the number of columns (along x).
    pub fn n_cols(&self) -> u32 {
        self.n_cols
    }

    /// M, the number of rows (along z).
    pub fn n_rows(&self) -> u32 {
        self.n_rows
    }

    pub fn cell_count(&self) -> u32 {
        self.n_cols * self.n_rows
    }

    /// `(col, row)` of a cell id.
    pub fn col_row(&self, id: u32) -> (u32, u32) {
        (id % self.n_cols, id / self.n_cols)
    }

    /// Cell id of `(col, row)`, `None` outside the grid.
    pub fn id(&self, col: i64, row: i64) -> Option<u32> {
        if col < 0 || row < 0 || col >= self.n_cols as i64 || row >= self.n_rows as i64 {
            return None;
        }
        Some(row as u32 * self.n_cols + col as u32)
    }

    /// Centre (x, z) of a lattice position `(col, row)`, also outside the grid.
    pub fn lattice_centre(&self, col: i64, row: i64) -> Vec2 {
        let c = self.cell_size;
        Vec2::new(
            self.origin.x + col as f32 * 1.5 * c,
            self.origin.y + row as f32 * SQRT3 * c + self.column_offset(col),
        )
    }

    /// How far up column `col`'s centres sit: odd columns half a cell height.
    fn column_offset(&self, col: i64) -> f32 {
        if col.rem_euclid(2) == 1 {
            SQRT3 * self.cell_size / 2.0
        } else {
            0.0
        }
    }

    /// The lattice column nearest `p` from the left; the nearest centre is in it,
    /// the one before or the two after.
    fn column_guess(&self, p: Vec2) -> i64 {
        ((p.x - self.origin.x) / (1.5 * self.cell_size)).floor() as i64
    }

    /// The row of column `col` whose centre is nearest `p` along y.
    fn row_guess(&self, p: Vec2, col: i64) -> i64 {
        ((p.y - self.origin.y - self.column_offset(col)) / (SQRT3 * self.cell_size)).round() as i64
    }

    /// Centre (x, z) of a cell.
    pub fn centre(&self, id: u32) -> Vec2 {
        let (col, row) = self.col_row(id);
        self.lattice_centre(col as i64, row as i64)
    }

    /// Lattice position `(col, row)` (possibly outside the grid) whose centre is
    /// nearest to `p`; exact ties go to the lower (row, col).
    fn nearest_lattice(&self, p: Vec2) -> (i64, i64) {
        let col_guess = self.column_guess(p);
        let mut best = (i64::MAX, i64::MAX);
        let mut best_d = f32::INFINITY;
        for col in col_guess - 1..=col_guess + 2 {
            let row_guess = self.row_guess(p, col);
            for row in row_guess - 1..=row_guess + 1 {
                let d = self.lattice_centre(col, row).distance_squared(p);
                if d < best_d || (d == best_d && (row, col) < (best.1, best.0)) {
                    best_d = d;
                    best = (col, row);
                }
            }
        }
        best
    }

    /// Nearest grid cell to `p` among the grid's own cells (for border notches).
    fn nearest_in_grid(&self, p: Vec2) -> u32 {
        let col_guess = self.column_guess(p);
        let mut best = u32::MAX;
        let mut best_d = f32::INFINITY;
        let lo = (col_guess - 1).clamp(0, self.n_cols as i64 - 1);
        let hi = (col_guess + 2).clamp(0, self.n_cols as i64 - 1);
        for col in lo..=hi {
            let row_guess = self.row_guess(p, col);
            let rlo = (row_guess - 1).clamp(0, self.n_rows as i64 - 1);
            let rhi = (row_guess + 1).clamp(0, self.n_rows as i64 - 1);
            for row in rlo..=rhi {
                let id = self.id(col, row).expect("clamped into the grid");
                let d = self.centre(id).distance_squared(p);
                if d < best_d || (d == best_d && id < best) {
                    best_d = d;
                    best = id;
                }
            }
        }
        best
    }

    fn ground_contains(&self, p: Vec2) -> bool {
        p.x >= self.ground.min[0]
            && p.x <= self.ground.max[0]
            && p.y >= self.ground.min[1]
            && p.y <= self.ground.max[1]
    }

    /// The cell of a point (x, z): the grid cell with the nearest centre, `None` off
    /// the grid (neither in a cell's hexagon nor on the ground). Ground points in a
    /// border notch (module docs) get the nearest border cell.
    pub fn cell_at(&self, p: Vec2) -> Option<u32> {
        if !p.is_finite() {
            return None;
        }
        let (col, row) = self.nearest_lattice(p);
        if let Some(id) = self.id(col, row) {
            return Some(id);
        }
        if self.ground_contains(p) {
            return Some(self.nearest_in_grid(p));
        }
        None
    }

    /// The grid cell with the nearest centre, also for points off the ground (the
    /// player keeps drawing the border cell when the viewer walks off the grid);
    /// `None` only for a non-finite `p`.
    pub fn nearest_cell(&self, p: Vec2) -> Option<u32> {
        if !p.is_finite() {
            return None;
        }
        self.cell_at(p).or_else(|| Some(self.nearest_in_grid(p)))
    }

    /// Whether `p` (x, z) is in the cell's closed hexagon.
    pub fn in_hexagon(&self, id: u32, p: Vec2) -> bool {
        let d = (p - self.centre(id)).abs();
        let c = self.cell_size;
        // Flat-top hexagon: |z| ≤ √3c/2 and √3|x| + |z| ≤ √3c.
        let tol = 1e-5 * c;
        d.y <= SQRT3 * c / 2.0 + tol && SQRT3 * d.x + d.y <= SQRT3 * c + tol
    }

    /// The distance from `p` (x, z) to the nearest edge of the hexagon of its cell
    /// ([`HexGrid::cell_at`]): how far the viewer is from crossing into another
    /// cell (issue 31's "frames near a border"). 0 on an edge, at most the apothem
    /// √3c/2 at the centre; `None` off the grid. In a border notch (outside every
    /// hexagon) it is 0.
    pub fn distance_to_border(&self, p: Vec2) -> Option<f32> {
        let id = self.cell_at(p)?;
        let d = p - self.centre(id);
        let apothem = SQRT3 * self.cell_size / 2.0;
        // Flat-top hexagon: edge normals at 90° and ±30° from +x.
        let reach =
            d.y.abs()
                .max((SQRT3 / 2.0 * d.x + 0.5 * d.y).abs())
                .max((SQRT3 / 2.0 * d.x - 0.5 * d.y).abs());
        Some((apothem - reach).max(0.0))
    }

    /// Whether the point (x, z) belongs to the cell: its hexagon, or for a border
    /// cell the part of a border notch nearest to it. Points on a shared edge
    /// belong to both hexagons; [`HexGrid::cell_at`] picks one of them.
    pub fn contains(&self, id: u32, p: Vec2) -> bool {
        if self.in_hexagon(id, p) {
            return true;
        }
        let (col, _) = self.col_row(id);
        let border = col == 0 || col + 1 == self.n_cols;
        border
            && self.ground_contains(p)
            && self.id_of_nearest_lattice(p).is_none()
            && self.nearest_in_grid(p) == id
    }

    fn id_of_nearest_lattice(&self, p: Vec2) -> Option<u32> {
        let (col, row) = self.nearest_lattice(p);
        self.id(col, row)
    }

    /// The up to 6 adjacent cells, sorted by id.
    pub fn neighbours(&self, id: u32) -> Vec<u32> {
        let (col, row) = self.col_row(id);
        let (col, row) = (col as i64, row as i64);
        // Odd columns are shifted +z: their side neighbours are rows (row, row+1);
        // even columns' side neighbours are rows (row-1, row).
        let side = if col % 2 == 1 {
            [row, row + 1]
        } else {
            [row - 1, row]
        };
        let candidates = [
            (col, row - 1),
            (col, row + 1),
            (col - 1, side[0]),
            (col - 1, side[1]),
            (col + 1, side[0]),
            (col + 1, side[1]),
        ];
        let mut out: Vec<u32> = candidates
            .iter()
            .filter_map(|&(c, r)| self.id(c, r))
            .collect();
        out.sort_unstable();
        out
    }

    /// The hexagon's corners (x, z), counter-clockwise from +x (corner k at k·60°).
    pub fn corners(&self, id: u32) -> [Vec2; 6] {
        hexagon_corners(self.centre(id), self.cell_size)
    }

    /// The view region's 12 corners: the 6 hexagon corners at `min_eye` height
    /// (y), then the same 6 at `max_eye`.
    pub fn prism_corners(&self, id: u32, min_eye: f32, max_eye: f32) -> [Vec3; 12] {
        self.prism(id, min_eye, max_eye).corners()
    }

    /// The 6 side faces as view windows: face k is
    /// `[bottom_k, bottom_k+1, top_k+1, top_k]` (corner numbering as above).
    pub fn side_faces(&self, id: u32, min_eye: f32, max_eye: f32) -> [[Vec3; 4]; 6] {
        self.prism(id, min_eye, max_eye).side_faces()
    }

    /// The cell's view region: its hexagon extruded from `min_eye` to `max_eye`.
    pub fn prism(&self, id: u32, min_eye: f32, max_eye: f32) -> Prism {
        Prism {
            centre: self.centre(id),
            cell_size: self.cell_size,
            min_y: min_eye.min(max_eye),
            max_y: min_eye.max(max_eye),
        }
    }

    /// A point of the cell's prism from three numbers in [0, 1] (uniform in the
    /// prism's volume for uniform `u, v, w`); see [`Prism::sample`].
    pub fn sample_point_in_prism(
        &self,
        id: u32,
        min_eye: f32,
        max_eye: f32,
        u: f32,
        v: f32,
        w: f32,
    ) -> Vec3 {
        self.prism(id, min_eye, max_eye).sample(u, v, w)
    }
}

fn hexagon_corners(centre: Vec2, c: f32) -> [Vec2; 6] {
    // cos/sin of k·60°, written out so that corners shared by neighbours round alike.
    const DIRS: [(f32, f32); 6] = [
        (1.0, 0.0),
        (0.5, SQRT3 / 2.0),
        (-0.5, SQRT3 / 2.0),
        (-1.0, 0.0),
        (-0.5, -SQRT3 / 2.0),
        (0.5, -SQRT3 / 2.0),
    ];
    DIRS.map(|(dx, dz)| Vec2::new(centre.x + dx * c, centre.y + dz * c))
}

/// A cell's view region: a regular flat-top hexagon in x–z extruded along y
/// between two eye heights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prism {
    /// Hexagon centre (x, z).
    pub centre: Vec2,
    /// Centre-to-corner distance.
    pub cell_size: f32,
    pub min_y: f32,
    pub max_y: f32,
}

impl Prism {
    /// Hexagon corners (x, z), counter-clockwise from +x.
    pub fn hexagon(&self) -> [Vec2; 6] {
        hexagon_corners(self.centre, self.cell_size)
    }

    /// 6 corners at `min_y`, then 6 at `max_y`.
    pub fn corners(&self) -> [Vec3; 12] {
        let hex = self.hexagon();
        std::array::from_fn(|i| {
            let p = hex[i % 6];
            Vec3::new(p.x, if i < 6 { self.min_y } else { self.max_y }, p.y)
        })
    }

    /// Face k = `[bottom_k, bottom_k+1, top_k+1, top_k]`.
    pub fn side_faces(&self) -> [[Vec3; 4]; 6] {
        let c = self.corners();
        std::array::from_fn(|k| {
            let k1 = (k + 1) % 6;
            [c[k], c[k1], c[6 + k1], c[6 + k]]
        })
    }

    /// Centre of the prism (hexagon centre at mid height).
    pub fn centre3(&self) -> Vec3 {
        Vec3::new(
            self.centre.x,
            0.5 * (self.min_y + self.max_y),
            self.centre.y,
        )
    }

    /// Closed point-in-prism test.
    pub fn contains(&self, p: Vec3) -> bool {
        if p.y < self.min_y || p.y > self.max_y {
            return false;
        }
        let d = (Vec2::new(p.x, p.z) - self.centre).abs();
        let c = self.cell_size;
        let tol = 1e-5 * c;
        d.y <= SQRT3 * c / 2.0 + tol && SQRT3 * d.x + d.y <= SQRT3 * c + tol
    }

    /// The point of the (closed) prism nearest to `p`: `p` itself inside, else the
    /// nearest point of the hexagon in x–z (nearest point on the nearest edge when
    /// outside) with y clamped to the prism's eye heights (the prism is a product of
    /// the two, so the nearest point is the product of the nearest points).
    pub fn closest_point(&self, p: Vec3) -> Vec3 {
        let y = p.y.clamp(self.min_y, self.max_y);
        let q = Vec2::new(p.x, p.z);
        let hex = self.hexagon();
        // Inside: on the inner side of every edge (counter-clockwise corners).
        let inside = (0..6).all(|k| {
            let (a, b) = (hex[k], hex[(k + 1) % 6]);
            (b - a).perp_dot(q - a) >= 0.0
        });
        let xz = if inside {
            q
        } else {
            let mut best = q;
            let mut best_d = f32::INFINITY;
            for k in 0..6 {
                let (a, b) = (hex[k], hex[(k + 1) % 6]);
                let ab = b - a;
                let t = ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                let c = a + t * ab;
                let d = c.distance_squared(q);
                if d < best_d {
                    best_d = d;
                    best = c;
                }
            }
            best
        };
        Vec3::new(xz.x, y, xz.y)
    }

    /// Whether the axis-aligned box `[min, max]` intersects the (closed) prism.
    ///
    /// Both are prisms along y, so this is a y-interval overlap plus a 2D
    /// separating-axis test between the hexagon and the box's x–z rectangle (axes:
    /// x, z and the hexagon's three edge normals). It is exact up to a relative
    /// tolerance of 1e-5·c, which it errs on the side of "intersects", so it is
    /// conservative.
    pub fn intersects_aabb(&self, min: Vec3, max: Vec3) -> bool {
        let tol = 1e-5 * self.cell_size;
        if max.y < self.min_y - tol || min.y > self.max_y + tol {
            return false;
        }
        self.footprint_overlaps_aabb(min, max)
    }

    /// Whether the x–z footprint of the box `[min, max]` (its rectangle seen from
    /// above) overlaps the (closed) hexagon, whatever their heights: the box lies
    /// under, over, across or around part of the prism. The separating-axis test of
    /// [`Prism::intersects_aabb`] without its y-interval test, with the same
    /// tolerance towards "overlaps".
    pub fn footprint_overlaps_aabb(&self, min: Vec3, max: Vec3) -> bool {
        let c = self.cell_size;
        let tol = 1e-5 * c;
        let hex = self.hexagon();
        let rect = [
            Vec2::new(min.x, min.z),
            Vec2::new(max.x, min.z),
            Vec2::new(max.x, max.z),
            Vec2::new(min.x, max.z),
        ];
        let axes = [
            Vec2::X,
            Vec2::Y,
            Vec2::new(SQRT3 / 2.0, 0.5),
            Vec2::new(SQRT3 / 2.0, -0.5),
        ];
        for axis in axes {
            let (h0, h1) = project(&hex, axis);
            let (r0, r1) = project(&rect, axis);
            if r1 < h0 - tol || r0 > h1 + tol {
                return false;
            }
        }
        true
    }

    /// A point of the prism from `u, v, w` in [0, 1]: the hexagon is split into 6
    /// equal triangles (centre, corner k, corner k+1); `u` picks the triangle and,
    /// rescaled, with `v` a uniform point in it; `w` the height. Uniform inputs give
    /// a uniform point of the prism.
    pub fn sample(&self, u: f32, v: f32, w: f32) -> Vec3 {
        let u = u.clamp(0.0, 1.0);
        let v = v.clamp(0.0, 1.0);
        let w = w.clamp(0.0, 1.0);
        let k = ((u * 6.0) as usize).min(5);
        let s = (u * 6.0 - k as f32).clamp(0.0, 1.0);
        let hex = self.hexagon();
        let a = hex[k];
        let b = hex[(k + 1) % 6];
        // Uniform in triangle (centre, a, b): sqrt warp on the first coordinate.
        let r = s.sqrt();
        let p = self.centre + r * ((1.0 - v) * (a - self.centre) + v * (b - self.centre));
        Vec3::new(p.x, self.min_y + w * (self.max_y - self.min_y), p.y)
    }
}

fn project(points: &[Vec2], axis: Vec2) -> (f32, f32) {
    points
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            let d = p.dot(axis);
            (lo.min(d), hi.max(d))
        })
}
