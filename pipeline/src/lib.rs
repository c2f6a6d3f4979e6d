//! hexbake's coordinator: plan, executors (local rayon, Slurm), resume, reports.

pub mod export;
pub mod heatmap;
pub mod inspect;
pub mod lock;
pub mod overrides;
pub mod pixel_font;
pub mod report;
pub mod run;
pub mod scene_cmd;
pub mod slurm;
pub mod status;
pub mod subset;
