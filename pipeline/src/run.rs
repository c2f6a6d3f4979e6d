//! `pipeline run`: validate → plan → bake the missing jobs → assemble → report
//! (DESIGN.md "Data flow"). Jobs run in-process on a rayon pool (local executor)
//! or as a Slurm job array (see [`crate::slurm`]); either way each job writes its
//! packs and record atomically (worker::job), so a rerun redoes only what is missing.
//! The files it writes besides packs (plan, partial, job records) are
//! `format::schema` (re-exported here where callers reach them through `run`).

use crate::lock::OutputLock;
use anyhow::Context;
use format::fingerprint::build_fingerprint;
use format::manifest::Plan;
use format::pack::index::LEGACY_BASE_FILE;
use format::pack::{generation, BaseEntry, BasePack, GridParams, Index, IndexEntry};
pub use format::schema::job::error_path;
use format::schema::plan::plan_path;
pub use format::schema::plan::{partial_path, read_partial, Partial, PlanFile};
use format::Scene;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use worker::job::{done_record, plan_jobs, BuildPlan, Job, JobRecord};
use worker::lod_chain::LodChains;

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
    /// `--set` overrides applied to `plan` (canonical `KEY=VALUE`).
    pub overrides: Vec<String>,
}

/// Parses the manifest, loads the scene and plans the jobs. `out` overrides the
/// manifest's output directory.
pub fn load(manifest: &Path, out: Option<&Path>) -> Result<Loaded, RunError> {
    load_with(manifest, out, &[])
}

/// [`load`] with `--set` overrides applied to the manifest's parameters before the
/// jobs are planned (a cell-size override changes the grid).
pub fn load_with(
    manifest: &Path,
    out: Option<&Path>,
    overrides: &[crate::overrides::Override],
) -> Result<Loaded, RunError> {
    // The overrides replace raw manifest values before validation (one validator).
    let plan = format::manifest::parse_manifest_with(manifest, overrides)
        .map_err(|e| RunError::BadInput(e.into()))?;
    let scene = scene::build_scene(&plan).map_err(|e| RunError::BadInput(e.into()))?;
    let build = plan_jobs(&plan, &scene);
    let out = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| plan.output.clone());
    Ok(Loaded {
        plan,
        scene,
        build,
        out,
        overrides: overrides.iter().map(|o| o.to_string()).collect(),
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
        overrides: l.overrides.clone(),
        bake: Some(l.plan.bake.clone()),
        cell_params: Some(l.plan.cells.clone()),
    };
    let text = serde_json::to_vec_pretty(&plan_file).expect("plan serializes");
    format::pack::write_atomic(&plan_path(&l.out), &text).map_err(failed)?;
    let mut base = BasePack::from_scene(&l.scene, grid_params(l), l.build.scene_fingerprint);
    let path = l.out.join(LEGACY_BASE_FILE);
    // Issue 17: per-model patch tiling, bitfields and normal cones (worker
    // `patches.rs`), taken from the existing base pack when its models are the same
    // and it was made with the same preset (the bake is deterministic).
    let preset = worker::patches::PatchPreset::standard();
    let reused = BasePack::read(&path).ok().and_then(|old| {
        let same = old.models == base.models
            && old.patches.as_ref().is_some_and(|p| {
                p.sample_level == preset.sample_level && p.shell_radius == preset.shell_radius
            });
        if same {
            old.patches
        } else {
            None
        }
    });
    base.patches = Some(reused.unwrap_or_else(|| {
        let meshes: Vec<&format::Mesh> = base.models.iter().map(|m| &m.mesh).collect();
        worker::patches::bake_patch_set(&meshes, &preset)
    }));
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
    let total_cells: u64 = jobs
        .iter()
        .map(|j| (j.cells.len() + j.groups.len()) as u64)
        .sum();
    let bar = if opts.progress {
        let bar = ProgressBar::new(total_cells);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:12} [{bar:30}] {pos}/{len} cells and groups  {per_sec}  ETA {eta}",
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
    // With several threads, several jobs bake side by side in this process and none
    // has a CPU time of its own.
    let shared_process = pool.current_num_threads() > 1 && jobs.len() > 1;
    if jobs.is_empty() {
        return Ok(BakeOutcome {
            done: Vec::new(),
            failed: Vec::new(),
        });
    }
    // Each model's LOD chain once, from `<out>/lod/` or built and cached there.
    bar.set_message("lod chains");
    let chains = pool.install(|| prepare_chains(l))?;
    bar.set_message("baking");
    pool.install(|| {
        jobs.par_iter().for_each(|job| {
            let result = worker::job::bake_job(
                &l.out,
                &l.plan,
                &l.scene,
                &chains,
                &l.build,
                job,
                shared_process,
                || bar.inc(1),
            );
            let mut o = outcome.lock().expect("no panics while locked");
            match result {
                Ok(record) => o.done.push(record),
                Err(message) => o.failed.push((job.id, message)),
            }
        })
    });
    bar.finish_and_clear();
    let mut o = outcome.into_inner().expect("no panics while locked");
    o.done.sort_by_key(|r| r.job);
    o.failed.sort();
    Ok(o)
}

/// The scene's per-model LOD chains (`worker::lod_chain`): loaded from `<out>/lod/`
/// or built there, once per model, before any job needs them.
pub fn prepare_chains(l: &Loaded) -> Result<LodChains, RunError> {
    let (chains, _) =
        LodChains::prepare(&l.scene, Some(&worker::job::lod_dir(&l.out))).map_err(failed)?;
    Ok(chains)
}

/// Writes `index.pack` from the done jobs (all must be done), checking each pack
/// against its record. Returns the index.
pub fn assemble(l: &Loaded) -> Result<Index, RunError> {
    let mut done = Vec::new();
    for job in &l.build.jobs {
        let record = done_record(&l.out, job).ok_or_else(|| {
            failed(anyhow::anyhow!(
                "job {} (cells {:?}) is not done: cannot assemble the index",
                job.id,
                job.cells
            ))
        })?;
        done.push((job, record));
    }
    write_index(l, &done)
}

/// Writes `index.pack` from whichever jobs are done (a `--cells` run): the index
/// lists the cells of done jobs only, so the player draws every other cell as
/// original geometry. Returns the index and the cells not baked (ascending).
pub fn assemble_available(l: &Loaded) -> Result<(Index, Vec<u32>), RunError> {
    let records: Vec<Option<JobRecord>> = l
        .build
        .jobs
        .par_iter()
        .map(|job| done_record(&l.out, job))
        .collect();
    let mut done = Vec::new();
    let mut not_baked = Vec::new();
    for (job, record) in l.build.jobs.iter().zip(records) {
        match record {
            Some(r) => done.push((job, r)),
            None => not_baked.extend(job.cells.iter().copied()),
        }
    }
    let index = write_index(l, &done)?;
    // A baked cell whose far-field group is not baked is left out (drawn as original
    // geometry): without its group's pack it would miss its far objects.
    for (_, r) in &done {
        for c in &r.cells {
            if index.cell(c.cell).is_none() {
                not_baked.push(c.cell);
            }
        }
    }
    not_baked.sort_unstable();
    Ok((index, not_baked))
}

/// The index of the done jobs' packs. A cell is listed only when its far-field
/// group (its record's `far_group`) is listed too, and a group only when its parent
/// is.
fn write_index(l: &Loaded, done: &[(&Job, JobRecord)]) -> Result<Index, RunError> {
    let mut entries = Vec::new();
    let mut groups = Vec::new();
    let mut fps = Vec::new();
    let entry = |c: &worker::job::CellRecord, neighbours, fingerprint, group| IndexEntry {
        cell_id: c.cell,
        file: c.file.clone(),
        bytes: c.bytes,
        checksum: c.checksum,
        neighbours,
        fingerprint,
        group,
    };
    for (job, record) in done {
        fps.push(job.fingerprint);
        for c in &record.groups {
            // A group's `far_group` is its parent (format version 5, issue 27).
            groups.push(entry(c, Vec::new(), job.fingerprint, c.report.far_group));
        }
    }
    groups.sort_by_key(|e| e.cell_id);
    // A group is listed only when its parent is: from the top level down (parents
    // have larger ids), so a listed cell's whole chain is listed.
    let mut keep = vec![true; groups.len()];
    for k in (0..groups.len()).rev() {
        if let Some(p) = groups[k].group {
            keep[k] = matches!(groups.binary_search_by_key(&p, |e| e.cell_id), Ok(j) if keep[j]);
        }
    }
    let mut keep = keep.into_iter();
    groups.retain(|_| keep.next().unwrap_or(false));
    let listed = |g: u32| groups.binary_search_by_key(&g, |e| e.cell_id).is_ok();
    for (job, record) in done {
        for c in &record.cells {
            let group = c.report.far_group;
            if group.is_some_and(|g| !listed(g)) {
                continue;
            }
            entries.push(entry(
                c,
                l.build.grid.neighbours(c.cell),
                job.fingerprint,
                group,
            ));
        }
    }
    entries.sort_by_key(|e| e.cell_id);
    // Issue 32: the index is the commit point of a generation. Every file it names is
    // published under a name of its content first (never written again), then the
    // index replaces the old one by one rename (format::pack::generation).
    let out = &l.out;
    let previous = Index::read(&out.join("index.pack")).ok();
    let publish = |file: &str, checksum: &[u8; 32]| {
        generation::publish(out, file, checksum)
            .with_context(|| format!("{}: publishing {file}", out.display()))
            .map_err(failed)
    };
    for e in entries.iter_mut().chain(groups.iter_mut()) {
        e.file = publish(&e.file, &e.checksum)?;
    }
    // The working base pack, read once: hashed for the index and decoded for its check.
    let base_path = out.join(LEGACY_BASE_FILE);
    let base_bytes = std::fs::read(&base_path)
        .with_context(|| base_path.display().to_string())
        .map_err(failed)?;
    let base_pack = BasePack::from_bytes(&base_bytes).map_err(failed)?;
    let base = BaseEntry::for_bytes(LEGACY_BASE_FILE, &base_bytes);
    if base_pack.scene_fingerprint != l.build.scene_fingerprint {
        return Err(failed(anyhow::anyhow!(
            "{}: its scene fingerprint is not the plan's: it was written for another \
             scene; run `pipeline run` again to rewrite it",
            out.join(LEGACY_BASE_FILE).display()
        )));
    }
    let base = BaseEntry {
        file: publish(&base.file, &base.checksum)?,
        ..base
    };
    let index = Index {
        build_fingerprint: build_fingerprint(&fps),
        cells: entries,
        groups,
        base: Some(base),
    };
    let bytes = index.encode().map_err(failed)?;
    format::pack::write_atomic(&out.join("index.pack"), &bytes).map_err(failed)?;
    // Published files of older generations go; the previous generation's stay for
    // readers still on it.
    let mut keep = generation::named_files(&index);
    keep.extend(previous.iter().flat_map(generation::named_files));
    generation::sweep(out, &keep)
        .with_context(|| format!("{}: sweeping old generations", out.display()))
        .map_err(failed)?;
    // Captures no pack names any more (an incremental rebake changed them) leave the
    // store; the output lock keeps every job of this bake out meanwhile.
    format::pack::texture_store::sweep_unreferenced(&l.out)
        .with_context(|| format!("{}: sweeping the texture store", l.out.display()))
        .map_err(failed)?;
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
    /// Every job is done and the index and report are written.
    pub complete: bool,
    /// A Slurm run with `--no-wait` or `--hold`: what was submitted. Nothing of it is
    /// baked yet, and the index and report are the finalize job's to write.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub submitted: Option<Submitted>,
}

/// Slurm jobs a run submitted and returned without waiting for.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Submitted {
    /// The array job: one task per missing job.
    pub array_job: String,
    /// The finalize job (`--dependency=afterok` on the array): it writes the index
    /// and the report once every task succeeded.
    pub finalize_job: String,
    /// Tasks in the array.
    pub tasks: usize,
    /// Submitted held (`--hold`): nothing runs before `scontrol release`.
    pub held: bool,
}

impl RunSummary {
    /// The run did what it was asked: every job done, or (`--no-wait`, `--hold`) the
    /// missing jobs submitted.
    pub fn succeeded(&self) -> bool {
        self.complete || self.submitted.is_some()
    }

    /// One line for people.
    pub fn line(&self) -> String {
        if let Some(s) = &self.submitted {
            return format!(
                "{}: {} cells in {} jobs — {} already done, {} submitted as Slurm array job {}{}, \
                 not baked yet; finalize job {} writes the index and report once every task \
                 succeeds; `pipeline status {}` shows progress — {:.1} s",
                self.out.display(),
                self.cells,
                self.jobs,
                self.jobs_skipped,
                s.tasks,
                s.array_job,
                if s.held {
                    format!(
                        " (held: nothing runs until `scontrol release {}`)",
                        s.array_job
                    )
                } else {
                    String::new()
                },
                s.finalize_job,
                self.out.display(),
                self.wall_s,
            );
        }
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

/// Temp files older than this are removed whoever wrote them (a pack's temp file
/// lives for the seconds of one write).
const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(3600);

/// Takes the output lock, refuses while Slurm tasks of an earlier submission still
/// write into the output ([`crate::lock::refuse_while_queued`]), and removes the temp
/// files an interrupted run left in the output, its `cells/`, `jobs/`, `lod/` and
/// `textures/` ([`format::pack::remove_stale_temps`]).
pub fn lock_output(out: &Path) -> Result<OutputLock, RunError> {
    std::fs::create_dir_all(out).map_err(failed)?;
    let lock = OutputLock::acquire(out).map_err(failed)?;
    crate::lock::refuse_while_queued(out).map_err(failed)?;
    for dir in [
        out.to_path_buf(),
        out.join("cells"),
        out.join("jobs"),
        worker::job::lod_dir(out),
    ] {
        format::pack::remove_stale_temps(&dir, STALE_TEMP_AGE)
            .with_context(|| {
                format!(
                    "{}: removing temp files of an interrupted run",
                    dir.display()
                )
            })
            .map_err(failed)?;
    }
    format::pack::texture_store::remove_stale_temps(out, STALE_TEMP_AGE)
        .with_context(|| {
            format!(
                "{}: removing temp files of the texture store",
                out.display()
            )
        })
        .map_err(failed)?;
    Ok(lock)
}

/// Takes the output lock, (re)writes plan and base, removes job records when
/// `force`, and returns the lock and the jobs still to bake.
pub fn prepare(l: &Loaded, force: bool) -> Result<(OutputLock, Vec<Job>), RunError> {
    let lock = lock_output(&l.out)?;
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
        let _ = std::fs::remove_file(partial_path(&l.out));
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
        submitted: None,
    })
}

/// `pipeline run --cells` with the local executor: bakes only the jobs holding a
/// selected cell (skipping those already done), then writes an index of every done
/// cell, `partial.json` (or removes it when every cell turned out baked) and the
/// report. The summary counts the selected jobs; it is `complete` when every
/// selected job is done.
pub fn run_local_selected(
    l: &Loaded,
    selection: &crate::subset::Selection,
    force: bool,
    opts: &LocalOptions,
) -> Result<(RunSummary, Option<Partial>), RunError> {
    let start = std::time::Instant::now();
    // 1. Lock, plan and base, as for a full run.
    let _lock = lock_output(&l.out)?;
    write_plan_and_base(l)?;
    // 2. The selected jobs; with --force their records go.
    let groups = &l.build.groups;
    let selected =
        crate::subset::jobs_for_cells(&l.build.jobs, &selection.cells, |c| groups.chain(c));
    if force {
        for job in &selected {
            let _ = std::fs::remove_file(worker::job::record_path(&l.out, job.id));
        }
    }
    let missing: Vec<Job> = selected
        .par_iter()
        .filter(|j| done_record(&l.out, j).is_none())
        .cloned()
        .collect();
    // 3. Bake them.
    let outcome = bake_local(l, &missing, opts)?;
    let complete = outcome.failed.is_empty();
    // 4. Index of what is done, partial.json, report.
    let mut partial = None;
    if complete {
        let (_, not_baked) = assemble_available(l)?;
        let grid_cells = l.build.grid.cell_count() as usize;
        let p = Partial {
            spec: selection.spec.clone(),
            requested_cells: selection.cells.iter().copied().collect(),
            baked_cells: grid_cells - not_baked.len(),
            grid_cells,
            requested_not_baked: selection
                .cells
                .iter()
                .copied()
                .filter(|c| not_baked.binary_search(c).is_ok())
                .collect(),
            not_baked_cells: not_baked,
        };
        if p.not_baked_cells.is_empty() {
            let _ = std::fs::remove_file(partial_path(&l.out));
        } else {
            let text = serde_json::to_vec_pretty(&p).expect("partial serializes");
            format::pack::write_atomic(&partial_path(&l.out), &text).map_err(failed)?;
            partial = Some(p);
        }
        crate::report::write_report(&l.out).map_err(failed)?;
    }
    Ok((
        RunSummary {
            out: l.out.clone(),
            cells: selected.iter().map(|j| j.cells.len()).sum(),
            jobs: selected.len(),
            jobs_skipped: selected.len() - missing.len(),
            jobs_baked: outcome.done.len(),
            jobs_failed: outcome.failed,
            wall_s: start.elapsed().as_secs_f64(),
            complete,
            submitted: None,
        },
        partial,
    ))
}
