//! Issue 14 item 3: the player and the worker share one home for each convention
//! (format::grid, format::shading, format::srgb, format::metrics); nothing here is a
//! copy any more.

use format::grid::HexGrid;
use format::manifest::CellParams;
use format::shading::{wgsl_constants, AMBIENT, LIGHT_DIR, SKY};
use format::Ground;
use glam::Vec2;
use player::grid::CellGrid;
use player::testdata::grid_params;

#[test]
fn the_players_grid_is_the_workers_hex_grid() {
    let params = grid_params(
        Ground {
            min: [-130.0, 40.0],
            max: [377.0, 611.0],
        },
        &CellParams {
            cell_size: 23.0,
            min_eye_height: 2.0,
            max_eye_height: 4.0,
        },
    );
    let cells = CellGrid::new(params);
    // The same type (worker::grid::HexGrid is a re-export of it) built from the same
    // parameters: equal, so every lookup is the worker's.
    let hex: &HexGrid = &cells;
    assert_eq!(hex, &HexGrid::from_params(&params).unwrap());
    assert_eq!((hex.n_cols(), hex.n_rows()), (params.n_cols, params.n_rows));
    for i in 0..500 {
        let p = Vec2::new(
            -160.0 + 0.37 * (i * 7 % 500) as f32 * 3.0,
            20.0 + 1.23 * i as f32,
        );
        assert_eq!(cells.cell_at(p), hex.cell_at(p));
        let n = cells.nearest_cell(p).unwrap();
        if let Some(c) = hex.cell_at(p) {
            assert_eq!(n, c);
        }
    }
}

#[test]
fn the_shader_takes_its_constants_from_rust() {
    let source = player::gpu::shader_source();
    assert!(source.starts_with(&wgsl_constants()));
    let file = include_str!("../src/shader.wgsl");
    let code: String = file
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    for name in [
        "AMBIENT",
        "LIGHT",
        "SRGB_DECODE_THRESHOLD",
        "SRGB_LINEAR_SLOPE",
        "SRGB_OFFSET",
        "SRGB_SCALE",
        "SRGB_GAMMA",
        "MAX_VIEWS",
    ] {
        assert!(code.contains(name), "shader.wgsl does not use {name}");
        assert!(
            !code.contains(&format!("const {name}")),
            "shader.wgsl declares its own {name}"
        );
    }
    // No copies of the numbers themselves.
    for literal in [
        "12.92", "0.04045", "0.055", "1.055", "2.4", "0.3)", "0.35777",
    ] {
        assert!(!code.contains(literal), "shader.wgsl repeats {literal}");
    }
    // The values the shader used to hard-code are the Rust ones (parsed as WGSL
    // parses them, to f32).
    let old_light = ["0.35777088", "0.89442719", "0.26832816"].map(|v| v.parse::<f32>().unwrap());
    assert_eq!(old_light, LIGHT_DIR.to_array());
    assert_eq!(AMBIENT, 0.3);
}

#[test]
fn sky_and_view_limit_are_the_shared_ones() {
    assert_eq!(player::gpu::SKY, SKY);
    assert_eq!(player::gpu::MAX_VIEWS, format::pack::cell::MAX_MV_VIEWS);
}

#[test]
fn player_metrics_are_formats() {
    let a = [10u8, 20, 30, 255].repeat(16);
    let mut b = a.clone();
    b[0] = 20;
    let want = format::metrics::psnr_of_mse(format::metrics::mse_y_rgba(&a, &b).unwrap());
    assert_eq!(player::metrics::psnr_y(&a, &b), want);
    assert_eq!(player::metrics::psnr_y(&a, &a), f64::INFINITY);
    for c in 0..=255u8 {
        assert_eq!(
            player::metrics::srgb_to_linear(c) as f32,
            format::srgb::srgb_to_linear(c)
        );
    }
}
