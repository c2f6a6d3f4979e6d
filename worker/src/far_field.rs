//! The far field shared by groups of cells (issue 13 item 2, "output-sensitive
//! bakes"; DESIGN.md "Cost structure"). Not in the paper: 000 §3.1 gives every cell
//! its own proxy of every outside object, however far. Far away, a proxy barely
//! depends on where in a cell the viewer stands, so neighbouring cells can share it.
//!
//! # Layout: 7-cell flowers
//!
//! The hex grid is tiled by *flowers*: a centre cell and its six neighbours. In axial
//! coordinates (q = col, r = row − (col − (col & 1)) / 2 for the grid's odd-q
//! layout) the flower centres are the cells with (q − 2r) ≡ 0 (mod 7): a lattice of
//! index 7 spanned by (2, 1) and (3, −2), whose six shortest vectors are 3 cells long,
//! so the flowers are disjoint and cover the plane. Each of a cell's seven candidate
//! centres (itself and its neighbours) has a different (q − 2r) mod 7, so exactly one
//! of them is a centre: the cell's group. Flowers cut by the grid's border keep the
//! cells they have (a group of 1 to 7 cells); its centre may lie off the grid. Groups
//! are numbered by their centres' (row, col), ascending.
//!
//! # The region a group serves
//!
//! A flower lies within √7·c of its centre (its farthest corners), so inside the
//! flat-top hexagon of inradius √7·c, i.e. of size (centre-to-corner)
//! `GROUP_SIZE_FACTOR`·c = 2√7/√3·c ≈ 3.06 c, extruded between the eye heights. That
//! *group prism* contains the prism of every cell of the group; every test made
//! against it is conservative for each of them:
//! - **outside**: an instance whose box misses the group prism misses every cell's
//!   prism;
//! - **self-occluding error** (000 §3.1.2) from the group centre with c = the group
//!   prism's size (the farthest viewpoint |VV'| of its region): below T_s, the object
//!   is a single-view object for the whole group;
//! - **regional back-face culling** (000 §3.1.5) over the group prism's 12 corners;
//! - the **deviation bound** and the **LOD chain start level** (worker `simplify.rs`,
//!   `lod_chain.rs`) measure from the group prism's nearest point, and T_l from the
//!   group centre, the capture eye.
//!
//! An outside object that is single-view for the whole group (and not culled from
//! it) is a *far* object of the group: it gets one SvMesh or cluster proxy, derived
//! once from the group centre exactly as a cell derives its SV proxies (captures,
//! classes, weights, collapse, clustering), stored once in `groups/<id>.pack` and
//! drawn by every cell of the group. Nearer objects keep per-cell proxies. One level
//! of groups: a second level (49 cells) would serve only objects √7 times farther
//! still, of which the paper's parks have few.

use crate::backface::all_culled;
use crate::grid::{HexGrid, Prism};
use crate::selfocc::{choose_representation, object_self_occluding_error, Representation};
use format::manifest::{BakeParams, CellParams};
use format::Scene;
use rayon::prelude::*;

/// Size (centre-to-corner) of a group prism in cell sizes: 2√7/√3 (module docs).
pub const GROUP_SIZE_FACTOR: f32 = 3.055_050_5;

/// The 7-cell groups of a grid (module docs, "Layout").
#[derive(Clone, Debug, PartialEq)]
pub struct CellGroups {
    /// Per group: its centre's lattice position `(col, row)` (possibly off the grid).
    centres: Vec<(i64, i64)>,
    /// Per group: its cells, ascending.
    cells: Vec<Vec<u32>>,
    /// Per cell: its group.
    of_cell: Vec<u32>,
}

/// Axial coordinates `(q, r)` of an odd-q offset position.
fn axial(col: i64, row: i64) -> (i64, i64) {
    (col, row - (col - col.rem_euclid(2)) / 2)
}

/// Odd-q offset position `(col, row)` of axial `(q, r)`.
fn offset(q: i64, r: i64) -> (i64, i64) {
    (q, r + (q - q.rem_euclid(2)) / 2)
}

/// Axial steps to the six neighbours.
const AXIAL_NEIGHBOURS: [(i64, i64); 6] = [(1, 0), (1, -1), (0, -1), (-1, 0), (-1, 1), (0, 1)];

/// Whether axial `(q, r)` is a flower centre.
fn is_centre(q: i64, r: i64) -> bool {
    (q - 2 * r).rem_euclid(7) == 0
}

impl CellGroups {
    pub fn new(grid: &HexGrid) -> CellGroups {
        let n = grid.cell_count();
        let centre_of: Vec<(i64, i64)> = (0..n)
            .map(|id| {
                let (col, row) = grid.col_row(id);
                let (q, r) = axial(col as i64, row as i64);
                let (dq, dr) = std::iter::once((0, 0))
                    .chain(AXIAL_NEIGHBOURS)
                    .find(|&(dq, dr)| is_centre(q + dq, r + dr))
                    .expect("every cell is a flower centre or next to exactly one");
                let (c, rw) = offset(q + dq, r + dr);
                (rw, c)
            })
            .collect();
        let mut centres: Vec<(i64, i64)> = centre_of.clone();
        centres.sort_unstable();
        centres.dedup();
        let mut cells = vec![Vec::new(); centres.len()];
        let of_cell: Vec<u32> = centre_of
            .iter()
            .enumerate()
            .map(|(id, key)| {
                let g = centres.binary_search(key).expect("listed above");
                cells[g].push(id as u32);
                g as u32
            })
            .collect();
        CellGroups {
            centres: centres.into_iter().map(|(row, col)| (col, row)).collect(),
            cells,
            of_cell,
        }
    }

    /// Number of groups.
    pub fn len(&self) -> u32 {
        self.cells.len() as u32
    }

    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The group of a cell of the grid.
    pub fn group_of(&self, cell: u32) -> u32 {
        self.of_cell[cell as usize]
    }

    /// The cells of a group, ascending.
    pub fn cells(&self, group: u32) -> &[u32] {
        &self.cells[group as usize]
    }

    /// The group prism (module docs, "The region a group serves").
    pub fn prism(&self, grid: &HexGrid, group: u32, cells: &CellParams) -> Prism {
        let (col, row) = self.centres[group as usize];
        Prism {
            centre: grid.lattice_centre(col, row),
            cell_size: GROUP_SIZE_FACTOR * grid.cell_size(),
            min_y: cells.min_eye_height,
            max_y: cells.max_eye_height,
        }
    }
}

/// The far objects of a group: per instance, whether it is outside the group prism,
/// not regionally back-facing to it, and a single-view object for it (module docs).
/// Deterministic and independent of the thread count.
pub fn far_instances(scene: &Scene, prism: &Prism, params: &BakeParams) -> Vec<bool> {
    let corners = prism.corners();
    let eye = prism.centre3();
    (0..scene.instances.len())
        .into_par_iter()
        .map(|i| {
            let inst = &scene.instances[i];
            let Some(model) = scene.models.get(inst.model as usize) else {
                return false;
            };
            if model.mesh.triangles.is_empty() {
                return false;
            }
            let (lo, hi) = scene.instance_bounds(i);
            if prism.intersects_aabb(lo, hi) || all_culled(&model.mesh, inst.transform, &corners) {
                return false;
            }
            let error = object_self_occluding_error(prism.cell_size, params.image_res, eye, lo, hi);
            choose_representation(error, params.self_occluding_tolerance_px) == Representation::Sv
        })
        .collect()
}

/// What a cell's bake needs to know of its group's far field.
#[derive(Clone, Debug, PartialEq)]
pub struct FarField {
    pub group: u32,
    /// Per instance: drawn from the group's pack, not derived for the cell.
    pub instances: Vec<bool>,
}

impl FarField {
    /// The far field of `cell`'s group, or `None` when `params.far_field` is off.
    pub fn of_cell(
        scene: &Scene,
        grid: &HexGrid,
        groups: &CellGroups,
        cell: u32,
        cells: &CellParams,
        params: &BakeParams,
    ) -> Option<FarField> {
        if !params.far_field || cell >= grid.cell_count() {
            return None;
        }
        let group = groups.group_of(cell);
        let prism = groups.prism(grid, group, cells);
        Some(FarField {
            group,
            instances: far_instances(scene, &prism, params),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use format::Ground;
    use proptest::prelude::*;

    fn grid(w: f32, h: f32, c: f32) -> HexGrid {
        HexGrid::new(
            Ground {
                min: [0.0, 0.0],
                max: [w, h],
            },
            c,
        )
    }

    #[test]
    fn offset_and_axial_are_inverse() {
        for col in -9..9 {
            for row in -9..9 {
                let (q, r) = axial(col, row);
                assert_eq!(offset(q, r), (col, row));
            }
        }
    }

    #[test]
    fn axial_neighbours_are_the_grids_neighbours() {
        let g = grid(1000.0, 1000.0, 50.0);
        for id in [0, 1, 30, 31, 77, g.cell_count() - 1] {
            let (col, row) = g.col_row(id);
            let (q, r) = axial(col as i64, row as i64);
            let mut mine: Vec<u32> = AXIAL_NEIGHBOURS
                .iter()
                .filter_map(|&(dq, dr)| {
                    let (c, rw) = offset(q + dq, r + dr);
                    g.id(c, rw)
                })
                .collect();
            mine.sort_unstable();
            assert_eq!(mine, g.neighbours(id), "cell {id}");
        }
    }

    proptest! {
        /// Every cell is in exactly one group; a group is its centre's flower (at
        /// most 7 cells, each the centre or one of its neighbours), and every cell's
        /// prism lies inside its group prism.
        #[test]
        fn groups_partition_the_grid_into_flowers(
            w in 50.0f32..2000.0, h in 50.0f32..2000.0, c in 20.0f32..120.0
        ) {
            let g = grid(w, h, c);
            let groups = CellGroups::new(&g);
            let cells = CellParams { cell_size: c, min_eye_height: 1.0, max_eye_height: 2.0 };
            let mut seen = vec![0u32; g.cell_count() as usize];
            for k in 0..groups.len() {
                let members = groups.cells(k);
                prop_assert!(!members.is_empty() && members.len() <= 7);
                let prism = groups.prism(&g, k, &cells);
                for &m in members {
                    seen[m as usize] += 1;
                    prop_assert_eq!(groups.group_of(m), k);
                    let d = g.centre(m).distance(prism.centre);
                    prop_assert!(d < 1e-3 * c || (d - 3f32.sqrt() * c).abs() < 1e-3 * c);
                    for corner in g.prism_corners(m, 1.0, 2.0) {
                        // The group prism's `contains` has a relative tolerance.
                        prop_assert!(prism.contains(corner), "cell {} corner {:?}", m, corner);
                    }
                }
            }
            prop_assert!(seen.iter().all(|&n| n == 1));
        }
    }

    #[test]
    fn a_full_flower_has_seven_cells() {
        let g = grid(1650.0, 2035.0, 50.0);
        let groups = CellGroups::new(&g);
        assert!(groups.len() < g.cell_count() / 5);
        assert!((0..groups.len()).any(|k| groups.cells(k).len() == 7));
    }
}
