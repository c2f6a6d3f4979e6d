//! `player view`'s overlay and representation colouring (issue 18 item 4), drawn
//! headless through [`ViewSession`] on whatever adapter the environment gives
//! (lavapipe in CI; skipped through `testkit::skip` without one, a failure under
//! HEXBAKE_REQUIRE_GPU=1).

use glam::Vec3;
use player::frame::Mode;
use player::overlay::{Representation, TEXT};
use player::testdata::write_synthetic_bake;
use player::view::{ViewOptions, ViewSession};

mod common;

#[track_caller]
fn open(dir: &std::path::Path, opts: &ViewOptions) -> Option<ViewSession> {
    common::open_player(dir, opts.size, &opts.draw).map(|p| ViewSession::new(p, opts))
}

#[test]
fn view_frame_shows_the_overlay_and_every_drawn_representation_in_its_colour() {
    let dir = tempfile::tempdir().unwrap();
    let info = write_synthetic_bake(dir.path()).unwrap();
    let size = (320u32, 240u32);
    let opts = ViewOptions {
        size,
        colours: true,
        overlay: false,
        lod_pixel_error: 2.5,
        ..ViewOptions::new(dir.path().to_path_buf())
    };
    let Some(mut s) = open(dir.path(), &opts) else {
        return;
    };
    // `view --lod-pixel-error` reaches the player's `lod` mode (issue 28).
    assert_eq!(s.player.lod_pixel_error, 2.5);
    // The synthetic bake's cells hold originals, SvMesh, MvMesh and Cluster proxies;
    // turning around at a cell centre sees them all.
    let g = info.grid;
    s.eye = Vec3::new(
        0.5 * (g.ground_min[0] + g.ground_max[0]),
        g.min_eye_height,
        0.5 * (g.ground_min[1] + g.ground_max[1]),
    );
    let mut seen = [0usize; 7];
    for yaw in 0..8 {
        s.yaw = (yaw as f32 * 45.0).to_radians();
        // A few frames: the first ones stream the cell and upload its textures.
        let mut frame = Vec::new();
        for _ in 0..4 {
            frame = s.frame().unwrap().0;
        }
        for (k, n) in Representation::count_pixels(&frame).into_iter().enumerate() {
            seen[k] += n;
        }
    }
    eprintln!("pixels per representation {seen:?} (Representation order)");
    for r in [
        Representation::Original,
        Representation::SvMesh,
        Representation::MvMesh,
        Representation::Cluster,
    ] {
        assert!(seen[r as usize] > 50, "{r:?}: {seen:?}");
    }
    assert_eq!(
        seen[Representation::LodLevel as usize],
        0,
        "no LOD levels in hybrid"
    );

    // M flips to full geometry at the same pose: every object is an original, and the
    // frame differs from the hybrid one.
    s.yaw = 0.0;
    let hybrid = s.frame().unwrap().0;
    s.cycle_mode();
    assert_eq!(s.mode, Mode::Full);
    let full = s.frame().unwrap().0;
    let c = Representation::count_pixels(&full);
    assert!(c[Representation::Original as usize] > 50, "{c:?}");
    for r in [
        Representation::SvMesh,
        Representation::MvMesh,
        Representation::Cluster,
    ] {
        assert_eq!(c[r as usize], 0, "{r:?} in full mode: {c:?}");
    }
    assert_ne!(hybrid, full);
    s.cycle_mode();
    assert_eq!(s.mode, Mode::Lod);
    // Cluster LOD (issue 30): originals and simplified clusters (the LOD colour),
    // no proxy.
    s.cycle_mode();
    assert_eq!(s.mode, Mode::ClusterLod);
    let clod = s.frame().unwrap().0;
    let c = Representation::count_pixels(&clod);
    assert!(
        c[Representation::Original as usize] + c[Representation::LodLevel as usize] > 50,
        "{c:?}"
    );
    for r in [
        Representation::SvMesh,
        Representation::MvMesh,
        Representation::Cluster,
    ] {
        assert_eq!(c[r as usize], 0, "{r:?} in cluster-lod mode: {c:?}");
    }
    s.cycle_mode();
    assert_eq!(s.mode, Mode::Hybrid);

    // The overlay: the same frame with it differs only in its panels, which hold text
    // pixels and the legend's swatches in the exact debug colours.
    s.frame().unwrap();
    let bare = s.frame().unwrap().0;
    s.overlay = true;
    let (with, shown) = s.frame().unwrap();
    assert!(shown.colouring && shown.triangles > 0 && shown.cell.is_some());
    let mut changed = 0;
    let mut text = 0;
    for (a, b) in bare.chunks_exact(4).zip(with.chunks_exact(4)) {
        if a != b {
            changed += 1;
            text += usize::from(b[..3] == TEXT);
        }
    }
    assert!(text > 300, "{text} text pixels");
    assert!(
        changed > 5000 && changed < bare.len() / 4 / 2,
        "{changed} pixels changed"
    );
    for r in Representation::ALL {
        let swatch = with
            .chunks_exact(4)
            .filter(|p| p[..3] == r.colour())
            .count();
        assert!(swatch >= 64, "legend swatch of {r:?}: {swatch} pixels");
    }
}
