//! `pipeline status <out>`: which jobs are done, failed or pending — from the output
//! directory (job records, error files) and, when a Slurm submission is recorded and
//! Slurm answers, from `squeue`.

use crate::lock::queued;
use format::schema::job::error_path;
use format::schema::plan::{plan_path, PlanFile};
use format::schema::slurm::read_submission;
use serde::Serialize;
use std::path::Path;
use worker::job::done_record;

#[derive(Debug, Serialize)]
pub struct Status {
    pub scene: String,
    pub done: Vec<u32>,
    /// (job, message)
    pub failed: Vec<(u32, String)>,
    pub pending: Vec<u32>,
    /// Slurm ids still queued (array tasks and the finalize job), if any.
    pub slurm_queued: Vec<String>,
    pub index_written: bool,
}

impl Status {
    pub fn to_text(&self) -> String {
        let list = |v: &[u32]| {
            v.iter()
                .map(|j| j.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mut s = format!(
            "scene {}: {} done, {} failed, {} pending; index {}\n",
            self.scene,
            self.done.len(),
            self.failed.len(),
            self.pending.len(),
            if self.index_written {
                "written"
            } else {
                "not written"
            }
        );
        if !self.failed.is_empty() {
            s += "failed:\n";
            // The message names its job (worker `job::bake_job`).
            for (j, m) in &self.failed {
                if m.starts_with(&format!("job {j}:")) {
                    s += &format!("  {m}\n");
                } else {
                    s += &format!("  job {j}: {m}\n");
                }
            }
        }
        if !self.pending.is_empty() {
            s += &format!("pending: {}\n", list(&self.pending));
        }
        if !self.slurm_queued.is_empty() {
            s += &format!("slurm queue: {}\n", self.slurm_queued.join(" "));
        }
        s
    }
}

pub fn status(out: &Path) -> anyhow::Result<Status> {
    use anyhow::Context;
    let plan: PlanFile = serde_json::from_slice(
        &std::fs::read(plan_path(out))
            .with_context(|| format!("{}: no plan.json: not a bake output", out.display()))?,
    )
    .with_context(|| format!("{}/plan.json", out.display()))?;
    let mut status = Status {
        scene: plan.name.clone(),
        done: Vec::new(),
        failed: Vec::new(),
        pending: Vec::new(),
        slurm_queued: Vec::new(),
        index_written: out.join("index.pack").exists(),
    };
    for job in &plan.jobs {
        if done_record(out, job).is_some() {
            status.done.push(job.id);
        } else if let Ok(msg) = std::fs::read_to_string(error_path(out, job.id)) {
            status.failed.push((job.id, msg.trim().to_string()));
        } else {
            status.pending.push(job.id);
        }
    }
    if let Some(sub) = read_submission(out) {
        status.slurm_queued = queued(&[&sub.array_job, &sub.finalize_job]).unwrap_or_default();
    }
    Ok(status)
}
