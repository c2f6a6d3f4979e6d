//! `player render` and `player compare` (issue 7; paper 000 §4: configurations A/B/C,
//! PSNR on luminance, frame rate at cell crossings — Fig. 14).

use crate::bake::Bake;
use crate::camera::Camera;
use crate::clusterlod::ClusterSet;
use crate::frame::{
    blend_frame, cluster_list, hybrid_list, list_stats, lod_list, originals_list, ListStats, Mode,
};
use crate::gpu::{DrawList, GpuError, GpuModels, Renderer};
use crate::lod::LodSet;
use crate::stream::{StreamConfig, Streamer};
use format::path::{CameraPath, PathFrame};
// The `--json` report: its schema lives in format (issue 14 item 2), read by the
// benchmark tool.
pub use format::schema::compare::{
    AaFrame, AaQuality, AaReference, ClusterLodSummary, CompareFrame, CompareReport, CrossingPop,
    CrossingStats, PopReport,
};
// `frames.csv`: one row type, also read by the benchmark tool (issue 28).
pub use format::schema::frames::{FrameRow, FRAMES_CSV_HEADER};
use glam::Vec2;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of the commands.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Bake(Box<crate::bake::BakeError>),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Path(#[from] format::path::PathError),
    #[error("{path}: {what}")]
    Write { path: PathBuf, what: String },
    #[error("the camera path has no frames")]
    NoFrames,
    #[error("--reference-ss {0} outside 1..={MAX_REFERENCE_SS}")]
    ReferenceSs(u32),
    #[error("--modes: {0}")]
    Runs(String),
}

impl From<crate::bake::BakeError> for RunError {
    fn from(e: crate::bake::BakeError) -> RunError {
        RunError::Bake(Box::new(e))
    }
}

pub(crate) fn write_err(path: &Path, e: impl std::fmt::Display) -> RunError {
    RunError::Write {
        path: path.to_path_buf(),
        what: e.to_string(),
    }
}

/// The camera of a path frame.
pub fn camera_for(frame: &PathFrame, path: &CameraPath, size: (u32, u32), far: f32) -> Camera {
    Camera {
        eye: frame.eye,
        dir: frame.dir,
        fov_y_deg: path.fov_y_deg,
        width: size.0,
        height: size.1,
        near: 0.25,
        far,
    }
}

/// The `frames.csv` row of frame `frame` drawn with `stats` and `options`; `prev` is
/// the previous frame's cell (`None` for the first frame), which marks crossings.
pub fn frame_row(
    frame: usize,
    time_s: f32,
    stats: &crate::stream::StreamStats,
    prev: Option<Option<u32>>,
    (frame_ms, list): (f64, ListStats),
    options: &crate::DrawOptions,
) -> FrameRow {
    FrameRow {
        frame,
        time_s,
        cell: stats.cell,
        crossing: prev.is_some_and(|p| p != stats.cell),
        frame_ms,
        triangles: list.triangles,
        texture_bytes: list.texture_bytes,
        draw_calls: list.draw_calls,
        cache_hits: stats.hits,
        cache_misses: stats.misses,
        stream_ms: stats.stream_ms,
        uploaded_bytes: stats.uploaded_bytes,
        pending_proxies: stats.pending_proxies as u64,
        draw_options: Some(*options),
    }
}

/// A renderer with a bake's models uploaded.
pub struct Player {
    pub bake: Bake,
    pub renderer: Renderer,
    pub models: GpuModels,
    /// The LOD baseline's chains, built on first use ([`Player::prepare_lod`]).
    pub lod: Option<LodSet>,
    /// `--lod-pixel-error`: the projected error a level may have, in pixels.
    pub lod_pixel_error: f32,
    /// Cluster LOD's DAGs, read or built on first use ([`Player::prepare_clusters`]).
    pub clusters: Option<ClusterSet>,
    /// `--cluster-tau`: the projected error a drawn cluster may have, in pixels.
    pub cluster_tau: f32,
    /// CPU time of the last cluster-LOD frame's cut and culling (building its draw
    /// list), milliseconds.
    pub last_cluster_cut_ms: f64,
    /// CPU time of the last frame's draw list in any configuration: its culling
    /// (instances, tiles, occlusion) and the statistics that settle its ranges,
    /// milliseconds; not in the frame time, which is the GPU's (the streamer's
    /// work before the list is not in it either).
    pub last_list_ms: f64,
    /// `compare --repeat`: times each configuration's frame is drawn; its frame time
    /// is the fastest (1: the one draw, with the uploads the frame submits).
    pub timing_repeats: u32,
}

impl Player {
    /// The bake in `dir` on a renderer of `size`, both drawing with `options`.
    pub fn open(
        dir: &Path,
        size: (u32, u32),
        options: &crate::DrawOptions,
    ) -> Result<Player, RunError> {
        let bake = Bake::open(dir, options)?;
        let renderer = Renderer::new(size.0, size.1, options)?;
        let models = renderer.upload_models(&bake.base, bake.draw_order.as_deref());
        Ok(Player::from_parts(bake, renderer, models))
    }

    pub fn from_parts(bake: Bake, renderer: Renderer, models: GpuModels) -> Player {
        Player {
            bake,
            renderer,
            models,
            lod: None,
            lod_pixel_error: crate::lod::DEFAULT_PIXEL_ERROR,
            clusters: None,
            cluster_tau: crate::clusterlod::DEFAULT_TAU_PX,
            last_cluster_cut_ms: 0.0,
            last_list_ms: 0.0,
            timing_repeats: 1,
        }
    }

    /// What its frames are drawn with, as in effect: the bake's culling tests and
    /// tile size, the renderer's texture path (BC off where the device lacks it).
    pub fn draw_options(&self) -> crate::DrawOptions {
        crate::DrawOptions {
            bc_textures: self.renderer.native_bc(),
            ..self.bake.options
        }
    }

    /// Builds the LOD chains of every model once (cached) and uploads their index
    /// buffers; prints the build time. Returns the chains.
    pub fn prepare_lod(&mut self) -> &LodSet {
        if self.lod.is_none() {
            let set = LodSet::build(&self.bake.base);
            self.renderer.upload_lods(&mut self.models, &set);
            eprintln!(
                "player: LOD chains of {} models built in {:.1} ms ({} simplified levels, {} triangles)",
                set.chains.len(),
                set.build_ms,
                set.simplified_levels(),
                set.simplified_triangles()
            );
            self.lod = Some(set);
        }
        self.lod.as_ref().expect("built above")
    }

    /// Reads (from `<out>/clusterlod/`) or builds every model's cluster DAG once
    /// (cached in memory and on disk beside the bake) and uploads their index
    /// buffers; prints the time and the cache's use. Returns the DAGs.
    pub fn prepare_clusters(&mut self) -> &ClusterSet {
        if self.clusters.is_none() {
            let dir = self.bake.dir.join(crate::clusterlod::CACHE_DIR);
            let set = ClusterSet::build(&self.bake.base, Some(&dir));
            self.renderer.upload_clusters(&mut self.models, &set);
            eprintln!(
                "player: cluster DAGs of {} models ready in {:.1} ms ({} from {}, {} built; {} clusters, {} bytes)",
                set.dags.len(),
                set.build_ms,
                set.cache_hits,
                dir.display(),
                set.built,
                set.cluster_count(),
                set.bytes
            );
            self.clusters = Some(set);
        }
        self.clusters.as_ref().expect("built above")
    }

    /// Bytes of the cluster index buffers on the GPU.
    pub fn cluster_resident_bytes(&self) -> u64 {
        self.models
            .models
            .iter()
            .filter_map(|m| m.clusters.as_ref())
            .map(|c| c.bytes)
            .sum()
    }

    /// Draws one frame of a configuration; `streamer` is needed for `Hybrid`.
    /// Returns (frame_ms, triangles, texture bytes, stream stats).
    pub fn draw(
        &mut self,
        camera: &Camera,
        mode: Mode,
        streamer: Option<&mut Streamer>,
    ) -> (f64, u64, u64, crate::stream::StreamStats) {
        let (ms, list, stats) = self.draw_listed(camera, mode, streamer);
        (ms, list.triangles, list.texture_bytes, stats)
    }

    /// [`Player::draw`] with everything the list submitted (draw calls too).
    pub fn draw_listed(
        &mut self,
        camera: &Camera,
        mode: Mode,
        streamer: Option<&mut Streamer>,
    ) -> (f64, ListStats, crate::stream::StreamStats) {
        match (mode, streamer) {
            (Mode::Hybrid, Some(s)) => {
                let pending = s.config().pending;
                let stats = s.advance(&self.renderer, &self.bake, camera);
                let t0 = std::time::Instant::now();
                // Near a border, the cells of the cross-fade (issue 31 item 2):
                // the current one as streamed, the others settled.
                let blend = s.blend(&self.bake);
                let cells = if blend.is_empty() {
                    vec![(s.current(), None)]
                } else {
                    blend
                        .iter()
                        .filter_map(|&(id, range)| {
                            let cell = if Some(id) == stats.cell {
                                s.current()
                            } else {
                                s.settled_cell(&self.bake, id)?
                            };
                            Some((cell, Some(range)))
                        })
                        .collect()
                };
                let lists = blend_frame(&self.bake, camera, cells, pending);
                let stats_of_list = lists
                    .iter()
                    .map(|(l, _)| list_stats(l, &self.models))
                    .fold(ListStats::default(), |a, b| a + b);
                self.last_list_ms = t0.elapsed().as_secs_f64() * 1e3;
                let refs: Vec<(&DrawList<'_>, Option<(u32, u32)>)> =
                    lists.iter().map(|(l, r)| (l, *r)).collect();
                let ms = self.renderer.render_blend_fastest(
                    self.timing_repeats,
                    camera,
                    &self.models,
                    &refs,
                );
                drop(lists);
                s.undrawn_frames(&self.renderer, &self.bake, camera);
                (ms, stats_of_list, stats)
            }
            (Mode::Lod, _) => {
                self.prepare_lod();
                let set = self.lod.as_ref().expect("prepared");
                let t0 = std::time::Instant::now();
                let list = lod_list(&self.bake, set, camera, self.lod_pixel_error);
                let stats_of_list = list_stats(&list, &self.models);
                self.last_list_ms = t0.elapsed().as_secs_f64() * 1e3;
                let ms =
                    self.renderer
                        .render_fastest(self.timing_repeats, camera, &self.models, &list);
                (ms, stats_of_list, self.cell_stats(camera))
            }
            (Mode::ClusterLod, _) => {
                self.prepare_clusters();
                let set = self.clusters.as_ref().expect("prepared");
                let t0 = std::time::Instant::now();
                let list = cluster_list(&self.bake, set, camera, self.cluster_tau);
                self.last_cluster_cut_ms = t0.elapsed().as_secs_f64() * 1e3;
                let stats_of_list = list_stats(&list, &self.models);
                self.last_list_ms = t0.elapsed().as_secs_f64() * 1e3;
                let ms =
                    self.renderer
                        .render_fastest(self.timing_repeats, camera, &self.models, &list);
                (ms, stats_of_list, self.cell_stats(camera))
            }
            (m, _) => {
                let t0 = std::time::Instant::now();
                let list = originals_list(&self.bake, camera, m != Mode::Full);
                let stats_of_list = list_stats(&list, &self.models);
                self.last_list_ms = t0.elapsed().as_secs_f64() * 1e3;
                let ms =
                    self.renderer
                        .render_fastest(self.timing_repeats, camera, &self.models, &list);
                (ms, stats_of_list, self.cell_stats(camera))
            }
        }
    }

    /// Stream statistics of a frame drawn without the streamer: only the cell.
    fn cell_stats(&self, camera: &Camera) -> crate::stream::StreamStats {
        crate::stream::StreamStats {
            cell: self
                .bake
                .grid
                .nearest_cell(Vec2::new(camera.eye.x, camera.eye.z)),
            ..Default::default()
        }
    }

    /// The loading screen before a walk ([`Streamer::prime`]).
    pub fn prime(&self, streamer: &mut Streamer, camera: &Camera) {
        streamer.prime(&self.renderer, &self.bake, camera);
    }

    /// Compiles the pipelines (shaders are compiled lazily on first use): one untimed
    /// frame of each kind at `camera`.
    pub fn warm_up(&mut self, camera: &Camera) {
        let mut s = Streamer::new(
            &self.bake,
            StreamConfig {
                prefetch: false,
                ..Default::default()
            },
        );
        self.draw(camera, Mode::Full, None);
        self.draw(camera, Mode::Hybrid, Some(&mut s));
        // The cross-fade's dithered pipelines (issue 31): the hybrid list as two
        // halves of the dither levels.
        let half = crate::transition::LEVELS / 2;
        let list = hybrid_list(&self.bake, camera, &s.current(), s.config().pending);
        self.renderer.render_blend(
            camera,
            &self.models,
            &[
                (&list, Some((0, half))),
                (&list, Some((half, crate::transition::LEVELS))),
            ],
        );
        if self.lod.is_some() {
            self.draw(camera, Mode::Lod, None);
        }
        if self.clusters.is_some() {
            self.draw(camera, Mode::ClusterLod, None);
        }
    }
}

/// Writes RGBA8 as PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), RunError> {
    let f = std::fs::File::create(path).map_err(|e| write_err(path, e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(f), width, height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| write_err(path, e))?;
    w.write_image_data(rgba).map_err(|e| write_err(path, e))?;
    Ok(())
}

/// Options of `player render`.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub mode: Mode,
    pub frames_dir: PathBuf,
    pub png: bool,
    pub stream: StreamConfig,
    /// Overrides the path's resolution.
    pub size: Option<(u32, u32)>,
    /// `--lod-pixel-error` of `lod` mode.
    pub lod_pixel_error: f32,
    /// `--cluster-tau` of `cluster-lod` mode.
    pub cluster_tau: f32,
    /// The frame model's switches (`--no-backface`, `--tile-triangles`, ...).
    pub draw: crate::DrawOptions,
    /// `--pace`: the walk's wall-clock speed as a multiple of the path's (0: none).
    pub pace: f64,
}

/// Renders every frame of `path`; writes `frames.csv` (and PNGs) into the frames dir.
pub fn render(
    out: &Path,
    path: &CameraPath,
    opts: &RenderOptions,
) -> Result<(Vec<FrameRow>, Player), RunError> {
    let size = opts.size.unwrap_or(path.resolution);
    let frames = path.frames();
    if frames.is_empty() {
        return Err(RunError::NoFrames);
    }
    let mut player = Player::open(out, size, &opts.draw)?;
    let options = player.draw_options();
    eprintln!("player: adapter {}", player.renderer.adapter());
    std::fs::create_dir_all(&opts.frames_dir).map_err(|e| write_err(&opts.frames_dir, e))?;
    player.lod_pixel_error = opts.lod_pixel_error;
    player.cluster_tau = opts.cluster_tau;
    if opts.mode == Mode::Lod {
        player.prepare_lod();
    }
    if opts.mode == Mode::ClusterLod {
        player.prepare_clusters();
    }
    let far = player.bake.extent;
    player.warm_up(&camera_for(&frames[0], path, size, far));
    let mut streamer = Streamer::new(&player.bake, opts.stream.clone());
    player.prime(&mut streamer, &camera_for(&frames[0], path, size, far));
    let mut records = Vec::with_capacity(frames.len());
    let mut prev: Option<Option<u32>> = None;
    let walk_start = std::time::Instant::now();
    for (i, f) in frames.iter().enumerate() {
        if opts.pace > 0.0 {
            let due = std::time::Duration::from_secs_f64(f64::from(f.time_s) / opts.pace);
            if let Some(wait) = due.checked_sub(walk_start.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        let cam = camera_for(f, path, size, far);
        let (ms, list, stats) = player.draw_listed(&cam, opts.mode, Some(&mut streamer));
        if opts.png {
            let px = player.renderer.read_pixels()?;
            let p = opts.frames_dir.join(format!("{i:05}.png"));
            write_png(&p, size.0, size.1, &px)?;
        }
        records.push(frame_row(i, f.time_s, &stats, prev, (ms, list), &options));
        prev = Some(stats.cell);
    }
    drop(streamer);
    let csv = opts.frames_dir.join("frames.csv");
    write_csv(&csv, &records)?;
    Ok((records, player))
}

/// Writes `records` as `frames.csv` ([`format::schema::frames::write_frames_csv`]).
pub fn write_csv(path: &Path, records: &[FrameRow]) -> Result<(), RunError> {
    let s = format::schema::frames::write_frames_csv(records);
    let mut f = std::fs::File::create(path).map_err(|e| write_err(path, e))?;
    f.write_all(s.as_bytes()).map_err(|e| write_err(path, e))
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Frames after a crossing that count as its window (the crossing frame and 9 after).
const CROSSING_WINDOW: usize = 10;

/// Frame-time behaviour at cell crossings (paper Fig. 14); see
/// [`CrossingStats`].
pub fn crossing_stats(records: &[FrameRow]) -> CrossingStats {
    let total = |r: &FrameRow| r.frame_ms + r.stream_ms;
    let ms: Vec<f64> = records.iter().map(total).collect();
    let mut near = vec![false; records.len()];
    let starts: Vec<usize> = (0..records.len())
        .filter(|&i| records[i].crossing)
        .collect();
    for &i in &starts {
        for n in near.iter_mut().skip(i).take(CROSSING_WINDOW) {
            *n = true;
        }
    }
    // The in-cell frames (outside every crossing window) of `lo..hi`.
    let inside = |lo: usize, hi: usize| -> Vec<f64> {
        (lo..hi.min(ms.len()))
            .filter(|&j| !near[j])
            .map(|j| ms[j])
            .collect()
    };
    let med = median(&mut inside(0, ms.len()));
    let max_after = (0..ms.len())
        .filter(|&j| near[j])
        .map(|j| ms[j])
        .fold(0.0, f64::max);
    // Each crossing against the in-cell frames of the cell it enters (of the two
    // cells it joins when that visit is too short, of the walk when both are).
    let mut local = Vec::with_capacity(starts.len());
    for (k, &i) in starts.iter().enumerate() {
        let lo = if k > 0 { starts[k - 1] } else { 0 };
        let hi = starts.get(k + 1).copied().unwrap_or(ms.len());
        let (mut entered, mut joined) = (inside(i, hi), inside(lo, hi));
        let m = if entered.len() >= 3 {
            median(&mut entered)
        } else if joined.len() >= 3 {
            median(&mut joined)
        } else {
            med
        };
        let peak = ms[i..(i + CROSSING_WINDOW).min(ms.len())]
            .iter()
            .copied()
            .fold(0.0, f64::max);
        if m > 0.0 {
            local.push(peak / m);
        }
    }
    // The same statistic where no crossing is: the noise floor.
    let quiet = (0..ms.len())
        .step_by(CROSSING_WINDOW)
        .filter(|&s| {
            s + CROSSING_WINDOW <= ms.len() && !near[s..s + CROSSING_WINDOW].contains(&true)
        })
        .filter_map(|s| {
            let m = median(&mut inside(s.saturating_sub(40), s + CROSSING_WINDOW + 40));
            let peak = ms[s..s + CROSSING_WINDOW]
                .iter()
                .copied()
                .fold(0.0, f64::max);
            (m > 0.0).then(|| peak / m)
        })
        .fold(f64::NAN, f64::max);
    CrossingStats {
        crossings: starts.len(),
        in_cell_median_ms: med,
        max_after_crossing_ms: max_after,
        ratio: if med > 0.0 { max_after / med } else { f64::NAN },
        local_ratio_max: local.iter().copied().fold(f64::NAN, f64::max),
        local_ratio_mean: if local.is_empty() {
            f64::NAN
        } else {
            local.iter().sum::<f64>() / local.len() as f64
        },
        quiet_ratio_max: quiet,
    }
}

pub use crate::metrics::PSNR_CAP;

/// `--reference-ss`: the anti-aliased reference is rendered this many times wider
/// and higher (4 × 4 = 16 samples per pixel).
pub const DEFAULT_REFERENCE_SS: u32 = 4;
/// The largest `--reference-ss`.
pub const MAX_REFERENCE_SS: u32 = 8;

#[cfg(test)]
mod tests {
    use super::*;

    /// A walk of `a` frames at `ms_a` then `b` at `ms_b`, crossing between them.
    fn walk(a: usize, ms_a: f64, b: usize, ms_b: f64) -> Vec<FrameRow> {
        (0..a + b)
            .map(|i| FrameRow {
                frame: i,
                cell: Some(u32::from(i >= a)),
                crossing: i == a,
                frame_ms: if i < a { ms_a } else { ms_b },
                ..Default::default()
            })
            .collect()
    }

    #[test]
    fn a_crossing_is_measured_against_the_cell_it_enters() {
        // Entering a dearer view is not a hitch: the whole-walk ratio says 5×.
        let c = crossing_stats(&walk(60, 10.0, 50, 50.0));
        assert_eq!(c.crossings, 1);
        assert!((c.ratio - 5.0).abs() < 1e-9, "{c:?}");
        assert!((c.local_ratio_max - 1.0).abs() < 1e-9, "{c:?}");
        assert!((c.quiet_ratio_max - 1.0).abs() < 1e-9, "{c:?}");
        // A spike in the crossing's window is one.
        let mut r = walk(60, 10.0, 50, 50.0);
        r[61].stream_ms = 30.0;
        let c = crossing_stats(&r);
        assert!((c.local_ratio_max - 1.6).abs() < 1e-9, "{c:?}");
        assert_eq!(c.local_ratio_max, c.local_ratio_mean);
    }

    #[test]
    fn a_walk_without_crossings_has_no_local_ratio() {
        let mut r = walk(40, 10.0, 0, 0.0);
        r[25].frame_ms = 20.0;
        let c = crossing_stats(&r);
        assert_eq!(c.crossings, 0);
        assert!(c.local_ratio_max.is_nan() && c.local_ratio_mean.is_nan());
        assert!((c.quiet_ratio_max - 2.0).abs() < 1e-9, "{c:?}");
    }
}
