//! Text of the pictures the pipeline draws (`report.png`'s heat maps, the benchmark
//! walk plots): DejaVu Sans (`pipeline/assets/DejaVuSans.ttf`, its licence beside
//! it: the Bitstream Vera licence, free to embed and redistribute), outlined by
//! `ab_glyph` and blended into a tiny-skia pixmap with its coverage as alpha.
//! tiny-skia draws paths, not text.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;
use tiny_skia::{Pixmap, PremultipliedColorU8};

/// The font file, embedded: pictures look the same on every machine.
const DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(DEJAVU_SANS).expect("the embedded font parses"))
}

/// Pixels per em for a text `size`: `size` is the height of a capital letter in
/// pixels divided by 5 (the unit of the pictures' layouts, drawn with a 5-pixel-high
/// bitmap font until issue 28), so callers' spacing still fits.
fn scale(size: f32) -> PxScale {
    PxScale::from(5.0 * size / 0.73)
}

/// Width of `s` drawn at `size` (see [`draw_text`]).
pub fn text_width(s: &str, size: f32) -> f32 {
    let f = font().as_scaled(scale(size));
    let mut width = 0.0;
    let mut last = None;
    for c in s.chars() {
        let id = f.glyph_id(c);
        if let Some(prev) = last {
            width += f.kern(prev, id);
        }
        width += f.h_advance(id);
        last = Some(id);
    }
    width
}

/// Draws `s` in colour `c` with the top of its capitals at `y` and its left edge at
/// `x`; `size` is a fifth of the capital height in pixels.
pub fn draw_text(pm: &mut Pixmap, x: f32, y: f32, s: &str, c: [u8; 3], size: f32) {
    let f = font().as_scaled(scale(size));
    // The baseline sits a capital height below `y`.
    let baseline = y + 5.0 * size;
    let (w, h) = (pm.width() as i32, pm.height() as i32);
    let mut pen = x;
    let mut last = None;
    for ch in s.chars() {
        let id = f.glyph_id(ch);
        if let Some(prev) = last {
            pen += f.kern(prev, id);
        }
        let glyph = id.with_scale_and_position(scale(size), ab_glyph::point(pen, baseline));
        pen += f.h_advance(id);
        last = Some(id);
        let Some(outline) = font().outline_glyph(glyph) else {
            continue;
        };
        let bounds = outline.px_bounds();
        let pixels = pm.pixels_mut();
        outline.draw(|gx, gy, coverage| {
            let px = bounds.min.x as i32 + gx as i32;
            let py = bounds.min.y as i32 + gy as i32;
            if px < 0 || py < 0 || px >= w || py >= h || coverage <= 0.0 {
                return;
            }
            let i = (py * w + px) as usize;
            let a = coverage.min(1.0);
            let d = pixels[i];
            // Source-over in premultiplied space: the text is opaque, `a` its coverage.
            let mix = |s: u8, d: u8| (f32::from(s) * a + f32::from(d) * (1.0 - a)).round() as u8;
            let out_a = mix(255, d.alpha());
            let blended = PremultipliedColorU8::from_rgba(
                mix(c[0], d.red()).min(out_a),
                mix(c[1], d.green()).min(out_a),
                mix(c[2], d.blue()).min(out_a),
                out_a,
            );
            if let Some(p) = blended {
                pixels[i] = p;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_inside_its_measured_box() {
        let mut pm = Pixmap::new(200, 40).unwrap();
        pm.fill(tiny_skia::Color::WHITE);
        let width = text_width("PSNR(Y) 23.9 dB", 2.0);
        assert!(width > 60.0 && width < 190.0, "{width}");
        draw_text(&mut pm, 5.0, 10.0, "PSNR(Y) 23.9 dB", [0, 0, 0], 2.0);
        let dark: Vec<(u32, u32)> = (0..40)
            .flat_map(|y| (0..200).map(move |x| (x, y)))
            .filter(|&(x, y)| pm.pixel(x, y).unwrap().red() < 128)
            .collect();
        assert!(dark.len() > 100, "{} dark pixels", dark.len());
        // Capitals span y 10..20; the parentheses reach a little above and below.
        assert!(dark
            .iter()
            .all(|&(x, y)| (4..=(6 + width as u32)).contains(&x) && (7..=24).contains(&y)));
    }
}
