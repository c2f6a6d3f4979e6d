//! Issue 19: `pipeline inspect <out>` verifies a whole bake — every cell pack against
//! `index.pack` (size, checksum, job fingerprint) and `base.pack` — and a pack of
//! another setting copied into the bake is reported by name (exit 1).

mod common;
use common::*;

#[test]
fn inspect_of_a_bake_directory_finds_a_pack_of_another_setting() {
    let tmp = tempfile::tempdir().unwrap();
    let (ours, other) = (tmp.path().join("ours"), tmp.path().join("other"));
    let o = run_quiet("tests/data/tiny.ron", &ours, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let v = succeeded_json(&pipeline(&["inspect", ours.to_str().unwrap(), "--json"]));
    assert_eq!(v["cells_indexed"], 9, "{v}");
    assert_eq!(v["cells_ok"], 9, "{v}");

    // The same cell baked with another T_l, copied over ours.
    let o = run_quiet("tests/data/tiny.ron", &other, &["--set", "T_l=3.0"]);
    assert!(o.status.success(), "{}", text(&o));
    // Over the file the index names (format version 7: a name of its content).
    let named = format::pack::Index::read(&ours.join("index.pack"))
        .unwrap()
        .cell(4)
        .unwrap()
        .file
        .clone();
    assert!(named.starts_with("cells/4-"), "{named}");
    std::fs::copy(other.join("cells/4.pack"), ours.join(&named)).unwrap();
    let o = pipeline(&["inspect", ours.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains(&named), "{out}");
    assert!(out.contains("8 of 9"), "{out}");
}
