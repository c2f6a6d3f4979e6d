//! The per-frame plot of a walk (000 Fig. 14 (b)): PSNR(Y) of every frame against
//! full geometry on top, triangles drawn (log scale) below, cell crossings as yellow
//! vertical lines — from `player compare`'s per-frame output. Drawn with tiny-skia;
//! text in DejaVu Sans ([`pipeline::text`]).

use crate::results::CompareReport;
use pipeline::text::{draw_text, text_width};
use tiny_skia::{Color, Paint, Path, PathBuilder, Pixmap, Rect, Stroke, Transform};

const W: f32 = 1200.0;
const PANEL_H: f32 = 230.0;
const LEFT: f32 = 90.0;
const RIGHT: f32 = 20.0;
const TOP: f32 = 40.0;
const GAP: f32 = 50.0;
const BOTTOM: f32 = 50.0;

const BLUE: [u8; 3] = [31, 119, 180];
const ORANGE: [u8; 3] = [255, 127, 14];
const GREY: [u8; 3] = [150, 150, 150];
const YELLOW: [u8; 3] = [230, 190, 0];
const INK: [u8; 3] = [30, 30, 30];

/// One line of a panel.
struct Series<'a> {
    values: Vec<f64>,
    colour: [u8; 3],
    name: &'a str,
}

/// Frames where the current cell differs from the previous frame's.
pub fn crossing_frames(s: &CompareReport) -> Vec<usize> {
    s.per_frame
        .windows(2)
        .filter(|w| w[0].cell != w[1].cell)
        .map(|w| w[1].frame)
        .collect()
}

/// Renders the plot of `hybrid` (and `lod` when given) as PNG bytes.
pub fn render_walk_plot(
    title: &str,
    hybrid: &CompareReport,
    lod: Option<&CompareReport>,
) -> anyhow::Result<Vec<u8>> {
    let h = TOP + 2.0 * PANEL_H + GAP + BOTTOM;
    let mut pm =
        Pixmap::new(W as u32, h as u32).ok_or_else(|| anyhow::anyhow!("bad image size"))?;
    pm.fill(Color::WHITE);
    let n = hybrid.per_frame.len().max(2);
    let crossings = crossing_frames(hybrid);
    draw_text(&mut pm, LEFT, 12.0, title, INK, 3.0);

    let lod_name = match lod.and_then(|l| l.lod_pixel_error) {
        Some(e) => format!("lod {e} px"),
        None => "lod".to_string(),
    };
    // Top: PSNR(Y), dB.
    let mut psnr = vec![Series {
        values: hybrid.per_frame.iter().map(|f| f.psnr_y).collect(),
        colour: BLUE,
        name: "hybrid",
    }];
    if let Some(l) = lod {
        psnr.push(Series {
            values: l.per_frame.iter().map(|f| f.psnr_y).collect(),
            colour: ORANGE,
            name: &lod_name,
        });
    }
    let (lo, hi) = range(psnr.iter().flat_map(|s| s.values.iter().copied()));
    let lo = (lo / 5.0).floor() * 5.0;
    let hi = ((hi / 5.0).ceil() * 5.0).max(lo + 5.0);
    let ticks: Vec<f64> = {
        let step = if hi - lo > 40.0 { 10.0 } else { 5.0 };
        let mut t = Vec::new();
        let mut v = lo;
        while v <= hi + 1e-9 {
            t.push(v);
            v += step;
        }
        t
    };
    panel(
        &mut pm,
        TOP,
        n,
        &crossings,
        &psnr,
        &|v| (v - lo) / (hi - lo),
        &ticks,
        &|v| format!("{v:.0}"),
        "PSNR(Y) against full geometry (dB)",
    );

    // Bottom: triangles, log10.
    let mut tris = vec![
        Series {
            values: hybrid
                .per_frame
                .iter()
                .map(|f| f.reference_triangles as f64)
                .collect(),
            colour: GREY,
            name: "full",
        },
        Series {
            values: hybrid
                .per_frame
                .iter()
                .map(|f| f.triangles as f64)
                .collect(),
            colour: BLUE,
            name: "hybrid",
        },
    ];
    if let Some(l) = lod {
        tris.push(Series {
            values: l.per_frame.iter().map(|f| f.triangles as f64).collect(),
            colour: ORANGE,
            name: &lod_name,
        });
    }
    let (tlo, thi) = range(
        tris.iter()
            .flat_map(|s| s.values.iter().copied())
            .filter(|v| *v > 0.0),
    );
    let e_lo = tlo.max(1.0).log10().floor();
    let e_hi = thi.max(10.0).log10().ceil().max(e_lo + 1.0);
    let ticks: Vec<f64> = (e_lo as i32..=e_hi as i32).map(|e| 10f64.powi(e)).collect();
    panel(
        &mut pm,
        TOP + PANEL_H + GAP,
        n,
        &crossings,
        &tris,
        &|v| (v.max(1.0).log10() - e_lo) / (e_hi - e_lo),
        &ticks,
        &|v| {
            if v >= 1e6 {
                format!("{:.0}M", v / 1e6)
            } else if v >= 1e3 {
                format!("{:.0}K", v / 1e3)
            } else {
                format!("{v:.0}")
            }
        },
        "triangles drawn per frame (log scale)",
    );
    // Frame axis labels.
    let y = TOP + 2.0 * PANEL_H + GAP + 12.0;
    let plot_w = W - LEFT - RIGHT;
    for k in 0..=5 {
        let f = (n - 1) * k / 5;
        let x = LEFT + plot_w * f as f32 / (n - 1) as f32;
        let t = f.to_string();
        draw_text(&mut pm, x - text_width(&t, 2.0) / 2.0, y, &t, INK, 2.0);
    }
    draw_text(
        &mut pm,
        LEFT + plot_w / 2.0 - text_width("frame of the walk", 2.0) / 2.0,
        y + 16.0,
        "frame of the walk",
        INK,
        2.0,
    );
    Ok(pm.encode_png()?)
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

#[allow(clippy::too_many_arguments)]
fn panel(
    pm: &mut Pixmap,
    y0: f32,
    n: usize,
    crossings: &[usize],
    series: &[Series],
    map: &dyn Fn(f64) -> f64,
    ticks: &[f64],
    label: &dyn Fn(f64) -> String,
    title: &str,
) {
    let plot_w = W - LEFT - RIGHT;
    let x_of = |i: usize| LEFT + plot_w * i as f32 / (n - 1) as f32;
    let y_of = |v: f64| y0 + PANEL_H * (1.0 - map(v).clamp(0.0, 1.0) as f32);
    // Frame and grid lines with tick labels.
    stroke_rect(pm, LEFT, y0, plot_w, PANEL_H, INK, 1.0);
    for &t in ticks {
        let y = y_of(t);
        line(pm, LEFT, y, LEFT + plot_w, y, [225, 225, 225], 1.0);
        let s = label(t);
        draw_text(pm, LEFT - 8.0 - text_width(&s, 2.0), y - 5.0, &s, INK, 2.0);
    }
    draw_text(pm, 8.0, y0 - 24.0, title, INK, 2.0);
    // Crossings.
    for &c in crossings {
        let x = x_of(c);
        line(pm, x, y0, x, y0 + PANEL_H, YELLOW, 1.5);
    }
    // Series and legend (crossings first).
    let mut lx = LEFT + plot_w;
    if !crossings.is_empty() {
        lx -= text_width("crossing", 2.0) + 30.0;
        line(pm, lx, y0 - 10.0, lx + 18.0, y0 - 10.0, YELLOW, 3.0);
        draw_text(pm, lx + 22.0, y0 - 15.0, "crossing", YELLOW, 2.0);
    }
    for s in series.iter().rev() {
        lx -= text_width(s.name, 2.0) + 30.0;
        line(pm, lx, y0 - 10.0, lx + 18.0, y0 - 10.0, s.colour, 3.0);
        draw_text(pm, lx + 22.0, y0 - 15.0, s.name, s.colour, 2.0);
    }
    for s in series {
        let mut pb = PathBuilder::new();
        let mut started = false;
        for (i, &v) in s.values.iter().enumerate() {
            if !v.is_finite() {
                started = false;
                continue;
            }
            let (x, y) = (x_of(i), y_of(v));
            if started {
                pb.line_to(x, y);
            } else {
                pb.move_to(x, y);
                started = true;
            }
        }
        if let Some(path) = pb.finish() {
            stroke(pm, &path, s.colour, 1.5);
        }
    }
}

fn line(pm: &mut Pixmap, x0: f32, y0: f32, x1: f32, y1: f32, c: [u8; 3], width: f32) {
    let mut pb = PathBuilder::new();
    pb.move_to(x0, y0);
    pb.line_to(x1, y1);
    if let Some(path) = pb.finish() {
        stroke(pm, &path, c, width);
    }
}

fn stroke_rect(pm: &mut Pixmap, x: f32, y: f32, w: f32, h: f32, c: [u8; 3], width: f32) {
    if let Some(r) = Rect::from_xywh(x, y, w, h) {
        stroke(pm, &PathBuilder::from_rect(r), c, width);
    }
}

/// Strokes `path` in the opaque colour `c`, `width` pixels wide (anti-aliased).
fn stroke(pm: &mut Pixmap, path: &Path, c: [u8; 3], width: f32) {
    let mut paint = Paint::default();
    paint.set_color_rgba8(c[0], c[1], c[2], 255);
    let stroke = Stroke {
        width,
        ..Stroke::default()
    };
    pm.stroke_path(path, &paint, &stroke, Transform::identity(), None);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::CompareFrame;

    fn summary() -> CompareReport {
        CompareReport {
            frames: 6,
            per_frame: (0..6)
                .map(|i| CompareFrame {
                    frame: i,
                    cell: Some(if i < 3 { 7 } else { 8 }),
                    psnr_y: 30.0 + i as f64,
                    ssim: 0.9,
                    triangles: 1000 + 100 * i as u64,
                    reference_triangles: 100_000,
                    ..CompareFrame::default()
                })
                .collect(),
            ..CompareReport::default()
        }
    }

    #[test]
    fn crossings_are_cell_changes() {
        assert_eq!(crossing_frames(&summary()), vec![3]);
    }

    #[test]
    fn plot_marks_crossings_in_yellow_and_draws_the_series() {
        let png = render_walk_plot("park-2m", &summary(), None).unwrap();
        let pm = Pixmap::decode_png(&png).unwrap();
        assert_eq!(
            (pm.width(), pm.height()),
            (W as u32, (TOP + 2.0 * PANEL_H + GAP + BOTTOM) as u32)
        );
        // The crossing's column inside the top panel is yellow.
        let x = (LEFT + (W - LEFT - RIGHT) * 3.0 / 5.0).round() as u32;
        let y = (TOP + PANEL_H * 0.1) as u32;
        let px = pm.pixel(x, y).unwrap();
        assert!(
            px.red() > 200 && px.green() > 150 && px.blue() < 80,
            "{px:?}"
        );
        // Some blue (the hybrid series) is drawn.
        let blue = pm
            .pixels()
            .iter()
            .filter(|p| p.blue() > 150 && p.red() < 80)
            .count();
        assert!(blue > 100, "{blue} blue pixels");
    }
}
