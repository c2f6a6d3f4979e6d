//! What every end-to-end test file needs: the repository root, the binaries
//! (built once per test run) and running them.

#![allow(dead_code)] // each test file uses a part of it

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Builds the binaries once per test run (a no-op when fresh) and returns the
/// directory holding them (the profile directory of this test executable).
///
/// `--tests` makes cargo resolve features as `cargo test --workspace` did (with the
/// dev-dependencies), so the binaries link the dependencies that test run already
/// compiled; without it cargo compiled a second copy of wgpu, winit and friends,
/// which filled a CI machine's disk.
pub fn bin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        let dir = exe.parent().unwrap().parent().unwrap().to_path_buf(); // target/<profile>
        let profile = dir.file_name().unwrap().to_str().unwrap().to_string();
        let mut cmd = Command::new(env!("CARGO"));
        cmd.current_dir(repo())
            .args(["build", "--workspace", "--bins", "--tests"]);
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

pub fn run(bin: &str, args: &[&str], cwd: &Path) -> Output {
    Command::new(bin_dir().join(bin))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {bin}: {e}"))
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A bake's current generation (issue 32): `index.pack` and every file it names (its
/// base, cell and far-field group packs), by name, sorted by name after the index.
/// This is what a reader sees; working files and the previous generation's files,
/// kept for readers still on it, are not part of it.
pub fn generation_files(out: &Path) -> Vec<(String, Vec<u8>)> {
    let read = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let index_bytes = read(out.join("index.pack"));
    let index = format::pack::Index::from_bytes(&index_bytes)
        .unwrap_or_else(|e| panic!("{}: {e}", out.join("index.pack").display()));
    let mut files = vec![("index.pack".to_string(), index_bytes)];
    for name in format::pack::generation::named_files(&index) {
        let bytes = read(out.join(&name));
        files.push((name, bytes));
    }
    files
}
