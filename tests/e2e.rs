//! End-to-end tests that run hexbake's binaries, each in its own temp dir
//! (STYLE.md habit 10). Tests that need the real meshes skip with a note when
//! `models/` has not been fetched (`scripts/fetch-models.sh`; CI always fetches).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Builds the binaries once per test run (a no-op when fresh) and returns the
/// directory holding them (the profile directory of this test executable).
fn bin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        let dir = exe.parent().unwrap().parent().unwrap().to_path_buf(); // target/<profile>
        let profile = dir.file_name().unwrap().to_str().unwrap().to_string();
        let mut cmd = Command::new(env!("CARGO"));
        cmd.current_dir(repo()).args([
            "build", "--bins", "-p", "worker", "-p", "pipeline", "-p", "player",
        ]);
        if profile != "debug" {
            cmd.args([
                "--profile",
                if profile == "release" {
                    "release"
                } else {
                    &profile
                },
            ]);
        }
        let status = cmd.status().expect("cargo runs");
        assert!(status.success(), "building the binaries failed");
        dir
    })
}

fn run(bin: &str, args: &[&str], cwd: &Path) -> Output {
    Command::new(bin_dir().join(bin))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {bin}: {e}"))
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn models_present() -> bool {
    let ok = repo().join("models/bunny.obj").exists();
    if !ok {
        eprintln!("SKIP: models/ not fetched (run scripts/fetch-models.sh)");
    }
    ok
}

fn scene_json(manifest: &str) -> serde_json::Value {
    let out = run("pipeline", &["scene", manifest, "--json"], &repo());
    assert!(
        out.status.success(),
        "pipeline scene {manifest}: {}",
        stderr(&out)
    );
    serde_json::from_str(&stdout(&out)).expect("scene --json prints JSON")
}

#[test]
fn scene_of_demo_needs_no_download() {
    let v = scene_json("manifests/demo.ron");
    assert!(v["instances"].as_u64().unwrap() > 0);
    assert!(v["triangles"].as_u64().unwrap() > 0);
    let grid = v["grid"].as_array().unwrap();
    let cells = grid[0].as_u64().unwrap() * grid[1].as_u64().unwrap();
    assert_eq!(v["cells"].as_u64().unwrap(), cells);
    for m in v["models"].as_array().unwrap() {
        assert!(
            m["source"].as_str().unwrap().starts_with("procedural:"),
            "{m}"
        );
    }
}

/// Issue 2: the parks reproduce the paper's Table 2 (64 / 132 / 253 instances,
/// 2.0M / 4.2M / 8.0M triangles within 5%, 22 × 24 cells).
#[test]
fn park_scenes_match_the_paper() {
    if !models_present() {
        return;
    }
    for (name, instances, triangles) in [
        ("park-2m", 64, 2_017_700.0),
        ("park-4m", 132, 4_188_885.0),
        ("park-8m", 253, 8_004_863.0),
    ] {
        let v = scene_json(&format!("manifests/{name}.ron"));
        assert_eq!(v["instances"].as_u64().unwrap(), instances, "{name}");
        let t = v["triangles"].as_u64().unwrap() as f64;
        assert!(
            (t / triangles - 1.0).abs() <= 0.05,
            "{name}: {t} triangles, paper {triangles}"
        );
        assert_eq!(v["grid"], serde_json::json!([22, 24]), "{name}");
        assert_eq!(v["models"].as_array().unwrap().len(), 8, "{name}");
    }
}

/// Issue 2: 2M ⊂ 4M ⊂ 8M — every instance of the smaller park stands at the same
/// place with the same model and tint in the larger one.
#[test]
fn park_scenes_are_nested() {
    if !models_present() {
        return;
    }
    let load = |name: &str| {
        let plan = format::manifest::parse_manifest(&repo().join(format!("manifests/{name}.ron")))
            .unwrap();
        plan.load_scene().unwrap()
    };
    let scenes = [load("park-2m"), load("park-4m"), load("park-8m")];
    for pair in scenes.windows(2) {
        let (small, big) = (&pair[0], &pair[1]);
        for inst in &small.instances {
            let name = &small.models[inst.model as usize].name;
            assert!(
                big.instances
                    .iter()
                    .any(|b| big.models[b.model as usize].name == *name
                        && b.transform == inst.transform
                        && b.tint == inst.tint),
                "instance of {name} at {:?} missing from the larger park",
                inst.transform.w_axis
            );
        }
    }
}

#[test]
fn misspelled_manifest_field_exits_2_with_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("manifests/demo.ron"))
        .unwrap()
        .replacen("cell_size", "cel_size", 1);
    let line = text
        .lines()
        .position(|l| l.contains("cel_size"))
        .expect("demo.ron has a cell_size")
        + 1;
    let path = dir.path().join("typo.ron");
    std::fs::write(&path, text).unwrap();
    let out = run("pipeline", &["scene", path.to_str().unwrap()], dir.path());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "one readable line: {err}");
    assert!(err.contains(&format!("typo.ron:{line}:")), "{err}");
    assert!(err.contains("cel_size"), "{err}");
}

#[test]
fn missing_manifest_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("pipeline", &["scene", "nope.ron"], dir.path());
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("nope.ron"), "{}", stderr(&out));
}

#[test]
fn player_prints_its_version() {
    let out = run("player", &["--version"], &repo());
    assert!(out.status.success());
    assert!(stdout(&out).contains(env!("CARGO_PKG_VERSION")));
}
