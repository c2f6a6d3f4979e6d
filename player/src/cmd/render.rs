//! `player render`: walks a camera path headless in one configuration (A full, B
//! frustum, C hybrid or the distance-LOD baseline; [`crate::run::render`]), writes
//! `frames.csv` (and PNGs) and prints the walk's mean frame time, triangles and
//! crossing spikes.

use super::args::{DrawArgs, PathArgs};
use crate::frame::Mode;
use crate::run::{crossing_stats, RenderOptions, RunError};
use std::path::PathBuf;

// The flags of `player render` (its help text is the `Command::Render` doc in main.rs).
#[derive(clap::Args, Clone)]
pub struct RenderArgs {
    /// Bake output directory (base.pack, index.pack, cells/).
    pub out: PathBuf,
    #[arg(long)]
    pub path: PathBuf,
    #[arg(long)]
    pub frames: PathBuf,
    #[arg(long, default_value = "hybrid")]
    pub mode: Mode,
    /// Also write one PNG per frame.
    #[arg(long)]
    pub png: bool,
    /// Walk the path in wall-clock time at this multiple of its own speed (1 =
    /// walking speed, 3 = three times as fast): each path frame is drawn no earlier
    /// than its time in the path ÷ pace after the walk began, so the prefetch thread
    /// has the time a viewer moving at that speed would give it. 0: as fast as the
    /// frames render (the walk then outruns a viewer and its prefetch).
    #[arg(long, default_value_t = 0.0)]
    pub pace: f64,
    #[command(flatten)]
    pub walk: PathArgs,
    #[command(flatten)]
    pub draw: DrawArgs,
}

/// Renders the path of `args` and prints its summary line.
pub fn render(args: RenderArgs) -> Result<(), RunError> {
    let RenderArgs {
        out,
        path,
        frames,
        mode,
        png,
        pace,
        walk,
        draw,
    } = args;
    let path = format::path::CameraPath::load(&path)?;
    let opts = RenderOptions {
        mode,
        frames_dir: frames.clone(),
        png,
        stream: walk.path_config(&path),
        size: walk.stream.size,
        lod_pixel_error: walk.stream.lod_pixel_error,
        cluster_tau: walk.stream.cluster_tau,
        draw: draw.options(),
        pace,
    };
    let (records, _) = crate::run::render(&out, &path, &opts)?;
    let n = records.len().max(1) as f64;
    let ms: f64 = records.iter().map(|r| r.frame_ms).sum::<f64>() / n;
    let tris: f64 = records.iter().map(|r| r.triangles as f64).sum::<f64>() / n;
    let c = crossing_stats(&records);
    println!(
        "{} frames ({}): mean {ms:.2} ms, {tris:.0} triangles; {} crossings, max after crossing {:.2} ms vs in-cell median {:.2} ms; against the two cells' medians worst {:.2}×, mean {:.2}× (windows without a crossing: up to {:.2}×); {}",
        records.len(),
        mode.name(),
        c.crossings,
        c.max_after_crossing_ms,
        c.in_cell_median_ms,
        c.local_ratio_max,
        c.local_ratio_mean,
        c.quiet_ratio_max,
        frames.join("frames.csv").display()
    );
    Ok(())
}
