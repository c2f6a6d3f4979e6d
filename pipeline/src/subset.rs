//! `pipeline run --cells SPEC`: bake only the jobs that contain some cells — for
//! benchmarks on machines too small to bake a whole scene (issue 8), e.g. every cell
//! a camera path walks through plus their neighbours, so that the player's prefetcher
//! (000 §3.2) finds packs for the cells it asks for.
//!
//! SPEC is a comma-separated list of
//! - `ID`: a cell id of this grid;
//! - `path:FILE.ron`: every cell a camera path's sampled eye positions fall in
//!   ([`format::path::CameraPath::frames`]) and all their grid neighbours;
//! - `at:X:Z`: the cell containing the ground point (X, Z);
//! - `grid:SIZE:ID`: the cell containing the centre of cell ID of the grid with cell
//!   size SIZE on the same ground — the same places across cell sizes (the paper's
//!   Table 5 compares cell sizes 50 and 100).
//!
//! A job is baked whole (its fingerprint covers its cells), so a few more cells than
//! requested may be baked; the index lists every baked cell and no other, and the
//! player draws a cell that is not in the index as original geometry.

use format::path::CameraPath;
use glam::Vec2;
use std::collections::BTreeSet;
use std::path::PathBuf;
use worker::grid::HexGrid;
use worker::job::Job;

/// One item of a `--cells` list.
#[derive(Clone, Debug, PartialEq)]
pub enum CellSpecItem {
    Id(u32),
    Path(PathBuf),
    At(f32, f32),
    OtherGrid { cell_size: f32, id: u32 },
}

#[derive(Debug, thiserror::Error)]
pub enum CellSpecError {
    #[error("--cells {item:?}: {reason}")]
    Syntax { item: String, reason: String },
    #[error("--cells: empty list")]
    Empty,
    #[error("--cells {id}: no such cell; the grid has {count} cells (0..{count})")]
    NoSuchCell { id: u32, count: u32 },
    #[error("--cells {item}: ({x}, {z}) is off the grid")]
    OffGrid { item: String, x: f32, z: f32 },
    #[error("--cells grid:{cell_size}:{id}: {reason}")]
    OtherGrid {
        cell_size: f32,
        id: u32,
        reason: String,
    },
    #[error("--cells path:{path}: {source}")]
    Path {
        path: PathBuf,
        source: format::path::PathError,
    },
    #[error("--cells path:{path}: the path has no frames on the grid")]
    EmptyPath { path: PathBuf },
}

fn syntax(item: &str, reason: &str) -> CellSpecError {
    CellSpecError::Syntax {
        item: item.to_string(),
        reason: reason.to_string(),
    }
}

/// Parses a `--cells` list. Relative `path:` files are taken as given (relative to
/// the working directory, like every other command-line path).
pub fn parse_cell_spec(spec: &str) -> Result<Vec<CellSpecItem>, CellSpecError> {
    let mut items = Vec::new();
    for raw in spec.split(',') {
        let item = raw.trim();
        if item.is_empty() {
            continue;
        }
        let number = |s: &str| {
            s.trim()
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| syntax(item, "expected a finite number"))
        };
        let id = |s: &str| {
            s.trim()
                .parse::<u32>()
                .map_err(|_| syntax(item, "expected a cell id (a non-negative integer)"))
        };
        let parsed = if let Some(file) = item.strip_prefix("path:") {
            if file.is_empty() {
                return Err(syntax(item, "expected path:FILE.ron"));
            }
            CellSpecItem::Path(PathBuf::from(file))
        } else if let Some(rest) = item.strip_prefix("at:") {
            let (x, z) = rest
                .split_once(':')
                .ok_or_else(|| syntax(item, "expected at:X:Z"))?;
            CellSpecItem::At(number(x)?, number(z)?)
        } else if let Some(rest) = item.strip_prefix("grid:") {
            let (size, cell) = rest
                .split_once(':')
                .ok_or_else(|| syntax(item, "expected grid:SIZE:ID"))?;
            CellSpecItem::OtherGrid {
                cell_size: number(size)?,
                id: id(cell)?,
            }
        } else {
            CellSpecItem::Id(id(item)?)
        };
        items.push(parsed);
    }
    if items.is_empty() {
        return Err(CellSpecError::Empty);
    }
    Ok(items)
}

fn cell_of(grid: &HexGrid, item: &str, p: Vec2) -> Result<u32, CellSpecError> {
    grid.cell_at(p).ok_or_else(|| CellSpecError::OffGrid {
        item: item.to_string(),
        x: p.x,
        z: p.y,
    })
}

/// The cells a camera path's eye positions fall in (eyes off the grid are skipped),
/// ascending.
pub fn path_cells(grid: &HexGrid, path: &CameraPath) -> BTreeSet<u32> {
    path.frames()
        .iter()
        .filter_map(|f| grid.cell_at(Vec2::new(f.eye.x, f.eye.z)))
        .collect()
}

/// Resolves the items to cell ids of `grid`, ascending and unique.
pub fn resolve_cells(
    grid: &HexGrid,
    items: &[CellSpecItem],
) -> Result<BTreeSet<u32>, CellSpecError> {
    let count = grid.cell_count();
    let mut cells = BTreeSet::new();
    for item in items {
        match item {
            CellSpecItem::Id(id) => {
                if *id >= count {
                    return Err(CellSpecError::NoSuchCell { id: *id, count });
                }
                cells.insert(*id);
            }
            CellSpecItem::At(x, z) => {
                cells.insert(cell_of(grid, &format!("at:{x}:{z}"), Vec2::new(*x, *z))?);
            }
            CellSpecItem::OtherGrid { cell_size, id } => {
                let other = HexGrid::try_new(grid.ground(), *cell_size).map_err(|e| {
                    CellSpecError::OtherGrid {
                        cell_size: *cell_size,
                        id: *id,
                        reason: e.to_string(),
                    }
                })?;
                if *id >= other.cell_count() {
                    return Err(CellSpecError::OtherGrid {
                        cell_size: *cell_size,
                        id: *id,
                        reason: format!("no such cell; that grid has {} cells", other.cell_count()),
                    });
                }
                let centre = other.centre(*id);
                // A border cell's centre may lie outside the ground: clamp it in.
                let g = grid.ground();
                let p = Vec2::new(
                    centre.x.clamp(g.min[0], g.max[0]),
                    centre.y.clamp(g.min[1], g.max[1]),
                );
                cells.insert(cell_of(grid, &format!("grid:{cell_size}:{id}"), p)?);
            }
            CellSpecItem::Path(file) => {
                let path = CameraPath::load(file).map_err(|source| CellSpecError::Path {
                    path: file.clone(),
                    source,
                })?;
                let on_path = path_cells(grid, &path);
                if on_path.is_empty() {
                    return Err(CellSpecError::EmptyPath { path: file.clone() });
                }
                for &c in &on_path {
                    cells.insert(c);
                    cells.extend(grid.neighbours(c));
                }
            }
        }
    }
    Ok(cells)
}

/// The jobs holding at least one of `cells`, and the far-field jobs of every group
/// (`groups_of`: a cell's chain, every level) a cell of those jobs belongs to (so
/// that each baked cell has its groups and is listed in the index), in job order.
pub fn jobs_for_cells(
    jobs: &[Job],
    cells: &BTreeSet<u32>,
    groups_of: impl Fn(u32) -> Vec<u32>,
) -> Vec<Job> {
    let holds = |j: &Job| j.cells.iter().any(|c| cells.contains(c));
    let groups: BTreeSet<u32> = jobs
        .iter()
        .filter(|j| holds(j))
        .flat_map(|j| j.cells.iter().flat_map(|&c| groups_of(c)))
        .collect();
    jobs.iter()
        .filter(|j| holds(j) || j.groups.iter().any(|g| groups.contains(g)))
        .cloned()
        .collect()
}

/// A resolved `--cells` selection.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// The spec as given.
    pub spec: String,
    /// Requested cells (ascending).
    pub cells: BTreeSet<u32>,
}

impl Selection {
    pub fn new(spec: &str, grid: &HexGrid) -> Result<Selection, CellSpecError> {
        let items = parse_cell_spec(spec)?;
        Ok(Selection {
            spec: spec.to_string(),
            cells: resolve_cells(grid, &items)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use format::Ground;
    use std::path::Path;

    fn park_grid(cell_size: f32) -> HexGrid {
        HexGrid::new(
            Ground {
                min: [0.0, 0.0],
                max: [1650.0, 2035.0],
            },
            cell_size,
        )
    }

    #[test]
    fn spec_items_parse() {
        let items = parse_cell_spec("275, 0,path:a/b.ron,at:10.5:20,grid:50:527").unwrap();
        assert_eq!(
            items,
            vec![
                CellSpecItem::Id(275),
                CellSpecItem::Id(0),
                CellSpecItem::Path("a/b.ron".into()),
                CellSpecItem::At(10.5, 20.0),
                CellSpecItem::OtherGrid {
                    cell_size: 50.0,
                    id: 527
                },
            ]
        );
        for bad in ["", " , ", "x", "-1", "at:1", "at:a:2", "grid:50", "path:"] {
            assert!(parse_cell_spec(bad).is_err(), "{bad:?} should not parse");
        }
    }

    #[test]
    fn ids_are_checked_against_the_grid() {
        let g = park_grid(50.0);
        assert_eq!(g.cell_count(), 528);
        let e = resolve_cells(&g, &[CellSpecItem::Id(528)]).unwrap_err();
        assert!(e.to_string().contains("528 cells"), "{e}");
        let e = resolve_cells(&g, &[CellSpecItem::At(-500.0, -500.0)]).unwrap_err();
        assert!(matches!(e, CellSpecError::OffGrid { .. }), "{e}");
    }

    #[test]
    fn other_grid_maps_centres_corners_and_edges_to_the_same_places() {
        let fine = park_grid(50.0);
        let coarse = park_grid(100.0);
        // The identity on the same grid.
        for id in [0, 264, 275, 517, 527] {
            let got = resolve_cells(
                &fine,
                &[CellSpecItem::OtherGrid {
                    cell_size: 50.0,
                    id,
                }],
            )
            .unwrap();
            assert_eq!(got.into_iter().collect::<Vec<_>>(), vec![id]);
        }
        // Corner cells of the fine grid land in corner cells of the coarse one.
        let map = |id| {
            *resolve_cells(
                &coarse,
                &[CellSpecItem::OtherGrid {
                    cell_size: 50.0,
                    id,
                }],
            )
            .unwrap()
            .iter()
            .next()
            .unwrap()
        };
        assert_eq!(map(0), 0);
        assert_eq!(map(527), coarse.cell_count() - 1);
        // The fine centre cell lands in the coarse cell containing its centre.
        let c = map(275);
        assert!(coarse.contains(c, fine.centre(275)));
    }

    #[test]
    fn path_cells_include_neighbours() {
        let g = park_grid(50.0);
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../manifests/paths/park-walk.ron");
        let path = CameraPath::load(&file).unwrap();
        let on_path = path_cells(&g, &path);
        assert!(on_path.len() > 12, "park-walk crosses > 12 cells");
        let sel = resolve_cells(&g, &[CellSpecItem::Path(file)]).unwrap();
        for c in &on_path {
            assert!(sel.contains(c));
            for n in g.neighbours(*c) {
                assert!(sel.contains(&n), "neighbour {n} of path cell {c}");
            }
        }
        assert!(sel.len() < 528 / 2, "{} cells: a subset", sel.len());
        // Jobs of 4 cells of a row, as park-4m plans them.
        let jobs: BTreeSet<u32> = sel.iter().map(|c| (c / 22) * 6 + (c % 22) / 4).collect();
        eprintln!(
            "TEMP path cells {} selected {} jobs {}",
            on_path.len(),
            sel.len(),
            jobs.len()
        );
    }

    #[test]
    fn jobs_for_cells_keeps_jobs_with_any_selected_cell() {
        let mut jobs: Vec<Job> = (0..4)
            .map(|j| Job {
                id: j,
                cells: vec![2 * j, 2 * j + 1],
                groups: Vec::new(),
                fingerprint: [0; 32],
            })
            .collect();
        // Far-field jobs: groups {0, 1} and {2, 3}; cell c is in group c / 2.
        for (id, groups) in [(4, vec![0, 1]), (5, vec![2, 3])] {
            jobs.push(Job {
                id,
                cells: Vec::new(),
                groups,
                fingerprint: [0; 32],
            });
        }
        let picked = jobs_for_cells(&jobs, &BTreeSet::from([1, 6]), |c| vec![c / 2]);
        assert_eq!(
            picked.iter().map(|j| j.id).collect::<Vec<_>>(),
            vec![0, 3, 4, 5]
        );
        let picked = jobs_for_cells(&jobs, &BTreeSet::from([1]), |c| vec![c / 2]);
        assert_eq!(picked.iter().map(|j| j.id).collect::<Vec<_>>(), vec![0, 4]);
    }
}
