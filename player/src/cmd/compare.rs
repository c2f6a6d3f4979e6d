//! `player compare`: the hybrid (or the distance-LOD baseline) against the
//! full-geometry reference along a camera path ([`crate::compare::compare`]): PSNR on
//! luminance and SSIM over whole frames and object pixels, also against an
//! anti-aliased reference; triangle and frame-time ratios; crossing spikes and, with
//! `--pops`, the pop at each crossing. Prints the report as text or as JSON.

use super::args::{DrawArgs, PathArgs};
use crate::compare::{CompareOptions, CompareRun};
use crate::frame::Mode;
use crate::run::{CompareReport, RunError};
use crate::table::{MultiCompare, TableRow};
use std::path::PathBuf;

// The flags of `player compare` (its help text is the `Command::Compare` doc in
// main.rs).
#[derive(clap::Args, Clone)]
pub struct CompareArgs {
    pub out: PathBuf,
    #[arg(long)]
    pub path: PathBuf,
    /// What to compare with the full-geometry reference: hybrid, lod or
    /// cluster-lod (full and frustum work too).
    #[arg(long, default_value = "hybrid")]
    pub mode: Mode,
    /// Compare several modes on one walk against one reference (comma-separated,
    /// e.g. `hybrid,cluster-lod,lod`; each at most once): prints one markdown table
    /// (a row per mode and sweep value) in place of the single report; with
    /// `--json` an object with the table's `rows`, `reach` and every run's report.
    #[arg(long, value_delimiter = ',', conflicts_with = "mode")]
    pub modes: Vec<Mode>,
    /// Also write the table (markdown) to this file (implies the table).
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// cluster-lod rows at each of these τ (pixels, comma-separated) in place of
    /// `--cluster-tau`; the table interpolates the triangles cluster LOD needs to
    /// reach the hybrid's object PSNR. Needs cluster-lod among the modes.
    #[arg(long, value_delimiter = ',', value_parser = super::args::parse_tau)]
    pub cluster_tau_sweep: Vec<f32>,
    /// lod rows at each of these pixel errors, as `--cluster-tau-sweep` for lod.
    #[arg(long, value_delimiter = ',', value_parser = super::args::parse_tau)]
    pub lod_pixel_error_sweep: Vec<f32>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write the worst frames by object-pixel PSNR (reference, hybrid,
    /// difference, anti-aliased reference) here.
    #[arg(long)]
    pub worst: Option<PathBuf>,
    /// How many worst frames to write.
    #[arg(long, default_value_t = 3)]
    pub worst_count: usize,
    /// Skip the extra no-prefetch pass (crossing frame times).
    #[arg(long)]
    pub no_crossings: bool,
    /// Measure the pop at each cell crossing: the crossing pose drawn with the
    /// outgoing and with the incoming representation (with --fade: the previous
    /// frame's blend and its own), compared over object pixels, beside the change
    /// a one-pixel camera turn makes (issue 31); with --worst, the worst
    /// crossing's pair as PNGs.
    #[arg(long)]
    pub pops: bool,
    /// Supersampling per axis of the anti-aliased reference (full geometry
    /// rendered N times wider and higher, box-filtered in linear light); 1 = none.
    #[arg(long, default_value_t = crate::run::DEFAULT_REFERENCE_SS,
          value_parser = clap::value_parser!(u32).range(1..=crate::run::MAX_REFERENCE_SS as i64))]
    pub reference_ss: u32,
    /// Draw each configuration's frame this many times and time it by the
    /// fastest draw (robust to a busy machine; above 1 the hybrid's time leaves
    /// out the texture uploads its first draw submits).
    #[arg(long, default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeat: u32,
    #[command(flatten)]
    pub walk: PathArgs,
    #[command(flatten)]
    pub draw: DrawArgs,
}

/// The runs `--modes` and the sweeps ask for, in the order of the modes (a swept
/// mode's rows in the order of its sweep); `None` for a plain single-mode compare.
/// Refuses a mode listed twice and a sweep whose mode is not listed.
pub fn runs_of(args: &CompareArgs) -> Result<Option<Vec<CompareRun>>, RunError> {
    if args.modes.is_empty()
        && args.table.is_none()
        && args.cluster_tau_sweep.is_empty()
        && args.lod_pixel_error_sweep.is_empty()
    {
        return Ok(None);
    }
    let modes = if args.modes.is_empty() {
        vec![args.mode]
    } else {
        args.modes.clone()
    };
    for (i, m) in modes.iter().enumerate() {
        if modes[..i].contains(m) {
            return Err(RunError::Runs(format!(
                "{} listed more than once",
                m.name()
            )));
        }
    }
    for (sweep, mode, flag) in [
        (
            &args.cluster_tau_sweep,
            Mode::ClusterLod,
            "--cluster-tau-sweep",
        ),
        (
            &args.lod_pixel_error_sweep,
            Mode::Lod,
            "--lod-pixel-error-sweep",
        ),
    ] {
        if !sweep.is_empty() && !modes.contains(&mode) {
            return Err(RunError::Runs(format!(
                "{flag} needs {} among the modes",
                mode.name()
            )));
        }
    }
    let one = |m: Mode| CompareRun {
        mode: m,
        lod_pixel_error: args.walk.stream.lod_pixel_error,
        cluster_tau: args.walk.stream.cluster_tau,
    };
    let or_one = |v: &[f32], x: f32| if v.is_empty() { vec![x] } else { v.to_vec() };
    let mut runs = Vec::new();
    for m in modes {
        match m {
            Mode::ClusterLod => {
                for tau in or_one(&args.cluster_tau_sweep, args.walk.stream.cluster_tau) {
                    runs.push(CompareRun {
                        cluster_tau: tau,
                        ..one(m)
                    });
                }
            }
            Mode::Lod => {
                for px in or_one(
                    &args.lod_pixel_error_sweep,
                    args.walk.stream.lod_pixel_error,
                ) {
                    runs.push(CompareRun {
                        lod_pixel_error: px,
                        ..one(m)
                    });
                }
            }
            m => runs.push(one(m)),
        }
    }
    Ok(Some(runs))
}

/// Compares along the path of `args` and prints the report (JSON with `--json`);
/// with `--modes` (or a sweep, or `--table`) the table of every run instead.
pub fn compare(args: CompareArgs) -> Result<(), RunError> {
    let path = format::path::CameraPath::load(&args.path)?;
    let runs = runs_of(&args)?;
    let opts = CompareOptions {
        worst_dir: args.worst,
        worst_count: args.worst_count,
        size: args.walk.stream.size,
        crossings: !args.no_crossings,
        pops: args.pops,
        stream: args.walk.path_config(&path),
        mode: args.mode,
        lod_pixel_error: args.walk.stream.lod_pixel_error,
        cluster_tau: args.walk.stream.cluster_tau,
        reference_ss: args.reference_ss,
        repeat: args.repeat,
        draw: args.draw.options(),
    };
    if let Some(runs) = runs {
        let m = multi_compare(&args.out, &path, &opts, &runs)?;
        let table = crate::table::markdown(&m, &args.path.display().to_string());
        if let Some(file) = &args.table {
            std::fs::write(file, &table).map_err(|e| RunError::Write {
                path: file.clone(),
                what: e.to_string(),
            })?;
        }
        if args.json {
            println!(
                "{}",
                serde_json::to_string_pretty(&m).unwrap_or_else(|e| e.to_string())
            );
        } else {
            print!("{table}");
        }
        return Ok(());
    }
    let r = crate::compare::compare(&args.out, &path, &opts)?;
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&r).unwrap_or_else(|e| e.to_string())
        );
    } else {
        print_report(&r);
    }
    Ok(())
}

/// [`crate::compare::compare_runs`] with the table's rows and reaches.
pub fn multi_compare(
    out: &std::path::Path,
    path: &format::path::CameraPath,
    opts: &CompareOptions,
    runs: &[CompareRun],
) -> Result<MultiCompare, RunError> {
    let results = crate::compare::compare_runs(out, path, opts, runs)?;
    let rows: Vec<TableRow> = runs
        .iter()
        .zip(&results)
        .map(|(run, (report, bytes))| TableRow::of(run, report, bytes))
        .collect();
    let first = &results[0].0;
    Ok(MultiCompare {
        adapter: first.adapter.clone(),
        width: first.width,
        height: first.height,
        frames: first.frames,
        reach: crate::table::reaches(&rows),
        rows,
        reports: results.into_iter().map(|(r, _)| r).collect(),
    })
}

/// The report as text: one line per frame, then the summary lines.
fn print_report(r: &CompareReport) {
    let db = |v: Option<f64>| v.map_or("      –".to_string(), |v| format!("{v:7.2}"));
    for f in &r.per_frame {
        let aa = f.aa_reference.as_ref().map_or(String::new(), |a| {
            format!(
                " | vs AA: object {} dB (full geometry {} dB)",
                db(a.compared.object_psnr_y_db),
                db(a.full.object_psnr_y_db)
            )
        });
        println!(
                "frame {:4} cell {:>4} psnr_y {:7.2} dB ssim {:.4} object {} dB ssim {} ({} px) triangles {} / {}{aa}",
                f.frame,
                f.cell.map_or(-1, |c| c as i64),
                f.psnr_y,
                f.ssim,
                db(f.object_psnr_y_db),
                f.object_ssim.map_or("     –".to_string(), |s| format!("{s:.4}")),
                f.object_pixels,
                f.triangles,
                f.reference_triangles
            );
    }
    println!(
            "{} frames ({}): mean PSNR(Y) {:.2} dB (min {:.2}), mean SSIM {:.4}, triangles {:.0} / {:.0} ({:.3}), frame time ratio {:.3} vs full, {:.3} vs frustum",
            r.frames,
            r.mode,
            r.mean_psnr_y,
            r.min_psnr_y,
            r.mean_ssim,
            r.mean_triangles,
            r.reference_triangles,
            r.mean_triangles / r.reference_triangles.max(1.0),
            r.frame_time_ratio,
            r.frame_time_ratio_frustum
        );
    let object = |o: &crate::metrics::ObjectQuality| {
        format!(
                "object pixels ({:.1}% of all): PSNR(Y) {:.2} dB pooled, worst frame {} at {:.2} dB, mean SSIM {:.4}",
                100.0 * o.object_pixel_fraction,
                o.object_psnr_y_db,
                o.worst_object_frame.map_or(-1, |f| f as i64),
                o.min_object_psnr_y_db,
                o.mean_object_ssim
            )
    };
    println!("{} vs full geometry: {}", r.mode, object(&r.object));
    if let Some(aa) = &r.aa_reference {
        for (name, q) in [(r.mode.as_str(), &aa.compared), ("full geometry", &aa.full)] {
            println!(
                    "{name} vs anti-aliased reference ({0}×{0} samples): mean PSNR(Y) {1:.2} dB (min {2:.2}), mean SSIM {3:.4}; {4}",
                    aa.supersampling_factor,
                    q.mean_psnr_y_db,
                    q.min_psnr_y_db,
                    q.mean_ssim,
                    object(&q.object)
                );
        }
    }
    if !r.fallback_cells.is_empty() {
        println!(
                "fallback: cells {:?} were drawn with original geometry (pack missing, corrupt or off the index); their frames count full geometry as the hybrid",
                r.fallback_cells
            );
    }
    if let Some(b) = &r.near_border {
        println!(
            "near borders ({} frames within {} units of a cell border): mean PSNR(Y) {:.2} dB (walk {:.2}, {:+.2} dB), object pixels {:.2} dB (walk {:.2}, {:+.2} dB)",
            b.frames,
            b.radius,
            b.mean_psnr_y,
            b.walk_mean_psnr_y,
            b.mean_psnr_y - b.walk_mean_psnr_y,
            b.object_psnr_y_db,
            b.walk_object_psnr_y_db,
            b.object_psnr_y_db - b.walk_object_psnr_y_db
        );
    }
    if let Some(p) = &r.pops {
        println!(
                "pops at {} crossings: object-pixel PSNR(Y) of outgoing vs incoming representation mean {:.2} dB, worst {:.2} dB (frame {}); a one-pixel turn: mean {:.2} dB; {} crossings no larger than the turn",
                p.crossings.len(),
                p.mean_pop_psnr_y_db,
                p.worst_pop_psnr_y_db,
                p.worst_frame.map_or("-".to_string(), |f| f.to_string()),
                p.mean_shift_psnr_y_db,
                p.below_shift
            );
        if p.fade > 0.0 {
            println!(
                "cross-fade {:.2} of the apothem: {} steps in bands without a crossing, object-pixel PSNR(Y) of each step mean {:.2} dB, worst {:.2} dB (frame {})",
                p.fade,
                p.fade_steps,
                p.mean_step_psnr_y_db,
                p.worst_step_psnr_y_db,
                p.worst_step_frame.map_or("-".to_string(), |f| f.to_string()),
            );
        }
    }
    for (name, c) in [
        ("prefetch on", &r.crossing_prefetch),
        ("prefetch off", &r.crossing_no_prefetch),
    ] {
        if let Some(c) = c {
            println!(
                    "crossings ({name}): {} — max frame time in the 10 frames after a crossing {:.2} ms = {:.2} × in-cell median {:.2} ms; against the two cells' medians worst {:.2}×, mean {:.2}× (windows without a crossing: up to {:.2}×)",
                    c.crossings, c.max_after_crossing_ms, c.ratio, c.in_cell_median_ms,
                    c.local_ratio_max, c.local_ratio_mean, c.quiet_ratio_max
                );
        }
    }
}
