//! hexbake's coordinator: plan, executors (local rayon, Slurm), resume, reports.

pub mod inspect;
pub mod scene_cmd;
