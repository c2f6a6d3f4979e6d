//! Layered impostors (issue 16; paper 001 §3–4) and the objective selection's
//! measurement (paper 004 §3.2–3.3) on the CPU rasterizer.
//!
//! Set `HEXBAKE_PNG_DIR=/some/dir` to keep PNGs (original, impostor from the capture
//! eye and from a displaced eye, one layer of the impostor) for a person to look at.

use format::pack::code_of_depth;
use glam::{Mat4, Vec3};
use proptest::prelude::*;
use std::path::PathBuf;
use worker::impostor::{
    build_layered_impostor, composite_impostors, layer_count, split_layers, ImpostorDraw,
    LayeredImpostor, MAX_LAYERS,
};
use worker::raster::{render, Capture, CullMode, DrawItem, View, BACKGROUND_ID};
use worker::select::{compare, measure, sample_viewpoints, subpixel_from_region, Candidate};

fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn maybe_png(name: &str, c: &Capture) {
    let Some(dir) = std::env::var_os("HEXBAKE_PNG_DIR") else {
        return;
    };
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).unwrap();
    worker::picture::write_rgba(
        &dir.join(format!("{name}.png")),
        c.view.width,
        c.view.height,
        &c.color,
    )
    .unwrap();
}

fn knot() -> format::Mesh {
    let mut m = scene::procedural::build("torus_knot").unwrap();
    scene::pattern::apply_albedo(&mut m, 3);
    m
}

fn item(mesh: &format::Mesh, at: Vec3, scale: f32, id: u32) -> DrawItem<'_> {
    DrawItem {
        mesh,
        transform: Mat4::from_translation(at) * Mat4::from_scale(Vec3::splat(scale)),
        tint: Vec3::ONE,
        object_id: id,
        triangles: None,
        albedo_map: None,
    }
}

fn impostor_frame(view: &View, imp: &LayeredImpostor, under: &[DrawItem]) -> Capture {
    let mut frame = render(view, under, CullMode::Back);
    composite_impostors(
        &mut frame,
        &[ImpostorDraw {
            texture: &imp.texture,
            layers: &imp.layers,
            object_id: 77,
        }],
    );
    frame
}

#[test]
fn split_layers_cover_every_code_with_overlap_and_ordered_depths() {
    for n in 1..=MAX_LAYERS {
        let layers = split_layers(40.0, 60.0, n);
        assert_eq!(layers.len(), n);
        for code in 1..=255u8 {
            assert!(
                layers
                    .iter()
                    .any(|l| l.code_lo <= code && code <= l.code_hi),
                "n {n}: code {code} in no layer"
            );
        }
        for w in layers.windows(2) {
            assert!(w[0].depth < w[1].depth);
            // Neighbours overlap (001 Fig. 2).
            assert!(w[1].code_lo <= w[0].code_hi, "{w:?}");
        }
        assert!(layers[0].depth >= 40.0 && layers[n - 1].depth <= 60.0);
    }
}

proptest! {
    /// 001 §3.3: with the chosen count, the error angle e·S/(2n) of the worst texel
    /// is within one pixel, unless the count hit the cap.
    #[test]
    fn layer_count_bounds_the_error_angle(
        near in 1.0f32..500.0,
        depth in 0.0f32..200.0,
        offset in 0.0f32..100.0,
        res in 64u32..2048,
    ) {
        let far = near + depth;
        let n = layer_count(near, far, offset, res);
        prop_assert!((1..=MAX_LAYERS).contains(&n));
        let span = 1.0 / near as f64 - 1.0 / far as f64;
        let error = offset as f64 * span / (2.0 * n as f64);
        let pixel = std::f64::consts::FRAC_PI_3 / res as f64;
        prop_assert!(n == MAX_LAYERS || error <= pixel * (1.0 + 1e-6), "{n} {error} {pixel}");
        // And one layer fewer would not do (the count is the smallest).
        if n > 1 {
            prop_assert!(offset as f64 * span / (2.0 * (n - 1) as f64) > pixel * (1.0 - 1e-6));
        }
    }

    /// Depth codes are monotone in depth and round-trip within one code.
    #[test]
    fn depth_codes_round_trip(near in 1.0f32..100.0, depth in 0.01f32..100.0, t in 0.0f32..1.0) {
        let far = near + depth;
        let d = near + t * depth;
        let c = code_of_depth(near, far, d);
        prop_assert!(c >= 1);
        let back = format::pack::depth_of_code(near, far, c);
        let step = (1.0 / near - 1.0 / far) / 254.0;
        prop_assert!((1.0 / back - 1.0 / d).abs() <= 0.51 * step + 1e-7);
    }
}

/// From its capture eye an impostor reproduces the object (up to texel
/// resampling); from a displaced eye the layers keep it close, and more layers are
/// better than one (001 §3.3). The CPU render is exact, so its hash is pinned.
#[test]
fn impostor_reproduces_the_object_and_layers_reduce_the_warp_error() {
    let mesh = knot();
    let items = [item(&mesh, Vec3::new(0.0, 10.0, -120.0), 10.0, 1)];
    let eye = Vec3::new(0.0, 10.0, 0.0);
    let imp = build_layered_impostor(eye, &items, 512, 512, 50.0)
        .unwrap()
        .expect("covers pixels");
    assert!(imp.layers.layers.len() > 1, "{:?}", imp.layers.layers.len());
    let (lo, hi) = worker::capture::items_aabb(&items).unwrap();
    let view = View::tight_around(eye, lo, hi, 512).unwrap();
    let reference = render(&view, &items, CullMode::Back);
    let frame = impostor_frame(&view, &imp, &[]);
    maybe_png("impostor-reference", &reference);
    maybe_png("impostor-same-eye", &frame);
    let mut hist = [0u64; 8];
    let c = compare(&reference, &frame, &mut hist);
    let (psnr, ssim) = (c.psnr_db, c.ssim);
    assert!(
        psnr > 30.0 && ssim > 0.9,
        "same eye: {psnr} dB, SSIM {ssim}"
    );

    // Displaced viewer: 30 units sideways.
    let moved = eye + Vec3::new(30.0, 0.0, 0.0);
    let view = View::tight_around(moved, lo, hi, 512).unwrap();
    let reference = render(&view, &items, CullMode::Back);
    let layered = impostor_frame(&view, &imp, &[]);
    let mut one = imp.clone();
    one.layers.layers = split_layers(one.layers.near, one.layers.far, 1);
    let flat = impostor_frame(&view, &one, &[]);
    maybe_png("impostor-moved-reference", &reference);
    maybe_png("impostor-moved-layered", &layered);
    maybe_png("impostor-moved-one-layer", &flat);
    let p_layered = compare(&reference, &layered, &mut hist).psnr_db;
    let p_flat = compare(&reference, &flat, &mut hist).psnr_db;
    assert!(
        p_layered > p_flat + 1.0,
        "layered {p_layered} dB vs one layer {p_flat} dB"
    );
    // Deterministic CPU render.
    assert_eq!(
        fnv1a(layered.color.iter().flatten().copied()),
        fnv1a(
            impostor_frame(&view, &imp, &[])
                .color
                .iter()
                .flatten()
                .copied()
        )
    );
}

/// The impostor is depth-tested against meshes: a wall in front hides it, one
/// behind does not.
#[test]
fn impostor_composites_with_meshes_by_depth() {
    let mesh = knot();
    let wall = scene::procedural::build("box").unwrap();
    let items = [item(&mesh, Vec3::new(0.0, 10.0, -120.0), 10.0, 1)];
    let eye = Vec3::new(0.0, 10.0, 0.0);
    let imp = build_layered_impostor(eye, &items, 256, 256, 10.0)
        .unwrap()
        .unwrap();
    let view = View::look_at_fov(
        eye,
        Vec3::new(0.0, 10.0, -1.0),
        Vec3::Y,
        30.0,
        96,
        96,
        0.5,
        1000.0,
    )
    .unwrap();
    let front = [item(&wall, Vec3::new(0.0, 0.0, -60.0), 60.0, 5)];
    let behind = [item(&wall, Vec3::new(0.0, 0.0, -200.0), 60.0, 5)];
    let hidden = impostor_frame(&view, &imp, &front);
    assert!(hidden.object_id.iter().all(|&id| id != 77));
    let shown = impostor_frame(&view, &imp, &behind);
    let n = shown.object_id.iter().filter(|&&id| id == 77).count();
    assert!(n > 100, "{n} impostor pixels in front of the far wall");
    assert!(shown.object_id.contains(&5));
    assert!(!shown.object_id.contains(&BACKGROUND_ID) || n > 0);
}

/// The selection's pieces: K = 20 sample viewpoints on the prism, sub-pixel culling,
/// and `measure` passing an impostor seen from its own capture eye only.
#[test]
fn selection_viewpoints_subpixel_and_measure() {
    let grid = worker::grid::HexGrid::new(
        format::scene::Ground {
            min: [0.0, 0.0],
            max: [200.0, 200.0],
        },
        20.0,
    );
    let prism = grid.prism(5, 2.0, 6.0);
    let eyes = sample_viewpoints(&prism);
    assert_eq!(eyes.len(), 20);
    assert!(eyes.iter().all(|&e| prism.contains(e)));
    // A 0.01-unit box 500 units away is below a pixel at 1024 per 60°; 10 units is not.
    let far = Vec3::new(prism.centre.x + 500.0, 4.0, prism.centre.y);
    assert!(subpixel_from_region(
        far,
        far + Vec3::splat(0.01),
        &prism,
        1024
    ));
    assert!(!subpixel_from_region(
        far,
        far + Vec3::splat(10.0),
        &prism,
        1024
    ));

    let mesh = knot();
    let c = prism.centre3();
    let items = [item(&mesh, c + Vec3::new(0.0, 0.0, -300.0), 10.0, 1)];
    let imp = build_layered_impostor(c, &items, 256 * worker::select::SUPERSAMPLE, 256, 25.0)
        .unwrap()
        .unwrap();
    let floor = format::manifest::QualityFloor::default();
    let m = measure(&items, &Candidate::Impostor(&imp), &[c], c, 256, &floor);
    assert_eq!(m.views, 1);
    assert!(m.passed, "{m:?}");
    let all = measure(&items, &Candidate::Impostor(&imp), &eyes, c, 256, &floor);
    assert_eq!(all.views, 20);
    assert!(all.worst_psnr_db <= m.worst_psnr_db);
    assert!(all.pooled_psnr_db >= all.worst_psnr_db);
}

/// At the measurement's resolution an impostor seen from its capture eye matches
/// the original exactly, whatever the size (the comparison is anti-aliased), and
/// quality falls as the viewer moves away (the region's corners are where it is
/// worst).
#[test]
fn impostor_quality_falls_with_the_viewer_offset() {
    let mesh = knot();
    let items = [item(&mesh, Vec3::new(0.0, 10.0, -300.0), 5.0, 1)];
    let eye = Vec3::new(0.0, 10.0, 0.0);
    let (lo, hi) = worker::capture::items_aabb(&items).unwrap();
    let ss = worker::select::SUPERSAMPLE;
    let imp = build_layered_impostor(eye, &items, 1024 * ss, 1024, 50.0)
        .unwrap()
        .unwrap();
    let mut last = f64::INFINITY;
    for off in [0.0f32, 10.0, 50.0] {
        let moved = eye + Vec3::new(off, 0.0, 0.0);
        let view = View::tight_around(moved, lo, hi, 1024 * ss).unwrap();
        let reference = render(&view, &items, CullMode::Back);
        let frame = impostor_frame(&view, &imp, &[]);
        let c = compare(&reference, &frame, &mut [0; 8]);
        if off == 0.0 {
            assert_eq!(c.psnr_db, 100.0, "{c:?}");
        }
        assert!(c.psnr_db < last || off == 0.0, "{off}: {c:?}");
        last = c.psnr_db;
    }
}
