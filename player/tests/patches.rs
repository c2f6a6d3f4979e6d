//! Issue 17 items 3–4 in the player: originals drawn as the index ranges of their
//! visible patches change no pixel of the hybrid frame (which, with every instance
//! an original, equals the full-geometry frame) and draw fewer triangles. The patch
//! data is written here with format code only (the player never links the worker):
//! one patch per triangle, its exact normal as a zero-width cone, every sample bit
//! set — so the test exercises the ranges, the patch-ordered index buffers and the
//! conservative cone test; a camera close to an instance exercises the per-tile
//! frustum test (`patches::refine_patches`).

use format::pack::BasePack;
use glam::Vec3;
use player::camera::Camera;
use player::frame::Mode;
use player::metrics::psnr_y;
use player::stream::{StreamConfig, Streamer};
use player::testdata::write_synthetic_bake_with;
use player::DrawOptions;

mod common;
use common::{open_player, per_triangle_patches};

/// (hybrid triangles, hybrid frame, full frame) from a camera 3 radii in front of
/// instance 0 (`close`: 0.6 radii, narrow, off-centre, so part of it is out of
/// view), with the per-tile frustum test on or off.
fn frame(dir: &std::path::Path, close: bool, frustum: bool) -> Option<(u64, Vec<u8>, Vec<u8>)> {
    let options = DrawOptions {
        frustum,
        ..Default::default()
    };
    let mut p = open_player(dir, (128, 128), &options)?;
    let b = p.bake.instance_bounds[0];
    let r = (b.max - b.min).length() * 0.5;
    let (offset, fov_y_deg) = if close {
        (Vec3::new(0.4 * r, 0.1 * r, 0.6 * r), 35.0)
    } else {
        (Vec3::new(0.3 * r, 0.2 * r, 3.0 * r), 60.0)
    };
    let cam = Camera {
        eye: b.centre() + offset,
        dir: Vec3::NEG_Z,
        fov_y_deg,
        width: 128,
        height: 128,
        near: 0.25,
        far: p.bake.extent,
    };
    p.warm_up(&cam);
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
    let (_, list, _) = p.draw_listed(&cam, Mode::Hybrid, Some(&mut s));
    // The draw calls counted for the report are the ones the renderer issued.
    assert_eq!(list.draw_calls, p.renderer.last_draw_calls);
    let tris = list.triangles;
    let hybrid = p.renderer.read_pixels().unwrap();
    let (_, list_full, _) = p.draw_listed(&cam, Mode::Full, None);
    assert_eq!(list_full.draw_calls, p.renderer.last_draw_calls);
    let full = p.renderer.read_pixels().unwrap();
    Some((tris, hybrid, full))
}

#[test]
fn patch_culling_changes_no_pixel_and_draws_fewer_triangles() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake_with(dir.path(), true).unwrap();
    let Some((tris_plain, hybrid_plain, full_plain)) = frame(dir.path(), false, true) else {
        return;
    };
    assert_eq!(psnr_y(&hybrid_plain, &full_plain), f64::INFINITY);
    let path = dir.path().join("base.pack");
    let mut base = BasePack::read(&path).unwrap();
    base.patches = Some(per_triangle_patches(&base));
    base.write(&path).unwrap();
    let (tris, hybrid, full) = frame(dir.path(), false, true).unwrap();
    eprintln!("triangles: {tris} with patches, {tris_plain} without");
    assert!(tris < tris_plain, "{tris} >= {tris_plain}");
    assert_eq!(psnr_y(&hybrid, &full), f64::INFINITY);
    assert_eq!(psnr_y(&full, &full_plain), f64::INFINITY);
    // Close up, the frustum test drops the tiles out of view and no pixel changes.
    let (tris_all, hybrid_all, full_all) = frame(dir.path(), true, false).unwrap();
    let (tris_in, hybrid_in, full_in) = frame(dir.path(), true, true).unwrap();
    eprintln!("close up: {tris_in} triangles with the frustum test, {tris_all} without");
    assert!(tris_in < tris_all, "{tris_in} >= {tris_all}");
    assert_eq!(psnr_y(&hybrid_all, &full_all), f64::INFINITY);
    assert_eq!(psnr_y(&hybrid_in, &full_in), f64::INFINITY);
    assert_eq!(psnr_y(&full_in, &full_all), f64::INFINITY);
    // The close-up frame shows the object over most of the image.
    let covered = player::metrics::measure_frame(&full_in, &hybrid_in, 128, 128).object_pixels;
    assert!(covered > 128 * 128 / 2, "{covered} object pixels");
}

/// Proxies split into tiles (`patches::cluster_proxy_vertices`) and drawn as the
/// tiles that pass the cone and frustum tests, gathered into one draw each
/// (`gpu::FrameIndices`), give the frame that drawing every proxy triangle gives, with
/// fewer triangles.
#[test]
fn proxy_tile_culling_changes_no_pixel_and_draws_fewer_triangles() {
    use player::frame::hybrid_list;
    use player::stream::PendingDraw;
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake_with(dir.path(), false).unwrap();
    let Some(mut p) = open_player(dir.path(), (96, 96), &DrawOptions::default()) else {
        return;
    };
    // Looking across the park from a corner, with proxies partly out of view.
    let cam = Camera {
        eye: Vec3::new(30.0, 6.0, 40.0),
        dir: Vec3::new(120.0, -2.0, 80.0),
        fov_y_deg: 40.0,
        width: 96,
        height: 96,
        near: 0.25,
        far: p.bake.extent,
    };
    p.warm_up(&cam);
    // Sky pixels read alpha 0: the object-pixel count below is the covered part.
    p.renderer.set_coverage_alpha(true);
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            upload_budget_bytes: 1 << 30,
            ..Default::default()
        },
    );
    p.draw(&cam, Mode::Hybrid, Some(&mut s));
    let (current, _) = s.begin_frame(&p.renderer, &p.bake, &cam);
    let culled = hybrid_list(&p.bake, &cam, &current, PendingDraw::StandIns);
    assert!(!culled.proxies.is_empty());
    let mut whole = hybrid_list(&p.bake, &cam, &current, PendingDraw::StandIns);
    whole.cull = None;
    let (t_culled, t_whole) = (
        culled.triangle_count(&p.models),
        whole.triangle_count(&p.models),
    );
    p.renderer.render(&cam, &p.models, &culled);
    let a = p.renderer.read_pixels().unwrap();
    assert_eq!(culled.draw_calls(&p.models), p.renderer.last_draw_calls);
    p.renderer.render(&cam, &p.models, &whole);
    let b = p.renderer.read_pixels().unwrap();
    eprintln!("proxies: {t_culled} triangles with tile culling, {t_whole} without");
    assert!(t_culled < t_whole, "{t_culled} >= {t_whole}");
    assert!(
        a == b,
        "tile culling changed pixels (PSNR {})",
        psnr_y(&a, &b)
    );
    let covered = player::metrics::measure_frame(&a, &b, 96, 96).object_pixels;
    eprintln!("{covered} of {} pixels show objects", 96 * 96);
    assert!(
        covered > 96 * 96 / 10,
        "too little of the frame shows objects to tell"
    );
    // Issue 28: the options reach the proxies. With both tests off the hybrid draws
    // every proxy triangle (as `cull: None` does) and the same pixels; with tiles of
    // one triangle the tests cull at least as much, with the same pixels.
    let draw_with = |options: DrawOptions| {
        let mut q = open_player(dir.path(), (96, 96), &options)
            .expect("an adapter (the first open found one)");
        q.warm_up(&cam);
        q.renderer.set_coverage_alpha(true);
        let mut s = Streamer::new(
            &q.bake,
            StreamConfig {
                prefetch: false,
                upload_budget_bytes: 1 << 30,
                ..Default::default()
            },
        );
        q.draw(&cam, Mode::Hybrid, Some(&mut s));
        let (current, _) = s.begin_frame(&q.renderer, &q.bake, &cam);
        let list = hybrid_list(&q.bake, &cam, &current, PendingDraw::StandIns);
        let proxy_triangles = list.triangle_count(&q.models);
        q.renderer.render(&cam, &q.models, &list);
        (proxy_triangles, q.renderer.read_pixels().unwrap())
    };
    let (t_off, off) = draw_with(DrawOptions {
        backface: false,
        frustum: false,
        occlusion: false,
        ..Default::default()
    });
    assert_eq!(t_off, t_whole);
    assert!(off == b, "tests off: not the frame of every triangle");
    let (t_fine, fine) = draw_with(DrawOptions {
        tile_triangles: 1,
        ..Default::default()
    });
    eprintln!("proxies: {t_fine} triangles with tiles of one triangle");
    assert!(t_fine <= t_culled, "{t_fine} > {t_culled}");
    assert!(fine == b, "tiles of one triangle changed pixels");
}

/// Run-time occlusion culling (000 §3.2 run-time step (3), `player::occlusion`):
/// along the demo walk at eye height, the hybrid with it draws the very frames it
/// draws without (pixel for pixel), never more proxy triangles, and fewer in all.
#[test]
fn occlusion_culling_changes_no_pixel_and_draws_fewer_triangles() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake_with(dir.path(), false).unwrap();
    let size = (160, 120);
    let Some(mut p) = open_player(dir.path(), size, &DrawOptions::default()) else {
        return;
    };
    let off = DrawOptions {
        occlusion: false,
        ..Default::default()
    };
    let mut q = open_player(dir.path(), size, &off).expect("an adapter (the first open found one)");
    let config = StreamConfig {
        prefetch: false,
        upload_budget_bytes: 1 << 30,
        ..Default::default()
    };
    let (mut sp, mut sq) = (
        Streamer::new(&p.bake, config.clone()),
        Streamer::new(&q.bake, config),
    );
    let path = common::demo_walk();
    let (mut culled, mut all, mut frames) = (0u64, 0u64, 0);
    for f in path.frames().iter().step_by(3) {
        let cam = player::run::camera_for(f, &path, size, p.bake.extent);
        let (_, a, _) = p.draw_listed(&cam, Mode::Hybrid, Some(&mut sp));
        let with = p.renderer.read_pixels().unwrap();
        let (_, b, _) = q.draw_listed(&cam, Mode::Hybrid, Some(&mut sq));
        let without = q.renderer.read_pixels().unwrap();
        assert!(
            with == without,
            "t={:.2}s: occlusion culling changed pixels (PSNR {})",
            f.time_s,
            psnr_y(&with, &without)
        );
        assert!(a.triangles <= b.triangles, "t={:.2}s", f.time_s);
        (culled, all, frames) = (culled + a.triangles, all + b.triangles, frames + 1);
    }
    eprintln!("{frames} frames identical; {culled} of {all} triangles with occlusion culling");
    assert!(
        culled < all,
        "occlusion culling removed nothing along the walk"
    );
}
