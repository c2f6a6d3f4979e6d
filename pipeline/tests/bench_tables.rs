//! BENCHMARKS.md generation (issue 8): a small run file (`tests/data/bench/
//! run-fixture.json`: a tiny bench.sh run on procedural scenes relabelled as the
//! parks, cut down, plus two synthetic lod points) regenerates a template's marked
//! sections into exactly `expected.md`; text outside the markers is untouched; the
//! walk plot is written; a missing marker is an error that leaves the document as it
//! was. Re-bless the golden file with `HEXBAKE_BLESS=1`.

use pipeline::bench_tables::regenerate;
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bench")
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

fn setup() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let results = tmp.path().join("results");
    std::fs::create_dir_all(&results).unwrap();
    std::fs::copy(
        data().join("run-fixture.json"),
        results.join("run-fixture.json"),
    )
    .unwrap();
    let doc = tmp.path().join("doc.md");
    std::fs::copy(data().join("template.md"), &doc).unwrap();
    (tmp, results, doc)
}

#[test]
fn fixture_regenerates_the_golden_document() {
    let (_tmp, results, doc) = setup();
    let r = regenerate(&results, &doc, "docs/bench").unwrap();
    assert_eq!(r.runs, 1);
    let got = std::fs::read_to_string(&doc).unwrap();
    let golden = data().join("expected.md");
    if std::env::var_os("HEXBAKE_BLESS").is_some() {
        std::fs::write(&golden, &got).unwrap();
    }
    let want = std::fs::read_to_string(&golden).expect("expected.md (HEXBAKE_BLESS=1 writes it)");
    assert!(
        got == want,
        "generated document differs from {}; got:\n{got}",
        golden.display()
    );
    // Outside the markers nothing changed.
    let template = std::fs::read_to_string(data().join("template.md")).unwrap();
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
fn golden_has_the_papers_numbers_and_ours_side_by_side() {
    let want = std::fs::read_to_string(data().join("expected.md")).unwrap();
    // Paper constants (Table 7 PSNR, Table 8 storage, Table 3 percentages) next to
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
}

#[test]
fn a_missing_marker_is_an_error_and_the_document_stays() {
    let (_tmp, results, doc) = setup();
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
    let (_tmp, results, doc) = setup();
    let path = results.join("run-fixture.json");
    let text =
        std::fs::read_to_string(&path)
            .unwrap()
            .replacen("\"schema\": 1", "\"schema\": 99", 1);
    std::fs::write(&path, text).unwrap();
    let e = regenerate(&results, &doc, "docs/bench").unwrap_err();
    assert!(format!("{e:#}").contains("schema 99"), "{e:#}");
}
