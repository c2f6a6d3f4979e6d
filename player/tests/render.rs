//! Headless rendering tests on whatever adapter the environment gives (lavapipe in CI);
//! every GPU test prints the adapter and skips with a note when there is none
//! (`testkit::skip`: a failure under `HEXBAKE_REQUIRE_GPU=1`; any other renderer
//! error fails).

mod common;
use common::{assert_has_keys, demo_walk, open_player as open, renderer, COMPARE_KEYS};
use format::pack::{Texture, TextureEncoding};
use glam::{Vec2, Vec3};
use player::camera::Camera;
use player::compare::{compare, CompareOptions};
use player::frame::Mode;
use player::gpu::SKY;
use player::metrics::psnr_y;
use player::run::{render, Player, RenderOptions, FRAMES_CSV_HEADER};
use player::stream::{PendingDraw, StreamConfig, Streamer};
use player::testdata::{capture_camera, quad_in_front, write_quad_bake, write_synthetic_bake};
use player::DrawOptions;

fn non_sky(px: &[u8]) -> usize {
    px.chunks_exact(4)
        .filter(|p| p[0] != SKY[0] || p[1] != SKY[1] || p[2] != SKY[2])
        .count()
}

#[test]
fn adapter_reports_backend_and_device_type() {
    let Some(r) = renderer(16, 16) else { return };
    let a = r.adapter();
    println!(
        "adapter {:?}, backend {}, device type {}",
        a.name, a.backend, a.device_type
    );
    assert!(!a.backend.is_empty() && !a.device_type.is_empty());
    assert!(["Vulkan", "Gl", "Metal", "Dx12"].contains(&a.backend.as_str()));
}

/// A camera 3 radii south of instance `i`, looking at it.
fn camera_at_instance(p: &Player, i: usize, size: u32) -> Camera {
    let b = p.bake.instance_bounds[i];
    let c = b.centre();
    let r = (b.max - b.min).length() * 0.5;
    Camera {
        eye: c + Vec3::new(0.0, 0.0, 3.0 * r),
        dir: Vec3::NEG_Z,
        fov_y_deg: 60.0,
        width: size,
        height: size,
        near: 0.25,
        far: p.bake.extent,
    }
}

#[test]
fn every_mode_draws_objects_and_frustum_culling_changes_no_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let info = write_synthetic_bake(dir.path()).unwrap();
    assert_eq!(info.cells, 16);
    let Some(mut p) = open(dir.path(), (128, 128), &DrawOptions::default()) else {
        return;
    };
    let cam = camera_at_instance(&p, 0, 128);
    p.warm_up(&cam);
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
    let mut images = Vec::new();
    for mode in [Mode::Full, Mode::Frustum, Mode::Hybrid] {
        let (_, tris, _, _) = p.draw(&cam, mode, Some(&mut s));
        let px = p.renderer.read_pixels().unwrap();
        let n = non_sky(&px);
        println!("{}: {tris} triangles, {n} non-sky pixels", mode.name());
        assert!(n > 300, "{}: only {n} object pixels", mode.name());
        assert!(tris > 0);
        images.push((tris, px));
    }
    assert!(images[1].0 < images[0].0, "frustum culling dropped nothing");
    assert_eq!(psnr_y(&images[0].1, &images[1].1), f64::INFINITY);
    // Sky where nothing is: looking straight up.
    let up = Camera {
        dir: Vec3::new(0.0, 1.0, 0.001),
        ..cam
    };
    p.draw(&up, Mode::Full, None);
    let px = p.renderer.read_pixels().unwrap();
    assert_eq!(&px[..4], &SKY[..]);
}

#[test]
fn projective_texture_shows_the_capture_with_u_right_and_v_down() {
    let dir = tempfile::tempdir().unwrap();
    let (centre, capture) = quad_in_front();
    // Quadrants: top-left red, top-right green, bottom-left blue, bottom-right yellow.
    let rgba: Vec<u8> = (0..64 * 64)
        .flat_map(|i| {
            let (x, y) = (i % 64, i / 64);
            match (x < 32, y < 32) {
                (true, true) => [255, 0, 0, 255],
                (false, true) => [0, 255, 0, 255],
                (true, false) => [0, 0, 255, 255],
                (false, false) => [255, 255, 0, 255],
            }
        })
        .collect();
    let tex = Texture::from_rgba8(64, 64, &rgba, TextureEncoding::Rgba8Left).unwrap();
    write_quad_bake(dir.path(), centre, &capture, tex).unwrap();
    let Some(mut p) = open(dir.path(), (64, 64), &DrawOptions::default()) else {
        return;
    };
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            fade: 0.0, // the quad's cell alone (its neighbours would add triangles)
            ..Default::default()
        },
    );
    for eye_dx in [0.0f32, 3.0] {
        let cam = Camera {
            eye: capture.eye + Vec3::new(eye_dx, 0.0, 0.0),
            dir: centre - (capture.eye + Vec3::new(eye_dx, 0.0, 0.0)),
            ..capture
        };
        let (_, tris, tex_bytes, stats) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
        assert_eq!(tris, 2);
        assert_eq!(tex_bytes, 64 * 64 * 4);
        assert!(stats.cell.is_some());
        let px = p.renderer.read_pixels().unwrap();
        let at = |x: usize, y: usize| {
            let i = (y * 64 + x) * 4;
            [px[i], px[i + 1], px[i + 2]]
        };
        // Project quad points on the player's camera to find their pixels.
        let m = cam.clip_from_world_gl();
        let pixel = |w: Vec3| {
            let c = m * w.extend(1.0);
            let ndc = Vec2::new(c.x / c.w, c.y / c.w);
            (
                ((ndc.x + 1.0) * 32.0) as usize,
                ((1.0 - ndc.y) * 32.0) as usize,
            )
        };
        let cases = [
            (Vec3::new(-2.5, 2.5, 0.0), [255, 0, 0]),
            (Vec3::new(2.5, 2.5, 0.0), [0, 255, 0]),
            (Vec3::new(-2.5, -2.5, 0.0), [0, 0, 255]),
            (Vec3::new(2.5, -2.5, 0.0), [255, 255, 0]),
        ];
        for (off, want) in cases {
            let (x, y) = pixel(centre + off);
            let got = at(x, y);
            for k in 0..3 {
                assert!(
                    (got[k] as i32 - want[k]).abs() <= 2,
                    "eye dx {eye_dx}: pixel ({x},{y}) of {off:?} is {got:?}, want {want:?}"
                );
            }
        }
        assert_eq!(at(0, 0), [SKY[0], SKY[1], SKY[2]]);
    }
}

#[test]
fn lit_shading_matches_the_design_formula() {
    // The quad bake drawn as an original: grey 128 albedo, normal +z:
    // linear 0.2158 · (0.3 + 0.7 · 0.26833) → sRGB8.
    let dir = tempfile::tempdir().unwrap();
    let centre = Vec3::new(50.0, 6.0, 50.0);
    let capture = capture_camera(
        Vec3::new(50.0, 6.0, 70.0),
        centre - Vec3::splat(5.0),
        centre + Vec3::splat(5.0),
        8,
    );
    let tex = Texture::from_rgba8(1, 1, &[0, 0, 0, 0], TextureEncoding::Rgba8).unwrap();
    write_quad_bake(dir.path(), centre, &capture, tex).unwrap();
    let Some(mut p) = open(dir.path(), (32, 32), &DrawOptions::default()) else {
        return;
    };
    let cam = Camera {
        width: 32,
        height: 32,
        ..capture
    };
    p.draw(&cam, Mode::Full, None);
    let px = p.renderer.read_pixels().unwrap();
    let i = (16 * 32 + 16) * 4;
    let lin = |c: f64| {
        let c = c / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let l = lin(128.0) * (0.3 + 0.7 * (0.3 / 1.25f64.sqrt()));
    let enc = if l <= 0.0031308 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    let want = (enc * 255.0).round() as i32;
    for k in 0..3 {
        assert!(
            (px[i + k] as i32 - want).abs() <= 1,
            "{:?} vs {want}",
            &px[i..i + 3]
        );
    }
    // The same quad as a proxy whose only texel is transparent falls back to the
    // lit vertex colour.
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
    p.draw(&cam, Mode::Hybrid, Some(&mut s));
    let px2 = p.renderer.read_pixels().unwrap();
    assert_eq!(&px2[i..i + 3], &px[i..i + 3]);
}

fn write_path(dir: &std::path::Path, res: u32) -> std::path::PathBuf {
    let p = dir.join("walk.ron");
    std::fs::write(
        &p,
        format!(
            "(eye_height: 6.0, fov_y_deg: 60.0, resolution: ({res}, {res}), max_speed: 30.0,
              max_turn_deg_per_s: 45.0, frame_rate: 1.0,
              waypoints: [(30.0, 40.0), (150.0, 120.0), (270.0, 210.0)])"
        ),
    )
    .unwrap();
    p
}

/// `render` of the bake in `dir` along `path` in hybrid mode, frames (and `frames.csv`)
/// into `dir/frames`.
fn render_hybrid(
    dir: &std::path::Path,
    path: &format::path::CameraPath,
    png: bool,
    stream: StreamConfig,
    size: Option<(u32, u32)>,
) -> Vec<player::run::FrameRow> {
    let opts = RenderOptions {
        mode: Mode::Hybrid,
        frames_dir: dir.join("frames"),
        png,
        stream,
        size,
        lod_pixel_error: 1.0,
        cluster_tau: player::clusterlod::DEFAULT_TAU_PX,
        draw: DrawOptions::default(),
        pace: 0.0,
    };
    render(dir, path, &opts).unwrap().0
}

#[test]
fn render_writes_csv_and_compare_reports_quality() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let path_file = write_path(dir.path(), 64);
    let path = format::path::CameraPath::load(&path_file).unwrap();
    if renderer(8, 8).is_none() {
        return;
    }
    let frames_dir = dir.path().join("frames");
    let records = render_hybrid(dir.path(), &path, true, StreamConfig::default(), None);
    assert_eq!(records.len(), path.frames().len());
    let crossings = records.iter().filter(|r| r.crossing).count();
    assert!(crossings >= 2, "{crossings} crossings");
    let last = records.last().unwrap();
    assert_eq!(
        last.cache_hits + last.cache_misses,
        records.len() as u64,
        "one current-cell lookup per frame"
    );
    let csv = std::fs::read_to_string(frames_dir.join("frames.csv")).unwrap();
    assert_eq!(csv.lines().next(), Some(FRAMES_CSV_HEADER));
    assert_eq!(csv.lines().count(), records.len() + 1);
    // Issue 28: every row says what it was drawn with (the defaults here; lavapipe
    // samples BC), and reads back as the row type the benchmark tool reads.
    let rows = format::schema::frames::parse_frames_csv(&csv).unwrap();
    assert_eq!(rows.len(), records.len());
    for (row, rec) in rows.iter().zip(&records) {
        assert_eq!(row.draw_options, rec.draw_options);
        assert_eq!(
            (row.frame, row.cell, row.triangles),
            (rec.frame, rec.cell, rec.triangles)
        );
        let o = row.draw_options.expect("written");
        assert_eq!(
            o,
            DrawOptions {
                bc_textures: o.bc_textures,
                ..Default::default()
            }
        );
    }
    assert!(frames_dir.join("00000.png").exists());

    let worst = dir.path().join("worst");
    let report = compare(
        dir.path(),
        &path,
        &CompareOptions {
            worst_dir: Some(worst.clone()),
            worst_count: 2,
            size: Some((48, 48)),
            crossings: true,
            stream: StreamConfig::default(),
            ..Default::default()
        },
    )
    .unwrap();
    println!(
        "compare: psnr {:.2} (min {:.2}), ssim {:.4}, tris {} / {}",
        report.mean_psnr_y,
        report.min_psnr_y,
        report.mean_ssim,
        report.mean_triangles,
        report.reference_triangles
    );
    assert_eq!(report.frames, records.len());
    // Issue 28: the report says what its frames were drawn with.
    assert_eq!(report.draw_options, rows[0].draw_options);
    // Measured 40.8 dB mean PSNR-Y (min 30.2) on lavapipe; floor 38 dB (a 2.8 dB
    // margin for other adapters' rasterization).
    assert!(
        report.mean_psnr_y.is_finite() && report.mean_psnr_y >= 38.0,
        "mean PSNR-Y {:.2} dB",
        report.mean_psnr_y
    );
    assert!(report.mean_ssim > 0.0 && report.mean_ssim <= 1.0);
    assert!(report.mean_triangles <= report.reference_triangles);
    let json = serde_json::to_value(&report).unwrap();
    assert_has_keys(
        &json,
        COMPARE_KEYS.into_iter().chain([
            "object_psnr_y_db",
            "min_object_psnr_y_db",
            "worst_object_frame",
            "mean_object_ssim",
            "object_pixel_fraction",
            "aa_reference",
        ]),
    );
    assert_object_figures_are_sane(&report);
    // Issue 14: the anti-aliased reference, 4 × 4 by default.
    let aa = report.aa_reference.as_ref().expect("on by default");
    assert_eq!((aa.supersampling_factor, aa.samples_per_pixel), (4, 16));
    for side in ["compared", "full"] {
        for key in [
            "mean_psnr_y_db",
            "min_psnr_y_db",
            "mean_ssim",
            "object_psnr_y_db",
            "min_object_psnr_y_db",
            "worst_object_frame",
            "mean_object_ssim",
            "object_pixel_fraction",
        ] {
            assert!(
                json["aa_reference"][side].get(key).is_some(),
                "missing aa_reference.{side}.{key}"
            );
        }
    }
    // Against the 4 × 4 reference, object pixels: measured 20.0 dB (compared frames)
    // and 19.5 dB (full geometry) on lavapipe; floor 17 dB (a 2.5 dB margin).
    for q in [&aa.compared, &aa.full] {
        println!(
            "aa reference: mean {:.2} dB, object {:.2} dB",
            q.mean_psnr_y_db, q.object.object_psnr_y_db
        );
        assert!(
            q.object.object_psnr_y_db >= 17.0 && q.object.object_psnr_y_db <= q.mean_psnr_y_db,
            "object PSNR-Y {:.2} dB (mean {:.2} dB)",
            q.object.object_psnr_y_db,
            q.mean_psnr_y_db
        );
        assert!(q.object.mean_object_ssim > 0.0 && q.object.mean_object_ssim <= 1.0);
    }
    // One sample per pixel is not the anti-aliased image: the aliased full-geometry
    // frame has an error of its own on object pixels (edges).
    assert!(aa.full.object.object_psnr_y_db < player::run::PSNR_CAP);
    let json_frame = &json["per_frame"][0];
    for key in [
        "object_pixels",
        "object_psnr_y_db",
        "object_ssim",
        "aa_reference",
    ] {
        assert!(json_frame.get(key).is_some(), "missing per_frame.{key}");
    }
    // Reference, compared mode, difference and the anti-aliased reference per frame.
    let pngs = std::fs::read_dir(&worst).unwrap().count();
    assert_eq!(pngs, 8);
}

/// The object-pixel figures of a report against the aliased full-geometry frame:
/// never better than the whole frame's (the sky adds pixels without error).
fn assert_object_figures_are_sane(report: &player::run::CompareReport) {
    let o = &report.object;
    println!(
        "object pixels {:.1}%: PSNR(Y) {:.2} dB pooled (worst frame {:?} {:.2}), SSIM {:.4}",
        100.0 * o.object_pixel_fraction,
        o.object_psnr_y_db,
        o.worst_object_frame,
        o.min_object_psnr_y_db,
        o.mean_object_ssim
    );
    assert!(o.object_pixel_fraction > 0.0 && o.object_pixel_fraction < 1.0);
    assert!(o.object_psnr_y_db <= report.mean_psnr_y, "{o:?}");
    assert!(o.min_object_psnr_y_db <= o.object_psnr_y_db, "{o:?}");
    assert!(o.min_object_psnr_y_db <= report.min_psnr_y, "{o:?}");
    assert!(o.mean_object_ssim <= 1.0 && o.mean_object_ssim > 0.0);
    let worst = o.worst_object_frame.expect("objects in view");
    assert_eq!(
        report.per_frame[worst].object_psnr_y_db,
        Some(o.min_object_psnr_y_db)
    );
    for f in &report.per_frame {
        if let Some(p) = f.object_psnr_y_db {
            assert!(
                p <= f.psnr_y + 1e-9,
                "frame {}: {p} > {}",
                f.frame,
                f.psnr_y
            );
            assert!(f.object_pixels > 0);
        } else {
            assert_eq!(f.object_pixels, 0);
        }
    }
}

/// The synthetic bake opened at 64², a camera at instance 0 and the cell it is in
/// (`None`: no graphics adapter).
fn synthetic_at_instance_0() -> Option<(tempfile::TempDir, Player, Camera, u32)> {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let p = open(dir.path(), (64, 64), &DrawOptions::default())?;
    let cam = camera_at_instance(&p, 0, 64);
    let cell = p
        .bake
        .grid
        .nearest_cell(Vec2::new(cam.eye.x, cam.eye.z))
        .unwrap();
    Some((dir, p, cam, cell))
}

/// Damages a pack in the middle (its checksums then refuse it).
fn flip_middle_byte(path: &std::path::Path) {
    let mut bytes = std::fs::read(path).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xff;
    std::fs::write(path, &bytes).unwrap();
}

#[test]
fn a_missing_or_corrupt_cell_pack_is_drawn_as_originals() {
    let Some((dir, mut p, cam, cell)) = synthetic_at_instance_0() else {
        return;
    };
    let pack = dir.path().join(format!("cells/{cell}.pack"));
    flip_middle_byte(&pack);
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            ..Default::default()
        },
    );
    let (_, tris, tex, stats) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
    let hybrid = p.renderer.read_pixels().unwrap();
    let (_, tris_b, _, _) = p.draw(&cam, Mode::Frustum, None);
    let frustum = p.renderer.read_pixels().unwrap();
    assert_eq!(stats.cell, Some(cell));
    assert_eq!((tris, tex), (tris_b, 0));
    assert_eq!(psnr_y(&hybrid, &frustum), f64::INFINITY);
    std::fs::remove_file(&pack).unwrap();
    let mut s2 = Streamer::new(&p.bake, StreamConfig::default());
    let (_, tris2, _, _) = p.draw(&cam, Mode::Hybrid, Some(&mut s2));
    assert_eq!(tris2, tris_b);
}

fn solid(rgb: [u8; 3]) -> Texture {
    let rgba: Vec<u8> = (0..16 * 16)
        .flat_map(|_| [rgb[0], rgb[1], rgb[2], 255])
        .collect();
    Texture::from_rgba8(16, 16, &rgba, TextureEncoding::Rgba8).unwrap()
}

#[test]
fn mv_mesh_blends_the_two_views_closest_to_the_viewer_direction() {
    // Three captures of the quad from the left, the front and the right; red, green,
    // blue. Triangle 0 sees all three views, triangle 1 none (lit fallback).
    let dir = tempfile::tempdir().unwrap();
    let centre = Vec3::new(50.0, 6.0, 50.0);
    let cap = |dx: f32| {
        capture_camera(
            Vec3::new(50.0 + dx, 6.0, 70.0),
            centre - Vec3::splat(6.0),
            centre + Vec3::splat(6.0),
            16,
        )
    };
    player::testdata::write_quad_bake_views(
        dir.path(),
        centre,
        format::pack::ProxyKind::MvMesh,
        vec![
            (cap(-20.0), solid([255, 0, 0])),
            (cap(0.0), solid([0, 255, 0])),
            (cap(20.0), solid([0, 0, 255])),
        ],
        vec![0b111, 0],
    )
    .unwrap();
    let Some(mut p) = open(dir.path(), (64, 64), &DrawOptions::default()) else {
        return;
    };
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
    // Triangle 0 = (-h,-h), (h,-h), (h,h): its lower-right half; sample near (3, -3).
    let probe = Vec3::new(3.0, -3.0, 0.0);
    let centroid = centre + Vec3::new(5.0 / 3.0, -5.0 / 3.0, 0.0);
    let mut last = None;
    for eye_dx in [-20.0f32, -10.0, 0.0, 10.0, 20.0] {
        let eye = Vec3::new(50.0 + eye_dx, 6.0, 70.0);
        let cam = Camera {
            eye,
            dir: centre - eye,
            fov_y_deg: 40.0,
            width: 64,
            height: 64,
            near: 0.5,
            far: 200.0,
        };
        p.draw(&cam, Mode::Hybrid, Some(&mut s));
        let px = p.renderer.read_pixels().unwrap();
        let c = cam.clip_from_world_gl() * (centre + probe).extend(1.0);
        let (x, y) = (
            ((c.x / c.w + 1.0) * 32.0) as usize,
            ((1.0 - c.y / c.w) * 32.0) as usize,
        );
        let i = (y * 64 + x) * 4;
        let got = [px[i], px[i + 1], px[i + 2]];
        // Expected: the two views with the smallest angle at the triangle centroid,
        // weights inversely proportional to the angles, blended in linear space.
        let to_poly = centroid - eye;
        let mut angles: Vec<(f32, usize)> = [-20.0f32, 0.0, 20.0]
            .iter()
            .enumerate()
            .map(|(k, dx)| {
                let ve = Vec3::new(50.0 + dx, 6.0, 70.0);
                ((centroid - ve).angle_between(to_poly), k)
            })
            .collect();
        angles.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (a0, a1) = (angles[0].0 as f64, angles[1].0 as f64);
        let (w0, w1) = if a0 + a1 > 1e-6 {
            (a1 / (a0 + a1), a0 / (a0 + a1))
        } else {
            (0.5, 0.5)
        };
        let mut lin = [0f64; 3];
        lin[angles[0].1] += w0;
        lin[angles[1].1] += w1;
        let enc = |l: f64| {
            let v = if l <= 0.0031308 {
                l * 12.92
            } else {
                1.055 * l.powf(1.0 / 2.4) - 0.055
            };
            (v * 255.0).round() as i32
        };
        for k in 0..3 {
            assert!(
                (got[k] as i32 - enc(lin[k])).abs() <= 3,
                "eye dx {eye_dx}: {got:?} vs expected linear {lin:?}"
            );
        }
        // Triangle 1 has an empty mask: lit grey, the same from every viewpoint.
        let q = cam.clip_from_world_gl() * (centre + Vec3::new(-3.0, 3.0, 0.0)).extend(1.0);
        let (x, y) = (
            ((q.x / q.w + 1.0) * 32.0) as usize,
            ((1.0 - q.y / q.w) * 32.0) as usize,
        );
        let j = (y * 64 + x) * 4;
        let lit = [px[j], px[j + 1], px[j + 2]];
        assert!(lit[0] == lit[1] && lit[1] == lit[2], "{lit:?}");
        if let Some(prev) = last {
            assert_eq!(prev, lit);
        }
        last = Some(lit);
    }
}

#[test]
fn compare_of_a_bake_without_proxies_is_perfect() {
    let dir = tempfile::tempdir().unwrap();
    player::testdata::write_synthetic_bake_with(dir.path(), true).unwrap();
    let path_file = write_path(dir.path(), 32);
    let path = format::path::CameraPath::load(&path_file).unwrap();
    if renderer(8, 8).is_none() {
        return;
    }
    let report = compare(
        dir.path(),
        &path,
        &CompareOptions {
            size: Some((32, 32)),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(report.mean_psnr_y, player::run::PSNR_CAP);
    assert_eq!(report.min_psnr_y, player::run::PSNR_CAP);
    assert!(
        (report.mean_ssim - 1.0).abs() < 1e-9,
        "{}",
        report.mean_ssim
    );
    assert!(report.mean_triangles <= report.reference_triangles);
    // Issue 14: no error on object pixels either, and the same frame scores the
    // same against the anti-aliased reference as the reference does.
    assert_eq!(report.object.object_psnr_y_db, player::run::PSNR_CAP);
    assert_eq!(report.object.min_object_psnr_y_db, player::run::PSNR_CAP);
    assert!(report.object.object_pixel_fraction > 0.0);
    let aa = report.aa_reference.as_ref().unwrap();
    assert_eq!(aa.compared, aa.full);
    assert!(aa.full.object.object_psnr_y_db < player::run::PSNR_CAP);
}

/// Pixels where the reference shows an object and `img` shows sky.
fn holes(reference: &[u8], img: &[u8]) -> usize {
    let sky = |p: &[u8]| p[0] == SKY[0] && p[1] == SKY[1] && p[2] == SKY[2];
    reference
        .chunks_exact(4)
        .zip(img.chunks_exact(4))
        .filter(|(r, h)| !sky(r) && sky(h))
        .count()
}

/// Issue 7 (the 723 ms crossing frame): the texture queue never uploads more than
/// the per-frame budget, also at crossings; the current cell's queued textures go
/// first, so its proxies waiting for textures only decrease while the viewer stays.
#[test]
fn texture_uploads_stay_under_the_budget_at_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    if renderer(8, 8).is_none() {
        return;
    }
    let path = demo_walk();
    let budget = 3 * 32 * 32 * 4; // three of the synthetic bake's 32² captures
    let frames_dir = dir.path().join("frames");
    let stream = StreamConfig {
        upload_budget_bytes: budget,
        ..Default::default()
    };
    let records = render_hybrid(dir.path(), &path, false, stream, Some((48, 48)));
    let csv = std::fs::read_to_string(frames_dir.join("frames.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (up, pend, cell) = (col("uploaded_bytes"), col("pending_proxies"), col("cell"));
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    assert_eq!(rows.len(), records.len());
    let mut total = 0u64;
    for (r, rec) in rows.iter().zip(&records) {
        let bytes: u64 = r[up].parse().unwrap();
        assert_eq!(bytes, rec.uploaded_bytes);
        assert!(
            bytes <= budget,
            "frame {}: {bytes} bytes uploaded, budget {budget}",
            r[0]
        );
        total += bytes;
    }
    assert!(total > 0, "textures were uploaded");
    let crossings = records.iter().filter(|r| r.crossing).count();
    assert!(crossings >= 3, "{crossings} crossings");
    // Within a stay in one cell, proxies waiting for textures never increase.
    for w in rows.windows(2) {
        if w[0][cell] == w[1][cell] {
            let (a, b): (usize, usize) = (w[0][pend].parse().unwrap(), w[1][pend].parse().unwrap());
            assert!(
                b <= a,
                "frames {} → {}: pending {a} → {b}",
                w[0][0],
                w[1][0]
            );
        }
    }
    assert!(
        records.iter().any(|r| r.pending_proxies > 0),
        "the small budget leaves proxies waiting at crossings"
    );
    println!(
        "uploads per frame: {:?}",
        records.iter().map(|r| r.uploaded_bytes).collect::<Vec<_>>()
    );
    println!(
        "pending proxies: {:?}",
        records
            .iter()
            .map(|r| r.pending_proxies)
            .collect::<Vec<_>>()
    );
}

/// The synthetic bake's hybrid frame looking across the park from a corner (many
/// SV mesh proxies in view), with the single-view mesh proxies of each pack drawn in
/// batches (`Renderer::set_mesh_batches`, the default) or one by one, every texture
/// resident (`PendingDraw::Lit`: the frame before is drawn with the lit ones too).
/// Returns the pixels, the draw calls (as the list predicts them and as submitted),
/// the triangles and the proxies waiting; `None` without an adapter.
fn mesh_batch_frame(batches: bool, budget: u64) -> Option<(Vec<u8>, u64, u64, u64, usize)> {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let mut p = open(dir.path(), (128, 128), &DrawOptions::default())?;
    p.renderer.set_mesh_batches(batches);
    let cam = Camera {
        eye: Vec3::new(30.0, 6.0, 40.0),
        dir: Vec3::new(120.0, -2.0, 80.0),
        fov_y_deg: 60.0,
        width: 128,
        height: 128,
        near: 0.25,
        far: p.bake.extent,
    };
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            upload_budget_bytes: budget,
            pending: PendingDraw::Lit,
            ..Default::default()
        },
    );
    let (_, list, stats) = p.draw_listed(&cam, Mode::Hybrid, Some(&mut s));
    let px = p.renderer.read_pixels().unwrap();
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mesh-batches-{batches}-budget-{budget}.png"));
    player::run::write_png(&out, 128, 128, &px).unwrap();
    eprintln!(
        "batches {batches}, budget {budget}: {} draw calls, {} triangles, {} proxies waiting; {}",
        list.draw_calls,
        list.triangles,
        stats.pending_proxies,
        out.display()
    );
    Some((
        px,
        list.draw_calls,
        p.renderer.last_draw_calls,
        list.triangles,
        stats.pending_proxies,
    ))
}

/// Issue 27: a pack's single-view mesh proxies (SV meshes, the synthetic bake's one
/// cluster) drawn in batches of up to 8 — one vertex buffer, one atlas, one uniform,
/// one draw call (`Renderer::create_pack_proxies`) — give the frame of drawing them
/// one by one in fewer draw calls, with the same tiles culled; so does a frame whose
/// proxies wait for their textures and are drawn lit.
#[test]
fn mesh_batches_draw_the_same_frame_in_fewer_calls() {
    let Some((batched, calls, submitted, tris, _)) = mesh_batch_frame(true, 1 << 30) else {
        return;
    };
    let (alone, calls_alone, submitted_alone, tris_alone, _) =
        mesh_batch_frame(false, 1 << 30).unwrap();
    assert_eq!((calls, calls_alone), (submitted, submitted_alone));
    assert_eq!(tris, tris_alone, "the tiles culled are the same");
    assert!(
        calls + 5 <= calls_alone,
        "{calls} draw calls batched, {calls_alone} alone"
    );
    assert!(
        non_sky(&batched) > 2000,
        "{} object pixels",
        non_sky(&batched)
    );
    let differ = |a: &[u8], b: &[u8]| {
        let worst = a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
        let n = a
            .chunks_exact(4)
            .zip(b.chunks_exact(4))
            .filter(|(x, y)| x != y)
            .count();
        (n, worst)
    };
    let (n, worst) = differ(&batched, &alone);
    eprintln!("batched vs alone: {n} pixels differ, worst channel by {worst}");
    assert_eq!((n, worst), (0, 0), "the same frame");
    // Nothing uploaded yet: every proxy drawn lit, batches as their members.
    let Some((lit, calls_lit, _, tris_lit, waiting)) = mesh_batch_frame(true, 1) else {
        return;
    };
    let (lit_alone, calls_lit_alone, _, _, waiting_alone) = mesh_batch_frame(false, 1).unwrap();
    assert!(
        waiting > 0 && waiting < waiting_alone,
        "{waiting} vs {waiting_alone}"
    );
    assert_eq!(tris_lit, tris);
    assert_eq!((calls_lit, calls_lit_alone), (calls, calls_alone));
    assert_eq!(differ(&lit, &lit_alone), (0, 0), "the same lit frame");
}

/// Proxies whose textures are still queued are drawn as their members' original
/// geometry: a frame with a tiny budget has no more holes than one with every
/// texture resident (a skipped proxy would leave sky where its objects are).
#[test]
fn proxies_waiting_for_textures_are_drawn_as_originals() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let Some(mut p) = open(dir.path(), (96, 96), &DrawOptions::default()) else {
        return;
    };
    // Looking across the park from a corner: many outside objects (proxies) in view.
    let cam = Camera {
        eye: Vec3::new(30.0, 6.0, 40.0),
        dir: Vec3::new(120.0, -2.0, 80.0),
        fov_y_deg: 60.0,
        width: 96,
        height: 96,
        near: 0.25,
        far: p.bake.extent,
    };
    p.warm_up(&cam);
    p.draw(&cam, Mode::Frustum, None);
    let reference = p.renderer.read_pixels().unwrap();
    let stream = |p: &Player, budget: u64, pending: PendingDraw| {
        Streamer::new(
            &p.bake,
            StreamConfig {
                prefetch: false,
                upload_budget_bytes: budget,
                pending,
                ..Default::default()
            },
        )
    };
    let mut tiny = stream(&p, 1, PendingDraw::Originals);
    let (_, _, _, stats) = p.draw(&cam, Mode::Hybrid, Some(&mut tiny));
    let waiting = p.renderer.read_pixels().unwrap();
    assert_eq!(stats.uploaded_bytes, 32 * 32 * 4, "one texture per frame");
    assert!(stats.pending_proxies > 0);
    // A drawn frame standing for 4 display frames (headless paths, `--display-hz`):
    // the 3 undrawn ones upload one texture each after it, at the same pose.
    let mut four = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            upload_budget_bytes: 1,
            display_frames_per_step: 4,
            ..Default::default()
        },
    );
    let (_, _, _, stats_four) = p.draw(&cam, Mode::Hybrid, Some(&mut four));
    assert_eq!(
        stats_four.uploaded_bytes,
        32 * 32 * 4,
        "the drawn frame's own upload"
    );
    assert!(tiny.queued_uploads() >= 4, "{}", tiny.queued_uploads());
    assert_eq!(four.queued_uploads() + 3, tiny.queued_uploads());
    let mut big = stream(&p, 1 << 30, PendingDraw::Originals);
    let (_, tris_ready, _, stats_big) = p.draw(&cam, Mode::Hybrid, Some(&mut big));
    let ready = p.renderer.read_pixels().unwrap();
    assert_eq!(stats_big.pending_proxies, 0);
    // `--pending lit`: the waiting proxies drawn untextured (the same triangles as
    // when they are ready; the synthetic proxies are not simplified, so their
    // members' originals are not more here), no holes either.
    let mut lit = stream(&p, 1, PendingDraw::Lit);
    let (_, tris_lit, _, stats_lit) = p.draw(&cam, Mode::Hybrid, Some(&mut lit));
    let lit_px = p.renderer.read_pixels().unwrap();
    assert_eq!(stats_lit.pending_proxies, stats.pending_proxies);
    assert_eq!(tris_lit, tris_ready);
    assert!(holes(&reference, &lit_px) <= holes(&reference, &ready));
    assert!(non_sky(&lit_px) >= non_sky(&ready) * 95 / 100);
    let object_pixels = non_sky(&reference);
    let (h_wait, h_ready) = (holes(&reference, &waiting), holes(&reference, &ready));
    println!(
        "{} proxies waiting; holes {h_wait} (waiting) vs {h_ready} (ready) of {object_pixels} object pixels; PSNR {:.2} / {:.2}",
        stats.pending_proxies,
        psnr_y(&reference, &waiting),
        psnr_y(&reference, &ready)
    );
    assert!(object_pixels > 500);
    assert!(h_wait <= h_ready, "{h_wait} > {h_ready}");
    assert!(psnr_y(&reference, &waiting) >= psnr_y(&reference, &ready));
}

/// After a crossing, a proxy of the new cell whose textures are still queued is
/// drawn by its stand-in, the previous cell's ready proxy of the same objects
/// (`--pending stand-ins`, the default), instead of its members as originals: the
/// frame submits no more triangles, draws textured proxies where `originals` draws
/// none, and has no more holes than the frame with every texture resident.
#[test]
fn after_a_crossing_the_previous_cells_proxies_stand_in() {
    let Some((_dir, mut p, cam_a, cell_a)) = synthetic_at_instance_0() else {
        return;
    };
    // A neighbour of the cell, entered at its centre, looking across the park
    // (both cameras).
    let grid = &p.bake.grid;
    let g = *grid.params();
    let middle = Vec3::new(
        0.5 * (g.ground_min[0] + g.ground_max[0]),
        cam_a.eye.y,
        0.5 * (g.ground_min[1] + g.ground_max[1]),
    );
    let across = |eye: Vec3| Camera {
        eye,
        dir: (middle - eye).normalize_or(Vec3::X) - Vec3::new(0.0, 0.02, 0.0),
        ..cam_a
    };
    let cam_a = across(cam_a.eye);
    let (cam_b, cell_b) = grid
        .neighbours(cell_a)
        .into_iter()
        .map(|n| {
            let c = grid.centre(n);
            (across(Vec3::new(c.x, cam_a.eye.y, c.y)), n)
        })
        .find(|(cam, n)| {
            grid.nearest_cell(Vec2::new(cam.eye.x, cam.eye.z)) == Some(*n)
                && p.bake.load_cell(*n).is_ok_and(|c| !c.proxies.is_empty())
        })
        .expect("a neighbour with proxies");
    p.warm_up(&cam_a);
    p.draw(&cam_b, Mode::Frustum, None);
    let reference = p.renderer.read_pixels().unwrap();
    let walk = |p: &mut Player, pending: PendingDraw| {
        let mut s = Streamer::new(
            &p.bake,
            StreamConfig {
                prefetch: false,
                upload_budget_bytes: 1, // one texture per frame
                pending,
                ..Default::default()
            },
        );
        // Stay in the first cell until its textures are all resident.
        for _ in 0..200 {
            let (_, _, _, st) = p.draw(&cam_a, Mode::Hybrid, Some(&mut s));
            if st.pending_proxies == 0 {
                break;
            }
        }
        let (_, tris, tex, st) = p.draw(&cam_b, Mode::Hybrid, Some(&mut s));
        assert_eq!(st.cell, Some(cell_b));
        assert!(st.pending_proxies > 0, "the new cell waits for textures");
        (tris, tex, p.renderer.read_pixels().unwrap())
    };
    let (tris_s, tex_s, stand_in) = walk(&mut p, PendingDraw::StandIns);
    let (tris_o, tex_o, originals) = walk(&mut p, PendingDraw::Originals);
    let mut ready_stream = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            ..Default::default()
        },
    );
    p.prime(&mut ready_stream, &cam_b);
    p.draw(&cam_b, Mode::Hybrid, Some(&mut ready_stream));
    let ready = p.renderer.read_pixels().unwrap();
    println!(
        "stand-ins {tris_s} triangles / {tex_s} texture bytes; originals {tris_o} / {tex_o}; \
         holes {} / {} / ready {}",
        holes(&reference, &stand_in),
        holes(&reference, &originals),
        holes(&reference, &ready)
    );
    assert!(tris_s <= tris_o, "{tris_s} > {tris_o}");
    assert!(
        tex_s > tex_o,
        "stand-ins drawn: {tex_s} vs {tex_o} texture bytes"
    );
    assert!(holes(&reference, &stand_in) <= holes(&reference, &ready));
}

/// The loading screen ([`Streamer::prime`]): the first frame of a walk shows the
/// start cell as baked (no proxy waiting for textures), and the cache statistics
/// do not count it.
#[test]
fn a_primed_walk_starts_with_its_cell_ready() {
    let Some((_dir, mut p, cam, cell)) = synthetic_at_instance_0() else {
        return;
    };
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            upload_budget_bytes: 1,
            ..Default::default()
        },
    );
    p.prime(&mut s, &cam);
    let (_, _, tex, st) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
    assert_eq!(st.cell, Some(cell));
    assert_eq!(st.pending_proxies, 0);
    assert!(tex > 0);
    assert_eq!((st.hits, st.misses), (1, 0));
}

/// The far field (format version 2, issue 13): a cell whose proxies live in its
/// group's pack (`groups/<id>.pack`) draws the same frame as when they were its own;
/// with the group's pack damaged, the cell draws those objects as originals (never a
/// hole).
#[test]
fn a_cells_far_field_group_is_drawn_with_it() {
    let Some((dir, mut p, cam, cell)) = synthetic_at_instance_0() else {
        return;
    };
    let no_prefetch = || StreamConfig {
        prefetch: false,
        ..Default::default()
    };
    let mut s = Streamer::new(&p.bake, no_prefetch());
    let (_, tris, _, _) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
    let before = p.renderer.read_pixels().unwrap();
    drop(s);
    // Move the cell's proxies into far-field group 0.
    share_a_group(dir.path(), &[cell]);
    let group_path = dir.path().join("groups/0.pack");
    let mut p = open(dir.path(), (64, 64), &DrawOptions::default()).unwrap();
    let mut s = Streamer::new(&p.bake, no_prefetch());
    let (_, tris_far, _, _) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
    let after = p.renderer.read_pixels().unwrap();
    assert_eq!(tris_far, tris);
    assert_eq!(psnr_y(&before, &after), f64::INFINITY);
    drop(s);
    // A damaged group pack: the group's objects are drawn as originals.
    flip_middle_byte(&group_path);
    let mut s = Streamer::new(&p.bake, no_prefetch());
    let (_, _, tex, _) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
    let hybrid = p.renderer.read_pixels().unwrap();
    let (_, _, _, _) = p.draw(&cam, Mode::Frustum, None);
    let frustum = p.renderer.read_pixels().unwrap();
    assert_eq!(tex, 0);
    assert_eq!(psnr_y(&hybrid, &frustum), f64::INFINITY);
}

/// Issue 31 item 3: the neighbours the prefetch thread prepares (here: all of them,
/// while the viewer stands still) arrive with their GPU objects made on that thread,
/// so a frame accepts them all without making any (`built_here` 0), and they are
/// resident afterwards. Fails when the render thread makes them (it did, one pack a
/// frame at 10–33 ms each on lavapipe).
#[test]
fn prefetched_packs_arrive_with_their_gpu_objects_made() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let path = demo_walk();
    let Some(mut p) = open(dir.path(), (96, 96), &DrawOptions::default()) else {
        return;
    };
    let cam = player::run::camera_for(&path.frames()[0], &path, (96, 96), p.bake.extent);
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
    let (_, _, _, first) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
    assert!(first.cell.is_some() && !first.fallback, "{first:?}");
    // The current cell was a demand load: made on the render thread.
    assert!(first.built_here >= 1, "{first:?}");
    let before = s.resident_cells().len();
    // The prefetch thread prepares the whole ring meanwhile.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let mut accepted = 0;
    while accepted < 2 && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(500));
        let (_, _, _, st) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
        assert_eq!(st.built_here, 0, "{st:?}");
        assert!(!st.fallback && st.cell == first.cell, "{st:?}");
        accepted += st.accepted_ahead;
    }
    assert!(accepted >= 2, "{accepted} neighbours accepted");
    assert_eq!(s.resident_cells().len(), before + accepted);
}

/// Issue 31 item 3: walking at the path's own speed (frames paced at `1 / frame_rate`
/// in real time, the prefetch thread running beside), the cell the viewer crosses
/// into is already resident: the first frame in it finds its pack in the cache (no
/// demand load) and draws no stand-in. Fails when prefetch is off (checked too).
#[test]
fn the_next_cell_is_resident_before_the_viewer_crosses_into_it() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let path = demo_walk();
    let Some(mut p) = open(dir.path(), (96, 96), &DrawOptions::default()) else {
        return;
    };
    let all_frames = path.frames();
    let period = std::time::Duration::from_secs_f32(1.0 / path.frame_rate);
    // (crossings, crossings into a cell that was not resident), walking at `speed`
    // times the path's speed (every `speed`-th frame, paced the same).
    let mut walk = |prefetch: bool, speed: usize| -> (usize, usize) {
        let frames: Vec<_> = all_frames.iter().step_by(speed).collect();
        let config = StreamConfig {
            prefetch,
            ..StreamConfig::default()
        };
        let budget = config.upload_budget_bytes;
        let mut s = Streamer::new(&p.bake, config);
        let (mut crossings, mut missed) = (0, 0);
        let (mut cell, mut misses) = (None, 0);
        for f in frames {
            let start = std::time::Instant::now();
            let cam = player::run::camera_for(f, &path, (96, 96), p.bake.extent);
            let (_, _, _, stats) = p.draw(&cam, Mode::Hybrid, Some(&mut s));
            // What is not drawn yet costs this thread little: prefetched packs
            // arrive with their GPU objects made, their textures go under a share
            // of the budget (the demo's textures are each smaller than that
            // share, and its queue drains at less than the whole budget).
            if prefetch && stats.misses == misses && cell.is_some() {
                assert_eq!(stats.built_here, 0, "no demand load, yet {stats:?}");
            }
            assert!(
                stats.uploaded_ahead_bytes <= stats.ahead_budget_bytes,
                "{stats:?}"
            );
            assert!(stats.ahead_budget_bytes < budget, "{stats:?}");
            if cell.is_some() && stats.cell != cell {
                crossings += 1;
                if stats.misses > misses || stats.fallback {
                    missed += 1;
                }
            }
            (cell, misses) = (stats.cell, stats.misses);
            std::thread::sleep(period.saturating_sub(start.elapsed()));
        }
        (crossings, missed)
    };
    for speed in [1, 3] {
        let (crossings, missed) = walk(true, speed);
        assert!(crossings >= 3, "{crossings} crossings");
        assert_eq!(
            missed, 0,
            "at {speed}× walking speed, {missed} of {crossings} crossings into a cell not resident"
        );
    }
    // The test can fail: without prefetch every crossing is a demand load.
    let (crossings, missed) = walk(false, 1);
    assert_eq!(
        missed, crossings,
        "without prefetch: {missed} of {crossings}"
    );
}

/// Issue 31 item 2, the cross-fade's renderer: lists drawn in one frame with
/// dither ranges that partition the 64 Bayer levels each own their pixels. Every
/// pixel of the blend is exactly the pixel of the list whose range holds its level
/// (so nothing is drawn twice opaque and nothing is missing), a list blended with
/// itself is the plain frame, and a shared list drawn first without a range
/// (`frame::blend_lists`) changes nothing.
#[test]
fn a_blended_frame_shows_each_pixel_from_the_list_owning_its_level() {
    use player::frame::{hybrid_list, originals_list};
    use player::gpu::DrawList;
    use player::transition::bayer8;
    let Some((_dir, mut p, cam, _)) = synthetic_at_instance_0() else {
        return;
    };
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            ..Default::default()
        },
    );
    p.prime(&mut s, &cam);
    s.advance(&p.renderer, &p.bake, &cam);
    let hybrid = hybrid_list(&p.bake, &cam, &s.current(), s.config().pending);
    let full = originals_list(&p.bake, &cam, false);
    let mut draw = |lists: &[(&DrawList<'_>, Option<(u32, u32)>)]| {
        p.renderer.render_blend(&cam, &p.models, lists);
        p.renderer.read_pixels().unwrap()
    };
    let a = draw(&[(&hybrid, None)]);
    let b = draw(&[(&full, None)]);
    assert_ne!(
        a, b,
        "the two lists must differ for the test to mean anything"
    );
    assert_eq!(
        draw(&[(&hybrid, Some((0, 23))), (&hybrid, Some((23, 64)))]),
        a
    );
    let empty = DrawList::default();
    // The shared list, then three cells' (a hexagon corner: every list the
    // renderer must keep), the third with the first one's list again.
    for (s1, s2) in [(0, 0), (23, 40), (40, 64), (64, 64), (10, 11)] {
        let blended = draw(&[
            (&empty, None),
            (&hybrid, Some((0, s1))),
            (&full, Some((s1, s2))),
            (&hybrid, Some((s2, 64))),
        ]);
        let mut from_a = 0;
        for (k, px) in blended.chunks_exact(4).enumerate() {
            let (x, y) = ((k % 64) as u32, (k / 64) as u32);
            let level = bayer8(x, y);
            let owner = if (s1..s2).contains(&level) { &b } else { &a };
            assert_eq!(
                px,
                &owner[4 * k..4 * k + 4],
                "pixel ({x}, {y}), split {s1}..{s2}"
            );
            from_a += usize::from(!(s1..s2).contains(&level));
        }
        assert_eq!(
            from_a,
            64 * (64 - (s2 - s1)) as usize,
            "each level is one pixel per 8 x 8 tile"
        );
    }
}

/// Issue 31 item 2 end to end: a viewer a little inside its cell near an edge,
/// with cross-fades on and both cells ready, sees a frame whose every pixel is the
/// pixel of one of the two cells' own frames (each drawn alone, settled): the one
/// whose dither range holds the pixel's Bayer level (`Streamer::blend`). What the
/// two cells draw alike is drawn once (`frame::blend_lists`), so this also shows
/// that sharing changes no pixel. Both cells' ranges are used (each owns pixels),
/// and the frame differs from the current cell's alone.
#[test]
fn a_frame_near_a_border_shows_each_pixel_from_one_of_the_two_cells() {
    use player::frame::hybrid_list;
    use player::stream::PendingDraw;
    use player::transition::bayer8;
    let Some((dir, p, cam0, _)) = synthetic_at_instance_0() else {
        return;
    };
    let grid = p.bake.grid.clone();
    // The edge of instance 0's cell nearest to the camera, and the cell across it.
    let eye0 = Vec2::new(cam0.eye.x, cam0.eye.z);
    let cell = grid.nearest_cell(eye0).unwrap();
    let c = grid.centre(cell);
    let (other, mid) = grid
        .neighbours(cell)
        .into_iter()
        .map(|n| (n, (c + grid.centre(n)) * 0.5))
        .min_by(|a, b| a.1.distance(eye0).total_cmp(&b.1.distance(eye0)))
        .unwrap();
    // 0.1 units inside the cell from the edge's midpoint, looking at instance 0.
    let at = mid + (c - mid).normalize() * 0.1;
    let target = p.bake.instance_bounds[0].centre();
    let eye = Vec3::new(at.x, cam0.eye.y, at.y);
    let cam = Camera {
        eye,
        dir: (target - eye).normalize(),
        ..cam0
    };
    // Both cells share far-field group 0, which holds `cell`'s proxies: what the
    // two draw alike (`blend_lists` draws it once). `other` then draws some
    // objects twice, as original and as the group's proxy: where the two tie in
    // depth the original must win in the blend as it does alone (originals first).
    share_a_group(dir.path(), &[cell, other]);
    let mut p = open(dir.path(), (64, 64), &DrawOptions::default()).unwrap();
    let config = StreamConfig {
        prefetch: false,
        fade: 0.5,
        ..Default::default()
    };
    let mut s = Streamer::new(&p.bake, config);
    for id in [cell, other] {
        assert!(s.settled(&p.renderer, &p.bake, id).is_some());
    }
    p.draw_listed(&cam, Mode::Hybrid, Some(&mut s));
    let blended = p.renderer.read_pixels().unwrap();
    let blend = s.blend(&p.bake);
    assert_eq!(blend.len(), 2, "{blend:?}");
    let mut alone = Vec::new();
    for &(id, _) in &blend {
        let current = s.settled_cell(&p.bake, id).unwrap();
        let list = hybrid_list(&p.bake, &cam, &current, PendingDraw::StandIns);
        p.renderer.render(&cam, &p.models, &list);
        alone.push(p.renderer.read_pixels().unwrap());
    }
    let mut owned = [0usize; 2];
    for (k, px) in blended.chunks_exact(4).enumerate() {
        let (x, y) = ((k % 64) as u32, (k / 64) as u32);
        let level = bayer8(x, y);
        let owner = blend
            .iter()
            .position(|&(_, (lo, hi))| (lo..hi).contains(&level))
            .unwrap();
        owned[owner] += 1;
        assert_eq!(px, &alone[owner][4 * k..4 * k + 4], "pixel ({x}, {y})");
    }
    assert!(owned.iter().all(|&n| n > 0), "{owned:?}");
    let here = blend.iter().position(|b| b.0 == cell).unwrap();
    assert_ne!(blended, alone[here], "the neighbour's share must show");
}

/// Moves the first of `cells`' proxies into far-field group 0 and makes it the
/// group of every one of `cells` (a bake where cells draw the same group pack).
fn share_a_group(dir: &std::path::Path, cells: &[u32]) {
    use format::pack::{CellPack, Index, IndexEntry};
    let path = dir.join(format!("cells/{}.pack", cells[0]));
    let mut pack = CellPack::read(&path).unwrap();
    assert!(!pack.proxies.is_empty());
    let group = CellPack {
        cell_id: 0,
        fingerprint: pack.fingerprint,
        far_group: None,
        originals: Vec::new(),
        proxies: std::mem::take(&mut pack.proxies),
    };
    pack.write(&path).unwrap();
    for &c in cells {
        let path = dir.join(format!("cells/{c}.pack"));
        let mut pack = CellPack::read(&path).unwrap();
        pack.far_group = Some(0);
        pack.write(&path).unwrap();
    }
    std::fs::create_dir_all(dir.join("groups")).unwrap();
    format::pack::write_atomic(&dir.join("groups/0.pack"), &group.encode_group().unwrap()).unwrap();
    let index_path = dir.join("index.pack");
    let mut index = Index::read(&index_path).unwrap();
    let fp = index.cells[0].fingerprint;
    for e in &mut index.cells {
        if cells.contains(&e.cell_id) {
            let mut fresh =
                IndexEntry::for_file(dir, &e.file, e.cell_id, e.neighbours.clone(), fp).unwrap();
            fresh.group = Some(0);
            *e = fresh;
        }
    }
    index.groups = vec![IndexEntry::for_file(dir, "groups/0.pack", 0, Vec::new(), fp).unwrap()];
    index.write(&index_path).unwrap();
}
