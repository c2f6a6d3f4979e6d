//! hexbake's benchmark tool (issue 8, moved out of the coordinator in issue 14):
//! the pieces `scripts/bench.sh` calls to re-run the paper's experiments (000 §4:
//! Tables 3–8, Fig. 14) and regenerate BENCHMARKS.md.
//!
//! - [`paper`]: the paper's published numbers, read from `data/paper-tables.ron`;
//! - [`labels`]: the labels of bench.sh's work files and the swept parameters, typed;
//! - [`results`]: a work folder collected into one run file (`docs/bench/run-*.json`),
//!   cell load times, the check-viewpoint camera paths of the sweeps;
//! - [`tables`]: BENCHMARKS.md's sections from the run files, beside the paper's;
//! - [`plot`]: the per-frame plot of a walk.

pub mod labels;
pub mod paper;
pub mod plot;
pub mod results;
pub mod tables;
