//! BENCHMARKS.md generation (issue 8; moved from `pipeline benchmarks tables` to
//! `hexbake-bench tables` in issue 14). Two run files regenerate a template's marked
//! sections into exactly the document the old code path (`pipeline/src/
//! bench_tables.rs`, the paper's numbers as Rust constants) wrote from them,
//! captured before it was deleted — apart from the two commands the generated text
//! names, which moved ([`RENAMED`]):
//!
//! - `data/fixture/`: a tiny bench.sh run on procedural scenes relabelled as the
//!   parks, cut down, plus two synthetic lod points;
//! - `data/park/`: the park run of 2026-11-21 (`docs/bench/run-20261121T140328Z.json`)
//!   with its per-frame series cut to 30 frames, 12 commands and 20 report lines per
//!   path bake: every section, all four sweeps, two lod points.
//!
//! Text outside the markers is untouched; the walk plots are written; a missing
//! marker is an error that leaves the document as it was.

use hexbake_bench::tables::regenerate;
use std::path::{Path, PathBuf};

/// Commands the generated text names that moved in issue 14: (old, new).
const RENAMED: [(&str, &str); 2] = [
    ("`pipeline benchmarks views`", "`hexbake-bench views`"),
    ("`pipeline benchmarks load`", "`hexbake-bench load`"),
];

fn data(set: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(set)
}

/// The golden document of a data set: the old generator's output, commands renamed.
fn golden(set: &str) -> String {
    let mut text = std::fs::read_to_string(data(set).join("expected.md")).unwrap();
    for (old, new) in RENAMED {
        text = text.replace(old, new);
    }
    text
}

/// The text of `doc` outside every `bench:` marker pair.
fn outside_markers(doc: &str) -> Vec<String> {
    let mut parts = Vec::new();
    let mut rest = doc;
    while let Some(b) = rest.find("<!-- bench:") {
        parts.push(rest[..b].to_string());
        let close = "end -->";
        let e = rest[b..].find(close).expect("an end marker") + b + close.len();
        rest = &rest[e..];
    }
    parts.push(rest.to_string());
    parts
}

/// A results folder with the data set's run file and a copy of its template.
fn setup(set: &str) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let results = tmp.path().join("results");
    std::fs::create_dir_all(&results).unwrap();
    for e in std::fs::read_dir(data(set)).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "json") {
            std::fs::copy(&p, results.join(p.file_name().unwrap())).unwrap();
        }
    }
    let doc = tmp.path().join("doc.md");
    std::fs::copy(data(set).join("template.md"), &doc).unwrap();
    (tmp, results, doc)
}

fn regenerates_the_old_document(set: &str) {
    let (_tmp, results, doc) = setup(set);
    let r = regenerate(&results, &doc, "docs/bench").unwrap();
    assert_eq!(r.runs, 1);
    let got = std::fs::read_to_string(&doc).unwrap();
    let want = golden(set);
    assert!(
        got == want,
        "generated document differs from {}/expected.md; got:\n{got}",
        data(set).display()
    );
    // Outside the markers nothing changed.
    let template = std::fs::read_to_string(data(set).join("template.md")).unwrap();
    assert_eq!(outside_markers(&got), outside_markers(&template));
    // Regenerating again changes nothing.
    regenerate(&results, &doc, "docs/bench").unwrap();
    assert_eq!(std::fs::read_to_string(&doc).unwrap(), got);
    // The park-2m walk plot (hybrid + lod) is drawn; park-4m has a hybrid compare too.
    assert_eq!(r.plots.len(), 2, "{:?}", r.plots);
    for p in &r.plots {
        let bytes = std::fs::read(p).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"), "{}", p.display());
    }
}

#[test]
fn fixture_regenerates_the_golden_document() {
    regenerates_the_old_document("fixture");
}

#[test]
fn park_run_regenerates_the_golden_document() {
    regenerates_the_old_document("park");
}

#[test]
fn golden_has_the_papers_numbers_and_ours_side_by_side() {
    let want = golden("fixture");
    // Paper numbers (Table 7 PSNR, Table 8 storage, Table 3 percentages) next to
    // numbers from the fixture, and the lod comparison with its interpolation.
    for needle in [
        "| PSNR(Y) mean, dB (Table 7) | 44.92 |",
        "| SVMesh & MVMesh (cell meshes, tables), MB | 101.4 |",
        "| SVMesh from clustered objects % (Table 3) | – |",
        "| park-4m (4M) | lod | lod: not available (",
        "park-2m: at the hybrid's",
        "Fixture CPU",
        "| polygons of SVMesh & MVMesh | 40,742 |",
        "| cells (grid) | 22 × 24 |",
        // Our deviation sweep has no paper columns.
        "| 4M, deviation px (not in the paper) | deviation px 0 ours (",
    ] {
        assert!(want.contains(needle), "expected.md lacks {needle:?}");
    }
    assert!(!want.contains("stale text"), "every section replaced");
    let park = golden("park");
    for needle in [
        "| 4M, T_s (Table 3) | T_s 3 paper |",
        "| 4M, T_l (Table 4) |",
        "| 4M, cell size (Table 5) |",
        "| park-2m (2M) | lod, 1 px |",
        "| park-2m (2M) | lod, 4 px |",
        "| FPS (ours: lavapipe, hybrid draw) | 271.5 |",
    ] {
        assert!(park.contains(needle), "park expected.md lacks {needle:?}");
    }
}

#[test]
fn a_missing_marker_is_an_error_and_the_document_stays() {
    let (_tmp, results, doc) = setup("fixture");
    let text = std::fs::read_to_string(&doc)
        .unwrap()
        .replace("<!-- bench:storage end -->", "");
    std::fs::write(&doc, &text).unwrap();
    let e = regenerate(&results, &doc, "docs/bench").unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("<!-- bench:storage end -->") && msg.contains("doc.md"),
        "{msg}"
    );
    assert_eq!(std::fs::read_to_string(&doc).unwrap(), text);
}

#[test]
fn a_run_file_of_another_schema_is_refused() {
    let (_tmp, results, doc) = setup("fixture");
    let path = results.join("run-fixture.json");
    let text =
        std::fs::read_to_string(&path)
            .unwrap()
            .replacen("\"schema\": 1", "\"schema\": 99", 1);
    std::fs::write(&path, text).unwrap();
    let e = regenerate(&results, &doc, "docs/bench").unwrap_err();
    assert!(format!("{e:#}").contains("schema 99"), "{e:#}");
}
