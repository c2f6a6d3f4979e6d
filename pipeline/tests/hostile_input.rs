//! Issue 19, "Trust nothing read from disk": manifests that parse but cannot be baked,
//! and outputs that cannot be written, are refused by the real `pipeline` binary with
//! exit code 2 and a message that says where (file:line:column of the field, or the
//! path and what hexbake was doing) — never a panic (exit 101) or an exhausted memory.

mod common;
use common::*;

/// The demo manifest with `from` replaced by `to`, written to `dir/m.ron`.
fn demo_with(dir: &Path, from: &str, to: &str) -> PathBuf {
    let demo = std::fs::read_to_string(repo().join("manifests/demo.ron")).unwrap();
    assert!(demo.contains(from), "{from}");
    let path = dir.join("m.ron");
    std::fs::write(&path, demo.replace(from, to)).unwrap();
    path
}

/// 1-based (line, column) of the first occurrence of `needle` in the file at `path`.
fn position_in(path: &Path, needle: &str) -> (usize, usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let offset = text.find(needle).expect("needle in text");
    let line = text[..offset].matches('\n').count() + 1;
    let line_start = text[..offset].rfind('\n').map_or(0, |k| k + 1);
    (line, text[line_start..offset].chars().count() + 1)
}

/// `cell_size: 0.001` on the demo's ground panicked in the worker's grid (exit 101).
#[test]
fn scene_and_run_refuse_a_grid_too_large_with_its_position() {
    let dir = tempfile::tempdir().unwrap();
    let m = demo_with(dir.path(), "cell_size: 50.0", "cell_size: 0.001");
    let (line, col) = position_in(&m, "cell_size");
    let at = format!("m.ron:{line}:{col}: `cells.cell_size`");
    let out_dir = dir.path().join("out");
    for args in [
        vec!["scene", m.to_str().unwrap()],
        vec![
            "run",
            m.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
            "--quiet",
        ],
    ] {
        assert_bad_input(&pipeline(&args), &[&at, "more than 1000000"]);
    }
    assert!(!out_dir.exists(), "nothing written for a refused manifest");
}

/// The same rule for `--set cell_size=...`.
#[test]
fn run_refuses_a_cell_size_override_too_small() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    let out = run_quiet(
        "manifests/demo.ron",
        &out_dir,
        &["--set", "cell_size=0.001"],
    );
    assert_bad_input(&out, &["--set cells.cell_size=0.001", "more than 1000000"]);
    assert!(!out_dir.exists());
}

/// Values that parse but no f32 rasterizer can bake.
#[test]
fn scene_refuses_absurd_values_with_their_position() {
    let dir = tempfile::tempdir().unwrap();
    for (from, to, key, field) in [
        (
            "max_eye_height: 12.0",
            "max_eye_height: 1e30",
            "max_eye_height",
            "cells.max_eye_height",
        ),
        (
            "max: (300.0, 260.0)",
            "max: (300.0, 1e38)",
            "max:",
            "ground.max",
        ),
        (
            "count: 4, target_height: 20.0",
            "count: 4, target_height: 1e30",
            "target_height: 1e30",
            "scene.models[0].target_height",
        ),
    ] {
        let m = demo_with(dir.path(), from, to);
        let (line, col) = position_in(&m, key);
        let at = format!("m.ron:{line}:{col}: `{field}`");
        assert_bad_input(&pipeline(&["scene", m.to_str().unwrap()]), &[&at]);
    }
}

/// 100,000 `[` exhausted memory before ron parsed anything.
#[test]
fn scene_refuses_deep_nesting_quickly() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("deep.ron");
    std::fs::write(&m, "[".repeat(100_000)).unwrap();
    let out = pipeline(&["scene", m.to_str().unwrap()]);
    assert_bad_input(&out, &["deep.ron:1:65: ", "nested more than 64 deep"]);
}

/// The four manifests (cell size 0.001, 100,000 brackets, an eye height of
/// 1e30, a coordinate of 1e38) are refused with their position using under a second
/// of CPU and under 100 MB of memory each.
#[test]
fn hostile_manifests_are_refused_quickly_and_in_little_memory() {
    let dir = tempfile::tempdir().unwrap();
    let deep = dir.path().join("deep.ron");
    std::fs::write(&deep, "[".repeat(100_000)).unwrap();
    let case = |name: &str, from: &str, to: &str| {
        let sub = dir.path().join(name);
        std::fs::create_dir_all(&sub).unwrap();
        demo_with(&sub, from, to)
    };
    let cases = [
        case("cell", "cell_size: 50.0", "cell_size: 0.001"),
        deep,
        case("eye", "max_eye_height: 12.0", "max_eye_height: 1e30"),
        case("ground", "max: (300.0, 260.0)", "max: (300.0, 1e38)"),
    ];
    for m in &cases {
        let (out, cpu_s, rss_kib) = pipeline_measured(&["scene", m.to_str().unwrap()]);
        let err = stderr(&out);
        eprintln!("{}: {cpu_s:.3} s CPU, {rss_kib} KiB: {err}", m.display());
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(".ron:"), "positioned: {err}");
        assert!(cpu_s < 1.0, "{cpu_s} s CPU: {err}");
        assert!(rss_kib < 100 * 1024, "{rss_kib} KiB: {err}");
    }
}

/// `--out` inside /proc printed a bare "No such file or directory", and `--out`
/// naming a regular file a bare "File exists": both now name the path and what
/// hexbake was doing.
#[test]
fn run_names_an_output_path_it_cannot_use() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let file_s = file.to_str().unwrap().to_string();
    let below = format!("{file_s}/out");
    for (out, says) in [
        (
            "/proc/hexbake-out".to_string(),
            "/proc/hexbake-out: cannot create the output directory: No such file or directory"
                .to_string(),
        ),
        (
            file_s.clone(),
            format!("{file_s}: cannot write the bake there: {file_s} is a file, not a directory"),
        ),
        (
            below.clone(),
            format!("{below}: cannot write the bake there: {file_s} is a file"),
        ),
    ] {
        let o = run_quiet("manifests/demo.ron", Path::new(&out), &[]);
        assert_bad_input(&o, &[&says]);
    }
    assert_eq!(
        std::fs::read_to_string(&file).unwrap(),
        "not a directory",
        "the file is left alone"
    );
}
