//! `player compare --modes` (issue 30 item 3, "one table, one run"): the rows of
//! the comparison table built from each run's report ([`TableRow::of`]), the
//! triangles each LOD mode needs to reach the hybrid's object PSNR, interpolated
//! over a threshold sweep ([`triangles_to_reach`]), and the table as markdown
//! ([`markdown`]). Plain data: the walk is [`crate::compare::compare_runs`].

use crate::compare::{CompareRun, RunBytes};
use crate::run::CompareReport;
use serde::Serialize;

/// One row of the table: a run's figures per frame over the walk.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TableRow {
    /// [`CompareRun::label`], e.g. `cluster-lod τ=1`.
    pub label: String,
    pub mode: String,
    /// `cluster-lod` rows: τ in pixels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cluster_tau_px: Option<f32>,
    /// `lod` rows: the pixel error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_pixel_error: Option<f32>,
    /// Mean triangles and draw calls per frame.
    pub triangles: f64,
    pub draw_calls: f64,
    /// Object-pixel PSNR(Y) (pooled, dB) and mean SSIM against the anti-aliased
    /// reference (`--reference-ss` > 1), else against the one-sample full-geometry
    /// frame (see `against`).
    pub object_psnr_y_db: f64,
    pub object_ssim: f64,
    /// `"aa NxN"` or `"full"`: what the two figures above are measured against.
    pub against: String,
    /// Bytes on disk and resident ([`RunBytes`]); `None` where the mode has none.
    pub disk_bytes: Option<u64>,
    pub resident_bytes: Option<u64>,
    /// Mean frame time on the adapter, ms; the frustum-culled originals' beside it.
    pub frame_ms: f64,
    pub frustum_frame_ms: f64,
    /// Mean CPU time of building the frame's draw list (culling included), ms,
    /// and the frustum-culled frames'; not in the frame times.
    pub list_ms: f64,
    pub frustum_list_ms: f64,
}

impl TableRow {
    pub fn of(run: &CompareRun, report: &CompareReport, bytes: &RunBytes) -> TableRow {
        let (object, against) = match &report.aa_reference {
            Some(aa) => (
                &aa.compared.object,
                format!("aa {0}x{0}", aa.supersampling_factor),
            ),
            None => (&report.object, "full".to_string()),
        };
        let mean = |f: fn(&crate::run::CompareFrame) -> f64| {
            let n = report.per_frame.len();
            if n == 0 {
                f64::NAN
            } else {
                report.per_frame.iter().map(f).sum::<f64>() / n as f64
            }
        };
        TableRow {
            label: run.label(),
            mode: run.mode.name().to_string(),
            cluster_tau_px: (run.mode == crate::frame::Mode::ClusterLod).then_some(run.cluster_tau),
            lod_pixel_error: (run.mode == crate::frame::Mode::Lod).then_some(run.lod_pixel_error),
            triangles: report.mean_triangles,
            draw_calls: report.mean_draw_calls,
            object_psnr_y_db: object.object_psnr_y_db,
            object_ssim: object.mean_object_ssim,
            against,
            disk_bytes: bytes.disk,
            resident_bytes: bytes.resident,
            frame_ms: mean(|f| f.frame_ms),
            frustum_frame_ms: mean(|f| f.frustum_frame_ms),
            list_ms: report.mean_list_ms,
            frustum_list_ms: report.mean_frustum_list_ms,
        }
    }
}

/// How many triangles a sweep needs to reach a target PSNR.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "status", content = "triangles", rename_all = "kebab-case")]
pub enum Reach {
    /// Linearly interpolated between the two sweep points around the target.
    Interpolated(f64),
    /// The sweep's cheapest point already reaches it: at most this many.
    AtMost(f64),
    /// No point of the sweep reaches it.
    NotReached,
}

/// The triangles at which `points` (triangles, PSNR dB; one per sweep value, any
/// order) first reach `target_db`: the points are ordered by triangles, and between
/// the first pair (a, b) with PSNR(a) < target ≤ PSNR(b) the triangles are
/// interpolated linearly in PSNR. Points with a non-finite figure are left out.
pub fn triangles_to_reach(points: &[(f64, f64)], target_db: f64) -> Reach {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(t, q)| t.is_finite() && q.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    match p.first() {
        None => return Reach::NotReached,
        Some(&(t, q)) if q >= target_db => return Reach::AtMost(t),
        _ => {}
    }
    for w in p.windows(2) {
        let ((ta, qa), (tb, qb)) = (w[0], w[1]);
        if qa < target_db && target_db <= qb {
            return Reach::Interpolated(ta + (target_db - qa) / (qb - qa) * (tb - ta));
        }
    }
    Reach::NotReached
}

/// The reach of one LOD mode: its rows' sweep against the hybrid's object PSNR.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModeReach {
    pub mode: String,
    pub target_object_psnr_y_db: f64,
    pub sweep_points: usize,
    pub reach: Reach,
}

/// For each LOD mode among `rows` (lod, cluster-lod), the triangles its sweep needs
/// to reach the hybrid row's object PSNR; empty without a hybrid row.
pub fn reaches(rows: &[TableRow]) -> Vec<ModeReach> {
    let Some(hybrid) = rows.iter().find(|r| r.mode == "hybrid") else {
        return Vec::new();
    };
    ["cluster-lod", "lod"]
        .iter()
        .filter_map(|&mode| {
            let points: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.mode == mode)
                .map(|r| (r.triangles, r.object_psnr_y_db))
                .collect();
            (!points.is_empty()).then(|| ModeReach {
                mode: mode.to_string(),
                target_object_psnr_y_db: hybrid.object_psnr_y_db,
                sweep_points: points.len(),
                reach: triangles_to_reach(&points, hybrid.object_psnr_y_db),
            })
        })
        .collect()
}

/// `player compare --modes --json`: the table's rows and reaches, and each run's
/// full report (as `--mode` writes it), in the order of the rows.
#[derive(Clone, Debug, Serialize)]
pub struct MultiCompare {
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    pub frames: usize,
    pub rows: Vec<TableRow>,
    pub reach: Vec<ModeReach>,
    pub reports: Vec<CompareReport>,
}

fn mib(b: Option<u64>) -> String {
    b.map_or("–".to_string(), |b| {
        format!("{:.2}", b as f64 / (1u64 << 20) as f64)
    })
}

/// `x / hybrid` as `×1.23`, or `–`.
fn ratio(x: Option<f64>, hybrid: Option<f64>) -> String {
    match (x, hybrid) {
        (Some(x), Some(h)) if h > 0.0 && x.is_finite() && h.is_finite() => {
            format!("×{:.2}", x / h)
        }
        _ => "–".to_string(),
    }
}

/// The table as markdown: a heading line (walk, adapter, reference), one row per
/// run with its figures and, for the other rows, each against the hybrid's (× for
/// ratios, dB and SSIM differences), then the reach of each LOD mode and one line
/// per column on which the hybrid loses, saying by how much.
pub fn markdown(m: &MultiCompare, walk: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let against = m.rows.first().map_or("full", |r| r.against.as_str());
    let _ = writeln!(
        s,
        "Walk `{walk}`: {} frames at {}×{}, adapter {}; object pixels against the {} reference; frustum-culled originals {:.2} ms per frame ({:.2} ms of CPU for their draw list).\n",
        m.frames,
        m.width,
        m.height,
        m.adapter,
        if against == "full" {
            "one-sample full-geometry".to_string()
        } else {
            format!("{against} supersampled")
        },
        m.rows.first().map_or(f64::NAN, |r| r.frustum_frame_ms),
        m.rows.first().map_or(f64::NAN, |r| r.frustum_list_ms)
    );
    s.push_str("| mode | triangles/frame | draw calls/frame | object PSNR(Y) dB | object SSIM | disk MiB | resident MiB | frame ms | list CPU ms | tris vs hybrid | ΔPSNR dB vs hybrid | ΔSSIM vs hybrid | disk vs hybrid | resident vs hybrid | frame time vs hybrid |\n");
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    let hybrid = m.rows.iter().find(|r| r.mode == "hybrid");
    let f = |b: Option<u64>| b.map(|b| b as f64);
    for r in &m.rows {
        let (tris, dpsnr, dssim, disk, res, ms) = match hybrid {
            Some(h) if r.mode != "hybrid" => (
                ratio(Some(r.triangles), Some(h.triangles)),
                format!("{:+.2}", r.object_psnr_y_db - h.object_psnr_y_db),
                format!("{:+.4}", r.object_ssim - h.object_ssim),
                ratio(f(r.disk_bytes), f(h.disk_bytes)),
                ratio(f(r.resident_bytes), f(h.resident_bytes)),
                ratio(Some(r.frame_ms), Some(h.frame_ms)),
            ),
            _ => Default::default(),
        };
        let _ = writeln!(
            s,
            "| {} | {:.0} | {:.1} | {:.2} | {:.4} | {} | {} | {:.2} | {:.2} | {tris} | {dpsnr} | {dssim} | {disk} | {res} | {ms} |",
            r.label,
            r.triangles,
            r.draw_calls,
            r.object_psnr_y_db,
            r.object_ssim,
            mib(r.disk_bytes),
            mib(r.resident_bytes),
            r.frame_ms,
            r.list_ms
        );
    }
    if let Some(h) = hybrid {
        s.push('\n');
        for reach in &m.reach {
            let what = match reach.reach {
                Reach::Interpolated(t) => format!(
                    "{t:.0} triangles/frame (×{:.2} the hybrid's {:.0}; interpolated)",
                    t / h.triangles,
                    h.triangles
                ),
                Reach::AtMost(t) => format!(
                    "at most {t:.0} triangles/frame (×{:.2} the hybrid's {:.0}; the sweep's cheapest point reaches it)",
                    t / h.triangles,
                    h.triangles
                ),
                Reach::NotReached => "not reached in the sweep".to_string(),
            };
            let _ = writeln!(
                s,
                "- {} reaches the hybrid's object PSNR ({:.2} dB) at: {what} (sweep of {}).",
                reach.mode, reach.target_object_psnr_y_db, reach.sweep_points
            );
        }
        for r in m.rows.iter().filter(|r| r.mode != "hybrid") {
            let mut losses = Vec::new();
            if r.triangles < h.triangles {
                losses.push(format!(
                    "triangles (hybrid's ×{:.2})",
                    h.triangles / r.triangles.max(1e-9)
                ));
            }
            if r.draw_calls < h.draw_calls {
                losses.push(format!(
                    "draw calls (hybrid's ×{:.2})",
                    h.draw_calls / r.draw_calls.max(1e-9)
                ));
            }
            if r.object_psnr_y_db > h.object_psnr_y_db {
                losses.push(format!(
                    "object PSNR {:.2} dB below",
                    r.object_psnr_y_db - h.object_psnr_y_db
                ));
            }
            if r.object_ssim > h.object_ssim {
                losses.push(format!(
                    "object SSIM {:.4} below",
                    r.object_ssim - h.object_ssim
                ));
            }
            for (name, x, y) in [
                ("disk", r.disk_bytes, h.disk_bytes),
                ("resident", r.resident_bytes, h.resident_bytes),
            ] {
                if let (Some(x), Some(y)) = (x, y) {
                    if x < y {
                        losses.push(format!(
                            "{name} bytes (hybrid's ×{:.2})",
                            y as f64 / x.max(1) as f64
                        ));
                    }
                }
            }
            if r.frame_ms < h.frame_ms {
                losses.push(format!(
                    "frame time (hybrid's ×{:.2})",
                    h.frame_ms / r.frame_ms.max(1e-9)
                ));
            }
            if !losses.is_empty() {
                let _ = writeln!(
                    s,
                    "- hybrid loses to {} on: {}.",
                    r.label,
                    losses.join("; ")
                );
            }
        }
    }
    s
}
