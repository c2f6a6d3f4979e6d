//! `pipeline run`: validate → plan → bake the missing jobs → assemble → report
//! (DESIGN.md "Data flow"). Jobs run in-process on a rayon pool (local executor)
//! or as a Slurm job array (see [`crate::slurm`]); either way each job writes its
//! packs and record atomically (worker::job), so a rerun redoes only what is missing.

use crate::lock::OutputLock;
use format::fingerprint::build_fingerprint;
use format::manifest::Plan;
use format::pack::{BasePack, GridParams, Index, IndexEntry};
use format::Scene;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use worker::job::{bake_cell_pack, done_record, plan_jobs, run_job, BuildPlan, Job, JobRecord};

/// `<out>/plan.json`: what the run planned, for `pipeline status` and Slurm tasks.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PlanFile {
    pub manifest: PathBuf,
    pub name: String,
    pub jobs: Vec<Job>,
}

/// A job that failed: `<out>/jobs/<id>.error` holds the message.
pub fn error_path(out: &Path, job: u32) -> PathBuf {
    out.join("jobs").join(format!("{job}.error"))
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    BadInput(anyhow::Error),
    #[error(transparent)]
    Failed(anyhow::Error),
}

fn failed(e: impl Into<anyhow::Error>) -> RunError {
    RunError::Failed(e.into())
}

/// Loaded inputs of a run.
pub struct Loaded {
    pub plan: Plan,
    pub scene: Scene,
    pub build: BuildPlan,
    pub out: PathBuf,
}

/// Parses the manifest, loads the scene and plans the jobs. `out` overrides the
/// manifest's output directory.
pub fn load(manifest: &Path, out: Option<&Path>) -> Result<Loaded, RunError> {
    let plan =
        format::manifest::parse_manifest(manifest).map_err(|e| RunError::BadInput(e.into()))?;
    let scene = plan
        .load_scene()
        .map_err(|e| RunError::BadInput(e.into()))?;
    let build = plan_jobs(&plan, &scene);
    let out = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| plan.output.clone());
    Ok(Loaded {
        plan,
        scene,
        build,
        out,
    })
}

pub fn grid_params(l: &Loaded) -> GridParams {
    GridParams {
        ground_min: l.scene.ground.min,
        ground_max: l.scene.ground.max,
        cell_size: l.plan.cells.cell_size,
        min_eye_height: l.plan.cells.min_eye_height,
        max_eye_height: l.plan.cells.max_eye_height,
        n_cols: l.build.grid.n_cols(),
        n_rows: l.build.grid.n_rows(),
    }
}

/// Writes `plan.json` and `base.pack` (same bytes on every run of the same input).
pub fn write_plan_and_base(l: &Loaded) -> Result<(), RunError> {
    std::fs::create_dir_all(l.out.join("jobs")).map_err(failed)?;
    let plan_file = PlanFile {
        manifest: std::fs::canonicalize(&l.plan.manifest_path)
            .unwrap_or(l.plan.manifest_path.clone()),
        name: l.plan.name.clone(),
        jobs: l.build.jobs.clone(),
    };
    let text = serde_json::to_vec_pretty(&plan_file).expect("plan serializes");
    format::pack::write_atomic(&l.out.join("plan.json"), &text).map_err(failed)?;
    let base = BasePack::from_scene(&l.scene, grid_params(l), l.build.scene_fingerprint);
    let path = l.out.join("base.pack");
    let bytes = base.encode().map_err(failed)?;
    if std::fs::read(&path).ok().as_deref() != Some(&bytes[..]) {
        format::pack::write_atomic(&path, &bytes).map_err(failed)?;
    }
    Ok(())
}

/// The jobs whose output is missing, stale or corrupt.
pub fn missing_jobs(l: &Loaded) -> Vec<Job> {
    l.build
        .jobs
        .par_iter()
        .filter(|j| done_record(&l.out, j).is_none())
        .cloned()
        .collect()
}

/// Options of the local executor.
pub struct LocalOptions {
    pub threads: Option<usize>,
    pub progress: bool,
}

/// Outcome of baking jobs: records of the jobs done now and failures (job, message).
pub struct BakeOutcome {
    pub done: Vec<JobRecord>,
    pub failed: Vec<(u32, String)>,
}

/// Bakes `jobs` in this process on a rayon pool; a failing job is recorded in
/// `jobs/<id>.error` and the others go on.
pub fn bake_local(l: &Loaded, jobs: &[Job], opts: &LocalOptions) -> Result<BakeOutcome, RunError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads.unwrap_or(0))
        .build()
        .map_err(failed)?;
    let total_cells: u64 = jobs.iter().map(|j| j.cells.len() as u64).sum();
    let bar = if opts.progress {
        let bar = ProgressBar::new(total_cells);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:12} [{bar:30}] {pos}/{len} cells  {per_sec}  ETA {eta}",
            )
            .expect("template")
            .progress_chars("=> "),
        );
        bar.set_message("baking");
        bar
    } else {
        ProgressBar::hidden()
    };
    let outcome = Mutex::new(BakeOutcome {
        done: Vec::new(),
        failed: Vec::new(),
    });
    pool.install(|| {
        jobs.par_iter().for_each(|job| {
            let _ = std::fs::remove_file(error_path(&l.out, job.id));
            let result = run_job(&l.out, job, |cell, fp| {
                let r = bake_cell_pack(&l.plan, &l.scene, &l.build.grid, cell, fp);
                bar.inc(1);
                r
            });
            let mut o = outcome.lock().expect("no panics while locked");
            match result {
                Ok(record) => o.done.push(record),
                Err(e) => {
                    let message = format!("job {}: {e}", job.id);
                    let _ = std::fs::write(error_path(&l.out, job.id), format!("{message}\n"));
                    o.failed.push((job.id, message));
                }
            }
        })
    });
    bar.finish_and_clear();
    let mut o = outcome.into_inner().expect("no panics while locked");
    o.done.sort_by_key(|r| r.job);
    o.failed.sort();
    Ok(o)
}

/// Writes `index.pack` from the done jobs (all must be done), checking each pack
/// against its record. Returns the index.
pub fn assemble(l: &Loaded) -> Result<Index, RunError> {
    let mut entries = Vec::new();
    let mut fps = Vec::new();
    for job in &l.build.jobs {
        let record = done_record(&l.out, job).ok_or_else(|| {
            failed(anyhow::anyhow!(
                "job {} (cells {:?}) is not done: cannot assemble the index",
                job.id,
                job.cells
            ))
        })?;
        fps.push(job.fingerprint);
        for c in &record.cells {
            entries.push(IndexEntry {
                cell_id: c.cell,
                file: c.file.clone(),
                bytes: c.bytes,
                checksum: c.checksum,
                neighbours: l.build.grid.neighbours(c.cell),
                fingerprint: job.fingerprint,
            });
        }
    }
    entries.sort_by_key(|e| e.cell_id);
    let index = Index {
        build_fingerprint: build_fingerprint(&fps),
        cells: entries,
    };
    let bytes = index.encode().map_err(failed)?;
    format::pack::write_atomic(&l.out.join("index.pack"), &bytes).map_err(failed)?;
    Ok(index)
}

/// Everything `run` did, for the summary line and `--json`.
#[derive(Debug, Serialize)]
pub struct RunSummary {
    pub out: PathBuf,
    pub cells: usize,
    pub jobs: usize,
    pub jobs_skipped: usize,
    pub jobs_baked: usize,
    pub jobs_failed: Vec<(u32, String)>,
    pub wall_s: f64,
    pub complete: bool,
}

impl RunSummary {
    /// One line for people.
    pub fn line(&self) -> String {
        format!(
            "{}: {} cells in {} jobs — {} already done, {} baked, {} failed — {:.1} s{}",
            self.out.display(),
            self.cells,
            self.jobs,
            self.jobs_skipped,
            self.jobs_baked,
            self.jobs_failed.len(),
            self.wall_s,
            if self.complete {
                "; index and report written"
            } else {
                ""
            }
        )
    }
}

/// Takes the output lock, (re)writes plan and base, removes job records when
/// `force`, and returns the lock and the jobs still to bake.
pub fn prepare(l: &Loaded, force: bool) -> Result<(OutputLock, Vec<Job>), RunError> {
    std::fs::create_dir_all(&l.out).map_err(failed)?;
    let lock = OutputLock::acquire(&l.out).map_err(failed)?;
    write_plan_and_base(l)?;
    if force {
        for job in &l.build.jobs {
            let _ = std::fs::remove_file(worker::job::record_path(&l.out, job.id));
        }
    }
    let missing = missing_jobs(l);
    Ok((lock, missing))
}

/// `pipeline run` with the local executor.
pub fn run_local(l: &Loaded, force: bool, opts: &LocalOptions) -> Result<RunSummary, RunError> {
    let start = std::time::Instant::now();
    let (_lock, missing) = prepare(l, force)?;
    let outcome = bake_local(l, &missing, opts)?;
    let complete = outcome.failed.is_empty();
    if complete {
        assemble(l)?;
        crate::report::write_report(&l.out).map_err(failed)?;
    }
    Ok(RunSummary {
        out: l.out.clone(),
        cells: l.build.grid.cell_count() as usize,
        jobs: l.build.jobs.len(),
        jobs_skipped: l.build.jobs.len() - missing.len(),
        jobs_baked: outcome.done.len(),
        jobs_failed: outcome.failed,
        wall_s: start.elapsed().as_secs_f64(),
        complete,
    })
}
