//! `<out>/jobs/<job>.json`: the job record, the journal's "end" (worker `job.rs`
//! writes it after all the job's packs; `pipeline` and the worker read it to tell a
//! done job from one to bake again), and `<out>/plan.json`'s list of jobs.
//!
//! JSON (`serde_json::to_vec_pretty`); fingerprints and checksums as 64 lowercase
//! hex digits. Fields added after the first records carry `#[serde(default)]`, so
//! older records still read; nothing is ever renamed. Golden files:
//! `format/tests/data/schema/job-record.json`, `plan.json`.

use crate::fingerprint::Fingerprint;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One job of a build: a few neighbouring cells, or far-field groups, baked together.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Job {
    pub id: u32,
    /// Ascending cell ids.
    pub cells: Vec<u32>,
    /// Ascending far-field group ids (worker `far_field.rs`); a job bakes cells or
    /// groups, never both.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub groups: Vec<u32>,
    #[serde(with = "hex32")]
    pub fingerprint: Fingerprint,
}

/// What a job bakes: a cell, or a far-field group (worker `far_field.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Unit {
    Cell(u32),
    Group(u32),
}

impl Unit {
    pub fn id(self) -> u32 {
        match self {
            Unit::Cell(id) | Unit::Group(id) => id,
        }
    }

    /// Its pack's path relative to the output directory.
    pub fn file(self) -> String {
        match self {
            Unit::Cell(c) => cell_file(c),
            Unit::Group(g) => group_file(g),
        }
    }
}

impl std::fmt::Display for Unit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unit::Cell(c) => write!(f, "cell {c}"),
            Unit::Group(g) => write!(f, "far-field group {g}"),
        }
    }
}

impl Job {
    /// The cells, then the groups, the job bakes.
    pub fn units(&self) -> impl Iterator<Item = Unit> + '_ {
        self.cells
            .iter()
            .map(|&c| Unit::Cell(c))
            .chain(self.groups.iter().map(|&g| Unit::Group(g)))
    }
}

/// What one cell's bake reports besides its pack (statistics, times): it goes into
/// the job record, never into pack bytes (times differ from run to run).
pub type CellReport = serde_json::Value;

/// One cell's (or far-field group's) entry in a job record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellRecord {
    /// Cell id, or group id in [`JobRecord::groups`].
    pub cell: u32,
    /// The pack's path relative to the output directory ([`cell_file`], [`group_file`]).
    pub file: String,
    /// The pack's size and blake3 checksum: a pack with both is the one the job wrote.
    pub bytes: u64,
    #[serde(with = "hex32")]
    pub checksum: [u8; 32],
    pub report: CellReport,
}

/// `jobs/<id>.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    pub job: u32,
    #[serde(with = "hex32")]
    pub fingerprint: Fingerprint,
    pub cells: Vec<CellRecord>,
    /// A far-field job's group packs (`cell` is the group id); records written
    /// before the far field read as none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub groups: Vec<CellRecord>,
    /// Wall time of the job in seconds.
    pub wall_s: f64,
    /// CPU time of the whole process while the job ran, in seconds (all threads). It is
    /// the job's own only when the job had the process to itself (`worker job`, a Slurm
    /// task, or a local run with one thread); see `shared_process`.
    pub cpu_s: f64,
    /// Other jobs ran in the same process at the same time (the local executor with
    /// more than one thread), so `cpu_s` also counts theirs and is not this job's.
    /// Records written before this field read as `false`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub shared_process: bool,
    /// Where it ran.
    pub host: String,
}

/// `cells/<cell>.pack`, relative to the output directory.
pub fn cell_file(cell: u32) -> String {
    format!("cells/{cell}.pack")
}

/// `groups/<group>.pack`, relative to the output directory.
pub fn group_file(group: u32) -> String {
    format!("groups/{group}.pack")
}

/// `<out>/jobs/<job>.json`: the job's record.
pub fn record_path(out: &Path, job: u32) -> PathBuf {
    out.join("jobs").join(format!("{job}.json"))
}

/// `<out>/jobs/<job>.error`: the message of the job's failed last attempt (plain text).
pub fn error_path(out: &Path, job: u32) -> PathBuf {
    out.join("jobs").join(format!("{job}.error"))
}

/// Serde for 32-byte hashes as 64 lowercase hex digits.
pub mod hex32 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &[u8; 32], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&crate::fingerprint::to_hex(v))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[u8; 32], D::Error> {
        let text = String::deserialize(d)?;
        crate::fingerprint::from_hex(&text)
            .ok_or_else(|| serde::de::Error::custom("expected 64 hex digits"))
    }
}
