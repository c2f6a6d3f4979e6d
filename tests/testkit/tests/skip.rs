//! `skip` as a test sees it: run this test binary again with one ignored test that
//! skips, under each setting of `HEXBAKE_REQUIRE_GPU` and `HEXBAKE_SKIP_LOG`.

use std::process::{Command, Output};
use testkit::Need;

/// Not a test of its own: the child run of [`run_child`].
#[test]
#[ignore = "run by the other tests in a child process"]
fn child_that_skips() {
    if std::env::var_os("TESTKIT_CHILD").is_none() {
        return; // `cargo test -- --ignored` by hand: nothing to skip
    }
    testkit::skip(Need::Gpu, "no adapter\there\n(test)");
}

fn run_child(require: Option<&str>, log: Option<&std::path::Path>) -> Output {
    let mut cmd = Command::new(std::env::current_exe().unwrap());
    cmd.args(["--ignored", "--exact", "child_that_skips", "--nocapture"])
        .env_remove("HEXBAKE_REQUIRE_GPU")
        .env("TESTKIT_CHILD", "1")
        .env_remove(testkit::SKIP_LOG);
    if let Some(v) = require {
        cmd.env("HEXBAKE_REQUIRE_GPU", v);
    }
    if let Some(l) = log {
        cmd.env(testkit::SKIP_LOG, l);
    }
    cmd.output().unwrap()
}

#[test]
fn unset_or_0_skips_and_logs_one_line() {
    let dir = tempfile_dir();
    let log = dir.join("skips.tsv");
    for require in [None, Some("0")] {
        let o = run_child(require, Some(&log));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{require:?}: {err}");
        assert!(
            err.contains(
                "SKIP tests/testkit/tests/skip.rs::child_that_skips: no adapter here (test)"
            ),
            "{err}"
        );
    }
    let text = std::fs::read_to_string(&log).unwrap();
    let line = "tests/testkit/tests/skip.rs::child_that_skips\tno adapter here (test)\n";
    assert_eq!(text, format!("{line}{line}"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn without_a_log_it_only_prints() {
    let o = run_child(None, None);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("SKIP "));
}

#[test]
fn required_fails_the_test_and_logs_nothing() {
    let dir = tempfile_dir();
    let log = dir.join("skips.tsv");
    for require in ["1", "true", "yes"] {
        let o = run_child(Some(require), Some(&log));
        let out = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{require}: {out}");
        assert!(
            out.contains(&format!(
                "HEXBAKE_REQUIRE_GPU={require} but no adapter here (test)"
            )),
            "{out}"
        );
    }
    assert!(!log.exists());
    // A value that is neither yes nor no fails too, instead of skipping.
    let o = run_child(Some("on"), Some(&log));
    assert!(!o.status.success());
    assert!(!log.exists());
    std::fs::remove_dir_all(dir).unwrap();
}

/// A fresh directory under the system temp dir (no tempfile dependency here).
fn tempfile_dir() -> std::path::PathBuf {
    use std::sync::atomic::{AtomicU32, Ordering};
    static N: AtomicU32 = AtomicU32::new(0);
    let d = std::env::temp_dir().join(format!(
        "testkit-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}
