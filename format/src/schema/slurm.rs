//! `<out>/slurm/submitted.json`: the output's last Slurm submission (written by
//! `pipeline run --executor slurm`, read by `pipeline status` and by the next run,
//! which refuses to start while its tasks are queued).
//!
//! JSON (`serde_json::to_vec_pretty`). Golden file:
//! `format/tests/data/schema/submitted.json`.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// `<out>/slurm/submitted.json`: the last submission.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Submission {
    pub array_job: String,
    pub finalize_job: String,
    /// Array index = job id.
    pub jobs: Vec<u32>,
}

/// `<out>/slurm/submitted.json`.
pub fn submission_path(out: &Path) -> PathBuf {
    out.join("slurm").join("submitted.json")
}

/// The output's last Slurm submission, if it has a readable one.
pub fn read_submission(out: &Path) -> Option<Submission> {
    serde_json::from_slice(&std::fs::read(submission_path(out)).ok()?).ok()
}
