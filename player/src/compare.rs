//! `player compare` (issue 7; paper 000 §4: configurations A/B/C, PSNR on luminance
//! of the object pixels against the full-geometry or supersampled reference, frame
//! rate at cell crossings — Fig. 14; issue 30: several modes against one reference,
//! one table; issue 31: the pop at each crossing).

use crate::camera::Camera;
use crate::frame::{blend_frame, originals_list, Mode};
use crate::gpu::{GpuError, GpuModels, Renderer};
use crate::metrics::{
    diff_image, downsample_linear, measure_frame, opaque, summarize_objects, FrameQuality,
};
use crate::stream::{StreamConfig, Streamer};
use format::path::{CameraPath, PathFrame};
// The `--json` report: its schema lives in format (issue 14 item 2), read by the
// benchmark tool.
use format::schema::compare::{
    AaFrame, AaQuality, AaReference, BorderQuality, ClusterLodSummary, CompareFrame, CompareReport,
    CrossingPop, CrossingStats, PopReport, BORDER_RADIUS,
};
// `frames.csv`: one row type, also read by the benchmark tool (issue 28).
use crate::run::{
    camera_for, crossing_stats, frame_row, write_err, write_png, Player, RunError,
    DEFAULT_REFERENCE_SS, MAX_REFERENCE_SS, PSNR_CAP,
};
use format::schema::frames::FrameRow;
use std::path::{Path, PathBuf};

/// One configuration's frames against the anti-aliased reference, summarised over
/// the path.
fn summarize_aa<'a>(frames: impl Iterator<Item = (usize, &'a FrameQuality)> + Clone) -> AaQuality {
    AaQuality {
        mean_psnr_y_db: mean(frames.clone().map(|(_, q)| q.psnr_y_db)),
        min_psnr_y_db: frames
            .clone()
            .map(|(_, q)| q.psnr_y_db)
            .fold(PSNR_CAP, f64::min),
        mean_ssim: mean(frames.clone().map(|(_, q)| q.ssim)),
        object: summarize_objects(frames),
    }
}

/// Options of `player compare`.
#[derive(Clone, Debug)]
pub struct CompareOptions {
    pub worst_dir: Option<PathBuf>,
    pub worst_count: usize,
    pub size: Option<(u32, u32)>,
    /// Also run the hybrid with prefetching off (Fig. 14 comparison).
    pub crossings: bool,
    /// `--pops`: measure the image jump at each cell crossing ([`measure_pops`]).
    pub pops: bool,
    pub stream: StreamConfig,
    /// What is compared with the full-geometry reference: `hybrid` (default) or
    /// `lod` (the distance-LOD baseline); `full`/`frustum` work too.
    pub mode: Mode,
    /// `--lod-pixel-error` of `lod` mode.
    pub lod_pixel_error: f32,
    /// `--cluster-tau` of `cluster-lod` mode.
    pub cluster_tau: f32,
    /// `--reference-ss`: supersampling per axis of the anti-aliased reference;
    /// 1 (or 0) renders none.
    pub reference_ss: u32,
    /// `--repeat`: each configuration's frame is drawn this many times and timed by
    /// its fastest draw ([`Player::timing_repeats`]); 1 (default) draws once.
    pub repeat: u32,
    /// The frame model's switches, for every configuration drawn (written into the
    /// report as `draw_options`).
    pub draw: crate::DrawOptions,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            worst_dir: None,
            worst_count: 0,
            size: None,
            crossings: false,
            pops: false,
            stream: StreamConfig::default(),
            mode: Mode::Hybrid,
            lod_pixel_error: crate::lod::DEFAULT_PIXEL_ERROR,
            cluster_tau: crate::clusterlod::DEFAULT_TAU_PX,
            reference_ss: DEFAULT_REFERENCE_SS,
            repeat: 1,
            draw: crate::DrawOptions::default(),
        }
    }
}

/// The crossing frame, its outgoing and its incoming frame (RGBA8) of the worst pop.
type PopPair = (usize, Vec<u8>, Vec<u8>);

/// A frame's representation: each cell it draws with its dither range (`None`:
/// the one cell, whole), as [`crate::transition`] decides at the frame's eye from
/// its cell with cross-fades `fade` (every neighbour in the band taken as ready).
type Blend = Vec<(u32, Option<(u32, u32)>)>;

fn blend_at(bake: &crate::bake::Bake, cell: u32, eye: glam::Vec3, fade: f32) -> Blend {
    let band = crate::transition::band(&bake.grid, fade);
    let p = glam::Vec2::new(eye.x, eye.z);
    let ranges = crate::transition::ranges(&crate::transition::weights(&bake.grid, cell, p, band));
    if ranges.len() < 2 {
        return vec![(cell, None)];
    }
    ranges
        .into_iter()
        .map(|(id, lo, hi)| (id, Some((lo, hi))))
        .collect()
}

/// `camera`'s frame drawn with `blend`'s cells, each settled
/// ([`Streamer::settled`]: all textures uploaded, no stand-ins, so that streaming
/// does not blur what the representation itself changes); `None` when a cell's
/// pack cannot be loaded.
fn draw_blend(
    player: &mut Player,
    streamer: &mut Streamer,
    camera: &Camera,
    blend: &Blend,
) -> Result<Option<Vec<u8>>, RunError> {
    for &(cell, _) in blend {
        if streamer
            .settled(&player.renderer, &player.bake, cell)
            .is_none()
        {
            return Ok(None);
        }
    }
    let mut cells = Vec::with_capacity(blend.len());
    for &(cell, range) in blend {
        let Some(current) = streamer.settled_cell(&player.bake, cell) else {
            return Ok(None);
        };
        cells.push((current, range));
    }
    let pending = crate::stream::PendingDraw::StandIns;
    let lists = blend_frame(&player.bake, camera, cells, pending);
    let refs: Vec<_> = lists.iter().map(|(l, r)| (l, *r)).collect();
    player.renderer.render_blend(camera, &player.models, &refs);
    Ok(Some(player.renderer.read_pixels()?))
}

/// Issue 31 item 1, the pop metric: at each frame whose representation differs
/// from the previous frame's, the frame's pose is drawn with the previous frame's
/// representation and with its own ([`draw_blend`]: each cell settled), and the
/// two are compared over object pixels. Without cross-fades (`fade` 0) that is
/// each crossing: the outgoing cell against the incoming. With them, the
/// representation is a function of the eye's position ([`crate::transition`]), so
/// it changes at every frame in a band; frames where the cell changes are the
/// crossings, the others the fade's steps (summarised apart). Beside each
/// crossing, the full-geometry frame at the pose against the same pose turned by
/// one pixel (the camera yawed by `fov_y / height`): a change a viewer does not
/// notice. Returns the report and the worst crossing's pair.
fn measure_pops(
    player: &mut Player,
    path: &CameraPath,
    frames: &[PathFrame],
    cells: &[Option<u32>],
    size: (u32, u32),
    opts: &CompareOptions,
) -> Result<(PopReport, Option<PopPair>), RunError> {
    let far = player.bake.extent;
    let fade = opts.stream.fade;
    let (w, h) = (size.0 as usize, size.1 as usize);
    let mut streamer = Streamer::new(
        &player.bake,
        StreamConfig {
            prefetch: false,
            ..opts.stream.clone()
        },
    );
    let mut crossings = Vec::new();
    let mut steps = Vec::new();
    let mut worst: Option<(f64, PopPair)> = None;
    let blend_of = |player: &Player, i: usize| {
        let cam = camera_for(&frames[i], path, size, far);
        cells[i].map(|c| blend_at(&player.bake, c, cam.eye, fade))
    };
    for i in 1..frames.len().min(cells.len()) {
        let (Some(from), Some(to)) = (blend_of(player, i - 1), blend_of(player, i)) else {
            continue;
        };
        if from == to {
            continue;
        }
        let cam = camera_for(&frames[i], path, size, far);
        let a = draw_blend(player, &mut streamer, &cam, &from)?;
        let b = draw_blend(player, &mut streamer, &cam, &to)?;
        let (Some(a), Some(b)) = (a, b) else {
            continue; // a pack that cannot be loaded: no pop to measure
        };
        let pop = measure_frame(&a, &b, w, h);
        let pop_psnr = pop.object_psnr_y_db.unwrap_or(PSNR_CAP);
        let (Some(from_cell), Some(to_cell)) = (cells[i - 1], cells[i]) else {
            continue;
        };
        if from_cell == to_cell {
            steps.push((i, pop_psnr));
            continue;
        }
        let turned = Camera {
            dir: glam::Quat::from_rotation_y(cam.fov_y_deg.to_radians() / size.1 as f32) * cam.dir,
            ..cam
        };
        let [r0, r1] = [cam, turned].map(|c| {
            let full = originals_list(&player.bake, &c, false);
            pixels_of(&mut player.renderer, &player.models, &c, &full)
        });
        let shift = measure_frame(&r0?, &r1?, w, h);
        crossings.push(CrossingPop {
            frame: i,
            from_cell,
            to_cell,
            pop_object_psnr_y_db: pop_psnr,
            pop_object_ssim: pop.object_ssim.unwrap_or(1.0),
            shift_object_psnr_y_db: shift.object_psnr_y_db.unwrap_or(PSNR_CAP),
            shift_object_ssim: shift.object_ssim.unwrap_or(1.0),
        });
        if worst.as_ref().is_none_or(|(p, _)| pop_psnr < *p) {
            worst = Some((pop_psnr, (i, a, b)));
        }
    }
    let mut report = PopReport::of(crossings);
    report.fade = fade;
    report.fade_steps = steps.len();
    if let Some(&(frame, psnr)) = steps.iter().min_by(|a, b| a.1.total_cmp(&b.1)) {
        report.worst_step_psnr_y_db = psnr;
        report.worst_step_frame = Some(frame);
        report.mean_step_psnr_y_db = mean(steps.iter().map(|s| s.1));
    }
    Ok((report, worst.map(|(_, pair)| pair)))
}

fn pixels_of(
    renderer: &mut Renderer,
    models: &GpuModels,
    camera: &Camera,
    list: &crate::gpu::DrawList<'_>,
) -> Result<Vec<u8>, GpuError> {
    renderer.render(camera, models, list);
    renderer.read_pixels()
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// One configuration of a multi-mode compare ([`compare_runs`]): a mode and the
/// threshold it is drawn at (`lod_pixel_error` for `lod`, `cluster_tau` for
/// `cluster-lod`; the other modes ignore both).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareRun {
    pub mode: Mode,
    pub lod_pixel_error: f32,
    pub cluster_tau: f32,
}

impl CompareRun {
    /// The run of a single-mode compare: `opts.mode` at `opts`' thresholds.
    pub fn of(opts: &CompareOptions) -> CompareRun {
        CompareRun {
            mode: opts.mode,
            lod_pixel_error: opts.lod_pixel_error,
            cluster_tau: opts.cluster_tau,
        }
    }

    /// A short name: the mode, with its threshold for the LOD modes
    /// (`cluster-lod τ=1`, `lod 2px`).
    pub fn label(&self) -> String {
        match self.mode {
            Mode::ClusterLod => format!("cluster-lod τ={}", self.cluster_tau),
            Mode::Lod => format!("lod {}px", self.lod_pixel_error),
            m => m.name().to_string(),
        }
    }

    /// A file-name-safe form of [`CompareRun::label`] (`cluster-lod-tau1`, `lod-px2`).
    pub fn slug(&self) -> String {
        match self.mode {
            Mode::ClusterLod => format!("cluster-lod-tau{}", self.cluster_tau),
            Mode::Lod => format!("lod-px{}", self.lod_pixel_error),
            m => m.name().to_string(),
        }
    }
}

/// What [`compare_runs`] measures besides each run's report: the bytes each run's
/// representation takes on disk and resident (`None` where it has none beyond the
/// base pack's originals, which every mode keeps resident and no row counts).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunBytes {
    /// hybrid: every `*.pack` of the bake; cluster-lod: the `.clod` DAGs; lod: none
    /// (its chains are built at load and not stored).
    pub disk: Option<u64>,
    /// hybrid: the streamer's resident cell data at its peak over the walk;
    /// cluster-lod: the DAGs' index buffers on the GPU; lod: the simplified levels'
    /// index buffers (u32 indices).
    pub resident: Option<u64>,
}

/// Renders the reference (config A) and the hybrid (C, or the mode of
/// `opts.mode`, e.g. the LOD baseline) for every frame of the path (and B for
/// timing); PSNR(Y) and SSIM against A, over the whole frame and over object pixels;
/// both A and C against the anti-aliased reference (A supersampled
/// `opts.reference_ss` per axis, [`AaReference`]).
pub fn compare(
    out: &Path,
    path: &CameraPath,
    opts: &CompareOptions,
) -> Result<CompareReport, RunError> {
    let mut all = compare_runs(out, path, opts, &[CompareRun::of(opts)])?;
    Ok(all.remove(0).0)
}

/// Per run of [`compare_runs`]: what its walk gathers.
struct RunAcc {
    run: CompareRun,
    per_frame: Vec<CompareFrame>,
    quality: Vec<FrameQuality>,
    records: Vec<FrameRow>,
    worst: Vec<Worst>,
    prev: Option<Option<u32>>,
    fallback_cells: std::collections::BTreeSet<u32>,
    clusters_drawn: Vec<f64>,
    cut_ms: Vec<f64>,
    /// CPU milliseconds of each frame's draw list ([`Player::last_list_ms`]).
    list_ms: Vec<f64>,
    peak_resident: u64,
}

/// [`compare`] for several configurations on one walk (`player compare --modes`,
/// issue 30 item 3): per frame the reference (A), B for timing and the anti-aliased
/// reference are rendered once, and each run of `runs` is drawn and measured
/// against them. `opts.mode`, `opts.lod_pixel_error` and `opts.cluster_tau` are
/// ignored (each run carries its own). Returns each run's report (in the order of
/// `runs`) with its bytes. At most one hybrid run (they would share a streamer);
/// with `opts.worst_dir` and more than one run, each run's worst frames go to a
/// folder of its own ([`CompareRun::slug`]).
pub fn compare_runs(
    out: &Path,
    path: &CameraPath,
    opts: &CompareOptions,
    runs: &[CompareRun],
) -> Result<Vec<(CompareReport, RunBytes)>, RunError> {
    // 1. The request checked; the bake, the renderers (the compared frames' and the
    //    anti-aliased reference's) and the streamer opened, warmed up and primed.
    let size = opts.size.unwrap_or(path.resolution);
    let frames = path.frames();
    if frames.is_empty() {
        return Err(RunError::NoFrames);
    }
    if opts.reference_ss > MAX_REFERENCE_SS {
        return Err(RunError::ReferenceSs(opts.reference_ss));
    }
    if runs.is_empty() {
        return Err(RunError::Runs("no mode to compare".into()));
    }
    if runs.iter().filter(|r| r.mode == Mode::Hybrid).count() > 1 {
        return Err(RunError::Runs("hybrid listed more than once".into()));
    }
    let has = |m: Mode| runs.iter().find(|r| r.mode == m);
    let ss = opts.reference_ss.max(1);
    let mut player = Player::open(out, size, &opts.draw)?;
    let options = player.draw_options();
    eprintln!("player: adapter {}", player.renderer.adapter());
    player.timing_repeats = opts.repeat;
    if let Some(r) = has(Mode::Lod) {
        player.lod_pixel_error = r.lod_pixel_error;
    }
    let lod_build_ms = has(Mode::Lod).map(|_| player.prepare_lod().build_ms);
    if let Some(r) = has(Mode::ClusterLod) {
        player.cluster_tau = r.cluster_tau;
        player.prepare_clusters();
    }
    let far = player.bake.extent;
    player.warm_up(&camera_for(&frames[0], path, size, far));
    // Alpha tells object pixels from sky in every frame compared (metrics.rs).
    player.renderer.set_coverage_alpha(true);
    let mut aa_renderer = if ss > 1 {
        let mut r = player.renderer.sibling(size.0 * ss, size.1 * ss)?;
        r.set_coverage_alpha(true);
        Some(r)
    } else {
        None
    };
    let (w, h) = (size.0 as usize, size.1 as usize);
    let mut streamer = Streamer::new(&player.bake, opts.stream.clone());
    player.prime(&mut streamer, &camera_for(&frames[0], path, size, far));
    let mut accs: Vec<RunAcc> = runs
        .iter()
        .map(|&run| RunAcc {
            run,
            per_frame: Vec::with_capacity(frames.len()),
            quality: Vec::with_capacity(frames.len()),
            records: Vec::with_capacity(frames.len()),
            worst: Vec::new(),
            prev: None,
            fallback_cells: Default::default(),
            clusters_drawn: Vec::new(),
            cut_ms: Vec::new(),
            list_ms: Vec::new(),
            peak_resident: 0,
        })
        .collect();
    let keep_worst = opts.worst_dir.is_some() && opts.worst_count > 0;
    // 2. The walk: per frame the reference (A), B for timing and the anti-aliased
    //    reference once, then each run's frame, its metrics and worst frames.
    let mut frustum_list_ms: Vec<f64> = Vec::with_capacity(frames.len());
    for (i, f) in frames.iter().enumerate() {
        // 2a. The reference (A) and B for timing.
        let cam = camera_for(f, path, size, far);
        let (ref_ms, ref_tris, _, _) = player.draw(&cam, Mode::Full, None);
        let reference = player.renderer.read_pixels()?;
        let (fr_ms, _, _, _) = player.draw(&cam, Mode::Frustum, None);
        frustum_list_ms.push(player.last_list_ms);
        // 2b. Each run's frame.
        let mut drawn = Vec::with_capacity(accs.len());
        for acc in accs.iter_mut() {
            player.lod_pixel_error = acc.run.lod_pixel_error;
            player.cluster_tau = acc.run.cluster_tau;
            let (ms, list, stats) = player.draw_listed(&cam, acc.run.mode, Some(&mut streamer));
            drawn.push((ms, list, stats, player.renderer.read_pixels()?));
            acc.clusters_drawn.push(list.clusters as f64);
            acc.cut_ms.push(player.last_cluster_cut_ms);
            acc.list_ms.push(player.last_list_ms);
            if acc.run.mode == Mode::Hybrid {
                acc.peak_resident = acc.peak_resident.max(streamer.resident_bytes());
            }
        }
        // 2c. The anti-aliased reference: A at ss × ss samples, box-filtered in
        //     linear light.
        let aa_reference = match aa_renderer.as_mut() {
            Some(r) => {
                let big = camera_for(f, path, (size.0 * ss, size.1 * ss), far);
                let list = originals_list(&player.bake, &big, false);
                r.render(&big, &player.models, &list);
                let px = r.read_pixels()?;
                Some(downsample_linear(
                    &px,
                    w * ss as usize,
                    h * ss as usize,
                    ss as usize,
                ))
            }
            None => None,
        };
        let aa_full = aa_reference
            .as_ref()
            .map(|aa| measure_frame(aa, &reference, w, h));
        // 2d. The metrics: full frame and object pixels, against A and the AA
        //     reference; the worst frames by object-pixel PSNR (frames without
        //     objects last).
        for (acc, (ms, list, stats, frame)) in accs.iter_mut().zip(drawn) {
            if let (true, Some(c)) = (stats.fallback, stats.cell) {
                acc.fallback_cells.insert(c);
            }
            let q = measure_frame(&reference, &frame, w, h);
            let aa = aa_reference
                .as_ref()
                .zip(aa_full.as_ref())
                .map(|(aa, full)| AaFrame {
                    compared: measure_frame(aa, &frame, w, h),
                    full: full.clone(),
                });
            acc.per_frame.push(CompareFrame {
                frame: i,
                cell: stats.cell,
                psnr_y: q.psnr_y_db,
                ssim: q.ssim,
                object_pixels: q.object_pixels,
                object_psnr_y_db: q.object_psnr_y_db,
                object_ssim: q.object_ssim,
                aa_reference: aa,
                triangles: list.triangles,
                reference_triangles: ref_tris,
                draw_calls: list.draw_calls,
                frame_ms: ms,
                reference_frame_ms: ref_ms,
                frustum_frame_ms: fr_ms,
                border_distance: player
                    .bake
                    .grid
                    .hex()
                    .distance_to_border(glam::Vec2::new(cam.eye.x, cam.eye.z))
                    .map(f64::from),
            });
            acc.records.push(frame_row(
                i,
                f.time_s,
                &stats,
                acc.prev,
                (ms, list),
                &options,
            ));
            acc.prev = Some(stats.cell);
            if keep_worst {
                let key = q.object_psnr_y_db.unwrap_or(f64::INFINITY);
                acc.worst
                    .push((key, i, reference.clone(), frame, aa_reference.clone()));
                acc.worst
                    .sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                acc.worst.truncate(opts.worst_count);
            }
            acc.quality.push(q);
        }
    }
    drop(streamer);
    let mut reports = Vec::with_capacity(accs.len());
    for acc in accs {
        let hybrid = acc.run.mode == Mode::Hybrid;
        // 3. The crossing spikes without prefetch (hybrid only, unless --no-crossings).
        let crossing_no_prefetch = (opts.crossings && hybrid)
            .then(|| crossings_without_prefetch(&mut player, path, &frames, size, opts));
        // 4. The pop at each crossing (`--pops`, hybrid only).
        let (pops, worst_pop) = if opts.pops && hybrid {
            let cells: Vec<Option<u32>> = acc.per_frame.iter().map(|f| f.cell).collect();
            let (report, worst_pair) =
                measure_pops(&mut player, path, &frames, &cells, size, opts)?;
            (Some(report), worst_pair)
        } else {
            (None, None)
        };
        // 5. The worst frames and the worst pop as PNGs (`--worst`).
        if let Some(dir) = &opts.worst_dir {
            let dir = if runs.len() > 1 {
                dir.join(acc.run.slug())
            } else {
                dir.clone()
            };
            write_worst(&dir, size, acc.run.mode, worst_pop, &acc.worst)?;
        }
        // 6. The report.
        let run = acc.run;
        let per_frame = acc.per_frame;
        let n = per_frame.len();
        let finite_min = per_frame
            .iter()
            .map(|f| f.psnr_y)
            .fold(f64::INFINITY, f64::min);
        let bytes = match run.mode {
            Mode::Hybrid => RunBytes {
                disk: Some(pack_bytes(out)),
                resident: Some(acc.peak_resident),
            },
            Mode::ClusterLod => RunBytes {
                disk: player.clusters.as_ref().map(|s| s.bytes),
                resident: Some(player.cluster_resident_bytes()),
            },
            Mode::Lod => RunBytes {
                disk: None,
                resident: player.lod.as_ref().map(|s| s.simplified_triangles() * 12),
            },
            _ => RunBytes::default(),
        };
        let report = CompareReport {
            frames: n,
            mean_psnr_y: mean(per_frame.iter().map(|f| f.psnr_y)),
            min_psnr_y: finite_min.min(PSNR_CAP),
            mean_ssim: mean(per_frame.iter().map(|f| f.ssim)),
            object: summarize_objects(acc.quality.iter().enumerate()),
            aa_reference: (ss > 1).then(|| {
                let aa = || {
                    per_frame
                        .iter()
                        .filter_map(|f| f.aa_reference.as_ref().map(|a| (f.frame, a)))
                };
                AaReference {
                    supersampling_factor: ss,
                    samples_per_pixel: ss * ss,
                    compared: summarize_aa(aa().map(|(i, a)| (i, &a.compared))),
                    full: summarize_aa(aa().map(|(i, a)| (i, &a.full))),
                }
            }),
            mean_triangles: mean(per_frame.iter().map(|f| f.triangles as f64)),
            reference_triangles: mean(per_frame.iter().map(|f| f.reference_triangles as f64)),
            mean_draw_calls: mean(per_frame.iter().map(|f| f.draw_calls as f64)),
            frame_time_ratio: mean(per_frame.iter().map(|f| f.frame_ms))
                / mean(per_frame.iter().map(|f| f.reference_frame_ms)),
            frame_time_ratio_frustum: mean(per_frame.iter().map(|f| f.frame_ms))
                / mean(per_frame.iter().map(|f| f.frustum_frame_ms)),
            adapter: player.renderer.adapter().to_string(),
            width: size.0,
            height: size.1,
            mode: run.mode.name().to_string(),
            lod_pixel_error: (run.mode == Mode::Lod).then_some(run.lod_pixel_error),
            lod_build_ms: lod_build_ms.filter(|_| run.mode == Mode::Lod),
            cluster_lod: player
                .clusters
                .as_ref()
                .filter(|_| run.mode == Mode::ClusterLod)
                .map(|set| ClusterLodSummary {
                    tau_px: run.cluster_tau,
                    build_ms: set.build_ms,
                    cache_hits: set.cache_hits,
                    built: set.built,
                    clusters: set.cluster_count(),
                    cluster_bytes: set.bytes,
                    pack_bytes: pack_bytes(out),
                    resident_bytes: player.cluster_resident_bytes(),
                    mean_clusters_drawn: mean(acc.clusters_drawn.iter().copied()),
                    mean_cut_ms: mean(acc.cut_ms.iter().copied()),
                }),
            draw_options: Some(options),
            crossing_prefetch: Some(crossing_stats(&acc.records)),
            crossing_no_prefetch,
            pops,
            fallback_cells: acc.fallback_cells.into_iter().collect(),
            near_border: near_border(&per_frame, &acc.quality),
            mean_list_ms: mean(acc.list_ms.iter().copied()),
            mean_frustum_list_ms: mean(frustum_list_ms.iter().copied()),
            per_frame,
        };
        reports.push((report, bytes));
    }
    Ok(reports)
}

/// The frames within [`BORDER_RADIUS`] of a border against the whole walk (issue
/// 31); `None` when no frame is that near.
fn near_border(per_frame: &[CompareFrame], quality: &[FrameQuality]) -> Option<BorderQuality> {
    let near: Vec<bool> = per_frame
        .iter()
        .map(|f| f.border_distance.is_some_and(|d| d <= BORDER_RADIUS))
        .collect();
    let frames = near.iter().filter(|&&n| n).count();
    if frames == 0 {
        return None;
    }
    let near_quality = quality
        .iter()
        .enumerate()
        .filter(|(i, _)| near.get(*i).copied().unwrap_or(false));
    Some(BorderQuality {
        radius: BORDER_RADIUS,
        frames,
        mean_psnr_y: mean(
            per_frame
                .iter()
                .zip(&near)
                .filter(|(_, &n)| n)
                .map(|(f, _)| f.psnr_y),
        ),
        walk_mean_psnr_y: mean(per_frame.iter().map(|f| f.psnr_y)),
        object_psnr_y_db: summarize_objects(near_quality).object_psnr_y_db,
        walk_object_psnr_y_db: summarize_objects(quality.iter().enumerate()).object_psnr_y_db,
    })
}

/// Bytes of the bake's packs as on disk: `index.pack` and the files it names (base,
/// cell and far-field group packs of this generation, issue 32; a bake without an
/// index: every `*.pack` in `out`, `cells/` and `groups/`), and the captures of its
/// texture store (`textures/`, format version 6).
pub fn pack_bytes(out: &Path) -> u64 {
    let files = |dirs: Vec<PathBuf>, ext: &'static str| {
        dirs.into_iter()
            .flat_map(|d| std::fs::read_dir(d).into_iter().flatten().flatten())
            .filter(move |e| e.path().extension().is_some_and(|x| x == ext))
            .filter_map(|e| e.metadata().ok())
            .filter(|m| m.is_file())
            .map(|m| m.len())
            .sum::<u64>()
    };
    let store: Vec<PathBuf> = std::fs::read_dir(out.join("textures"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .collect();
    let packs = match format::pack::Index::read(&out.join("index.pack")) {
        Ok(index) => {
            let len = |p: &Path| std::fs::metadata(p).map_or(0, |m| m.len());
            len(&out.join("index.pack"))
                + len(&out.join(index.base_file()))
                + index
                    .cells
                    .iter()
                    .chain(&index.groups)
                    .map(|e| e.bytes)
                    .sum::<u64>()
        }
        Err(_) => files(
            vec![out.to_path_buf(), out.join("cells"), out.join("groups")],
            "pack",
        ),
    };
    packs + files(store, "tex")
}

/// Step 3 of [`compare`]: the hybrid walked again with the prefetch thread off, for
/// the frame-time spikes after cell crossings (paper Fig. 14).
fn crossings_without_prefetch(
    player: &mut Player,
    path: &CameraPath,
    frames: &[PathFrame],
    size: (u32, u32),
    opts: &CompareOptions,
) -> CrossingStats {
    let far = player.bake.extent;
    let options = player.draw_options();
    let mut s = Streamer::new(
        &player.bake,
        StreamConfig {
            prefetch: false,
            ..opts.stream.clone()
        },
    );
    player.prime(&mut s, &camera_for(&frames[0], path, size, far));
    let mut recs = Vec::new();
    let mut prev: Option<Option<u32>> = None;
    for (i, f) in frames.iter().enumerate() {
        let cam = camera_for(f, path, size, far);
        let (ms, list, stats) = player.draw_listed(&cam, Mode::Hybrid, Some(&mut s));
        recs.push(frame_row(i, f.time_s, &stats, prev, (ms, list), &options));
        prev = Some(stats.cell);
    }
    crossing_stats(&recs)
}

/// The worst frames of a comparison, worst first: (object PSNR, frame, reference,
/// compared frame, anti-aliased reference).
type Worst = (f64, usize, Vec<u8>, Vec<u8>, Option<Vec<u8>>);

/// Step 5 of [`compare`]: the worst crossing's pair (`pop`: frame, outgoing,
/// incoming) and the worst frames (reference, `mode`'s frame, anti-aliased
/// reference, difference) as PNGs in `dir`.
fn write_worst(
    dir: &Path,
    size: (u32, u32),
    mode: Mode,
    pop: Option<(usize, Vec<u8>, Vec<u8>)>,
    worst: &[Worst],
) -> Result<(), RunError> {
    if let Some((i, from, to)) = pop {
        std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e))?;
        write_png(
            &dir.join(format!("{i:05}-pop-from.png")),
            size.0,
            size.1,
            &opaque(&from),
        )?;
        write_png(
            &dir.join(format!("{i:05}-pop-to.png")),
            size.0,
            size.1,
            &opaque(&to),
        )?;
        write_png(
            &dir.join(format!("{i:05}-pop-diff.png")),
            size.0,
            size.1,
            &diff_image(&from, &to),
        )?;
    }
    std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e))?;
    for (_, i, r, h, aa) in worst {
        write_png(
            &dir.join(format!("{i:05}-reference.png")),
            size.0,
            size.1,
            &opaque(r),
        )?;
        write_png(
            &dir.join(format!("{i:05}-{}.png", mode.name())),
            size.0,
            size.1,
            &opaque(h),
        )?;
        if let Some(aa) = aa {
            write_png(
                &dir.join(format!("{i:05}-aa-reference.png")),
                size.0,
                size.1,
                &opaque(aa),
            )?;
        }
        write_png(
            &dir.join(format!("{i:05}-diff.png")),
            size.0,
            size.1,
            &diff_image(r, h),
        )?;
    }
    Ok(())
}
