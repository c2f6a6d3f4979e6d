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

/// Frames of the impostor bake with one layer of codes `lo..=hi`, from the capture
/// eye and from one displaced by 2 units; `None` without an adapter.
fn draw(lo: u8, hi: u8) -> Option<Vec<(u64, usize)>> {
    let dir = tempfile::tempdir().unwrap();
    let capture = Camera {
        eye: Vec3::new(50.0, 6.0, 80.0),
        dir: Vec3::NEG_Z,
        fov_y_deg: 30.0,
        width: 64,
        height: 64,
        near: 0.5,
        far: 200.0,
    };
    let tex = Texture::from_rgba8(64, 64, &disc(), TextureEncoding::Rgba8).unwrap();
    let layers = ImpostorLayers {
        corner_rays: [[0.0; 3]; 4],
        near: 15.0,
        far: 25.0,
        layers: vec![ImpostorLayer {
            depth: format::pack::depth_of_code(15.0, 25.0, 128),
            code_lo: lo,
            code_hi: hi,
        }],
    };
    write_impostor_bake(dir.path(), &capture, tex, layers).unwrap();
    let mut p = common::open_player(dir.path(), (96, 96), &player::DrawOptions::default())?;
    let mut s = Streamer::new(&p.bake, StreamConfig::default());
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
