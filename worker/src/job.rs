//! Jobs: a few neighbouring cells baked together (DESIGN.md "Data flow"), the unit
//! the pipeline schedules locally (rayon) or as one Slurm array task.
//!
//! Output directory layout (format/README.md describes the files):
//!
//! ```text
//! <out>/base.pack            models + instances + grid (written by the pipeline)
//! <out>/cells/<id>.pack      one per cell, written atomically by its job
//! <out>/groups/<id>.pack     one per far-field group (crate::far_field), written by
//!                            the far-field jobs that follow the cell jobs
//! <out>/jobs/<job>.json      the job's record: fingerprint, cells, per-cell stats;
//!                            written atomically AFTER all its packs (the journal's "end")
//! <out>/index.pack           assembled once every job is done
//! <out>/lod/<hash>.lod       per-model LOD chains (crate::lod_chain), a cache
//! <out>/textures/<h>/<h>.tex the captures, each stored once under its content hash
//!                            and named by the packs (format version 6), written
//!                            before the pack that names them
//! ```
//!
//! The record, the job list and these paths are `format::schema::job` (one schema
//! for the worker that writes records and the pipeline that reads them).
//!
//! A record lists, per cell, the content key of each proxy in pack order
//! (`proxy_keys`): when the job is baked again (its fingerprint changed), every
//! proxy whose key is unchanged is taken from the previous pack instead of derived
//! ([`previous_proxies`]).
//!
//! A job is done when its record exists with the job's current fingerprint, every
//! texture its packs name is in the store and whole, and every
//! cell pack it lists has the size and blake3 checksum in the record (the record is
//! written after the packs, so that is the pack the job wrote). Anything else (a crash at any moment, a changed model or parameter,
//! a corrupt pack) means the job is run again, from scratch. Since packs are written
//! with temp-file + rename and the record last, a SIGKILL at any moment leaves either
//! a done job or one that will be redone, and the bytes of a redone job are the same.

use crate::bake::ProxyReuse;
use crate::far_field::{CellGroups, FarField};
use crate::grid::HexGrid;
use crate::lod_chain::LodChains;
use format::fingerprint::{
    group_job_fingerprint, job_fingerprint, params_fingerprint, scene_fingerprint, Fingerprint,
};
use format::manifest::Plan;
use format::pack::CellPack;
pub use format::schema::job::{
    cell_file, error_path, group_file, record_path, CellQualityReport, CellRecord, CellReport, Job,
    JobRecord, StageMs, Unit,
};
use format::Scene;
use std::path::{Path, PathBuf};

/// The jobs of a manifest and the fingerprints they depend on.
#[derive(Clone, Debug)]
pub struct BuildPlan {
    pub grid: HexGrid,
    /// The grid's 7-cell groups; they have packs only when `bake.far_field` is on.
    pub groups: CellGroups,
    pub scene_fingerprint: Fingerprint,
    pub params_fingerprint: Fingerprint,
    pub jobs: Vec<Job>,
}

/// Groups the grid's cells into jobs of `plan.cells_per_job` neighbouring cells:
/// cells are taken in blocks of `cells_per_job` consecutive columns of one row
/// (each cell's left/right neighbours share its job), so a job's captures and
/// model loads stay local. With `bake.far_field`, jobs of `cells_per_job`
/// consecutive far-field groups follow (a cell's bake only needs to know which
/// objects its group takes, not the group's proxies, so any order works).
pub fn plan_jobs(plan: &Plan, scene: &Scene) -> BuildPlan {
    let grid = HexGrid::new(scene.ground, plan.cells.cell_size);
    let scene_fp = scene_fingerprint(scene);
    let params_fp = params_fingerprint(&plan.bake, &plan.cells);
    let per_job = plan.cells_per_job.max(1);
    let mut jobs = Vec::new();
    for row in 0..grid.n_rows() {
        let mut col = 0;
        while col < grid.n_cols() {
            let end = (col + per_job).min(grid.n_cols());
            let cells: Vec<u32> = (col..end).map(|c| row * grid.n_cols() + c).collect();
            jobs.push(Job {
                id: jobs.len() as u32,
                fingerprint: job_fingerprint(&scene_fp, &params_fp, &cells),
                cells,
                groups: Vec::new(),
            });
            col = end;
        }
    }
    let groups = CellGroups::for_params(&grid, &plan.bake);
    if plan.bake.far_field {
        let ids: Vec<u32> = (0..groups.len()).collect();
        for chunk in ids.chunks(per_job as usize) {
            jobs.push(Job {
                id: jobs.len() as u32,
                fingerprint: group_job_fingerprint(&scene_fp, &params_fp, chunk),
                cells: Vec::new(),
                groups: chunk.to_vec(),
            });
        }
    }
    BuildPlan {
        grid,
        groups,
        scene_fingerprint: scene_fp,
        params_fingerprint: params_fp,
        jobs,
    }
}

/// `<out>/lod/`: the per-model LOD chain cache ([`crate::lod_chain`]).
pub fn lod_dir(out: &Path) -> PathBuf {
    out.join("lod")
}

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("{unit}: {message}")]
    Unit { unit: Unit, message: String },
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
}

/// Reads a job's record if the job is done (see the module docs), else `None`.
pub fn done_record(out: &Path, job: &Job) -> Option<JobRecord> {
    let text = std::fs::read_to_string(record_path(out, job.id)).ok()?;
    let record = JobRecord::from_sealed_json(&text).ok()?;
    if record.fingerprint != job.fingerprint
        || record
            .cells
            .iter()
            .map(|c| c.cell)
            .ne(job.cells.iter().copied())
        || record
            .groups
            .iter()
            .map(|c| c.cell)
            .ne(job.groups.iter().copied())
    {
        return None;
    }
    for c in record.cells.iter().chain(&record.groups) {
        // The record is written after its packs and names their exact bytes: a pack
        // with the recorded size and blake3 is the pack this job wrote for this cell
        // with this fingerprint (checked above), so it is not decoded again here
        // (decoding every pack three times per run cost ~17 CPU s on park-2m).
        let bytes = recorded_pack(out, c)?;
        // Version 6: the pack's textures live in the bake's store, written without
        // fsync before the pack; the job is only done when each is there and whole.
        let pack = format::pack::PackFile::from_bytes_named(&bytes, &out.join(&c.file)).ok()?;
        if format::pack::texture_store::missing_texture(&pack).is_some() {
            return None;
        }
    }
    Some(record)
}

/// The bytes of the pack a job record lists for a cell, if the file still has the
/// recorded size and blake3 checksum.
fn recorded_pack(out: &Path, c: &CellRecord) -> Option<Vec<u8>> {
    let bytes = std::fs::read(out.join(&c.file)).ok()?;
    (bytes.len() as u64 == c.bytes && *blake3::hash(&bytes).as_bytes() == c.checksum)
        .then_some(bytes)
}

/// Bakes job `job` of `plan` into `out` — the one way both executors bake a job
/// (`pipeline run`'s local pool and the `worker job` a Slurm task runs): its stale
/// error file goes, proxies of its earlier bake whose keys still match are reused
/// ([`previous_proxies`]), every cell and group is baked ([`bake_cell_pack`]) and
/// written with the record last ([`run_job`]); `after_unit` runs after each unit
/// (a progress bar). On failure the message, naming the job, is also written to
/// `jobs/<id>.error` for `pipeline status`.
#[allow(clippy::too_many_arguments)]
pub fn bake_job(
    out: &Path,
    plan: &Plan,
    scene: &Scene,
    chains: &LodChains,
    build: &BuildPlan,
    job: &Job,
    shared_process: bool,
    after_unit: impl Fn(),
) -> Result<JobRecord, String> {
    let _ = std::fs::remove_file(error_path(out, job.id));
    let reuse = previous_proxies(out, job);
    let none = ProxyReuse::new();
    run_job(out, job, shared_process, |unit, fp| {
        let reuse = reuse.get(&unit).unwrap_or(&none);
        let r = bake_cell_pack(plan, scene, chains, reuse, build, unit, fp);
        after_unit();
        r
    })
    .map_err(|e| {
        let message = format!("job {}: {e}", job.id);
        let _ = std::fs::create_dir_all(out.join("jobs"));
        let _ = std::fs::write(error_path(out, job.id), format!("{message}\n"));
        message
    })
}

/// Runs one job: bakes each cell or group with `bake` (which returns its pack
/// content and its report), writes the packs atomically, then the record. Stops at
/// the first failing unit, naming it. `shared_process`: other jobs run in this
/// process at the same time (recorded, see [`JobRecord::shared_process`]).
pub fn run_job<F>(
    out: &Path,
    job: &Job,
    shared_process: bool,
    mut bake: F,
) -> Result<JobRecord, JobError>
where
    F: FnMut(Unit, &Fingerprint) -> Result<(CellPack, CellReport), String>,
{
    let start = std::time::Instant::now();
    let cpu_start = process_cpu_seconds();
    let io = |path: &Path, e: &dyn std::fmt::Display| JobError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut cells = Vec::with_capacity(job.cells.len());
    let mut groups = Vec::with_capacity(job.groups.len());
    for unit in job.units() {
        let failed = |message: String| JobError::Unit { unit, message };
        let (pack, report) = bake(unit, &job.fingerprint).map_err(failed)?;
        if pack.cell_id != unit.id() || pack.fingerprint != job.fingerprint {
            return Err(failed(
                "the bake returned a pack for another cell, group or job".into(),
            ));
        }
        let file = unit.file();
        let path = out.join(&file);
        // The unit's earlier pack, if any: sections whose content is unchanged (often
        // the textures, after a small manifest change) are copied, not recompressed.
        let previous = std::fs::read(&path)
            .ok()
            .and_then(|b| format::pack::PackFile::from_bytes(&b).ok());
        let bytes = pack
            .encode_reusing(matches!(unit, Unit::Group(_)), previous.as_ref(), Some(out))
            .map_err(|e| failed(e.to_string()))?;
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| io(dir, &e))?;
        }
        format::pack::write_atomic(&path, &bytes).map_err(|e| io(&path, &e))?;
        let record = CellRecord {
            cell: unit.id(),
            file,
            bytes: bytes.len() as u64,
            checksum: *blake3::hash(&bytes).as_bytes(),
            report,
        };
        match unit {
            Unit::Cell(_) => cells.push(record),
            Unit::Group(_) => groups.push(record),
        }
    }
    let record = JobRecord {
        job: job.id,
        fingerprint: job.fingerprint,
        cells,
        groups,
        wall_s: start.elapsed().as_secs_f64(),
        cpu_s: (process_cpu_seconds() - cpu_start).max(0.0),
        shared_process,
        host: format::pack::hostname(),
        seal: None,
    };
    let path = record_path(out, job.id);
    std::fs::create_dir_all(path.parent().unwrap()).map_err(|e| io(&path, &e))?;
    let text = record.sealed_json();
    format::pack::write_atomic(&path, &text).map_err(|e| io(&path, &e))?;
    Ok(record)
}

/// User + system CPU time of this process in seconds (Linux `/proc/self/stat`,
/// clock ticks of 1/100 s); 0 where that is not available.
pub fn process_cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which may contain spaces) start at ") ".
    let Some(rest) = stat.rsplit_once(") ").map(|(_, r)| r) else {
        return 0.0;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // utime and stime are fields 14 and 15 of stat, i.e. 11 and 12 after the name.
    (ticks(11) + ticks(12)) / 100.0
}

/// The proxies of the job's earlier bake, per cell, by key (issue 13, per-proxy
/// content-addressed cache): read from the job's previous record (whatever its
/// fingerprint) and the packs it lists, taking only packs whose size and checksum
/// still match the record and that decode, with one key per proxy. Anything else
/// gives no proxies for that cell (they are derived again).
pub fn previous_proxies(out: &Path, job: &Job) -> std::collections::BTreeMap<Unit, ProxyReuse> {
    let mut reuse = std::collections::BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(record_path(out, job.id)) else {
        return reuse;
    };
    let Ok(record) = JobRecord::from_sealed_json(&text) else {
        return reuse;
    };
    let units = record
        .cells
        .iter()
        .filter(|c| job.cells.contains(&c.cell))
        .map(|c| (Unit::Cell(c.cell), c))
        .chain(
            record
                .groups
                .iter()
                .filter(|c| job.groups.contains(&c.cell))
                .map(|c| (Unit::Group(c.cell), c)),
        );
    for (unit, c) in units {
        let Some(bytes) = recorded_pack(out, c) else {
            continue;
        };
        // Named by its path, so that a version-6 pack finds its textures in the store.
        let pack =
            format::pack::PackFile::from_bytes_named(&bytes, &out.join(&c.file)).and_then(|file| {
                match unit {
                    Unit::Cell(_) => CellPack::decode(&file),
                    Unit::Group(_) => CellPack::decode_group(&file),
                }
            });
        let Ok(pack) = pack else {
            continue;
        };
        let keys: Vec<Fingerprint> = c
            .report
            .proxy_keys
            .iter()
            .filter_map(|k| format::fingerprint::from_hex(k))
            .collect();
        if pack.cell_id != c.cell || keys.len() != pack.proxies.len() {
            continue;
        }
        // What the earlier bake measured of each proxy, where the record has it.
        let facts = &c.report.proxy_facts;
        let facts = (facts.len() == keys.len()).then_some(facts);
        let reused = keys
            .into_iter()
            .zip(pack.proxies)
            .enumerate()
            .map(|(i, (key, proxy))| {
                let facts = facts.map(|f| f[i].clone());
                (key, crate::proxy::Reused { proxy, facts })
            });
        reuse.insert(unit, reused.collect());
    }
    reuse
}

/// Bakes one cell or far-field group of a job into its pack and report (the
/// function every executor runs for each unit).
pub fn bake_cell_pack(
    plan: &Plan,
    scene: &Scene,
    chains: &LodChains,
    reuse: &ProxyReuse,
    build: &BuildPlan,
    unit: Unit,
    fingerprint: &Fingerprint,
) -> Result<(CellPack, CellReport), String> {
    let (grid, groups) = (&build.grid, &build.groups);
    let bake = match unit {
        Unit::Cell(cell) => {
            let far = FarField::of_cell(scene, grid, groups, cell, &plan.cells, &plan.bake);
            crate::bake::bake_cell_with(
                scene,
                chains,
                reuse,
                grid,
                cell,
                &plan.cells,
                &plan.bake,
                far.as_ref(),
            )
        }
        Unit::Group(group) => crate::groups::bake_group(
            scene,
            chains,
            reuse,
            grid,
            groups,
            group,
            &plan.cells,
            &plan.bake,
        ),
    }
    .map_err(|e| e.explain(scene))?;
    let pack = bake
        .to_pack_with(*fingerprint, chains.captures())
        .map_err(|e| e.explain(scene))?;
    let s = &bake.stats;
    let t = &s.times;
    // What `pipeline report` reads (the paper's Tables 3–8 per cell), the quality
    // check, and per proxy in pack order its content key (crate::bake::proxy_key),
    // read back by `previous_proxies` when the job is baked again.
    let report = CellReport {
        cluster_objects: s.cluster_members,
        cluster_polygons: s.cluster_polygons,
        clusters: s.cluster_count,
        culled_objects: s.culled,
        far_group: bake.far_group,
        far_objects: s.far_objects,
        impostor_objects: s.impostor_members,
        impostor_polygons: s.impostor_polygons,
        impostors: s.impostor_count,
        instances: s.instances,
        mv_objects: s.mv_count,
        mv_polygons: s.mv_polygons,
        originals: s.originals,
        outside_original_polygons: s.proxied_original_polygons,
        polygons_inside: s.polygons_inside,
        proxy_keys: bake
            .proxies
            .iter()
            .map(|p| format::fingerprint::to_hex(&p.key))
            .collect(),
        proxy_facts: bake.proxies.iter().map(|p| p.facts()).collect(),
        quality: CellQualityReport {
            error_histogram: s.quality.error_histogram,
            measured_proxies: s.quality.measured,
            worst_psnr_db: s.quality.worst_psnr_db,
            worst_ssim: s.quality.worst_ssim,
        },
        reused_proxies: s.reused_proxies,
        selection_culled: s.selection_culled,
        simplified_ratio: s.simplified_ratio,
        stage_ms: StageMs {
            capture: t.capture_ms,
            cluster: t.cluster_ms,
            select: t.select_ms,
            simplify: t.simplify_ms,
            split: t.split_ms,
            weights: t.weights_ms,
        },
        sv_objects: s.sv_count,
        sv_polygons: s.sv_polygons,
        texture_bytes: s.texture_bytes,
        total_ms: t.total_ms,
        views: s.views,
    };
    Ok((pack, report))
}
