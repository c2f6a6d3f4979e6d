//! The player's current-cell lookup is `format::grid::HexGrid`, the worker's own grid
//! (odd-q flat-top layout, DESIGN.md "Hex grid"): hand values on the demo park's grid.

use format::manifest::CellParams;
use format::Ground;
use glam::Vec2;
use player::grid::CellGrid;
use player::testdata::grid_params;

fn demo() -> CellGrid {
    CellGrid::new(grid_params(
        Ground {
            min: [0.0, 0.0],
            max: [300.0, 260.0],
        },
        &CellParams {
            cell_size: 50.0,
            min_eye_height: 6.0,
            max_eye_height: 12.0,
        },
    ))
}

#[test]
fn demo_grid_has_the_workers_shape_and_centres() {
    let g = demo();
    // N = ceil(300 / 75) = 4, M = ceil(260 / 86.6 + 0.5) = 4.
    assert_eq!((g.params().n_cols, g.params().n_rows), (4, 4));
    // Column strip centred in x: origin x = (300 − 3·75) / 2 = 37.5; z starts at 0.
    let h = 3f32.sqrt() * 50.0;
    for (id, x, z) in [
        (0, 37.5, 0.0),
        (1, 112.5, h / 2.0),
        (2, 187.5, 0.0),
        (4, 37.5, h),
        (5, 112.5, 1.5 * h),
        (15, 262.5, 3.5 * h),
    ] {
        let c = g.centre(id);
        assert!((c - Vec2::new(x, z)).length() < 1e-3, "cell {id}: {c}");
    }
}

#[test]
fn current_cell_matches_hand_values() {
    let g = demo();
    for (p, want) in [
        ((37.5, 0.0), Some(0)),
        ((112.5, 43.3), Some(1)),
        ((40.0, 80.0), Some(4)),
        ((150.0, 120.0), Some(5)),
        ((299.0, 259.0), Some(11)),
        ((262.5, 300.0), Some(15)),
        ((150.0, 400.0), None),
        // Left border notch, on the ground: nearest in-grid centre is cell 8
        // ((37.5, 173.2) is 0.2 units nearer than (37.5, 86.6)).
        ((1.0, 130.0), Some(8)),
        ((-100.0, -100.0), None),
        ((f32::NAN, 0.0), None),
    ] {
        assert_eq!(g.cell_at(Vec2::new(p.0, p.1)), want, "{p:?}");
    }
    assert_eq!(g.nearest_cell(Vec2::new(-100.0, -100.0)), Some(0));
}

#[test]
fn on_the_ground_the_cell_is_the_nearest_centre() {
    let g = demo();
    for i in 0..60 {
        for j in 0..52 {
            let p = Vec2::new(i as f32 * 5.0 + 0.3, j as f32 * 5.0 + 0.7);
            let brute = (0..g.cell_count())
                .min_by(|&a, &b| {
                    g.centre(a)
                        .distance_squared(p)
                        .total_cmp(&g.centre(b).distance_squared(p))
                })
                .unwrap();
            assert_eq!(g.cell_at(p), Some(brute), "{p}");
        }
    }
}
