//! `worker job`: bake one job of a manifest (what a Slurm array task runs).

use std::path::PathBuf;
use worker::cli::{bad_input, failed, Failure};

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long)]
    pub job: Option<u32>,
    /// Threads for this job's bake (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
        manifest,
        out,
        job,
        threads,
    } = args;
    let id = match job {
        Some(id) => id,
        None => std::env::var("SLURM_ARRAY_TASK_ID")
            .ok()
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| {
                bad_input(anyhow::anyhow!(
                    "--job not given and SLURM_ARRAY_TASK_ID not set"
                ))
            })?,
    };
    let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
    let scene = scene::build_scene(&plan).map_err(bad_input)?;
    let build = worker::job::plan_jobs(&plan, &scene);
    let job = build.jobs.get(id as usize).ok_or_else(|| {
        bad_input(anyhow::anyhow!(
            "job {id} does not exist ({} jobs)",
            build.jobs.len()
        ))
    })?;
    if worker::job::done_record(&out, job).is_some() {
        println!("job {id}: already done");
        return Ok(());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(failed)?;
    let result = pool.install(|| {
        // The chains `pipeline run` prepared (or this task builds and caches).
        let (chains, _) =
            worker::lod_chain::LodChains::prepare(&scene, Some(&worker::job::lod_dir(&out)))
                .map_err(|e| format!("job {id}: {}: {e}", worker::job::lod_dir(&out).display()))?;
        worker::job::bake_job(&out, &plan, &scene, &chains, &build, job, false, || {})
    });
    match result {
        Ok(record) => {
            println!(
                "job {id}: {} cells in {:.1} s",
                record.cells.len(),
                record.wall_s
            );
            Ok(())
        }
        Err(message) => {
            // bake_job wrote it for a bake error; the chains' own error too.
            let _ = std::fs::create_dir_all(out.join("jobs"));
            let _ = std::fs::write(worker::job::error_path(&out, id), format!("{message}\n"));
            Err(failed(anyhow::anyhow!(message)))
        }
    }
}
