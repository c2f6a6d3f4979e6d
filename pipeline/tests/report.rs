//! `pipeline report` on a bake that is not finished (issue 19): it says plainly which
//! jobs are done, failed and pending, and gives no averages over no cells (with none
//! baked, every average printed `-0`). Runs the real binary on `tests/data/tiny.ron`
//! (9 cells, at most 2 per job: 6 jobs, a row of 3 cells making two), without the
//! far field (whose jobs `cells.rs` and the e2e tests cover), so the jobs are the
//! cells' only.

mod common;
use common::*;

#[test]
fn report_of_an_unfinished_bake_says_so_and_averages_only_baked_cells() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let out_s = out.to_str().unwrap();
    let o = run_quiet(
        "tests/data/tiny.ron",
        &out,
        &["--set", "bake.far_field=false"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let jobs = out.join("jobs");
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
    assert_eq!(plan["jobs"].as_array().unwrap().len(), 6);
    assert_eq!(plan["jobs"][0]["cells"], serde_json::json!([0, 1]));
    let record0 = std::fs::read(jobs.join("0.json")).unwrap();

    // 1. No job done: job 1 failed, the others pending.
    for job in 0..6 {
        std::fs::remove_file(jobs.join(format!("{job}.json"))).unwrap();
    }
    std::fs::write(jobs.join("1.error"), "cell 2: it broke\n").unwrap();
    let o = pipeline(&["report", out_s]);
    assert!(o.status.success(), "{}", text(&o));
    let md = String::from_utf8_lossy(&o.stdout);
    assert!(
        md.contains(
            "**The bake is not finished: 0 of 6 jobs done; 1 failed (job 1); \
             5 pending (jobs 0, 2, 3, 4, 5).**"
        ),
        "{}",
        text(&o)
    );
    assert!(md.contains("No cell is baked yet"), "{md}");
    assert!(!md.contains("-0"), "{md}");
    assert!(!md.contains("Avg. polygon"), "{md}");
    assert!(!md.contains("per cell (average)"), "{md}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("note: the bake is not finished"),
        "{stderr}"
    );
    let v = succeeded_json(&pipeline(&["report", out_s, "--json"]));
    assert_eq!(v["cells"], 0, "{v}");
    assert!(v["per_cell"].is_null(), "{v}");
    assert_eq!(v["jobs_done"], 0);
    assert_eq!(v["jobs_failed"], serde_json::json!([1]));
    assert_eq!(v["jobs_pending"], serde_json::json!([0, 2, 3, 4, 5]));

    // 2. One job done: averages over its two cells, still marked unfinished.
    std::fs::write(jobs.join("0.json"), &record0).unwrap();
    let v = succeeded_json(&pipeline(&["report", out_s, "--json"]));
    assert_eq!(v["cells"], 2, "{v}");
    assert!(v["per_cell"].is_object(), "{v}");
    assert_eq!(v["jobs_done"], 1);
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("1 of 6 jobs done; 1 failed (job 1); 4 pending (jobs 2, 3, 4, 5)"),
        "{md}"
    );
    assert!(md.contains("cover only the baked cells (2 of 9)"), "{md}");
    assert!(md.contains("Avg. polygon no. inside a viewcell"), "{md}");
}
