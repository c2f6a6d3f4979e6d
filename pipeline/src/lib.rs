//! hexbake's coordinator: plan, executors (local rayon, Slurm), resume, reports.

pub mod heatmap;
pub mod inspect;
pub mod lock;
pub mod report;
pub mod run;
pub mod scene_cmd;
pub mod slurm;
pub mod status;
