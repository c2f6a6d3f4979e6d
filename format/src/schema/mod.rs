//! The JSON files hexbake writes besides its packs, one definition each, used by
//! their writers and readers (STYLE.md habit 14): the compare report ([`compare`]),
//! `frames.csv` and the player's draw options ([`frames`]),
//! the job record and its journal paths ([`job`]), the plan and partial-bake files
//! ([`plan`]), the bake report ([`report`]) and the Slurm submission ([`slurm`]).
//! Golden files under `format/tests/data/schema/` pin their bytes
//! (`format/tests/schema_golden.rs`, `schema_compare_golden.rs`).

pub mod compare;
pub mod frames;
pub mod job;
pub mod plan;
pub mod report;
pub mod slurm;
