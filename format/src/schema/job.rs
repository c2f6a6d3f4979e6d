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

/// What one cell's (or far-field group's) bake reports besides its pack: the
/// statistics `pipeline report` turns into the paper's Tables 3–8, the quality
/// check, the proxies' content keys and the stage times. It goes into the job
/// record, never into pack bytes (times differ from run to run).
///
/// The fields are in alphabetical order, the order in which the record has always
/// held them (it was written from a JSON map before it had a type), so records stay
/// byte-identical. A record written before a field existed reads it as 0 / empty.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CellReport {
    /// Objects in clusters of two or more, their proxies' triangles, the clusters.
    pub cluster_objects: u32,
    pub cluster_polygons: u64,
    pub clusters: u32,
    /// Outside objects culled (back-facing or occluded from the whole region, or
    /// below a pixel for the objective selection).
    pub culled_objects: u32,
    /// A cell: its far-field group (`None` without the far field); a group: `None`.
    pub far_group: Option<u32>,
    /// A cell: objects drawn from its group's far field; a group: its cells.
    pub far_objects: u32,
    /// Layered impostors (issue 16): objects, quad triangles, impostors.
    pub impostor_objects: u32,
    pub impostor_polygons: u64,
    pub impostors: u32,
    /// Instances of the scene.
    pub instances: u32,
    /// Multi-view objects and their proxies' triangles.
    pub mv_objects: u32,
    pub mv_polygons: u64,
    /// Instances drawn as originals (inside the cell) and their triangles.
    pub originals: u32,
    /// Triangles of the proxied objects' full models.
    pub outside_original_polygons: u64,
    pub polygons_inside: u64,
    /// Per proxy, in pack order: its content key (64 hex digits), read back when the
    /// job is baked again to reuse unchanged proxies.
    pub proxy_keys: Vec<String>,
    /// Per proxy, in pack order: what its bake measured and counted (issue 32 item 2),
    /// carried over to the report of a rebake that reuses the proxy by key, so an
    /// incremental bake's report equals a clean bake's. Empty in records written
    /// before it (a reused proxy then counts as unmeasured).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub proxy_facts: Vec<ProxyFacts>,
    pub quality: CellQualityReport,
    /// Proxies taken from the job's earlier bake by key instead of derived.
    pub reused_proxies: u32,
    /// Outside objects the objective selection culled (also in `culled_objects`).
    pub selection_culled: u32,
    /// (SV + MV + cluster triangles) / `outside_original_polygons`.
    pub simplified_ratio: f64,
    pub stage_ms: StageMs,
    /// Single-view objects and their proxies' triangles.
    pub sv_objects: u32,
    pub sv_polygons: u64,
    /// Decoded RGBA8 bytes of the proxies' textures.
    pub texture_bytes: u64,
    /// Wall time of the unit's bake in ms.
    pub total_ms: f64,
    /// Captures taken.
    pub views: u32,
}

/// The objective selection's quality check of a cell's proxies (issue 16).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CellQualityReport {
    /// |ΔY| over the measured object pixels, bins of 8 levels (last ≥ 56).
    pub error_histogram: [u64; 8],
    /// Proxies whose kept candidate was measured; the figures below count only
    /// when it is not 0.
    pub measured_proxies: u32,
    /// The worst sample view's object-pixel PSNR(Y) and SSIM.
    pub worst_psnr_db: f64,
    pub worst_ssim: f64,
}

/// Bake time per stage in ms (summed over the unit's objects and threads).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StageMs {
    pub capture: f64,
    pub cluster: f64,
    pub select: f64,
    pub simplify: f64,
    pub split: f64,
    pub weights: f64,
}

impl StageMs {
    /// (stage name, ms) in the record's order.
    pub fn entries(&self) -> [(&'static str, f64); 6] {
        [
            ("capture", self.capture),
            ("cluster", self.cluster),
            ("select", self.select),
            ("simplify", self.simplify),
            ("split", self.split),
            ("weights", self.weights),
        ]
    }
}

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

/// What one proxy's bake measured and counted ([`CellReport::proxy_facts`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ProxyFacts {
    /// Decoded RGBA8 bytes of its captures as derived (the report's `texture_bytes`).
    pub texture_bytes: u64,
    /// The quality check's measurement of the proxy, where one was made.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quality: Option<ProxyQuality>,
}

/// One proxy's measurement by the quality check (worker `select::Measured`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ProxyQuality {
    pub worst_psnr_db: f64,
    pub worst_ssim: f64,
    pub pooled_psnr_db: f64,
    pub mean_ssim: f64,
    pub views: u32,
    pub passed: bool,
    pub error_histogram: [u64; 8],
}

/// `jobs/<id>.json`. Unknown keys are refused: a record says exactly what it says.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
    /// blake3 of the record's JSON with this field absent (issue 32 item 2: a record is
    /// bound to its content; [`JobRecord::sealed_json`] writes it,
    /// [`JobRecord::from_sealed_json`] checks it). Records written before the seal
    /// read as `None` and are not trusted as done.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "hex32_option"
    )]
    pub seal: Option<[u8; 32]>,
}

impl JobRecord {
    /// The record as written to `jobs/<id>.json`: pretty JSON with its seal.
    pub fn sealed_json(&self) -> Vec<u8> {
        let mut sealed = self.clone();
        sealed.seal = Some(self.content_hash());
        serde_json::to_vec_pretty(&sealed).expect("a job record serializes")
    }

    /// Reads a record written by [`JobRecord::sealed_json`]: unknown keys, a missing
    /// seal or one that does not match the content (an edited field, a flipped bit
    /// that still parses) are errors, each saying which.
    pub fn from_sealed_json(text: &str) -> Result<JobRecord, String> {
        let record: JobRecord = serde_json::from_str(text).map_err(|e| e.to_string())?;
        match record.seal {
            None => Err("the record has no seal (written before issue 32)".into()),
            Some(seal) if seal != record.content_hash() => Err(format!(
                "its seal {} does not match its content {}: the record was edited",
                crate::fingerprint::to_hex(&seal),
                crate::fingerprint::to_hex(&record.content_hash())
            )),
            Some(_) => Ok(record),
        }
    }

    /// blake3 of the compact JSON of the record without its seal.
    fn content_hash(&self) -> [u8; 32] {
        let mut bare = self.clone();
        bare.seal = None;
        *blake3::hash(&serde_json::to_vec(&bare).expect("a job record serializes")).as_bytes()
    }
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

/// Serde for an optional 32-byte hash as 64 lowercase hex digits.
pub mod hex32_option {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<[u8; 32]>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => super::hex32::serialize(v, s),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[u8; 32]>, D::Error> {
        let text = Option::<String>::deserialize(d)?;
        text.map(|t| {
            crate::fingerprint::from_hex(&t)
                .ok_or_else(|| serde::de::Error::custom("expected 64 hex digits"))
        })
        .transpose()
    }
}
