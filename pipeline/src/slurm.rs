//! The Slurm executor (DESIGN.md "Distribution"; facts in ../shared/SLURM.md): one
//! array task per missing job, each running `worker job`, plus a finalize job
//! (`--dependency=afterok`) that runs `pipeline finalize` (index + report). Running
//! it again submits only the jobs still missing. Waiting polls `squeue` with a
//! timeout (`sbatch --wait` polls too slowly), unless `--no-wait`.

use crate::lock::queued;
use crate::run::{missing_jobs, prepare, Loaded, RunError, RunSummary, Submitted};
use format::schema::job::error_path;
use format::schema::slurm::{submission_path, Submission};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

#[derive(clap::Args, Clone, Debug, Default)]
pub struct SlurmArgs {
    /// Slurm partition (default: the cluster's default partition).
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit per array task (sbatch --time), e.g. 00:30:00.
    #[arg(long)]
    pub time: Option<String>,
    /// Memory per task (sbatch --mem), e.g. 4G.
    #[arg(long)]
    pub mem: Option<String>,
    /// CPUs per task (sbatch --cpus-per-task); the task's rayon pool uses them.
    #[arg(long)]
    pub cpus_per_task: Option<u32>,
    /// Submit and return without waiting for the jobs.
    #[arg(long)]
    pub no_wait: bool,
    /// Submit the array held (release it with `scontrol release <id>`), e.g. to
    /// stage a bake or to cancel some tasks first. Implies --no-wait.
    #[arg(long)]
    pub hold: bool,
    /// Give up waiting after this many seconds (the jobs keep running).
    #[arg(long, default_value_t = 3600)]
    pub wait_timeout_s: u64,
}

fn failed(e: impl Into<anyhow::Error>) -> RunError {
    RunError::Failed(e.into())
}

fn shell_quote(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', r"'\''"))
}

/// The binary `name` next to the running one (cargo puts `worker` beside `pipeline`).
fn sibling_binary(name: &str) -> Result<PathBuf, RunError> {
    let exe = std::env::current_exe().map_err(failed)?;
    let path = exe.with_file_name(name);
    if path.exists() {
        Ok(path)
    } else {
        Err(failed(anyhow::anyhow!(
            "{} not found next to {}: build it (cargo build --bins)",
            name,
            exe.display()
        )))
    }
}

fn sbatch_header(args: &SlurmArgs, name: &str, log: &Path) -> String {
    let mut s = format!(
        "#!/bin/bash\n#SBATCH --job-name={name}\n#SBATCH --output={}\n",
        log.display()
    );
    if let Some(p) = &args.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &args.time {
        s += &format!("#SBATCH --time={t}\n");
    }
    if let Some(m) = &args.mem {
        s += &format!("#SBATCH --mem={m}\n");
    }
    if let Some(c) = args.cpus_per_task {
        s += &format!("#SBATCH --cpus-per-task={c}\n");
    }
    s + "set -euo pipefail\n"
}

fn sbatch(args: &[&str]) -> Result<String, RunError> {
    let out = Command::new("sbatch").args(args).output().map_err(|e| {
        failed(anyhow::anyhow!(
            "cannot run sbatch ({e}): is Slurm installed and SLURM_CONF set?"
        ))
    })?;
    if !out.status.success() {
        return Err(failed(anyhow::anyhow!(
            "sbatch {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // --parsable prints "id" or "id;cluster".
    Ok(text.trim().split(';').next().unwrap_or("").to_string())
}

pub fn run_slurm(
    l: &Loaded,
    force: bool,
    args: &SlurmArgs,
    progress: bool,
) -> Result<RunSummary, RunError> {
    let start = Instant::now();
    let (lock, missing) = prepare(l, force)?;
    let out = std::fs::canonicalize(&l.out).map_err(failed)?;
    let manifest = std::fs::canonicalize(&l.plan.manifest_path).map_err(failed)?;
    let dir = out.join("slurm");
    std::fs::create_dir_all(&dir).map_err(failed)?;

    if !missing.is_empty() {
        // 0. The models' LOD chains, once, here: every task loads them from <out>/lod/.
        crate::run::prepare_chains(l)?;
        // 1. Scripts.
        let worker = sibling_binary("worker")?;
        let pipeline = sibling_binary("pipeline")?;
        let bake = sbatch_header(args, &format!("hexbake-{}", l.plan.name), &dir.join("job-%a.log"))
            + &format!(
                "exec {} job {} --out {} --job \"$SLURM_ARRAY_TASK_ID\" --threads \"${{SLURM_CPUS_PER_TASK:-1}}\"\n",
                shell_quote(&worker),
                shell_quote(&manifest),
                shell_quote(&out)
            );
        let finalize = sbatch_header(
            &SlurmArgs {
                cpus_per_task: None,
                ..args.clone()
            },
            &format!("hexbake-{}-finalize", l.plan.name),
            &dir.join("finalize.log"),
        ) + &format!(
            "exec {} finalize {} --out {}\n",
            shell_quote(&pipeline),
            shell_quote(&manifest),
            shell_quote(&out)
        );
        let bake_path = dir.join("bake.sbatch");
        let finalize_path = dir.join("finalize.sbatch");
        std::fs::write(&bake_path, bake).map_err(failed)?;
        std::fs::write(&finalize_path, finalize).map_err(failed)?;
        for job in &missing {
            let _ = std::fs::remove_file(error_path(&out, job.id));
        }

        // 2. Submit the array (only the missing jobs) and the finalize job.
        let ids: Vec<String> = missing.iter().map(|j| j.id.to_string()).collect();
        let array_arg = format!("--array={}", ids.join(","));
        let mut array_args = vec!["--parsable", array_arg.as_str()];
        if args.hold {
            array_args.push("--hold");
        }
        array_args.push(bake_path.to_str().unwrap());
        let array = sbatch(&array_args)?;
        let fin = sbatch(&[
            "--parsable",
            &format!("--dependency=afterok:{array}"),
            finalize_path.to_str().unwrap(),
        ])?;
        let submission = Submission {
            array_job: array.clone(),
            finalize_job: fin.clone(),
            jobs: missing.iter().map(|j| j.id).collect(),
        };
        std::fs::write(
            submission_path(&out),
            serde_json::to_vec_pretty(&submission).expect("serializes"),
        )
        .map_err(failed)?;
        if progress {
            eprintln!(
                "submitted array job {array} ({} tasks) and finalize job {fin}; logs in {}",
                missing.len(),
                dir.display()
            );
        }
        if args.no_wait || args.hold {
            drop(lock);
            return Ok(submitted_summary(
                l.out.clone(),
                l.build.grid.cell_count() as usize,
                l.build.jobs.len(),
                &submission,
                args.hold,
                start.elapsed().as_secs_f64(),
            ));
        }

        // 3. Wait for both (poll squeue).
        let deadline = Instant::now() + Duration::from_secs(args.wait_timeout_s);
        loop {
            let q = queued(&[&array, &fin]).map_err(failed)?;
            if q.is_empty() {
                break;
            }
            if Instant::now() > deadline {
                return Err(failed(anyhow::anyhow!(
                    "gave up waiting after {} s; jobs {array} and {fin} are still queued (`pipeline status {}`)",
                    args.wait_timeout_s,
                    l.out.display()
                )));
            }
            std::thread::sleep(Duration::from_millis(500));
        }
    } else {
        crate::run::assemble(l)?;
        crate::report::write_report(&l.out).map_err(failed)?;
    }

    // 4. What is done now.
    let still = missing_jobs(l);
    let jobs_failed: Vec<(u32, String)> = still
        .iter()
        .map(|j| {
            let msg = std::fs::read_to_string(error_path(&l.out, j.id))
                .map(|s| s.trim().to_string())
                .unwrap_or_else(|_| {
                    format!(
                        "job {}: the Slurm task did not finish (see {})",
                        j.id,
                        dir.join(format!("job-{}.log", j.id)).display()
                    )
                });
            (j.id, msg)
        })
        .collect();
    let complete = jobs_failed.is_empty() && l.out.join("index.pack").exists();
    Ok(RunSummary {
        out: l.out.clone(),
        cells: l.build.grid.cell_count() as usize,
        jobs: l.build.jobs.len(),
        jobs_skipped: l.build.jobs.len() - missing.len(),
        jobs_baked: missing.len() - still.len(),
        jobs_failed,
        wall_s: start.elapsed().as_secs_f64(),
        complete,
        submitted: None,
    })
}

/// The summary of a run that submitted `submission` and returned (`--no-wait`,
/// `held`): not complete — nothing is baked and the index and report are the
/// finalize job's — but a success (exit 0), with the job ids and how to follow them.
pub fn submitted_summary(
    out: PathBuf,
    cells: usize,
    jobs: usize,
    submission: &Submission,
    held: bool,
    wall_s: f64,
) -> RunSummary {
    RunSummary {
        out,
        cells,
        jobs,
        jobs_skipped: jobs - submission.jobs.len(),
        jobs_baked: 0,
        jobs_failed: Vec::new(),
        wall_s,
        complete: false,
        submitted: Some(Submitted {
            array_job: submission.array_job.clone(),
            finalize_job: submission.finalize_job.clone(),
            tasks: submission.jobs.len(),
            held,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn submission() -> Submission {
        Submission {
            array_job: "4711".into(),
            finalize_job: "4712".into(),
            jobs: vec![0, 2, 5],
        }
    }

    /// `--no-wait` (issue 28): the line names the jobs, says nothing is baked and
    /// that the finalize job writes index and report, points at `pipeline status`,
    /// and never claims they are written; the run succeeds but is not complete.
    #[test]
    fn no_wait_says_what_was_submitted_not_that_the_index_is_written() {
        let s = submitted_summary("out/demo".into(), 42, 11, &submission(), false, 0.3);
        let line = s.line();
        assert!(!line.contains("written"), "{line}");
        for want in [
            "3 submitted as Slurm array job 4711",
            "8 already done",
            "not baked yet",
            "finalize job 4712 writes the index and report",
            "`pipeline status out/demo`",
        ] {
            assert!(line.contains(want), "{want:?} missing from {line}");
        }
        assert!(!line.contains("held"), "{line}");
        assert!(!s.complete && s.succeeded());
        assert_eq!(s.jobs_baked, 0);
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["complete"], false);
        assert_eq!(json["submitted"]["array_job"], "4711");
        assert_eq!(json["submitted"]["finalize_job"], "4712");
    }

    /// `--hold`: the same, and how to release the array.
    #[test]
    fn hold_says_how_to_release() {
        let s = submitted_summary("out/demo".into(), 42, 11, &submission(), true, 0.3);
        let line = s.line();
        assert!(!line.contains("written"), "{line}");
        assert!(
            line.contains("held: nothing runs until `scontrol release 4711`"),
            "{line}"
        );
        assert!(!s.complete && s.succeeded());
    }

    /// A finished run still says so (and only then).
    #[test]
    fn complete_run_says_index_and_report_written() {
        let mut s = submitted_summary("o".into(), 42, 11, &submission(), false, 0.0);
        s.submitted = None;
        assert!(!s.line().contains("written"));
        s.complete = true;
        assert!(s.line().contains("index and report written"));
    }
}
