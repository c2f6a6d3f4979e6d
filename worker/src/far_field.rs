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
//! - **outside** ([`crate::bake::draws_as_original`], issue 29): an instance whose
//!   box's footprint misses the group's hexagon misses every cell's hexagon, and
//!   one that overlaps it — a ground mesh under the group — is never far for it;
//!   nor is a chunk any of its cells draws as an original for the cells' margin
//!   ([`crate::grid::instance_draws_as_original`]);
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
//! drawn by every cell of the group. Nearer objects keep per-cell proxies.
//!
//! # Levels (issue 27)
//!
//! One level is not enough for a world: a 7-cell group's far objects are every
//! single-view object of the *whole* world, so what a cell draws grew with the world
//! (park-2m tiled 3 × 3: 50× the far objects of the cell's group). The flower
//! construction repeats: the level-1 centres form a hexagonal lattice of their own
//! — in the basis a = (2, 1), b = (3, −2) (axial), whose six shortest vectors are
//! ±a, ±b, ±(a − b), lattice coordinates `(u, v)` (`(q, r) = u·a + v·b`) are axial
//! coordinates of a hex grid √7 times larger, rotated by atan(√3/5) ≈ 19.1° — so
//! level 2 is the flowers of level-1 groups (49 cells), level 3 of level-2 groups
//! (343 cells), and so on, until one group holds every cell (at most
//! [`MAX_LEVELS`]). Group ids run over the levels, level 1 first (its ids and
//! prisms are those of the one-level far field). Each group names its parent.
//!
//! A level-k group's cells lie within R_k of its centre, R₁ = √7·c (exact) and
//! R_{k+1} = R_k + √3·√7^k·c (its children's centres lie one level-k lattice step,
//! √3·√7^k·c, from its centre; partial groups at the border only shrink); its prism
//! is the flat-top hexagon of inradius R_k ([`level_radius`]), so it holds the prism
//! of every cell and of every child group, and every test above stays conservative.
//!
//! Which group draws an object is decided for a cell's whole chain (level 1, its
//! parent, …): the *highest* group for which the object is far
//! ([`served_instances`]: far for the group, far for none of its ancestors); a
//! cell derives only objects far for no group of its chain ([`FarField::of_cell`]).
//! The sets are disjoint and cover what the cell would have derived. Levels below
//! `bake.merge_level` (default 1: none) keep SvMesh and cluster proxies, one per
//! object, as the one-level far field did; from it on,
//! groups draw merged layered impostors ([`crate::levels`]), and an object is far
//! for such a group only when it also lies at least [`crate::levels::merged_min_distance`] from
//! its centre — a distance proportional to the group's size, so a merged level
//! serves an annulus whose radii scale with the level (× √7 each), and its
//! impostors need at most [`crate::levels::MAX_BANDS`] depth bands per sector:
//! what a cell draws from each level is bounded, and levels grow as log₇ of the
//! world's cells. (The paper's single-view test alone does not scale so: its
//! distance grows only as the square root of the region's size, so the parallax
//! of objects just past it, seen across a large region, would need ever more
//! layers.)

use crate::backface::all_culled;
use crate::grid::{HexGrid, Prism};
use crate::selfocc::{choose_representation, object_self_occluding_error, Representation};
use format::manifest::{BakeParams, CellParams};
use format::Scene;
use rayon::prelude::*;

/// Size (centre-to-corner) of a level-1 group prism in cell sizes: 2√7/√3 (module
/// docs).
pub const GROUP_SIZE_FACTOR: f32 = 3.055_050_5;

/// Most levels of groups a grid gets (7⁸ ≈ 5.8M cells in one top group).
pub const MAX_LEVELS: u32 = format::manifest::MAX_FAR_LEVELS;

/// The groups of a grid at every level (module docs, "Layout" and "Levels"): level 1
/// the 7-cell flowers, level k+1 the flowers of level-k groups. Ids run over all
/// levels, level 1 first (ids `0..level_len(1)`, unchanged from the one-level far
/// field), then level 2, and so on.
#[derive(Clone, Debug, PartialEq)]
pub struct CellGroups {
    /// Per group: its centre's lattice position `(col, row)` (possibly off the grid).
    centres: Vec<(i64, i64)>,
    /// Per group: its level (1, 2, …).
    levels: Vec<u32>,
    /// Per group: its parent (the group of the next level holding its cells).
    parents: Vec<Option<u32>>,
    /// Per group: its cells, ascending.
    cells: Vec<Vec<u32>>,
    /// Per cell: its level-1 group.
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

/// The flower centre of axial `(q, r)`: itself or the one neighbour that is a centre.
fn flower_centre(q: i64, r: i64) -> (i64, i64) {
    let (dq, dr) = std::iter::once((0, 0))
        .chain(AXIAL_NEIGHBOURS)
        .find(|&(dq, dr)| is_centre(q + dq, r + dr))
        .expect("every position is a flower centre or next to exactly one");
    (q + dq, r + dr)
}

/// Lattice coordinates `(u, v)` of flower centre `(q, r)` in the basis
/// a = (2, 1), b = (3, −2) (module docs, "Levels"): `(q, r) = u·a + v·b`.
fn to_lattice(q: i64, r: i64) -> (i64, i64) {
    debug_assert!(is_centre(q, r));
    let v = (q - 2 * r).div_euclid(7);
    (r + 2 * v, v)
}

/// Inverse of [`to_lattice`]: `u·a + v·b`.
fn from_lattice(u: i64, v: i64) -> (i64, i64) {
    (2 * u + 3 * v, u - 2 * v)
}

/// Radius (in cell sizes) of the disc about a level-`level` group's centre that
/// holds every point of its cells (module docs, "Levels"): R₁ = √7, then
/// R_{k+1} = R_k + √3·√7^k (a child's centre lies one level-k lattice step away).
pub fn level_radius(level: u32) -> f64 {
    let (s3, s7) = (3f64.sqrt(), 7f64.sqrt());
    let mut r = s7;
    for k in 1..level.max(1) {
        r += s3 * s7.powi(k as i32);
    }
    r
}

impl CellGroups {
    /// Every level a grid needs (up to [`MAX_LEVELS`]): levels are added until one
    /// has a single group.
    pub fn new(grid: &HexGrid) -> CellGroups {
        CellGroups::with_levels(grid, MAX_LEVELS)
    }

    /// The levels `params.far_levels` asks for (0 = every level the grid needs).
    pub fn for_params(grid: &HexGrid, params: &BakeParams) -> CellGroups {
        match params.far_levels {
            0 => CellGroups::new(grid),
            n => CellGroups::with_levels(grid, n),
        }
    }

    /// At most `max_levels` levels (at least 1); fewer when a level has one group.
    pub fn with_levels(grid: &HexGrid, max_levels: u32) -> CellGroups {
        let n = grid.cell_count();
        // Per cell: its centre at the current level, in that level's lattice
        // coordinates (level 0: the cell's own axial position).
        let mut at: Vec<(i64, i64)> = (0..n)
            .map(|id| {
                let (col, row) = grid.col_row(id);
                axial(col as i64, row as i64)
            })
            .collect();
        let mut groups = CellGroups {
            centres: Vec::new(),
            levels: Vec::new(),
            parents: Vec::new(),
            cells: Vec::new(),
            of_cell: vec![0; n as usize],
        };
        let mut previous: Vec<u32> = Vec::new(); // per cell: its group one level down
        for level in 1..=max_levels.clamp(1, MAX_LEVELS) {
            // Centres at this level, in level-0 axial coordinates for the ordering.
            let mut key_of: Vec<(i64, i64)> = Vec::with_capacity(n as usize);
            for p in at.iter_mut() {
                let (q, r) = flower_centre(p.0, p.1);
                *p = to_lattice(q, r);
                let (mut q0, mut r0) = (q, r);
                for _ in 1..level {
                    (q0, r0) = from_lattice(q0, r0);
                }
                let (c, rw) = offset(q0, r0);
                key_of.push((rw, c));
            }
            let mut keys = key_of.clone();
            keys.sort_unstable();
            keys.dedup();
            let first = groups.cells.len() as u32;
            groups
                .cells
                .extend(std::iter::repeat_n(Vec::new(), keys.len()));
            let mine: Vec<u32> = key_of
                .iter()
                .enumerate()
                .map(|(id, key)| {
                    let g = first + keys.binary_search(key).expect("listed above") as u32;
                    groups.cells[g as usize].push(id as u32);
                    g
                })
                .collect();
            groups
                .centres
                .extend(keys.iter().map(|&(row, col)| (col, row)));
            groups.levels.extend(std::iter::repeat_n(level, keys.len()));
            groups.parents.extend(std::iter::repeat_n(None, keys.len()));
            if level == 1 {
                groups.of_cell = mine.clone();
            } else {
                for (cell, &child) in previous.iter().enumerate() {
                    groups.parents[child as usize] = Some(mine[cell]);
                }
            }
            previous = mine;
            if keys.len() <= 1 {
                break;
            }
        }
        groups
    }

    /// Number of groups over all levels.
    pub fn len(&self) -> u32 {
        self.cells.len() as u32
    }

    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Number of levels.
    pub fn level_count(&self) -> u32 {
        self.levels.last().copied().unwrap_or(0)
    }

    /// The level of a group (1 = 7-cell flowers).
    pub fn level(&self, group: u32) -> u32 {
        self.levels[group as usize]
    }

    /// The group of the next level that holds this group's cells.
    pub fn parent(&self, group: u32) -> Option<u32> {
        self.parents[group as usize]
    }

    /// The level-1 group of a cell of the grid.
    pub fn group_of(&self, cell: u32) -> u32 {
        self.of_cell[cell as usize]
    }

    /// The groups of a cell, level 1 first, then each parent.
    pub fn chain(&self, cell: u32) -> Vec<u32> {
        self.ancestors_and_self(self.group_of(cell))
    }

    /// `group`, then its parent, its parent's parent, … .
    pub fn ancestors_and_self(&self, group: u32) -> Vec<u32> {
        std::iter::successors(Some(group), |&g| self.parent(g)).collect()
    }

    /// The cells of a group, ascending.
    pub fn cells(&self, group: u32) -> &[u32] {
        &self.cells[group as usize]
    }

    /// The group prism (module docs, "The region a group serves" and "Levels").
    pub fn prism(&self, grid: &HexGrid, group: u32, cells: &CellParams) -> Prism {
        let (col, row) = self.centres[group as usize];
        let level = self.level(group);
        let factor = if level <= 1 {
            GROUP_SIZE_FACTOR
        } else {
            (2.0 / 3f64.sqrt() * level_radius(level)) as f32
        };
        Prism {
            centre: grid.lattice_centre(col, row),
            cell_size: factor * grid.cell_size(),
            min_y: cells.min_eye_height,
            max_y: cells.max_eye_height,
        }
    }
}

/// The far test of one group for one instance (module docs): outside the group
/// prism's footprint ([`crate::bake::draws_as_original`]), a single-view object for it, at a merged level no nearer than
/// [`crate::levels::merged_min_distance`], and not regionally back-facing to it. The cheap tests
/// run first: the back-face test reads every triangle.
struct FarTest {
    prism: Prism,
    corners: [glam::Vec3; 12],
    eye: glam::Vec3,
    /// At a merged level: [`crate::levels::merged_min_distance`].
    min_distance: Option<f32>,
    /// The cells' margin for chunks ([`crate::grid::CHUNK_MARGIN_CELLS`] × the
    /// cell's c, not the group's): a chunk any cell of the group draws as an
    /// original is never far for the group.
    chunk_margin: f32,
}

impl FarTest {
    fn new(prism: Prism, merged: bool, params: &BakeParams, chunk_margin: f32) -> FarTest {
        FarTest {
            chunk_margin,
            corners: prism.corners(),
            eye: prism.centre3(),
            min_distance: merged
                .then(|| crate::levels::merged_min_distance(&prism, params.image_res)),
            prism,
        }
    }

    fn of_group(
        grid: &HexGrid,
        groups: &CellGroups,
        group: u32,
        cells: &CellParams,
        params: &BakeParams,
    ) -> FarTest {
        let merged = groups.level(group) >= params.merge_level;
        let chunk_margin = crate::grid::CHUNK_MARGIN_CELLS * grid.cell_size();
        FarTest::new(
            groups.prism(grid, group, cells),
            merged,
            params,
            chunk_margin,
        )
    }

    fn far(&self, scene: &Scene, i: usize, params: &BakeParams) -> bool {
        let inst = &scene.instances[i];
        let Some(model) = scene.models.get(inst.model as usize) else {
            return false;
        };
        if model.mesh.triangles.is_empty() {
            return false;
        }
        let (lo, hi) = scene.instance_bounds(i);
        let chunk = model.chunk_cell.is_some();
        if crate::grid::instance_draws_as_original(&self.prism, lo, hi, chunk, self.chunk_margin) {
            return false;
        }
        let error =
            object_self_occluding_error(self.prism.cell_size, params.image_res, self.eye, lo, hi);
        if choose_representation(error, params.self_occluding_tolerance_px) != Representation::Sv {
            return false;
        }
        if self
            .min_distance
            .is_some_and(|min| self.eye.clamp(lo, hi).distance(self.eye) < min)
        {
            return false;
        }
        !all_culled(&model.mesh, inst.transform, &self.corners)
    }
}

/// What group `group` serves (module docs, "Levels"): its far objects that are far
/// for none of its ancestors (those draw them). Each instance's tests stop at the
/// first answer.
pub fn served_instances(
    scene: &Scene,
    grid: &HexGrid,
    groups: &CellGroups,
    group: u32,
    cells: &CellParams,
    params: &BakeParams,
) -> Vec<bool> {
    let tests: Vec<FarTest> = groups
        .ancestors_and_self(group)
        .into_iter()
        .map(|g| FarTest::of_group(grid, groups, g, cells, params))
        .collect();
    (0..scene.instances.len())
        .into_par_iter()
        .map(|i| {
            tests[0].far(scene, i, params) && !tests[1..].iter().any(|t| t.far(scene, i, params))
        })
        .collect()
}

/// What a cell's bake needs to know of its groups' far field.
#[derive(Clone, Debug, PartialEq)]
pub struct FarField {
    /// The cell's level-1 group (its pack names it; the groups name their parents).
    pub group: u32,
    /// Per instance: drawn from one of the groups' packs, not derived for the cell
    /// (far for at least one group of the cell's chain).
    pub instances: Vec<bool>,
}

impl FarField {
    /// The far field of `cell`'s groups, or `None` when `params.far_field` is off.
    /// An instance's tests run from the top level down and stop at the first group
    /// it is far for (the distant objects of a large world are far for several
    /// levels; the back-face test then reads their triangles once, not per level).
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
        let tests: Vec<FarTest> = groups
            .chain(cell)
            .into_iter()
            .rev()
            .map(|g| FarTest::of_group(grid, groups, g, cells, params))
            .collect();
        let instances = (0..scene.instances.len())
            .into_par_iter()
            .map(|i| tests.iter().any(|t| t.far(scene, i, params)))
            .collect();
        Some(FarField { group, instances })
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
            for k in (0..groups.len()).filter(|&k| groups.level(k) == 1) {
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

    proptest! {
        /// Levels (module docs, "Levels"): at each level every cell is in exactly
        /// one group; a level-k group has at most 7^k cells, and they are the union
        /// of its children's; every cell's prism lies inside the prism of each group
        /// of its chain; parents have larger ids and the top level has one group.
        #[test]
        fn levels_nest_and_contain_their_cells(
            w in 50.0f32..3000.0, h in 50.0f32..3000.0, c in 20.0f32..120.0
        ) {
            let g = grid(w, h, c);
            let groups = CellGroups::new(&g);
            let cells = CellParams { cell_size: c, min_eye_height: 1.0, max_eye_height: 2.0 };
            let levels = groups.level_count();
            prop_assert!(levels >= 1);
            let top: Vec<u32> = (0..groups.len()).filter(|&k| groups.level(k) == levels).collect();
            prop_assert!(top.len() == 1 || levels == MAX_LEVELS);
            for k in 0..groups.len() {
                let level = groups.level(k);
                prop_assert!(groups.cells(k).len() <= 7usize.pow(level));
                if let Some(p) = groups.parent(k) {
                    prop_assert!(p > k && groups.level(p) == level + 1);
                    for m in groups.cells(k) {
                        prop_assert!(groups.cells(p).binary_search(m).is_ok());
                    }
                } else {
                    prop_assert_eq!(level, levels);
                }
            }
            for cell in 0..g.cell_count() {
                let chain = groups.chain(cell);
                prop_assert_eq!(chain.len() as u32, levels);
                for (i, &k) in chain.iter().enumerate() {
                    prop_assert_eq!(groups.level(k), i as u32 + 1);
                    prop_assert!(groups.cells(k).binary_search(&cell).is_ok());
                    let prism = groups.prism(&g, k, &cells);
                    for corner in g.prism_corners(cell, 1.0, 2.0) {
                        prop_assert!(prism.contains(corner), "cell {} group {} corner {:?}", cell, k, corner);
                    }
                }
            }
        }
    }

    #[test]
    fn lattice_coordinates_are_a_hex_grid_of_flower_centres() {
        // The basis a = (2, 1), b = (3, -2) maps the axial neighbours to the six
        // nearest flower centres (hex distance 3).
        for &(du, dv) in &AXIAL_NEIGHBOURS {
            let (q, r) = from_lattice(du, dv);
            assert!(is_centre(q, r));
            assert_eq!((q.abs() + r.abs() + (q + r).abs()) / 2, 3, "{du},{dv}");
            assert_eq!(to_lattice(q, r), (du, dv));
        }
        // A level-2 group of a large grid is 49 cells.
        let g = grid(3000.0, 3000.0, 20.0);
        let groups = CellGroups::with_levels(&g, 2);
        assert_eq!(groups.level_count(), 2);
        assert!((0..groups.len()).any(|k| groups.level(k) == 2 && groups.cells(k).len() == 49));
        // The level radius: R1 = √7, R2 = √7 + √21.
        assert!((level_radius(1) - 7f64.sqrt()).abs() < 1e-12);
        assert!((level_radius(2) - 7f64.sqrt() - 21f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn a_full_flower_has_seven_cells() {
        let g = grid(1650.0, 2035.0, 50.0);
        let groups = CellGroups::with_levels(&g, 1);
        assert!(groups.len() < g.cell_count() / 5);
        assert!((0..groups.len()).any(|k| groups.cells(k).len() == 7));
    }
}
