//! Helpers shared by the pipeline's integration tests that run the real binary.
#![allow(dead_code)] // each test file uses its own subset

pub use std::path::{Path, PathBuf};
pub use std::process::{Command, Output};

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs `pipeline ARGS` in the repository root.
pub fn pipeline(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pipeline"))
        .args(args)
        .current_dir(repo())
        .output()
        .expect("pipeline runs")
}

/// Bakes `manifest` into `out`: `pipeline run MANIFEST --quiet --out OUT EXTRA...`.
pub fn run_quiet(manifest: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["run", manifest, "--quiet", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    pipeline(&args)
}

/// The JSON a command printed, once it is known to have succeeded.
pub fn succeeded_json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", text(o));
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts the run refused its input (exit 2) without panicking, naming each of
/// `says` in its message.
pub fn assert_bad_input(out: &Output, says: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for s in says {
        assert!(err.contains(s), "expected {s:?} in: {err}");
    }
}

/// Both streams, for assertion messages.
pub fn text(o: &Output) -> String {
    format!(
        "stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// [`pipeline`] with the child's own CPU time (user + system, seconds) and peak
/// resident memory (KiB), read with `wait4` (Linux).
#[allow(clippy::zombie_processes)] // reaped by `wait4` below, which also gives its rusage
pub fn pipeline_measured(args: &[&str]) -> (Output, f64, u64) {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    let mut child = Command::new(env!("CARGO_BIN_EXE_pipeline"))
        .args(args)
        .current_dir(repo())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("pipeline runs");
    // The commands measured print a few lines: read both pipes, then reap.
    let (mut stdout, mut stderr) = (Vec::new(), Vec::new());
    child
        .stdout
        .take()
        .unwrap()
        .read_to_end(&mut stdout)
        .unwrap();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_end(&mut stderr)
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: plain syscall on our own child; `usage` is a valid out-parameter.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(reaped, pid, "wait4 on the pipeline child");
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    let cpu = seconds(usage.ru_utime) + seconds(usage.ru_stime);
    let output = Output {
        status: std::process::ExitStatus::from_raw(status),
        stdout,
        stderr,
    };
    (output, cpu, usage.ru_maxrss as u64)
}
