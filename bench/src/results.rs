//! Benchmark results of `scripts/bench.sh` (issue 8): the paper's experiments
//! (000 §4, Tables 3–8, Fig. 14) re-run on hexbake, one JSON file per run in
//! `docs/bench/`.
//!
//! `bench.sh` runs the bakes and the player and leaves its raw outputs in a work
//! folder; `hexbake-bench collect` turns that folder into one [`BenchRun`] JSON
//! (machine, exact commands, every bake's report, the player's compare output and
//! per-frame CSVs, cell load times). `hexbake-bench tables` (see [`crate::tables`])
//! regenerates BENCHMARKS.md's measured tables from those files and draws the
//! per-frame plots ([`crate::plot`]). The labels in the file names are
//! [`crate::labels::RunLabel`]s.
//!
//! Work folder layout (all written by `bench.sh`):
//!
//! ```text
//! meta.txt              key=value lines: date, git_commit, nproc, cpu_model, ...
//! commands.tsv          wall_s <TAB> exit <TAB> command, one line per command run
//! bake-<label>.txt      key=value: label, scene, manifest, out, cells, set (repeated),
//!                       sweep=PARAM:VALUE (repeated, PARAM a SweepParam key),
//!                       wall_s, exit
//! compare-<label>.txt   key=value: label, scene, mode, out, path, size, wall_s, exit,
//!                       lod_pixel_error (lod), note (why a mode is not available)
//! compare-<label>.json  `player compare --json` stdout (absent when it failed)
//! compare-<label>.err   its stderr
//! render-<label>.txt    key=value: label, scene, mode, out, path, size, wall_s, exit
//! render-<label>/frames.csv
//! load-<label>.json     `hexbake-bench load` stdout
//! ```

use crate::labels::SweepParam;
use anyhow::Context;
use format::pack::{BasePack, CellPack, Index, PackFile};
pub use format::schema::compare::{CompareFrame, CompareReport, CrossingStats};
// `frames.csv`: the player's row type (issue 28: one shape, read by header).
pub use format::schema::frames::{parse_frames_csv, FrameRow};
use pipeline::report::Report;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Version of the [`BenchRun`] file layout.
pub const BENCH_SCHEMA: u32 = 1;

/// One run of `scripts/bench.sh`: the file `docs/bench/run-<id>.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BenchRun {
    pub schema: u32,
    /// Run id: the UTC start time, `YYYYMMDDTHHMMSSZ` (sorts by time).
    pub run: String,
    /// `default`, `full`, or what BENCH_MODE said.
    pub mode: String,
    /// Machine and software: `nproc`, `cpu_model`, `date`, `git_commit`, `os`, ...
    pub machine: BTreeMap<String, String>,
    pub commands: Vec<CommandLine>,
    pub bakes: Vec<BakeResult>,
    pub compares: Vec<CompareResult>,
    pub renders: Vec<RenderResult>,
    pub load_times: Vec<LoadTime>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CommandLine {
    pub command: String,
    pub wall_s: f64,
    pub exit: i32,
}

/// A parameter sweep point (paper Tables 3–5, and the deviation bound).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    pub param: SweepParam,
    pub value: f64,
}

/// One `pipeline run`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BakeResult {
    /// Unique within a run, e.g. `park-2m`, `park-4m-path`, `sweep-ts3`.
    pub label: String,
    /// Scene name (`park-2m`, ...).
    pub scene: String,
    pub manifest: String,
    pub out: String,
    /// `--cells` spec, if any.
    pub cells: Option<String>,
    /// `--set` overrides.
    pub set: Vec<String>,
    /// The sweep points this bake stands for (the base setting is a point of every
    /// sweep).
    pub sweeps: Vec<Sweep>,
    /// Wall time of the `pipeline run` command (a resumed run: only what it baked).
    pub wall_s: f64,
    pub exit: i32,
    /// `<out>/report.json`, when the run wrote one.
    pub report: Option<Report>,
}

/// Reader's figures of a `player compare` report.
pub trait CompareStats {
    /// The lowest per-frame SSIM (NaN without frames).
    fn min_ssim(&self) -> f64;
    /// Mean frame time of one configuration in ms (NaN without frames).
    fn mean_ms(&self, pick: fn(&CompareFrame) -> f64) -> f64;
}

impl CompareStats for CompareReport {
    fn min_ssim(&self) -> f64 {
        self.per_frame
            .iter()
            .map(|f| f.ssim)
            .filter(|v| v.is_finite())
            .fold(f64::NAN, f64::min)
    }

    fn mean_ms(&self, pick: fn(&CompareFrame) -> f64) -> f64 {
        mean(self.per_frame.iter().map(pick))
    }
}

/// One `player compare` along a path.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CompareResult {
    pub label: String,
    pub scene: String,
    /// `hybrid` or `lod` (`--mode lod`).
    pub mode: String,
    /// `--lod-pixel-error` given to a `lod` compare (None: the player's default).
    pub lod_pixel_error: Option<f64>,
    pub out: String,
    pub path: String,
    pub size: String,
    pub wall_s: f64,
    pub exit: i32,
    /// False when the player could not run this mode (e.g. `lod` unknown).
    pub available: bool,
    /// Why not available (the player's message).
    pub message: Option<String>,
    /// `player compare --json` (older run files lack the newer keys: defaults).
    pub summary: Option<CompareReport>,
}

/// One `player render --mode M` along a path.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RenderResult {
    pub label: String,
    pub scene: String,
    pub mode: String,
    pub out: String,
    pub path: String,
    pub size: String,
    pub wall_s: f64,
    pub exit: i32,
    pub available: bool,
    pub message: Option<String>,
    pub frames: Vec<FrameRow>,
}

impl RenderResult {
    pub fn mean_triangles(&self) -> f64 {
        mean(self.frames.iter().map(|f| f.triangles as f64))
    }
    pub fn mean_frame_ms(&self) -> f64 {
        mean(self.frames.iter().map(|f| f.frame_ms))
    }
}

/// Cell load times of one bake (`hexbake-bench load`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LoadTime {
    pub label: String,
    pub out: String,
    pub cells_timed: usize,
    pub mean_bytes: f64,
    /// Open (mmap) + validate every checksum + decode + check against the base pack,
    /// warm page cache, one thread.
    pub mean_ms: f64,
    pub max_ms: f64,
    pub mib_per_s: f64,
}

pub fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v
        .filter(|x| x.is_finite())
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

// ---------------------------------------------------------------------------------
// Cell load times.

/// Times loading up to `sample` cells of the bake in `out` (evenly spread over the
/// index, every cell when `sample` is 0): open (mmap) + validate every checksum +
/// decode + check against the base pack, as the player's prefetch thread does before
/// preparing a cell. Warm page cache: this is CPU time, not disk time.
pub fn time_cell_loads(out: &Path, label: &str, sample: usize) -> anyhow::Result<LoadTime> {
    let base_path = out.join("base.pack");
    let base = BasePack::read(&base_path).with_context(|| base_path.display().to_string())?;
    let index_path = out.join("index.pack");
    let index = Index::read(&index_path).with_context(|| index_path.display().to_string())?;
    let n = index.cells.len();
    let picks: Vec<usize> = if sample == 0 || sample >= n {
        (0..n).collect()
    } else {
        (0..sample).map(|i| i * n / sample).collect()
    };
    let mut times = Vec::with_capacity(picks.len());
    let mut bytes = 0u64;
    for &i in &picks {
        let entry = &index.cells[i];
        let path = out.join(&entry.file);
        let t0 = std::time::Instant::now();
        let pack = PackFile::open(&path)
            .and_then(|f| CellPack::decode(&f))
            .and_then(|p| p.check_against(&base).map(|_| p))
            .with_context(|| path.display().to_string())?;
        times.push(t0.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(&pack);
        bytes += entry.bytes;
    }
    let total_ms: f64 = times.iter().sum();
    Ok(LoadTime {
        label: label.to_string(),
        out: out.display().to_string(),
        cells_timed: times.len(),
        mean_bytes: bytes as f64 / times.len().max(1) as f64,
        mean_ms: mean(times.iter().copied()),
        max_ms: times.iter().copied().fold(f64::NAN, f64::max),
        mib_per_s: if total_ms > 0.0 {
            bytes as f64 / (1 << 20) as f64 / (total_ms / 1e3)
        } else {
            f64::NAN
        },
    })
}

// ---------------------------------------------------------------------------------
// Check viewpoints of sampled cells as a camera path.

/// The camera path of `hexbake-bench views`: `per_cell` viewpoints of each of
/// `cells` (default: the cells a partial bake was asked for, `<out>/partial.json`)
/// on the bake's own grid (its `base.pack`), placed as `worker check` places them
/// (`worker::check::check_views`: spread over the cell's prism, directions evenly
/// around the horizon), one frame each at 60° FOV and `resolution`. With it the
/// player measures the sweeps' partial bakes (paper Tables 3–5, FPS and PSNR rows)
/// without walking through cells that were not baked.
pub fn check_view_path(
    out: &Path,
    cells: Option<Vec<u32>>,
    per_cell: usize,
    resolution: (u32, u32),
) -> anyhow::Result<format::path::CameraPath> {
    let base_path = out.join("base.pack");
    let base = BasePack::read(&base_path).with_context(|| base_path.display().to_string())?;
    let g = &base.grid;
    let grid = worker::grid::HexGrid::from_params(g)
        .with_context(|| format!("{}: grid", base_path.display()))?;
    let cells = match cells {
        Some(c) => c,
        None => {
            pipeline::run::read_partial(out)
                .with_context(|| {
                    format!(
                        "{}: not a partial bake (no readable partial.json): give --cells",
                        out.display()
                    )
                })?
                .requested_cells
        }
    };
    anyhow::ensure!(!cells.is_empty(), "no cells to place views in");
    anyhow::ensure!(per_cell > 0, "--per-cell must be at least 1");
    let params = format::manifest::CellParams {
        cell_size: g.cell_size,
        min_eye_height: g.min_eye_height,
        max_eye_height: g.max_eye_height,
    };
    let mut views = Vec::with_capacity(cells.len() * per_cell);
    for &cell in &cells {
        anyhow::ensure!(
            cell < grid.cell_count(),
            "cell {cell} is not on the grid ({} cells)",
            grid.cell_count()
        );
        for (eye, dir) in worker::check::check_views(&grid, cell, &params, per_cell) {
            views.push(((eye.x, eye.y, eye.z), (dir.x, dir.y, dir.z)));
        }
    }
    Ok(format::path::CameraPath {
        eye_height: 0.5 * (g.min_eye_height + g.max_eye_height),
        fov_y_deg: 60.0,
        resolution,
        max_speed: 30.0,
        max_turn_deg_per_s: 45.0,
        frame_rate: 10.0,
        waypoints: Vec::new(),
        views,
    })
}

// ---------------------------------------------------------------------------------
// Collecting a work folder into one run file.

/// Reads `key=value` lines (`#` comments and blank lines skipped); repeated keys keep
/// every value in order.
pub fn read_key_values(path: &Path) -> anyhow::Result<Vec<(String, String)>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (k, v) = line.split_once('=').with_context(|| {
            format!(
                "{}:{}: expected key=value, found {line:?}",
                path.display(),
                n + 1
            )
        })?;
        out.push((k.trim().to_string(), v.trim().to_string()));
    }
    Ok(out)
}

struct Fields(Vec<(String, String)>);

impl Fields {
    fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
    fn string(&self, key: &str) -> String {
        self.get(key).unwrap_or_default().to_string()
    }
    fn all(&self, key: &str) -> Vec<String> {
        self.0
            .iter()
            .filter(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
            .collect()
    }
    fn f64(&self, key: &str) -> f64 {
        self.get(key)
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::NAN)
    }
    fn exit(&self) -> i32 {
        self.get("exit").and_then(|v| v.parse().ok()).unwrap_or(-1)
    }
}

/// Files `<dir>/<prefix>*<suffix>`, sorted by name.
fn listed(dir: &Path, prefix: &str, suffix: &str) -> anyhow::Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("{}: cannot list", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix) && n.ends_with(suffix))
        })
        .collect();
    v.sort();
    Ok(v)
}

/// `sweep=PARAM:VALUE` lines.
fn parse_sweeps(f: &Fields, file: &Path) -> anyhow::Result<Vec<Sweep>> {
    f.all("sweep")
        .iter()
        .map(|s| {
            let (param, value) = s
                .split_once(':')
                .and_then(|(p, v)| Some((SweepParam::from_key(p)?, v.parse::<f64>().ok()?)))
                .with_context(|| {
                    format!(
                        "{}: sweep={s:?}: expected PARAM:VALUE, PARAM one of {}",
                        file.display(),
                        SweepParam::ALL.map(SweepParam::key).join(", ")
                    )
                })?;
            Ok(Sweep { param, value })
        })
        .collect()
}

/// Reads a work folder of `bench.sh` into a [`BenchRun`].
pub fn collect(work: &Path) -> anyhow::Result<BenchRun> {
    let meta = Fields(read_key_values(&work.join("meta.txt"))?);
    let mut run = BenchRun {
        schema: BENCH_SCHEMA,
        run: meta.string("run"),
        mode: meta.string("mode"),
        machine: meta
            .0
            .iter()
            .filter(|(k, _)| k != "run" && k != "mode")
            .cloned()
            .collect(),
        ..BenchRun::default()
    };
    // Commands, in the order they ran.
    if let Ok(text) = std::fs::read_to_string(work.join("commands.tsv")) {
        for line in text.lines().filter(|l| !l.trim().is_empty()) {
            let mut parts = line.splitn(3, '\t');
            let wall_s = parts
                .next()
                .and_then(|v| v.parse().ok())
                .unwrap_or(f64::NAN);
            let exit = parts.next().and_then(|v| v.parse().ok()).unwrap_or(-1);
            let command = parts.next().unwrap_or_default().to_string();
            run.commands.push(CommandLine {
                command,
                wall_s,
                exit,
            });
        }
    }
    // Bakes and their reports.
    for file in listed(work, "bake-", ".txt")? {
        let f = Fields(read_key_values(&file)?);
        let out = f.string("out");
        let report_path = Path::new(&out).join("report.json");
        let report = match std::fs::read(&report_path) {
            Ok(bytes) => Some(
                serde_json::from_slice::<Report>(&bytes)
                    .with_context(|| report_path.display().to_string())?,
            ),
            Err(_) => None,
        };
        run.bakes.push(BakeResult {
            label: f.string("label"),
            scene: f.string("scene"),
            manifest: f.string("manifest"),
            out,
            cells: f.get("cells").filter(|s| !s.is_empty()).map(str::to_string),
            set: f.all("set"),
            sweeps: parse_sweeps(&f, &file)?,
            wall_s: f.f64("wall_s"),
            exit: f.exit(),
            report,
        });
    }
    // Player comparisons.
    for file in listed(work, "compare-", ".txt")? {
        let f = Fields(read_key_values(&file)?);
        let label = f.string("label");
        let json = work.join(format!("compare-{label}.json"));
        let err =
            std::fs::read_to_string(work.join(format!("compare-{label}.err"))).unwrap_or_default();
        let summary = std::fs::read(&json)
            .ok()
            .filter(|b| !b.is_empty())
            .map(|b| serde_json::from_slice::<CompareReport>(&b))
            .transpose()
            .with_context(|| json.display().to_string())?;
        let available = f.exit() == 0 && summary.is_some();
        run.compares.push(CompareResult {
            label,
            scene: f.string("scene"),
            mode: f.string("mode"),
            lod_pixel_error: f.get("lod_pixel_error").and_then(|v| v.parse().ok()),
            out: f.string("out"),
            path: f.string("path"),
            size: f.string("size"),
            wall_s: f.f64("wall_s"),
            exit: f.exit(),
            available,
            message: (!available).then(|| failure_message(&f, &err)),
            summary,
        });
    }
    // Player renders.
    for file in listed(work, "render-", ".txt")? {
        let f = Fields(read_key_values(&file)?);
        let label = f.string("label");
        let csv = work.join(format!("render-{label}")).join("frames.csv");
        let frames = match std::fs::read_to_string(&csv) {
            Ok(text) if f.exit() == 0 => {
                parse_frames_csv(&text).with_context(|| csv.display().to_string())?
            }
            _ => Vec::new(),
        };
        let err =
            std::fs::read_to_string(work.join(format!("render-{label}.err"))).unwrap_or_default();
        let available = f.exit() == 0 && !frames.is_empty();
        run.renders.push(RenderResult {
            label,
            scene: f.string("scene"),
            mode: f.string("mode"),
            out: f.string("out"),
            path: f.string("path"),
            size: f.string("size"),
            wall_s: f.f64("wall_s"),
            exit: f.exit(),
            available,
            message: (!available).then(|| failure_message(&f, &err)),
            frames,
        });
    }
    // Load times.
    for file in listed(work, "load-", ".json")? {
        let t: LoadTime = serde_json::from_slice(&std::fs::read(&file)?)
            .with_context(|| file.display().to_string())?;
        run.load_times.push(t);
    }
    Ok(run)
}

/// A short reason for a failed player command: bench.sh's `note=` if it wrote one,
/// else the last non-empty line of stderr.
fn failure_message(f: &Fields, stderr: &str) -> String {
    if let Some(note) = f.get("note").filter(|n| !n.is_empty()) {
        return note.to_string();
    }
    let last = stderr
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("no output");
    format!("exit {}: {last}", f.exit())
}

/// Reads every `*.json` run file in `dir` (sorted by run id, oldest first).
pub fn read_runs(dir: &Path) -> anyhow::Result<Vec<(String, BenchRun)>> {
    let mut runs = Vec::new();
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(runs),
        Err(e) => return Err(e).with_context(|| dir.display().to_string()),
    };
    for e in entries {
        let path = e?.path();
        if path.extension().and_then(|x| x.to_str()) != Some("json") {
            continue;
        }
        let run: BenchRun = serde_json::from_slice(&std::fs::read(&path)?)
            .with_context(|| format!("{}: not a bench run file", path.display()))?;
        if run.schema != BENCH_SCHEMA {
            anyhow::bail!(
                "{}: schema {} (hexbake-bench reads {BENCH_SCHEMA})",
                path.display(),
                run.schema
            );
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        runs.push((name, run));
    }
    runs.sort_by(|a, b| a.1.run.cmp(&b.1.run).then(a.0.cmp(&b.0)));
    Ok(runs)
}

/// Items of every run merged by label, a newer run's item replacing an older one's:
/// `--full` items (park-8m, ...) stay from the last run that had them.
#[derive(Clone, Debug, Default)]
pub struct Merged {
    /// (run file, run) of every run read, oldest first.
    pub runs: Vec<(String, BenchRun)>,
    /// label → (run file, item).
    pub bakes: BTreeMap<String, (String, BakeResult)>,
    pub compares: BTreeMap<String, (String, CompareResult)>,
    pub renders: BTreeMap<String, (String, RenderResult)>,
    pub load_times: BTreeMap<String, (String, LoadTime)>,
}

pub fn merge(runs: Vec<(String, BenchRun)>) -> Merged {
    let mut m = Merged::default();
    for (file, run) in &runs {
        for b in &run.bakes {
            m.bakes.insert(b.label.clone(), (file.clone(), b.clone()));
        }
        for c in &run.compares {
            m.compares
                .insert(c.label.clone(), (file.clone(), c.clone()));
        }
        for r in &run.renders {
            m.renders.insert(r.label.clone(), (file.clone(), r.clone()));
        }
        for t in &run.load_times {
            m.load_times
                .insert(t.label.clone(), (file.clone(), t.clone()));
        }
    }
    m.runs = runs;
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_csv_is_read_by_header() {
        // The columns of 2026-11's player (no draw calls or options).
        let csv = "frame,time_s,cell,crossing,frame_ms,triangles,texture_bytes,cache_hits,cache_misses,stream_ms\n\
                   0,0.0000,5,0,1.500,1200,0,0,1,3.000\n\
                   1,0.1000,-1,1,2.000,900,64,1,1,0.500\n";
        let rows = parse_frames_csv(csv).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].cell, Some(5));
        assert!(!rows[0].crossing && rows[1].crossing);
        assert_eq!(rows[1].triangles, 900);
        assert_eq!(rows[1].cell, None);
        assert!(parse_frames_csv("frame,cell\n1,x\n").is_err());
    }

    #[test]
    fn compare_json_with_nulls_and_unknown_keys_reads() {
        let json = r#"{"frames":2,"mean_psnr_y":40.5,"min_psnr_y":30.0,"mean_ssim":0.9,
            "mean_triangles":100.0,"reference_triangles":1000.0,"frame_time_ratio":0.5,
            "frame_time_ratio_frustum":0.7,"adapter":"llvmpipe","width":64,"height":64,
            "crossing_prefetch":{"crossings":0,"in_cell_median_ms":1.0,"max_after_crossing_ms":0.0,"ratio":null},
            "something_new":[1,2],
            "per_frame":[{"frame":0,"cell":3,"psnr_y":30.0,"ssim":0.8,"triangles":90,"reference_triangles":1000,
                          "frame_ms":1.0,"reference_frame_ms":2.0,"frustum_frame_ms":1.5},
                         {"frame":1,"cell":null,"psnr_y":51.0,"ssim":1.0,"triangles":110,"reference_triangles":1000,
                          "frame_ms":1.0,"reference_frame_ms":2.0,"frustum_frame_ms":1.5}]}"#;
        let s: CompareReport = serde_json::from_str(json).unwrap();
        assert_eq!(s.per_frame.len(), 2);
        assert!(s.crossing_prefetch.as_ref().unwrap().ratio.is_nan());
        assert_eq!(s.min_ssim(), 0.8);
        assert_eq!(s.mean_ms(|f| f.frustum_frame_ms), 1.5);
    }

    #[test]
    fn newer_runs_replace_older_items_by_label() {
        let run = |id: &str, labels: &[&str], wall: f64| BenchRun {
            schema: BENCH_SCHEMA,
            run: id.into(),
            bakes: labels
                .iter()
                .map(|l| BakeResult {
                    label: l.to_string(),
                    wall_s: wall,
                    ..BakeResult::default()
                })
                .collect(),
            ..BenchRun::default()
        };
        let m = merge(vec![
            (
                "a.json".into(),
                run("20260101T000000Z", &["park-2m", "park-8m"], 1.0),
            ),
            ("b.json".into(), run("20260102T000000Z", &["park-2m"], 2.0)),
        ]);
        assert_eq!(m.bakes["park-2m"].0, "b.json");
        assert_eq!(m.bakes["park-2m"].1.wall_s, 2.0);
        assert_eq!(m.bakes["park-8m"].0, "a.json");
    }
}
