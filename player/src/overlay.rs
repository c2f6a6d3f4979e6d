//! The on-screen overlay of `player view` (issue 18 item 4): a text panel built from
//! plain numbers ([`OverlayInfo`]) and the legend of the representation colours.
//!
//! The overlay is text in a translucent panel, drawn on the CPU into the RGBA8 frame
//! the view reads back anyway (the window shows the offscreen frame the headless tools
//! measure, [`crate::view`]), so the window, `--screenshot` and the headless path show
//! the same pixels; the frame time it reports is the 3D frame's alone. Glyphs are the
//! public-domain 8×8 bitmap font of the `font8x8` crate (ASCII), scaled by an integer.
//!
//! The legend draws the debug colours of [`Representation`] (their one home is
//! `representation.rs`; re-exported here for the tools that read coloured frames).

use crate::mode::Mode;
pub use crate::representation::Representation;

/// What the overlay shows.
#[derive(Clone, Debug, Default)]
pub struct OverlayInfo {
    pub mode: Mode,
    pub fps: f64,
    /// The 3D frame's GPU time (submit → done), milliseconds.
    pub frame_ms: f64,
    pub triangles: u64,
    pub draw_calls: u64,
    /// Clusters drawn (`cluster-lod` mode; shown in that mode only).
    pub clusters: u64,
    pub cell: Option<u32>,
    pub resident_packs: usize,
    pub resident_mib: f64,
    /// Texture uploads waiting in the streamer's queue.
    pub queued_uploads: usize,
    /// Proxies of the current cell waiting for their textures.
    pub pending_proxies: usize,
    pub eye: [f32; 3],
    pub colouring: bool,
}

/// Text scale: glyphs are 8 × `scale` pixels.
pub fn text_scale(height: u32) -> u32 {
    if height >= 700 {
        2
    } else {
        1
    }
}

/// The overlay's lines (without the legend).
pub fn overlay_lines(info: &OverlayInfo) -> Vec<String> {
    vec![
        format!(
            "{}  {:.1} FPS  {:.2} ms",
            info.mode.name(),
            info.fps,
            info.frame_ms
        ),
        format!(
            "{} tris  {} draws  cell {}{}",
            group_thousands(info.triangles),
            info.draw_calls,
            info.cell.map_or("-".to_string(), |c| c.to_string()),
            if info.mode == Mode::ClusterLod {
                format!("  {} clusters", group_thousands(info.clusters))
            } else {
                String::new()
            }
        ),
        format!(
            "packs {} ({:.1} MiB)",
            info.resident_packs, info.resident_mib
        ),
        format!(
            "queued {} uploads, {} proxies",
            info.queued_uploads, info.pending_proxies
        ),
        format!(
            "eye {:.0} {:.1} {:.0}",
            info.eye[0], info.eye[1], info.eye[2]
        ),
        "M mode C colour H hide".to_string(),
    ]
}

fn group_thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// Text colour (sRGB8) of the overlay.
pub const TEXT: [u8; 3] = [255, 255, 255];
/// The panel darkens the frame to this fraction behind the text.
const PANEL_KEEP: u32 = 35; // percent

/// Draws the overlay (panel, lines, and with `info.colouring` the legend) into the
/// top-left corner of `rgba` (`width × height`, row 0 at the top), the legend in the
/// bottom-left one. Returns the rectangle (x, y, w, h) that holds both.
pub fn draw_overlay(
    rgba: &mut [u8],
    width: u32,
    height: u32,
    info: &OverlayInfo,
) -> (u32, u32, u32, u32) {
    let scale = text_scale(height);
    let line_h = 10 * scale;
    let lines = overlay_lines(info);
    let legend: Vec<Representation> = if info.colouring {
        Representation::ALL.to_vec()
    } else {
        Vec::new()
    };
    let pad = 4 * scale;
    let widest = |n: u32| (n * 8 * scale + 2 * pad).min(width);
    let stats_w = widest(lines.iter().map(|l| l.len() as u32).max().unwrap_or(0));
    let stats_h = (lines.len() as u32 * line_h + 2 * pad).min(height);
    darken(rgba, width, height, (0, 0, stats_w, stats_h));
    let mut y = pad;
    for line in &lines {
        draw_text(rgba, width, height, pad, y, line, TEXT, scale);
        y += line_h;
    }
    let mut panel = (0, 0, stats_w, stats_h);
    if !legend.is_empty() {
        // The legend: a second panel in the bottom-left corner.
        let w = widest(
            legend
                .iter()
                .map(|r| r.label().len() as u32 + 2)
                .max()
                .unwrap_or(0),
        );
        let h = legend.len() as u32 * line_h + 2 * pad;
        let y0 = height.saturating_sub(h).max(stats_h);
        darken(rgba, width, height, (0, y0, w, h));
        let mut y = y0 + pad;
        for r in legend {
            fill(
                rgba,
                width,
                height,
                (pad, y, 8 * scale, 8 * scale),
                r.colour(),
            );
            draw_text(
                rgba,
                width,
                height,
                pad + 16 * scale,
                y,
                r.label(),
                TEXT,
                scale,
            );
            y += line_h;
        }
        panel = (0, 0, stats_w.max(w), (y0 + h).min(height));
    }
    panel
}

fn darken(rgba: &mut [u8], width: u32, height: u32, (x0, y0, w, h): (u32, u32, u32, u32)) {
    for y in y0..(y0 + h).min(height) {
        for x in x0..(x0 + w).min(width) {
            let i = ((y * width + x) * 4) as usize;
            for c in &mut rgba[i..i + 3] {
                *c = (u32::from(*c) * PANEL_KEEP / 100) as u8;
            }
        }
    }
}

fn fill(rgba: &mut [u8], width: u32, height: u32, rect: (u32, u32, u32, u32), c: [u8; 3]) {
    let (x0, y0, w, h) = rect;
    for y in y0..(y0 + h).min(height) {
        for x in x0..(x0 + w).min(width) {
            let i = ((y * width + x) * 4) as usize;
            rgba[i..i + 3].copy_from_slice(&c);
        }
    }
}

/// Draws `text` with its top-left corner at (x, y); characters outside ASCII are
/// drawn as `?`; pixels outside the frame are clipped.
#[allow(clippy::too_many_arguments)]
pub fn draw_text(
    rgba: &mut [u8],
    width: u32,
    height: u32,
    x: u32,
    y: u32,
    text: &str,
    colour: [u8; 3],
    scale: u32,
) {
    for (k, ch) in text.chars().enumerate() {
        let code = if ch.is_ascii() {
            ch as usize
        } else {
            '?' as usize
        };
        let glyph = font8x8::legacy::BASIC_LEGACY[code];
        let gx = x + k as u32 * 8 * scale;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8u32 {
                // font8x8: bit 0 is the leftmost pixel of a row.
                if bits & (1 << col) == 0 {
                    continue;
                }
                let px = gx + col * scale;
                let py = y + row as u32 * scale;
                fill(rgba, width, height, (px, py, scale, scale), colour);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_draws_white_pixels_inside_the_panel_only() {
        let (w, h) = (320u32, 200u32);
        let mut px = vec![100u8; (w * h * 4) as usize];
        let info = OverlayInfo {
            triangles: 1_234_567,
            draw_calls: 33,
            cell: Some(7),
            colouring: true,
            ..Default::default()
        };
        let (_, _, pw, ph) = draw_overlay(&mut px, w, h, &info);
        assert!(pw > 100 && ph > 50);
        let white = |x: u32, y: u32| {
            let i = ((y * w + x) * 4) as usize;
            px[i..i + 3] == TEXT
        };
        let inside = (0..ph)
            .flat_map(|y| (0..pw).map(move |x| (x, y)))
            .filter(|&(x, y)| white(x, y))
            .count();
        assert!(inside > 200, "{inside} text pixels");
        let outside = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| (x >= pw || y >= ph) && white(x, y))
            .count();
        assert_eq!(outside, 0);
        assert_eq!(overlay_lines(&info)[1], "1,234,567 tris  33 draws  cell 7");
        let clusters = OverlayInfo {
            mode: Mode::ClusterLod,
            clusters: 1_500,
            ..info
        };
        assert_eq!(
            overlay_lines(&clusters)[1],
            "1,234,567 tris  33 draws  cell 7  1,500 clusters"
        );
    }

    #[test]
    fn palette_colours_are_distinct() {
        for a in Representation::ALL {
            for b in Representation::ALL {
                if a != b {
                    assert_ne!(a.colour(), b.colour());
                }
            }
        }
    }
}
