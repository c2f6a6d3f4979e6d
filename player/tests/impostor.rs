//! Issue 16: the player draws layered impostors (paper 001 §4) — each layer a quad
//! alpha-tested on the depth codes in its texture's alpha, written to the depth
//! buffer. A disc captured at one depth code is drawn by the layer whose codes hold
//! it, and by no layer whose codes do not (lavapipe).

use format::pack::{ImpostorLayer, ImpostorLayers, Texture, TextureEncoding};
use glam::Vec3;
use player::camera::Camera;
use player::frame::Mode;
use player::stream::{StreamConfig, Streamer};
use player::testdata::write_impostor_bake;

mod common;

/// A 64 × 64 capture: an orange disc whose texels carry depth code 128, background
/// code 0 (nothing captured).
fn disc() -> Vec<u8> {
    (0..64 * 64)
        .flat_map(|i| {
            let (x, y) = ((i % 64) as f32 - 31.5, (i / 64) as f32 - 31.5);
            let inside = (x * x + y * y).sqrt() < 24.0;
            [230, 140, 40, if inside { 128 } else { 0 }]
        })
        .collect()
}

/// The 64² capture camera of a test impostor at x = `x`, looking down −z.
fn capture_camera(x: f32) -> Camera {
    Camera {
        eye: Vec3::new(x, 6.0, 80.0),
        dir: Vec3::NEG_Z,
        fov_y_deg: 30.0,
        width: 64,
        height: 64,
        near: 0.5,
        far: 200.0,
    }
}

/// Impostor layers between depths 15 and 25: one layer at code 128 showing codes
/// `lo..=hi`.
fn one_layer(lo: u8, hi: u8) -> ImpostorLayers {
    ImpostorLayers {
        corner_rays: [[0.0; 3]; 4],
        near: 15.0,
        far: 25.0,
        layers: vec![ImpostorLayer {
            depth: format::pack::depth_of_code(15.0, 25.0, 128),
            code_lo: lo,
            code_hi: hi,
        }],
    }
}

/// Frames of the impostor bake with one layer of codes `lo..=hi`, from the capture
/// eye and from one displaced by 2 units; `None` without an adapter.
fn draw(lo: u8, hi: u8) -> Option<Vec<(u64, usize)>> {
    let dir = tempfile::tempdir().unwrap();
    let capture = capture_camera(50.0);
    let tex = Texture::from_rgba8(64, 64, &disc(), TextureEncoding::Rgba8).unwrap();
    let layers = one_layer(lo, hi);
    write_impostor_bake(dir.path(), &capture, tex, layers).unwrap();
    let mut p = common::open_player(dir.path(), (96, 96), &player::DrawOptions::default())?;
    // The cell alone: no cross-fade with a neighbour (issue 31), whose lists
    // would add their triangles.
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            fade: 0.0,
            ..Default::default()
        },
    );
    let mut out = Vec::new();
    for dx in [0.0f32, 2.0] {
        let cam = Camera {
            eye: capture.eye + Vec3::new(dx, 0.0, 0.0),
            width: 96,
            height: 96,
            ..capture
        };
        // Let the streamer load the cell and upload its texture.
        let mut tris = 0;
        for _ in 0..3 {
            tris = p.draw(&cam, Mode::Hybrid, Some(&mut s)).1;
        }
        let px = p.renderer.read_pixels().unwrap();
        let orange = px
            .chunks_exact(4)
            .filter(|c| c[0] > 200 && c[1] > 110 && c[1] < 170 && c[2] < 80)
            .count();
        out.push((tris, orange));
    }
    Some(out)
}

#[test]
fn impostor_layers_are_drawn_where_their_codes_match() {
    let Some(hit) = draw(100, 160) else {
        return;
    };
    for (tris, orange) in &hit {
        assert_eq!(*tris, 2, "one layer = two triangles");
        assert!(*orange > 500, "the disc is drawn: {orange} pixels");
    }
    let miss = draw(1, 90).unwrap();
    for (tris, orange) in &miss {
        assert_eq!(*tris, 2);
        assert_eq!(*orange, 0, "texels outside the layer's codes are discarded");
    }
}

/// A 64 × 64 capture of a disc of colour `rgb` at depth code 128 (background code 0).
fn disc_of(rgb: [u8; 3]) -> Vec<u8> {
    disc()
        .chunks_exact(4)
        .flat_map(|c| [rgb[0], rgb[1], rgb[2], c[3]])
        .collect()
}

/// Ten layered impostors of one pack, side by side, each its own colour, drawn from
/// a viewer that sees them all: with batches on (the default) and off. Returns per
/// setting the frame's pixels, its draw calls (submitted, and as the list predicts)
/// and triangles; `None` without an adapter.
fn draw_ten(batches: bool) -> Option<(Vec<u8>, u64, u64, u64)> {
    let (_dir, p, _) = ten_impostors(batches)?;
    let list = p.1;
    let p = p.0;
    let px = p.renderer.read_pixels().unwrap();
    Some((
        px,
        list.draw_calls,
        p.renderer.last_draw_calls,
        list.triangles,
    ))
}

/// The bake of [`draw_ten`] opened at 96², drawn three times from the viewer that
/// sees all ten: the player, the last frame's list figures, and the camera.
#[allow(clippy::type_complexity)]
fn ten_impostors(
    batches: bool,
) -> Option<(
    tempfile::TempDir,
    (player::run::Player, player::frame::ListStats, Streamer),
    Camera,
)> {
    let dir = tempfile::tempdir().unwrap();
    let impostors: Vec<_> = (0..10u8)
        .map(|k| {
            let capture = capture_camera(10.0 + 9.0 * f32::from(k));
            let rgb = [20 + 23 * k, 220 - 19 * k, 40 + 17 * k];
            let tex = Texture::from_rgba8(64, 64, &disc_of(rgb), TextureEncoding::Rgba8).unwrap();
            let layers = one_layer(100, 160);
            (capture, tex, layers)
        })
        .collect();
    player::testdata::write_impostors_bake(dir.path(), &impostors).unwrap();
    let mut p = common::open_player(dir.path(), (96, 96), &player::DrawOptions::default())?;
    p.renderer.set_impostor_batches(batches);
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
    let cam = Camera {
        eye: Vec3::new(50.0, 6.0, 95.0),
        dir: Vec3::NEG_Z,
        fov_y_deg: 90.0,
        width: 96,
        height: 96,
        near: 0.5,
        far: 200.0,
    };
    let mut last = None;
    for _ in 0..3 {
        last = Some(p.draw_listed(&cam, Mode::Hybrid, Some(&mut s)).1);
    }
    let list = last.unwrap();
    assert_eq!(
        list.draw_calls, p.renderer.last_draw_calls,
        "batches {batches}"
    );
    Some((dir, (p, list, s), cam))
}

/// Issue 31's cross-fade draws impostor layers (the alpha-tested pipeline) with
/// every dither slot: split into two dither ranges after a shared list, batched or
/// not, the frame is the plain one pixel for pixel.
#[test]
fn impostors_blended_with_themselves_give_the_plain_frame() {
    use player::frame::hybrid_list;
    use player::gpu::DrawList;
    for batches in [true, false] {
        let Some((_dir, (mut p, _, mut s), cam)) = ten_impostors(batches) else {
            return;
        };
        let plain = p.renderer.read_pixels().unwrap();
        s.advance(&p.renderer, &p.bake, &cam);
        let list = hybrid_list(&p.bake, &cam, &s.current(), s.config().pending);
        assert!(!list.proxies.is_empty());
        let empty = DrawList::default();
        for split in [0, 20, 64] {
            p.renderer.render_blend(
                &cam,
                &p.models,
                &[
                    (&empty, None),
                    (&list, Some((0, split))),
                    (&list, Some((split, 64))),
                ],
            );
            let blended = p.renderer.read_pixels().unwrap();
            assert!(blended == plain, "batches {batches}, split {split}");
        }
    }
}

/// A pack's layered impostors drawn in batches (one atlas, one uniform, one draw
/// call per up to `PROXY_SLOTS` impostors) give the frame of drawing them one by
/// one, in fewer draw calls (8 impostors in view: 1 batch instead of 8 draws).
#[test]
fn impostor_batches_draw_the_same_frame_in_fewer_calls() {
    let Some((batched, calls, submitted, tris)) = draw_ten(true) else {
        return;
    };
    let (alone, calls_alone, _, tris_alone) = draw_ten(false).unwrap();
    assert_eq!(calls, submitted);
    // The ground, then 8 of the 10 impostors in view (the two at the ends are
    // outside the frustum): 8 draws alone, the one batch of all ten batched.
    const _: () = assert!(player::vertex::PROXY_SLOTS >= 10);
    assert_eq!((calls_alone, calls), (1 + 8, 1 + 1));
    assert_eq!(tris, tris_alone, "the tiles culled are the same");
    assert_eq!(tris, 2 * 8, "eight one-layer impostors drawn");
    // Above the horizon (the upper half) only the discs are drawn on the sky.
    let sky = batched.chunks_exact(4).next().unwrap().to_vec();
    let drawn = batched[..96 * 48 * 4]
        .chunks_exact(4)
        .filter(|c| *c != sky.as_slice())
        .count();
    assert!(
        drawn > 300,
        "the discs are drawn: {drawn} pixels above the horizon"
    );
    let worst = batched
        .iter()
        .zip(&alone)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    let differ = batched
        .chunks_exact(4)
        .zip(alone.chunks_exact(4))
        .filter(|(a, b)| a != b)
        .count();
    eprintln!("batched vs alone: {differ} pixels differ, worst channel by {worst}");
    assert!(
        worst <= 1,
        "worst channel difference {worst} ({differ} pixels differ)"
    );
}
