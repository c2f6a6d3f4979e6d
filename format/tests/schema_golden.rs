//! Golden files of the JSON files a bake writes besides its packs
//! (`format::schema`, issue 14 item 2): each file under `tests/data/schema/` is what
//! the writer produced (a demo bake's files, trimmed), parsed into its one schema
//! type and written again byte for byte; files from older versions still read, with
//! their missing fields at the documented defaults.

use format::schema::job::{JobRecord, Unit};
use format::schema::plan::{Partial, PlanFile};
use format::schema::report::Report;
use format::schema::slurm::Submission;
use serde::{de::DeserializeOwned, Serialize};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/schema")
        .join(name)
}

/// Parses golden `name` as `T` and checks that the writers' serialisation
/// (`serde_json::to_vec_pretty`, as `pipeline` and `worker` write) gives its bytes.
fn round_trip<T: Serialize + DeserializeOwned>(name: &str) -> T {
    let bytes = std::fs::read(data(name)).unwrap();
    let value: T =
        serde_json::from_slice(&bytes).unwrap_or_else(|e| panic!("{name} does not parse: {e}"));
    let again = serde_json::to_vec_pretty(&value).unwrap();
    assert!(
        again == bytes,
        "{name}: written again it differs:\n{}",
        String::from_utf8_lossy(&again)
    );
    value
}

fn hex(text: &str) -> [u8; 32] {
    format::fingerprint::from_hex(text).unwrap()
}

#[test]
fn job_record_round_trips() {
    let r: JobRecord = round_trip("job-record.json");
    assert_eq!(r.job, 0);
    assert_eq!(
        r.fingerprint,
        hex("f7da76e9f53b57bb3a89b1c221e1d73691639fd0277bdfc1d99bdb0229ef5ae6")
    );
    assert_eq!(r.cells.len(), 1);
    let c = &r.cells[0];
    assert_eq!(
        (c.cell, c.file.as_str(), c.bytes),
        (0, "cells/0.pack", 43920)
    );
    assert_eq!(
        c.checksum,
        hex("606fda84e366dc7230e6fea3ff6a8f5f9977b895b4354e86d97a7842c248ed18")
    );
    // The per-cell report keys `pipeline report` and the proxy reuse read.
    assert_eq!(c.report.far_group, Some(1));
    assert_eq!(c.report.proxy_keys.len(), 2);
    assert_eq!(c.report.stage_ms.simplify, 76.373);
    assert_eq!(c.report.quality.error_histogram[0], 10678);
    assert_eq!((c.report.mv_objects, c.report.mv_polygons), (8, 2357));
    assert!(r.groups.is_empty());
    assert!(r.shared_process);
    assert_eq!((r.wall_s, r.cpu_s, r.host.as_str()), (2.5, 4.75, "node-1"));
    assert_eq!(format::schema::job::cell_file(0), c.file);
}

#[test]
fn far_field_job_record_round_trips() {
    let r: JobRecord = round_trip("job-record-groups.json");
    assert!(r.cells.is_empty());
    let groups: Vec<u32> = r.groups.iter().map(|g| g.cell).collect();
    assert_eq!(groups, [4, 5]);
    for g in &r.groups {
        assert_eq!(g.file, Unit::Group(g.cell).file());
    }
    assert!(!r.shared_process);
}

/// A record from before far-field groups and `shared_process` reads with neither.
#[test]
fn old_job_record_reads_with_defaults() {
    let r: JobRecord =
        serde_json::from_slice(&std::fs::read(data("job-record-old.json")).unwrap()).unwrap();
    assert_eq!(r.job, 3);
    assert!(r.groups.is_empty());
    assert!(!r.shared_process);
    // Its cell report has only some of today's keys: the rest read as 0.
    let report = &r.cells[0].report;
    assert_eq!(report.sv_objects, 3);
    assert_eq!(report.stage_ms.split, 1.5);
    assert_eq!((report.mv_objects, report.quality.measured_proxies), (0, 0));
    assert!(report.proxy_keys.is_empty() && report.far_group.is_none());
}

#[test]
fn plan_round_trips() {
    let p: PlanFile = round_trip("plan.json");
    assert_eq!(p.name, "demo");
    assert_eq!(p.jobs.len(), 11);
    assert_eq!(p.jobs[0].cells, [0, 1]);
    // The far-field jobs come last, with groups and no cells.
    let last = p.jobs.last().unwrap();
    assert!(last.cells.is_empty() && !last.groups.is_empty());
    assert_eq!(
        p.overrides,
        ["bake.edge_length_tolerance_px=6.0", "cells_per_job=2"]
    );
    let bake = p.bake.as_ref().unwrap();
    assert_eq!(bake.edge_length_tolerance_px, 6.0);
    assert_eq!(bake.image_res, 256);
    assert_eq!(bake.max_deviation_px, 0.5);
    assert!(bake.quality.is_some());
    assert_eq!(p.cell_params.as_ref().unwrap().cell_size, 50.0);
}

/// Issue 14: a plan written before `edge_length_tolerance` was renamed
/// `edge_length_tolerance_px` reads (the old key is an alias), and is written back
/// with the new key.
#[test]
fn plan_before_the_unit_rename_reads() {
    let text = std::fs::read_to_string(data("plan-before-units.json")).unwrap();
    assert!(text.contains("\"edge_length_tolerance\": 6.0"));
    let p: PlanFile = serde_json::from_str(&text).unwrap();
    assert_eq!(p.bake.as_ref().unwrap().edge_length_tolerance_px, 6.0);
    let now: PlanFile = round_trip("plan.json");
    assert_eq!(p.bake, now.bake);
    assert_eq!(p.jobs, now.jobs);
}

/// A plan from before overrides and parameters were recorded reads without them.
#[test]
fn old_plan_reads_without_parameters() {
    let p: PlanFile =
        serde_json::from_slice(&std::fs::read(data("plan-old.json")).unwrap()).unwrap();
    assert_eq!(p.jobs.len(), 2);
    assert!(p.overrides.is_empty() && p.bake.is_none() && p.cell_params.is_none());
}

#[test]
fn partial_round_trips() {
    let p: Partial = round_trip("partial.json");
    assert_eq!(p.spec, "0,2");
    assert_eq!(p.requested_cells, [0, 2]);
    assert_eq!((p.baked_cells, p.grid_cells), (4, 16));
    assert_eq!(p.not_baked_cells.len(), 12);
    assert!(p.line().starts_with("partial: 4 of 16 cells baked"));
}

#[test]
fn report_round_trips() {
    let r: Report = round_trip("report.json");
    assert_eq!((r.scene.as_str(), r.cells, r.grid_cells), ("demo", 4, 16));
    assert_eq!(r.partial.as_ref().unwrap().spec, "0,2");
    assert_eq!(r.jobs_done, 3);
    assert!(r.incomplete());
    assert_eq!(r.cell_lines.len(), 1);
    assert_eq!(r.cell_lines[0].error_histogram[0], 10737);
    assert_eq!(r.far_field.as_ref().unwrap().groups, 2);
    assert_eq!(r.storage.total_bytes, 935514);
    assert_eq!(r.worst_cells[0], (0, 16.576305801541498));
    assert_eq!(r.averages().texture_kb, 370.9091796875);
}

/// A report from before the far field, the quality check and partial bakes reads
/// with those absent.
#[test]
fn old_report_reads_with_defaults() {
    let r: Report =
        serde_json::from_slice(&std::fs::read(data("report-old.json")).unwrap()).unwrap();
    assert_eq!(r.cells, 2);
    assert!(r.partial.is_none() && r.far_field.is_none() && r.per_cell.is_none());
    assert!(r.averages().texture_kb.is_nan());
    assert_eq!(r.cell_lines[0].sv_objects, 3.0);
    assert_eq!(r.cell_lines[0].error_histogram, [0; 8]);
}

#[test]
fn slurm_submission_round_trips() {
    let s: Submission = round_trip("submitted.json");
    assert_eq!(s.array_job, "4711");
    assert_eq!(s.finalize_job, "4712");
    assert_eq!(s.jobs, [0, 3, 5]);
}

/// Issue 32 item 2: a job record is bound to its content. Sealed, it reads back;
/// an edited field, an unknown key or a missing seal is refused, saying which.
#[test]
fn job_records_are_sealed() {
    let mut r: JobRecord =
        serde_json::from_slice(&std::fs::read(data("job-record.json")).unwrap()).unwrap();
    // Times as a bake measures them: floats whose shortest text must read back to the
    // same bits (serde_json's `float_roundtrip`), or the seal would not match.
    r.wall_s = 0.1 + 0.2;
    r.cpu_s = std::f64::consts::PI / 7.0;
    for (k, c) in r.cells.iter_mut().enumerate() {
        c.report.stage_ms.capture = 1.0 / (3.0 + k as f64);
    }
    let sealed = String::from_utf8(r.sealed_json()).unwrap();
    let read = JobRecord::from_sealed_json(&sealed).unwrap();
    assert_eq!(
        JobRecord {
            seal: None,
            ..read.clone()
        },
        JobRecord {
            seal: None,
            ..r.clone()
        }
    );
    assert!(read.seal.is_some());

    let host = format!("\"host\": {}", serde_json::to_string(&r.host).unwrap());
    assert!(sealed.contains(&host), "{sealed}");
    let edited = sealed.replace(&host, "\"host\": \"elsewhere\"");
    let e = JobRecord::from_sealed_json(&edited).unwrap_err();
    assert!(e.contains("does not match its content"), "{e}");

    let unknown = sealed.replacen('{', "{\n  \"extra\": 1,", 1);
    let e = JobRecord::from_sealed_json(&unknown).unwrap_err();
    assert!(e.contains("unknown field `extra`"), "{e}");

    let unsealed = String::from_utf8(serde_json::to_vec_pretty(&r).unwrap()).unwrap();
    let e = JobRecord::from_sealed_json(&unsealed).unwrap_err();
    assert!(e.contains("no seal"), "{e}");
}
