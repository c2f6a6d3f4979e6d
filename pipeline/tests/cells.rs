//! `pipeline run --cells` and `--set` (issue 8: benchmarks on a 2-core machine bake
//! only the cells a camera path needs, and sweep parameters into separate outputs).
//! Runs the real binary on `tests/data/tiny.ron` (9 cells, 2 per job).

use format::pack::Index;
mod common;
use common::*;

const TINY: &str = "tests/data/tiny.ron";

fn run_json(out: &Path, extra: &[&str]) -> (Output, serde_json::Value) {
    let mut args = vec!["run", TINY, "--json", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = pipeline(&args);
    let v = serde_json::from_slice(&o.stdout).unwrap_or(serde_json::Value::Null);
    (o, v)
}

fn indexed_cells(out: &Path) -> Vec<u32> {
    Index::read(&out.join("index.pack"))
        .expect("index")
        .cells
        .iter()
        .map(|c| c.cell_id)
        .collect()
}

#[test]
fn cells_bakes_only_their_jobs_then_a_full_run_completes_identically() {
    let tmp = tempfile::tempdir().unwrap();
    let part = tmp.path().join("part");
    // 1. Cell 4 only: its job (cells 3 and 4 of row 1) is baked, nothing else.
    let o = run_quiet(TINY, &part, &["--cells", "4"]);
    assert!(o.status.success(), "{}", text(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("partial: 2 of 9 cells baked (1 requested"),
        "{}",
        text(&o)
    );
    assert_eq!(indexed_cells(&part), vec![3, 4]);
    let partial: serde_json::Value =
        serde_json::from_slice(&std::fs::read(part.join("partial.json")).unwrap()).unwrap();
    assert_eq!(
        partial["not_baked_cells"],
        serde_json::json!([0, 1, 2, 5, 6, 7, 8])
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(part.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["cells"], 2);
    assert_eq!(report["grid_cells"], 9);
    assert!(report["partial"].is_object());
    let md = std::fs::read_to_string(part.join("report.md")).unwrap();
    assert!(md.contains("**partial: 2 of 9 cells baked"), "{md}");

    // 2. More cells: done jobs are skipped (resumable).
    let (o, v) = run_json(&part, &["--cells", "3,at:1:1"]);
    assert!(o.status.success(), "{}", text(&o));
    // The cell at (1, 1) is cell 0: job (0, 1) is new, job (3, 4) is done, and so
    // are the far-field jobs of their cells' groups at both levels (baked in step 1).
    assert_eq!(v["jobs"], 5, "{v}");
    assert_eq!(v["jobs_skipped"], 4, "{v}");
    assert_eq!(v["jobs_baked"], 1, "{v}");
    assert_eq!(v["partial"]["baked_cells"], 4, "{v}");
    assert_eq!(indexed_cells(&part), vec![0, 1, 3, 4]);

    // 3. A full run bakes the rest, drops partial.json and ends byte-identical to a
    //    bake that never was partial.
    let (o, v) = run_json(&part, &[]);
    assert!(o.status.success(), "{}", text(&o));
    // The two cell jobs and three far-field jobs (two levels) of steps 1–2 are done.
    assert_eq!(v["jobs_skipped"], 5, "{v}");
    assert!(!part.join("partial.json").exists());
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(part.join("report.json")).unwrap()).unwrap();
    assert!(report["partial"].is_null(), "{report}");
    let full = tmp.path().join("full");
    let (o, _) = run_json(&full, &[]);
    assert!(o.status.success(), "{}", text(&o));
    for f in ["base.pack", "index.pack"] {
        assert!(
            std::fs::read(part.join(f)).unwrap() == std::fs::read(full.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let groups = Index::read(&full.join("index.pack")).unwrap().groups;
    assert!(!groups.is_empty());
    for g in &groups {
        assert!(
            std::fs::read(part.join(&g.file)).unwrap()
                == std::fs::read(full.join(&g.file)).unwrap(),
            "{} differs",
            g.file
        );
    }
    for c in 0..9 {
        let f = format!("cells/{c}.pack");
        assert!(
            std::fs::read(part.join(&f)).unwrap() == std::fs::read(full.join(&f)).unwrap(),
            "{f} differs"
        );
    }
}

#[test]
fn set_overrides_make_a_different_bake() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    let (o, v) = run_json(&out, &["--cells", "0", "--set", "cells_per_job=1"]);
    assert!(o.status.success(), "{}", text(&o));
    // The cell's job and the far-field jobs of its groups (two levels on 3 × 3 cells).
    assert_eq!(
        (v["jobs"].as_u64(), v["cells"].as_u64()),
        (Some(3), Some(1)),
        "{v}"
    );
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
    assert_eq!(plan["overrides"], serde_json::json!(["cells_per_job=1"]));
    assert_eq!(plan["bake"]["edge_length_tolerance_px"], 4.5);
    // A different T_l on the same output: the job's fingerprint differs, so it is
    // baked again rather than taken for done.
    let (o, v) = run_json(
        &out,
        &[
            "--cells",
            "0",
            "--set",
            "cells_per_job=1",
            "--set",
            "T_l=6.0",
        ],
    );
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(v["jobs_baked"], 3, "{v}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["bake"]["edge_length_tolerance_px"], 6.0);
    assert_eq!(
        report["overrides"],
        serde_json::json!(["cells_per_job=1", "bake.edge_length_tolerance_px=6.0"])
    );
}

#[test]
fn bad_cells_and_set_arguments_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    for (args, says) in [
        (vec!["--cells", "9"], "the grid has 9 cells"),
        (vec!["--cells", "path:nope.ron"], "nope.ron"),
        (vec!["--cells", "x"], "expected a cell id"),
        (vec!["--set", "T_x=1"], "unknown key"),
        // The manifest's own message, naming the override (issue 14).
        (
            vec!["--set", "T_s=-2"],
            "--set bake.self_occluding_tolerance_px=-2: `bake.self_occluding_tolerance_px` must be > 0, found -2",
        ),
        (
            vec!["--set", "bake.edge_length_tolerance=6"],
            "`bake.edge_length_tolerance` was renamed `bake.edge_length_tolerance_px` (pixels)",
        ),
        (
            vec!["--cells", "0", "--executor", "slurm"],
            "local executor only",
        ),
    ] {
        let o = run_quiet(TINY, &out, &args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(says),
            "{args:?}: {}",
            text(&o)
        );
    }
}
