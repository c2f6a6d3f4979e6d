//! Hex grid properties (issue 2 item 6; paper 000 §3.1.1).

use format::Ground;
use glam::{Vec2, Vec3};
use proptest::prelude::*;
use worker::grid::HexGrid;

fn park() -> HexGrid {
    HexGrid::new(
        Ground {
            min: [0.0, 0.0],
            max: [1650.0, 2035.0],
        },
        50.0,
    )
}

/// A grid with an offset, non-fitting ground to exercise the general layout.
fn odd_grid() -> HexGrid {
    HexGrid::new(
        Ground {
            min: [-130.0, 40.0],
            max: [377.0, 611.0],
        },
        23.0,
    )
}

/// The cell with the nearest centre by brute force over the whole grid (ties: lower id).
fn brute_nearest(g: &HexGrid, p: Vec2) -> u32 {
    let mut best = 0;
    let mut best_d = f32::INFINITY;
    for id in 0..g.cell_count() {
        let d = g.centre(id).distance_squared(p);
        if d < best_d {
            best_d = d;
            best = id;
        }
    }
    best
}

#[test]
fn paper_park_is_22_by_24_cells() {
    let g = park();
    assert_eq!((g.n_cols(), g.n_rows()), (22, 24));
    assert_eq!(g.cell_count(), 528);
}

#[test]
fn cell_ids_are_row_major() {
    let g = park();
    for id in [0, 1, 21, 22, 23, 527] {
        let (col, row) = g.col_row(id);
        assert_eq!(row * 22 + col, id);
        assert_eq!(g.id(col as i64, row as i64), Some(id));
    }
    // Columns step 1.5c in x; rows √3c in z; odd columns shifted by √3c/2.
    let c0 = g.centre(0);
    let c1 = g.centre(1);
    let c22 = g.centre(22);
    assert!((c1.x - c0.x - 75.0).abs() < 1e-3);
    assert!((c1.y - c0.y - 50.0 * 3f32.sqrt() / 2.0).abs() < 1e-3);
    assert!((c22.y - c0.y - 50.0 * 3f32.sqrt()).abs() < 1e-3);
    assert_eq!(c22.x, c0.x);
}

#[test]
fn interior_cell_has_six_neighbours_corner_cells_fewer() {
    let g = park();
    let interior = g.id(5, 7).unwrap();
    assert_eq!(g.neighbours(interior).len(), 6);
    let odd = g.id(6, 7).unwrap();
    assert_eq!(g.neighbours(odd).len(), 6);
    assert_eq!(g.neighbours(0).len(), 2); // even column 0, row 0: up and right-up
    assert!(g.neighbours(g.cell_count() - 1).len() < 6);
    for id in 0..g.cell_count() {
        let n = g.neighbours(id);
        assert!(n.windows(2).all(|w| w[0] < w[1]), "sorted, unique");
        assert!(!n.contains(&id));
        // Neighbours are exactly the cells at distance √3·c.
        for &m in &n {
            let d = g.centre(id).distance(g.centre(m));
            assert!((d - 50.0 * 3f32.sqrt()).abs() < 1e-2, "{id}-{m}: {d}");
        }
    }
}

#[test]
fn side_faces_use_prism_corners() {
    let g = park();
    let id = g.id(3, 4).unwrap();
    let corners = g.prism_corners(id, 1.0, 9.0);
    let faces = g.side_faces(id, 1.0, 9.0);
    for (k, f) in faces.iter().enumerate() {
        assert_eq!(f[0], corners[k]);
        assert_eq!(f[1], corners[(k + 1) % 6]);
        assert_eq!(f[2], corners[6 + (k + 1) % 6]);
        assert_eq!(f[3], corners[6 + k]);
        // Each side face is a vertical c × (max − min) rectangle.
        assert!((f[0].distance(f[1]) - 50.0).abs() < 1e-3);
        assert!((f[3].y - f[0].y - 8.0).abs() < 1e-6);
    }
    let hex = g.corners(id);
    for k in 0..6 {
        assert!((hex[k].distance(g.centre(id)) - 50.0).abs() < 1e-3);
        assert_eq!(corners[k], Vec3::new(hex[k].x, 1.0, hex[k].y));
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let ground = Ground {
        min: [0.0, 0.0],
        max: [10.0, 10.0],
    };
    assert!(HexGrid::try_new(ground, 0.0).is_err());
    assert!(HexGrid::try_new(ground, f32::NAN).is_err());
    let empty = Ground {
        min: [5.0, 0.0],
        max: [5.0, 10.0],
    };
    assert!(HexGrid::try_new(empty, 1.0).is_err());
    assert!(HexGrid::try_new(ground, 1e-6).is_err()); // 10^13 cells
}

#[test]
fn prism_aabb_test_matches_sampling() {
    let g = park();
    let prism = g.prism(g.id(4, 4).unwrap(), 2.0, 10.0);
    let c = prism.centre3();
    // A box inside, a box far away, a box just outside a flat side, a box above.
    assert!(prism.intersects_aabb(c - Vec3::ONE, c + Vec3::ONE));
    assert!(!prism.intersects_aabb(c + Vec3::splat(200.0), c + Vec3::splat(210.0)));
    let h = 50.0 * 3f32.sqrt() / 2.0;
    let z0 = c.z + h + 0.5;
    assert!(!prism.intersects_aabb(
        Vec3::new(c.x - 5.0, 0.0, z0),
        Vec3::new(c.x + 5.0, 5.0, z0 + 3.0)
    ));
    assert!(prism.intersects_aabb(
        Vec3::new(c.x - 5.0, 0.0, z0 - 1.0),
        Vec3::new(c.x + 5.0, 5.0, z0 + 3.0)
    ));
    assert!(!prism.intersects_aabb(
        c + Vec3::new(-1.0, 20.0, -1.0),
        c + Vec3::new(1.0, 30.0, 1.0)
    ));
    // Box near a slanted edge, outside the hexagon but inside its bounding rectangle.
    let corner_gap = Vec3::new(c.x + 45.0, 5.0, c.z + 40.0);
    assert!(!prism.contains(corner_gap));
    assert!(!prism.intersects_aabb(corner_gap - Vec3::splat(0.5), corner_gap + Vec3::splat(0.5)));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// `distance_to_border` (issue 31, frames near a border): the distance from a point
    /// inside a hexagon to the nearest of its six edges, by brute force over the
    /// edges as segments; a point that far along any direction stays in the cell.
    #[test]
    fn distance_to_border_is_the_distance_to_the_nearest_hexagon_edge(
        x in 200.0f32..1400.0, z in 200.0f32..1800.0,
    ) {
        let g = park();
        let p = Vec2::new(x, z);
        let id = g.cell_at(p).unwrap();
        prop_assume!(g.in_hexagon(id, p));
        let d = g.distance_to_border(p).unwrap();
        let c = g.corners(id);
        let brute = (0..6)
            .map(|k| {
                let (a, b) = (c[k], c[(k + 1) % 6]);
                let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                p.distance(a + t * (b - a))
            })
            .fold(f32::INFINITY, f32::min);
        prop_assert!((d - brute).abs() < 1e-3, "{d} vs brute force {brute}");
        let centre = g.centre(id);
        prop_assert!((g.distance_to_border(centre).unwrap() - 50.0 * 3f32.sqrt() / 2.0).abs() < 1e-3);
    }

    /// `Prism::closest_point` (the MVMesh's l′ looks from it): in the prism, the point
    /// itself when inside, and no sampled point of the prism is nearer.
    #[test]
    fn closest_point_of_prism_is_nearest(
        x in -120.0f32..120.0, y in -20.0f32..40.0, z in -120.0f32..120.0,
    ) {
        let g = park();
        let id = g.cell_at(Vec2::new(800.0, 1000.0)).unwrap();
        let prism = g.prism(id, 5.0, 12.0);
        let c = prism.centre3();
        let p = c + Vec3::new(x, y, z);
        let q = prism.closest_point(p);
        prop_assert!(prism.contains(q), "{q} not in the prism");
        if prism.contains(p) {
            prop_assert!(q.distance(p) < 1e-4, "inside point {p} moved to {q}");
        }
        let d = q.distance(p);
        for i in 0..12u32 {
            for j in 0..12u32 {
                for k in 0..3u32 {
                    let s = prism.sample(i as f32 / 11.0, j as f32 / 11.0, k as f32 / 2.0);
                    prop_assert!(d <= s.distance(p) + 1e-3, "{s} is nearer to {p} than {q}");
                }
            }
        }
        for corner in prism.corners() {
            prop_assert!(d <= corner.distance(p) + 1e-3);
        }
    }

    #[test]
    fn point_maps_to_nearest_centre(x in -100.0f32..1750.0, z in -100.0f32..2135.0) {
        let g = park();
        let p = Vec2::new(x, z);
        match g.cell_at(p) {
            Some(id) => {
                let b = brute_nearest(&g, p);
                let d_id = g.centre(id).distance(p);
                let d_b = g.centre(b).distance(p);
                prop_assert!((d_id - d_b).abs() < 1e-3, "cell_at {id} ({d_id}) vs nearest {b} ({d_b})");
            }
            None => {
                // Off the grid: off the ground and in no cell's hexagon.
                prop_assert!(!(0.0..=1650.0).contains(&x) || !(0.0..=2035.0).contains(&z));
                prop_assert!((0..g.cell_count()).all(|id| !g.in_hexagon(id, p)));
            }
        }
    }

    #[test]
    fn every_ground_point_is_in_exactly_one_cell(u in 0.0f32..=1.0, v in 0.0f32..=1.0, which in 0..2usize) {
        let g = if which == 0 { park() } else { odd_grid() };
        let gr = g.ground();
        let p = Vec2::new(
            gr.min[0] + u * (gr.max[0] - gr.min[0]),
            gr.min[1] + v * (gr.max[1] - gr.min[1]),
        );
        let id = g.cell_at(p);
        prop_assert!(id.is_some(), "ground point {p} has no cell");
        let id = id.unwrap();
        let holders: Vec<u32> = (0..g.cell_count()).filter(|&c| g.contains(c, p)).collect();
        // Points exactly on a shared edge are in both closed hexagons; random points
        // are not, up to the test's tolerance.
        let on_edge = holders.len() > 1
            && holders.iter().all(|&c| (g.centre(c).distance(p) - g.centre(id).distance(p)).abs() < 1e-2);
        prop_assert!(holders == vec![id] || on_edge, "{p}: cell_at {id}, contained in {holders:?}");
        if !g.in_hexagon(id, p) {
            // A border notch: within c/4 of the left or right ground edge.
            let c = g.cell_size();
            let near_edge = (p.x - gr.min[0]).abs() <= 0.25 * c + 1e-3 || (gr.max[0] - p.x).abs() <= 0.25 * c + 1e-3;
            prop_assert!(near_edge, "{p} outside its hexagon away from the border");
        }
    }

    #[test]
    fn neighbour_relation_is_symmetric(col in 0i64..22, row in 0i64..24) {
        let g = park();
        let id = g.id(col, row).unwrap();
        for m in g.neighbours(id) {
            prop_assert!(g.neighbours(m).contains(&id), "{id} → {m} but not back");
        }
    }

    #[test]
    fn adjacent_cells_share_two_corners_per_height(col in 0i64..22, row in 0i64..24) {
        let g = park();
        let id = g.id(col, row).unwrap();
        let a = g.prism_corners(id, 1.5, 6.0);
        for m in g.neighbours(id) {
            let b = g.prism_corners(m, 1.5, 6.0);
            let shared: Vec<Vec3> = a
                .iter()
                .filter(|p| b.iter().any(|q| p.distance(*q) < 1e-3))
                .copied()
                .collect();
            prop_assert_eq!(shared.len(), 4, "{} and {} share {:?}", id, m, shared);
            prop_assert_eq!(shared.iter().filter(|p| p.y == 1.5).count(), 2);
        }
        // Non-neighbours share no corner.
        for other in 0..g.cell_count() {
            if other != id && !g.neighbours(id).contains(&other) {
                let b = g.corners(other);
                let hex = g.corners(id);
                prop_assert!(!hex.iter().any(|p| b.iter().any(|q| p.distance(*q) < 1e-3)));
            }
        }
    }

    #[test]
    fn prism_samples_are_inside_and_hit_the_right_cell(col in 0i64..22, row in 0i64..24, u in 0.0f32..1.0, v in 0.0f32..1.0, w in 0.0f32..1.0) {
        let g = park();
        let id = g.id(col, row).unwrap();
        let prism = g.prism(id, 1.0, 3.0);
        let p = g.sample_point_in_prism(id, 1.0, 3.0, u, v, w);
        prop_assert!(prism.contains(p));
        prop_assert!(g.in_hexagon(id, Vec2::new(p.x, p.z)));
        prop_assert!(prism.intersects_aabb(p, p));
        let tiny = Vec3::splat(1e-3);
        prop_assert!(prism.intersects_aabb(p - tiny, p + tiny));
    }

    #[test]
    fn aabb_test_is_conservative(col in 1i64..21, row in 1i64..23, cx in -80.0f32..80.0, cz in -80.0f32..80.0, sx in 0.1f32..30.0, sz in 0.1f32..30.0, u in 0.0f32..1.0, v in 0.0f32..1.0) {
        // If any point of the box lies in the prism, the test must say "intersects".
        let g = park();
        let id = g.id(col, row).unwrap();
        let prism = g.prism(id, 0.0, 10.0);
        let c = g.centre(id);
        let lo = Vec3::new(c.x + cx, 2.0, c.y + cz);
        let hi = lo + Vec3::new(sx, 1.0, sz);
        let p = Vec3::new(lo.x + u * sx, 2.5, lo.z + v * sz);
        if prism.contains(p) {
            prop_assert!(prism.intersects_aabb(lo, hi));
        }
        // And "no intersection" means no box corner and no hexagon corner inside the other.
        if !prism.intersects_aabb(lo, hi) {
            for k in 0..4 {
                let q = Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, 2.5, if k & 2 == 0 { lo.z } else { hi.z });
                prop_assert!(!prism.contains(q));
            }
            for h in prism.hexagon() {
                prop_assert!(!(h.x > lo.x && h.x < hi.x && h.y > lo.z && h.y < hi.z));
            }
        }
    }
}

#[test]
fn border_notch_points_belong_to_the_nearest_border_cell() {
    // Column 0's centres are at x = 37.5 (the 22-column strip is centred on the
    // 1650-wide ground), so between rows 0 and 1 a notch reaches x = 12.5.
    let g = park();
    assert!((g.centre(0).x - 37.5).abs() < 1e-3);
    let p = Vec2::new(2.0, 50.0 * 3f32.sqrt() / 2.0 + 1.0);
    assert!((0..g.cell_count()).all(|id| !g.in_hexagon(id, p)));
    let id = g.cell_at(p).expect("ground point");
    assert_eq!(id, 22, "row 1 of column 0 is nearer");
    let holders: Vec<u32> = (0..g.cell_count()).filter(|&c| g.contains(c, p)).collect();
    assert_eq!(holders, vec![22]);
    // Just off the ground there is no cell.
    assert_eq!(g.cell_at(Vec2::new(-2.0, p.y)), None);
    // But a point off the ground inside a border hexagon has one.
    assert_eq!(g.cell_at(Vec2::new(-5.0, 0.0)), Some(0));
}

/// The worker's grid is format's (issue 14 item 3): one type, shared with the player.
#[test]
fn worker_grid_is_formats() {
    fn same(g: format::grid::HexGrid) -> HexGrid {
        g
    }
    assert_eq!(same(park()), park());
}
