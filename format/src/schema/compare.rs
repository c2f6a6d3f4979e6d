//! `player compare --json`: the image-quality and frame-time report of a compare
//! along a camera path (issue 14 items 2 and 6), written by the player
//! (`player/src/run.rs`) and read by the benchmark tool (`bench/`, the run files of
//! `scripts/bench.sh`). player/README.md describes the keys.
//!
//! JSON (`serde_json::to_string_pretty`). A figure that is not a number (the mean of
//! no frames, a ratio over a zero median) is written as `null` and reads back as NaN;
//! every struct reads with `#[serde(default)]`, so a report written before a field
//! existed (run files of older players) still reads, and unknown keys are ignored.
//! Golden file: `format/tests/data/schema/compare.json`
//! (`format/tests/schema_compare_golden.rs`).

pub use super::frames::DrawOptions;
use serde::{Deserialize, Deserializer, Serialize};

/// The top-level keys every `player compare --json` report has, whatever its mode
/// (for readers and tests that check the contract; reports of older players may
/// lack `draw_options`, which reads as `None`).
pub const REQUIRED_KEYS: [&str; 8] = [
    "frames",
    "mean_psnr_y",
    "min_psnr_y",
    "mean_ssim",
    "mean_triangles",
    "reference_triangles",
    "frame_time_ratio",
    "draw_options",
];

/// Frame-time behaviour at cell crossings (paper Fig. 14): per crossing, the maximum
/// total frame time (GPU + streaming) in the crossing frame and the 9 after it,
/// relative to the median of the other (in-cell) frames.
///
/// `ratio` divides by the median of the whole walk's in-cell frames; where a walk's
/// cost varies with what is in view (park-2m's walk: 45–50 ms a frame facing the
/// statues, 10 ms later), it measures where the crossings lie more than a hitch.
/// `local_ratio_*` divide each crossing's maximum by the median of the in-cell
/// frames of the two cells it joins (the frames since the previous crossing and
/// until the next, outside crossing windows); `quiet_ratio_max` is the same
/// statistic on 10-frame windows with no crossing (their maximum over the median of
/// the in-cell frames within 40 frames): what frame-time noise alone gives. The
/// three are left out of the JSON when NaN, as files of older players lack them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CrossingStats {
    pub crossings: usize,
    #[serde(deserialize_with = "nan_if_null")]
    pub in_cell_median_ms: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub max_after_crossing_ms: f64,
    /// max_after_crossing_ms / in_cell_median_ms.
    #[serde(deserialize_with = "nan_if_null")]
    pub ratio: f64,
    /// The largest per-crossing ratio against its two cells' median (NaN: no
    /// crossing, or a file of an older player).
    #[serde(deserialize_with = "nan_if_null", skip_serializing_if = "is_nan")]
    pub local_ratio_max: f64,
    /// The mean of the per-crossing ratios against their two cells' medians.
    #[serde(deserialize_with = "nan_if_null", skip_serializing_if = "is_nan")]
    pub local_ratio_mean: f64,
    /// The largest ratio of the same statistic on windows without a crossing
    /// (NaN: none).
    #[serde(deserialize_with = "nan_if_null", skip_serializing_if = "is_nan")]
    pub quiet_ratio_max: f64,
}

/// Absent ratios (files of older players) read as NaN, not 0.
impl Default for CrossingStats {
    fn default() -> Self {
        Self {
            crossings: 0,
            in_cell_median_ms: f64::NAN,
            max_after_crossing_ms: f64::NAN,
            ratio: f64::NAN,
            local_ratio_max: f64::NAN,
            local_ratio_mean: f64::NAN,
            quiet_ratio_max: f64::NAN,
        }
    }
}

/// Image quality of one frame against one reference (both rendered with coverage
/// alpha, `width × height` RGBA8); measured by `player::metrics::measure_frame`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FrameQuality {
    /// Full-frame PSNR(Y), capped at [`crate::metrics::PSNR_CAP`].
    #[serde(deserialize_with = "nan_if_null")]
    pub psnr_y_db: f64,
    /// Full-frame mean SSIM on Y.
    #[serde(deserialize_with = "nan_if_null")]
    pub ssim: f64,
    /// Pixels that are not background in the frame or in the reference.
    pub object_pixels: usize,
    /// PSNR(Y) over the object pixels, capped; `None` without object pixels.
    pub object_psnr_y_db: Option<f64>,
    /// Mean SSIM over the windows centred on object pixels; `None` without any.
    pub object_ssim: Option<f64>,
    /// Σ ΔY² over the object pixels (8-bit levels²), for pooling over a path. Not
    /// written: the writer's pooling state.
    #[serde(skip)]
    pub object_sq_error: f64,
    /// All pixels of the frame. Not written.
    #[serde(skip)]
    pub pixels: usize,
}

/// Object-pixel quality over a path (`player::metrics::summarize_objects`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ObjectQuality {
    /// PSNR(Y) of the MSE pooled over every object pixel of every frame, capped
    /// ([`crate::metrics::PSNR_CAP`] without any object pixel).
    #[serde(deserialize_with = "nan_if_null")]
    pub object_psnr_y_db: f64,
    /// The lowest per-frame object PSNR(Y) ([`crate::metrics::PSNR_CAP`] without
    /// object pixels).
    #[serde(deserialize_with = "nan_if_null")]
    pub min_object_psnr_y_db: f64,
    /// The frame of that minimum.
    pub worst_object_frame: Option<usize>,
    /// Mean of the per-frame object SSIM over the frames that have object pixels
    /// (1 without any).
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_object_ssim: f64,
    /// Object pixels / all pixels over the path (what the full-frame figures are
    /// diluted by: 1 − this is sky).
    #[serde(deserialize_with = "nan_if_null")]
    pub object_pixel_fraction: f64,
}

/// Frames whose eye is at most this far (ground units) from a cell border count as
/// "near a border" (issue 31's 5 units).
pub const BORDER_RADIUS: f64 = 5.0;

/// One frame of `player compare`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CompareFrame {
    pub frame: usize,
    pub cell: Option<u32>,
    /// Full-frame PSNR(Y) against the full-geometry frame, dB (capped).
    #[serde(deserialize_with = "nan_if_null")]
    pub psnr_y: f64,
    /// Full-frame mean SSIM against the full-geometry frame.
    #[serde(deserialize_with = "nan_if_null")]
    pub ssim: f64,
    /// Pixels where either frame is not sky.
    pub object_pixels: usize,
    /// PSNR(Y) over the object pixels, dB (capped); `None` without object pixels.
    pub object_psnr_y_db: Option<f64>,
    /// Mean SSIM over the windows centred on object pixels.
    pub object_ssim: Option<f64>,
    /// Both frames against the anti-aliased reference (`--reference-ss` > 1).
    pub aa_reference: Option<AaFrame>,
    pub triangles: u64,
    pub reference_triangles: u64,
    /// Draw calls the compared mode submits (at least 1, the ground). 0 stands for a
    /// report written before they were counted, and is not written.
    #[serde(skip_serializing_if = "is_zero_u64")]
    pub draw_calls: u64,
    #[serde(deserialize_with = "nan_if_null")]
    pub frame_ms: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub reference_frame_ms: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub frustum_frame_ms: f64,
    /// Ground distance from the eye to the nearest edge of its cell's hexagon (issue
    /// 31: image quality near borders); `None` off the grid and in older reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub border_distance: Option<f64>,
}

/// The frames of a walk near cell borders against the whole walk (issue 31: "over
/// every walk, the mean PSNR(Y) of frames within 5 units of a border is within 1 dB
/// of the walk's mean").
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BorderQuality {
    /// Frames whose eye is at most this far from its hexagon's edge (ground units).
    pub radius: f64,
    pub frames: usize,
    /// Mean full-frame PSNR(Y) of those frames and of the whole walk, dB.
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_psnr_y: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub walk_mean_psnr_y: f64,
    /// Object-pixel PSNR(Y), pooled over those frames and over the whole walk, dB.
    #[serde(deserialize_with = "nan_if_null")]
    pub object_psnr_y_db: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub walk_object_psnr_y_db: f64,
}

/// One frame against the anti-aliased reference.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AaFrame {
    /// The compared mode's frame (hybrid or lod).
    pub compared: FrameQuality,
    /// The full-geometry frame rendered at one sample per pixel (aliased).
    pub full: FrameQuality,
}

/// One configuration's frames against the anti-aliased reference, over the path.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AaQuality {
    /// Mean of the per-frame full-frame PSNR(Y), dB.
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_psnr_y_db: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub min_psnr_y_db: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_ssim: f64,
    #[serde(flatten)]
    pub object: ObjectQuality,
}

/// The anti-aliased reference (DESIGN.md "Measuring quality honestly"): full
/// geometry rendered `supersampling_factor` times wider and higher and box-filtered
/// in linear light. `compared` minus `full` is the error of the proxies (or LOD
/// levels) beyond the aliasing that the one-sample full-geometry frame already has.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AaReference {
    /// Per axis (`--reference-ss`).
    pub supersampling_factor: u32,
    /// supersampling_factor².
    pub samples_per_pixel: u32,
    /// The compared mode (hybrid or lod) against it.
    pub compared: AaQuality,
    /// The aliased full-geometry frame against it: the sampling noise alone.
    pub full: AaQuality,
}

/// The result of `player compare` (its `--json` output).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CompareReport {
    pub frames: usize,
    /// Full-frame figures against the aliased full-geometry frame: mean and minimum
    /// of the per-frame PSNR(Y) in dB, mean SSIM.
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_psnr_y: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub min_psnr_y: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_ssim: f64,
    /// The same over object pixels (where either frame is not sky): pooled
    /// `object_psnr_y_db`, `min_object_psnr_y_db`, `worst_object_frame`,
    /// `mean_object_ssim`, `object_pixel_fraction`.
    #[serde(flatten)]
    pub object: ObjectQuality,
    /// Both frames against the anti-aliased reference; `None` with
    /// `--reference-ss 1`.
    pub aa_reference: Option<AaReference>,
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_triangles: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub reference_triangles: f64,
    /// Mean draw calls per frame of the compared mode (one per instanced model
    /// group, per index range of a patched original, per vertex range of a proxy,
    /// plus the ground). 0 stands for a report written before they were counted,
    /// and is not written.
    #[serde(deserialize_with = "nan_if_null", skip_serializing_if = "is_zero_f64")]
    pub mean_draw_calls: f64,
    /// Mean frame time of the compared mode (hybrid or lod) / mean full-geometry
    /// frame time.
    #[serde(deserialize_with = "nan_if_null")]
    pub frame_time_ratio: f64,
    /// Mean frame time of the compared mode / mean frustum-culled frame time (config
    /// C vs B for the hybrid).
    #[serde(deserialize_with = "nan_if_null")]
    pub frame_time_ratio_frustum: f64,
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    /// The compared configuration (`hybrid`, `lod`, ...); older players omit it.
    pub mode: String,
    /// The LOD threshold in pixels (`lod` mode only; the player's `f32`).
    pub lod_pixel_error: Option<f32>,
    /// Wall time of building the LOD chains (`lod` mode only), milliseconds.
    pub lod_build_ms: Option<f64>,
    /// Cluster LOD's figures (`cluster-lod` mode only, issue 30): its τ, the DAGs'
    /// build and bytes beside the packs' bytes, clusters drawn per frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cluster_lod: Option<ClusterLodSummary>,
    /// What every configuration's frames were drawn with (the player's flags; issue
    /// 28). `None` in reports of older players, which did not record it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub draw_options: Option<DrawOptions>,
    pub crossing_prefetch: Option<CrossingStats>,
    pub crossing_no_prefetch: Option<CrossingStats>,
    /// The image jump at each cell crossing of the walk (issue 31, `player compare
    /// --pops`); `None` when not measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pops: Option<PopReport>,
    /// Cells of the walk (ascending) whose frames the compared mode drew with
    /// original geometry in place of a pack: the cell's pack missing, corrupt or off
    /// the index, or a far-field group's pack of its chain unavailable (issue 32).
    /// Those frames' figures count full geometry as the hybrid.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fallback_cells: Vec<u32>,
    /// The frames within [`BORDER_RADIUS`] of a cell border against the whole walk
    /// (issue 31); `None` when no frame is that near or in older reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near_border: Option<BorderQuality>,
    /// Mean CPU time of building the compared mode's draw list per frame
    /// (culling included: instances, tiles, the hybrid's occlusion map),
    /// milliseconds, and the same for the frustum-culled frames; not in any frame
    /// time. 0: a report of a player before it (not written).
    #[serde(deserialize_with = "nan_if_null", skip_serializing_if = "is_zero_f64")]
    pub mean_list_ms: f64,
    #[serde(deserialize_with = "nan_if_null", skip_serializing_if = "is_zero_f64")]
    pub mean_frustum_list_ms: f64,
    pub per_frame: Vec<CompareFrame>,
}

/// What `player compare --mode cluster-lod` adds to its report (issue 30 item 1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ClusterLodSummary {
    /// `--cluster-tau`: the projected error a drawn cluster may have, pixels.
    pub tau_px: f32,
    /// Wall time of reading or building every model's cluster DAG, milliseconds.
    pub build_ms: f64,
    /// Models whose DAG came from the cache beside the bake / was built.
    pub cache_hits: usize,
    pub built: usize,
    /// Clusters over all DAGs (every level).
    pub clusters: usize,
    /// Bytes of the DAGs on disk (`<out>/clusterlod/*.clod`), and of the bake's
    /// packs (`*.pack`) beside them.
    pub cluster_bytes: u64,
    pub pack_bytes: u64,
    /// Bytes of the DAGs' index buffers resident on the GPU.
    pub resident_bytes: u64,
    /// Mean clusters drawn per frame.
    pub mean_clusters_drawn: f64,
    /// Mean CPU time of a frame's DAG cut and cluster culling, milliseconds (not
    /// in the frame time, like every mode's draw-list building).
    pub mean_cut_ms: f64,
}

/// The pop at one cell crossing (issue 31 item 1): the crossing frame's pose drawn
/// with the outgoing cell's packs and with the incoming cell's (each settled: every
/// texture uploaded, no stand-ins), compared over object pixels; beside it, the
/// change a one-pixel camera turn makes in the full-geometry frame at that pose,
/// the threshold a viewer would not notice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CrossingPop {
    pub frame: usize,
    pub from_cell: u32,
    pub to_cell: u32,
    /// Outgoing against incoming, object pixels (capped at the PSNR cap).
    #[serde(deserialize_with = "nan_if_null")]
    pub pop_object_psnr_y_db: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub pop_object_ssim: f64,
    /// Full geometry at the pose against full geometry turned by one pixel.
    #[serde(deserialize_with = "nan_if_null")]
    pub shift_object_psnr_y_db: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub shift_object_ssim: f64,
}

/// Every crossing's pop and their summary: PSNRs pooled as the mean of the
/// per-crossing dB figures, the worst (lowest) pop, and the crossing it is at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PopReport {
    pub crossings: Vec<CrossingPop>,
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_pop_psnr_y_db: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub worst_pop_psnr_y_db: f64,
    pub worst_frame: Option<usize>,
    #[serde(deserialize_with = "nan_if_null")]
    pub mean_shift_psnr_y_db: f64,
    /// Crossings whose pop is no larger than the one-pixel turn (pop PSNR ≥ shift
    /// PSNR).
    pub below_shift: usize,
    /// The cross-fade band the walk was drawn with, as a share of the hexagon's
    /// apothem (`--fade`; 0: none). With a fade, a crossing's outgoing and
    /// incoming representations are those of the frames before and after it (both
    /// blends), and every other frame in a band changes the blend a little: a step.
    #[serde(default)]
    pub fade: f32,
    /// Frames in a band whose blend differs from the previous frame's, crossings
    /// left out; each is measured like a crossing (the previous frame's blend
    /// against its own at its pose).
    #[serde(default)]
    pub fade_steps: usize,
    /// The largest step (lowest PSNR), its frame, and the mean over steps; NaN and
    /// `None` without steps.
    #[serde(default = "nan", deserialize_with = "nan_if_null")]
    pub worst_step_psnr_y_db: f64,
    #[serde(default)]
    pub worst_step_frame: Option<usize>,
    #[serde(default = "nan", deserialize_with = "nan_if_null")]
    pub mean_step_psnr_y_db: f64,
}

fn nan() -> f64 {
    f64::NAN
}

impl PopReport {
    pub fn of(crossings: Vec<CrossingPop>) -> PopReport {
        let n = crossings.len();
        let mean = |f: fn(&CrossingPop) -> f64| {
            if n == 0 {
                f64::NAN
            } else {
                crossings.iter().map(f).sum::<f64>() / n as f64
            }
        };
        let worst = crossings
            .iter()
            .min_by(|a, b| a.pop_object_psnr_y_db.total_cmp(&b.pop_object_psnr_y_db));
        PopReport {
            mean_pop_psnr_y_db: mean(|c| c.pop_object_psnr_y_db),
            worst_pop_psnr_y_db: worst.map_or(f64::NAN, |c| c.pop_object_psnr_y_db),
            worst_frame: worst.map(|c| c.frame),
            mean_shift_psnr_y_db: mean(|c| c.shift_object_psnr_y_db),
            below_shift: crossings
                .iter()
                .filter(|c| c.pop_object_psnr_y_db >= c.shift_object_psnr_y_db)
                .count(),
            crossings,
            fade: 0.0,
            fade_steps: 0,
            worst_step_psnr_y_db: f64::NAN,
            worst_step_frame: None,
            mean_step_psnr_y_db: f64::NAN,
        }
    }
}

/// serde_json writes a non-finite f64 as `null`: read it back as NaN.
pub(super) fn is_zero_u64(v: &u64) -> bool {
    *v == 0
}

fn is_zero_f64(v: &f64) -> bool {
    *v == 0.0
}

fn is_nan(x: &f64) -> bool {
    x.is_nan()
}

fn nan_if_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_is_written_as_null_and_reads_back_as_nan() {
        let c = CrossingStats {
            crossings: 0,
            in_cell_median_ms: 1.0,
            max_after_crossing_ms: 0.0,
            ratio: f64::NAN,
            ..Default::default()
        };
        let json = serde_json::to_string(&c).unwrap();
        assert!(json.contains("\"ratio\":null"), "{json}");
        let back: CrossingStats = serde_json::from_str(&json).unwrap();
        assert!(back.ratio.is_nan());
        assert_eq!(back.in_cell_median_ms, 1.0);
    }

    /// A pop report written before the cross-fade (issue 31 item 2) reads with no
    /// fade and no steps; one with steps writes them and reads them back.
    #[test]
    fn pop_reports_before_and_with_the_fade_read() {
        let old = r#"{"crossings":[],"mean_pop_psnr_y_db":null,"worst_pop_psnr_y_db":null,
            "worst_frame":null,"mean_shift_psnr_y_db":null,"below_shift":0}"#;
        let r: PopReport = serde_json::from_str(old).unwrap();
        assert_eq!((r.fade, r.fade_steps, r.worst_step_frame), (0.0, 0, None));
        assert!(r.worst_step_psnr_y_db.is_nan() && r.mean_step_psnr_y_db.is_nan());
        let with = PopReport {
            fade: 0.15,
            fade_steps: 7,
            worst_step_psnr_y_db: 21.5,
            worst_step_frame: Some(40),
            mean_step_psnr_y_db: 33.25,
            ..r
        };
        let json = serde_json::to_string(&with).unwrap();
        assert!(
            json.contains("\"fade\":0.15") && json.contains("\"fade_steps\":7"),
            "{json}"
        );
        let back: PopReport = serde_json::from_str(&json).unwrap();
        assert_eq!(
            (
                back.fade,
                back.fade_steps,
                back.worst_step_frame,
                back.worst_step_psnr_y_db
            ),
            (0.15, 7, Some(40), 21.5)
        );
        assert_eq!(back.mean_step_psnr_y_db, 33.25);
    }

    #[test]
    fn pop_report_summarises_its_crossings() {
        let pop = |frame, p, s| CrossingPop {
            frame,
            from_cell: 1,
            to_cell: 2,
            pop_object_psnr_y_db: p,
            pop_object_ssim: 0.9,
            shift_object_psnr_y_db: s,
            shift_object_ssim: 0.8,
        };
        let r = PopReport::of(vec![pop(3, 30.0, 20.0), pop(9, 18.0, 22.0)]);
        assert_eq!(r.mean_pop_psnr_y_db, 24.0);
        assert_eq!(r.worst_pop_psnr_y_db, 18.0);
        assert_eq!(r.worst_frame, Some(9));
        assert_eq!(r.mean_shift_psnr_y_db, 21.0);
        assert_eq!(r.below_shift, 1);
        let empty = PopReport::of(Vec::new());
        assert!(empty.mean_pop_psnr_y_db.is_nan() && empty.worst_frame.is_none());
        let json = serde_json::to_string(&empty).unwrap();
        let back: PopReport = serde_json::from_str(&json).unwrap();
        assert!(back.worst_pop_psnr_y_db.is_nan());
    }

    #[test]
    fn a_report_of_an_older_player_reads_with_defaults() {
        // Before object pixels and the anti-aliased reference (run files up to
        // 2026-11-21), with a key this schema does not know.
        let json = r#"{"frames":1,"mean_psnr_y":40.5,"min_psnr_y":40.5,"mean_ssim":0.9,
            "mean_triangles":100.0,"reference_triangles":1000.0,"frame_time_ratio":0.5,
            "frame_time_ratio_frustum":0.7,"adapter":"llvmpipe","width":64,"height":64,
            "something_new":[1,2],
            "per_frame":[{"frame":0,"cell":null,"psnr_y":40.5,"ssim":0.9,"triangles":90,
                          "reference_triangles":1000,"frame_ms":1.0,"reference_frame_ms":2.0,
                          "frustum_frame_ms":1.5}]}"#;
        let r: CompareReport = serde_json::from_str(json).unwrap();
        assert_eq!(r.frames, 1);
        assert_eq!(r.mode, "");
        assert_eq!(r.object, ObjectQuality::default());
        assert!(r.pops.is_none());
        assert!(r.fallback_cells.is_empty());
        assert!(r.aa_reference.is_none() && r.per_frame[0].aa_reference.is_none());
        assert_eq!(r.per_frame[0].object_psnr_y_db, None);
        assert_eq!((r.mean_draw_calls, r.per_frame[0].draw_calls), (0.0, 0));
        assert_eq!(r.draw_options, None);
    }

    #[test]
    fn draw_options_are_written_and_read_back() {
        let options = DrawOptions {
            frustum: false,
            tile_triangles: 64,
            ..Default::default()
        };
        let r = CompareReport {
            draw_options: Some(options),
            ..Default::default()
        };
        let json = serde_json::to_string(&r).unwrap();
        assert!(
            json.contains(r#""draw_options":{"patch_bitfields":true,"backface":true,"frustum":false,"tile_triangles":64,"bc_textures":true,"occlusion":true}"#),
            "{json}"
        );
        let back: CompareReport = serde_json::from_str(&json).unwrap();
        assert_eq!(back.draw_options, Some(options));
    }

    #[test]
    fn draw_calls_are_written_when_counted_and_read_back() {
        let mut r = CompareReport {
            mean_draw_calls: 32.5,
            per_frame: vec![CompareFrame {
                draw_calls: 33,
                ..Default::default()
            }],
            ..Default::default()
        };
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains("\"mean_draw_calls\":32.5"), "{json}");
        assert!(json.contains("\"draw_calls\":33"), "{json}");
        let back: CompareReport = serde_json::from_str(&json).unwrap();
        assert_eq!(
            (back.mean_draw_calls, back.per_frame[0].draw_calls),
            (32.5, 33)
        );
        // Uncounted (an older report read back) they stay out, as they came in.
        r.mean_draw_calls = 0.0;
        r.per_frame[0].draw_calls = 0;
        let json = serde_json::to_string(&r).unwrap();
        assert!(!json.contains("draw_calls"), "{json}");
    }
}
