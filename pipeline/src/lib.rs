//! hexbake's coordinator: plan, executors (local rayon, Slurm), resume, reports.

pub mod export;
pub mod heatmap;
pub mod inspect;
pub mod lock;
pub mod overrides;
pub mod report;
pub mod run;
pub mod scene_cmd;
pub mod serve;
pub mod slurm;
pub mod status;
pub mod subset;
pub mod text;

/// `items` joined by ", " between `before` and `after`; empty when there are none
/// (an optional list inside a summary line).
pub(crate) fn list_or_nothing(before: &str, items: &[String], after: &str) -> String {
    if items.is_empty() {
        String::new()
    } else {
        format!("{before}{}{after}", items.join(", "))
    }
}
