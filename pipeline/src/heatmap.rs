//! `report.png`: the hex grid drawn four times as heat maps — polygons per cell
//! (inside + proxies), pack bytes, bake time, and (issue 16) the quality check's
//! worst sample view PSNR(Y) per cell in dB (low is bad, so its
//! ramp runs the other way — the lowest PSNR is the hot end, at the bar's right,
//! labelled with its positive dB value) — each with a colour bar whose ends are
//! labelled with the values there, each panel titled with its unit (text in
//! DejaVu Sans, [`crate::text`]).

use format::pack::GridParams;
use format::schema::report::CellLine;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};
use worker::grid::HexGrid;
use worker::picture::ramp;

const PANEL: f32 = 360.0;
const MARGIN: f32 = 16.0;
const BAR_H: f32 = 14.0;
const LABEL_H: f32 = 24.0;
/// The row of panel titles above the maps.
const TITLE_H: f32 = 26.0;

/// A panel: its label, the value it maps per cell, whether the lowest value is the
/// hot end of the ramp (PSNR), and how an end of its colour bar is labelled.
struct Metric {
    name: &'static str,
    value: fn(&CellLine) -> f64,
    low_is_hot: bool,
    label: fn(f64) -> String,
}

impl Metric {
    /// Where `v` lies on the ramp (0 cold … 1 hot) between the panel's `lo` and `hi`.
    fn ramp_position(&self, v: f64, lo: f64, hi: f64) -> f32 {
        let span = if hi > lo { hi - lo } else { 1.0 };
        let t = ((v - lo) / span) as f32;
        if self.low_is_hot {
            1.0 - t
        } else {
            t
        }
    }

    /// The labels of the colour bar's cold (left) and hot (right) ends for the
    /// values `lo..=hi`; `-` for none.
    fn legend(&self, lo: f64, hi: f64) -> (String, String) {
        if !(lo.is_finite() && hi.is_finite()) {
            return ("-".to_string(), "-".to_string());
        }
        if self.low_is_hot {
            ((self.label)(hi), (self.label)(lo))
        } else {
            ((self.label)(lo), (self.label)(hi))
        }
    }
}

/// The four panels.
fn metrics() -> [Metric; 4] {
    [
        Metric {
            name: "triangles of the cell (inside + proxies)",
            value: |l| {
                l.polygons_inside
                    + l.sv_polygons
                    + l.mv_polygons
                    + l.cluster_polygons
                    + l.impostor_polygons
            },
            low_is_hot: false,
            label: format_value,
        },
        Metric {
            name: "cell pack size (bytes)",
            value: |l| l.pack_bytes as f64,
            low_is_hot: false,
            label: format_value,
        },
        Metric {
            name: "bake time of the cell (ms)",
            value: |l| l.bake_ms,
            low_is_hot: false,
            label: format_value,
        },
        // The worst (lowest) PSNR is the hot end; labels are its dB, positive.
        Metric {
            name: "worst check view, PSNR(Y) (dB)",
            value: |l| l.worst_view_psnr_db,
            low_is_hot: true,
            label: |v| format!("{v:.1}"),
        },
    ]
}

/// Renders the three panels; returns PNG bytes.
pub fn render(grid_params: &GridParams, lines: &[CellLine]) -> anyhow::Result<Vec<u8>> {
    let grid = HexGrid::from_params(grid_params)?;
    // Fit the cells themselves (they reach past the ground rectangle).
    let (mut cmin, mut cmax) = (
        glam::Vec2::splat(f32::INFINITY),
        glam::Vec2::splat(f32::NEG_INFINITY),
    );
    for cell in 0..grid.cell_count() {
        for c in grid.corners(cell) {
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
    }
    let [gw, gd] = [cmax.x - cmin.x, cmax.y - cmin.y];
    let scale = PANEL / gw.max(gd).max(1e-6);
    let panel_h = gd * scale;
    let width = (4.0 * PANEL + 5.0 * MARGIN) as u32;
    let height = (TITLE_H + panel_h + 2.0 * MARGIN + BAR_H + LABEL_H + 8.0) as u32;
    let mut pm = Pixmap::new(width, height).ok_or_else(|| anyhow::anyhow!("bad image size"))?;
    pm.fill(Color::WHITE);
    for (k, metric) in metrics().iter().enumerate() {
        let x0 = MARGIN + k as f32 * (PANEL + MARGIN);
        let values: Vec<f64> = lines.iter().map(metric.value).collect();
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // Cells without a record stay grey.
        for cell in 0..grid.cell_count() {
            let value = lines.iter().position(|l| l.cell == cell).map(|i| values[i]);
            let colour = match value {
                Some(v) => ramp(metric.ramp_position(v, lo, hi)),
                None => [200, 200, 200, 255],
            };
            let corners = grid.corners(cell);
            let mut pb = PathBuilder::new();
            for (i, c) in corners.iter().enumerate() {
                let px = x0 + (c.x - cmin.x) * scale;
                let py = TITLE_H + MARGIN + (c.y - cmin.y) * scale;
                if i == 0 {
                    pb.move_to(px, py);
                } else {
                    pb.line_to(px, py);
                }
            }
            pb.close();
            if let Some(path) = pb.finish() {
                let mut paint = Paint::default();
                paint.set_color_rgba8(colour[0], colour[1], colour[2], 255);
                paint.anti_alias = true;
                pm.fill_path(
                    &path,
                    &paint,
                    FillRule::Winding,
                    Transform::identity(),
                    None,
                );
                paint.set_color_rgba8(255, 255, 255, 255);
                let stroke = Stroke {
                    width: 0.5,
                    ..Stroke::default()
                };
                pm.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
            }
        }
        // Colour bar and its labels.
        let bar_y = TITLE_H + MARGIN + panel_h + 8.0;
        let steps = 64;
        for s in 0..steps {
            let c = ramp(s as f32 / (steps - 1) as f32);
            let mut paint = Paint::default();
            paint.set_color_rgba8(c[0], c[1], c[2], 255);
            let w = PANEL / steps as f32;
            if let Some(r) = Rect::from_xywh(x0 + s as f32 * w, bar_y, w + 0.5, BAR_H) {
                pm.fill_rect(r, &paint, Transform::identity(), None);
            }
        }
        let label_y = bar_y + BAR_H + 4.0;
        let (cold, hot) = metric.legend(lo, hi);
        draw_text(&mut pm, x0, label_y, &cold);
        draw_text(&mut pm, x0 + PANEL - text_width(&hot), label_y, &hot);
        // The panel's title, with its unit, centred above the map.
        let name = metric.name;
        crate::text::draw_text(
            &mut pm,
            x0 + PANEL / 2.0 - crate::text::text_width(name, TITLE_PX) / 2.0,
            MARGIN,
            name,
            [30, 30, 30],
            TITLE_PX,
        );
    }
    Ok(pm.encode_png()?)
}

fn format_value(v: f64) -> String {
    if v >= 1e6 {
        format!("{:.1}m", v / 1e6)
    } else if v >= 1e4 {
        format!("{:.0}k", v / 1e3)
    } else {
        format!("{v:.0}")
    }
}

const PX: f32 = 2.6;
const TITLE_PX: f32 = 2.8;

fn text_width(s: &str) -> f32 {
    crate::text::text_width(s, PX)
}

fn draw_text(pm: &mut Pixmap, x: f32, y: f32, s: &str) {
    crate::text::draw_text(pm, x, y, s, [30, 30, 30], PX);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 28: the worst-PSNR panel's bar reads positive dB, the best cell's at the
    /// cold (left) end and the worst cell's at the hot (right) end — it read
    /// "-16 … -12" when the values were negated for the ramp — and the worst cell is
    /// the hottest.
    #[test]
    fn worst_psnr_legend_reads_positive_db_best_to_worst() {
        let m = metrics();
        let psnr = m.iter().find(|m| m.name.starts_with("worst")).unwrap();
        let (lo, hi) = (11.8, 16.04);
        assert_eq!(
            psnr.legend(lo, hi),
            ("16.0".to_string(), "11.8".to_string())
        );
        assert_eq!(psnr.ramp_position(lo, lo, hi), 1.0, "the worst cell is hot");
        assert_eq!(psnr.ramp_position(hi, lo, hi), 0.0);
        // The other panels: low values cold, at the left.
        let bytes = m.iter().find(|m| m.name.starts_with("cell pack")).unwrap();
        assert_eq!(
            bytes.legend(1e3, 2e6),
            ("1000".to_string(), "2.0m".to_string())
        );
        assert_eq!(bytes.ramp_position(2e6, 1e3, 2e6), 1.0);
        assert_eq!(psnr.legend(f64::INFINITY, f64::NEG_INFINITY).0, "-");
    }
}
