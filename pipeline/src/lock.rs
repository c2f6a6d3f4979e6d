//! The output directory's lock: one `pipeline run` at a time per output directory.
//! `<out>/.lock` holds the holder's pid and host. It is published whole
//! ([`format::pack::create_new_atomic`]: a temp file hard-linked to `.lock`, which
//! fails when `.lock` exists), so a SIGKILL at any moment leaves either no lock or a
//! complete one, never a torn one. A lock left by a dead process on this host is
//! taken over (a crash must not block the next run). The temp file a kill may leave
//! is swept with the other stale temp files.
//!
//! Before the lock, [`create_output_dir`] makes the directory itself, with errors that
//! name the path and say what hexbake was doing (issue 19: `--out` inside `/proc` or
//! naming a regular file printed a bare "No such file or directory" / "File exists").
//!
//! The lock keeps out other runs on this host and others; the tasks of an earlier
//! Slurm submission still writing into the output are kept out by
//! [`refuse_while_queued`] (the submission is `format::schema::slurm`).

use format::schema::slurm::read_submission;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
}

#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error("{path}: another `pipeline run` holds this output (pid {pid} on {host}); wait for it or stop it")]
    Held {
        path: PathBuf,
        pid: u32,
        host: String,
    },
    #[error("{path}: a lock file is being written right now (its text {text:?} is not yet `<pid> <host>`); if no `pipeline run` uses this output, remove it")]
    Unreadable { path: PathBuf, text: String },
    #[error("{path}: cannot create the lock file: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// Why the output directory cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum OutputDirError {
    #[error(
        "{}: cannot write the bake there: {} is a file, not a directory (the output is a \
         directory of packs; choose a new or existing directory for --out or the \
         manifest's `output`)",
        out.display(), file.display()
    )]
    NotADirectory { out: PathBuf, file: PathBuf },
    #[error("{}: cannot create the output directory: {source}", out.display())]
    Create {
        out: PathBuf,
        source: std::io::Error,
    },
}

/// Creates the output directory `out` and its parents (nothing when it exists), or
/// says why not, naming the path: `out` or one of its ancestors is a file, or the
/// system refuses the directory (inside `/proc`, a read-only file system, no
/// permission).
pub fn create_output_dir(out: &Path) -> Result<(), OutputDirError> {
    // The nearest existing ancestor (or `out` itself) must be a directory.
    if let Some(file) = out
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| a.symlink_metadata().is_ok())
        .filter(|a| !a.is_dir())
    {
        return Err(OutputDirError::NotADirectory {
            out: out.to_path_buf(),
            file: file.to_path_buf(),
        });
    }
    std::fs::create_dir_all(out).map_err(|source| OutputDirError::Create {
        out: out.to_path_buf(),
        source,
    })
}

/// A lock whose text does not parse and that has not changed for this long was torn
/// by a kill (only possible on the `create_new` fallback, or from an older hexbake).
const TORN_LOCK_AGE: Duration = Duration::from_secs(10);

/// What an existing lock file says about its holder.
enum Holder {
    /// `pid` on `host`.
    Process { pid: u32, host: String },
    /// The text does not parse; `age` since it was last modified.
    Torn { text: String, age: Duration },
}

fn read_holder(path: &Path) -> std::io::Result<Holder> {
    let text = std::fs::read_to_string(path)?;
    let mut parts = text.split_whitespace();
    let pid = parts.next().and_then(|p| p.parse::<u32>().ok());
    let host = parts.next();
    Ok(match (pid, host, parts.next()) {
        (Some(pid), Some(host), None) if pid != 0 => Holder::Process {
            pid,
            host: host.to_string(),
        },
        _ => {
            let age = std::fs::metadata(path)?
                .modified()?
                .elapsed()
                .unwrap_or_default();
            Holder::Torn { text, age }
        }
    })
}

impl OutputLock {
    pub fn acquire(out: &Path) -> Result<OutputLock, LockError> {
        let path = out.join(".lock");
        let me = std::process::id();
        let host = format::pack::hostname();
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| LockError::Io { path, source }
        };
        for _ in 0..3 {
            match format::pack::create_new_atomic(&path, format!("{me} {host}\n").as_bytes()) {
                Ok(()) => return Ok(OutputLock { path }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = match read_holder(&path) {
                        Ok(h) => h,
                        // Released between our attempt and the read: try again.
                        Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                        Err(e) => return Err(io(&path)(e)),
                    };
                    let stale = match &holder {
                        Holder::Process { pid, host: h } => {
                            *h == host && !format::pack::process_alive(*pid)
                        }
                        Holder::Torn { age, .. } => *age >= TORN_LOCK_AGE,
                    };
                    if stale {
                        // Its process is gone. Take it over.
                        match std::fs::remove_file(&path) {
                            Ok(()) => continue,
                            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                            Err(e) => return Err(io(&path)(e)),
                        }
                    }
                    return Err(match holder {
                        Holder::Process { pid, host } => LockError::Held { path, pid, host },
                        Holder::Torn { text, .. } => LockError::Unreadable { path, text },
                    });
                }
                Err(source) => return Err(LockError::Io { path, source }),
            }
        }
        Err(LockError::Io {
            path,
            source: std::io::Error::other("the lock file keeps reappearing"),
        })
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Refuses to start a run on `out` while tasks of its last Slurm submission are
/// queued or running: they write into the output, so a second run would bake their
/// jobs twice and could not tell their temp files from those of a killed run. The
/// finalize job is not counted: where a task failed and the cluster lacks
/// `kill_invalid_depend` it stays pending forever, and running it twice is harmless.
/// Where `squeue` cannot run (no Slurm here) nothing is refused.
pub fn refuse_while_queued(out: &Path) -> anyhow::Result<()> {
    let Some(sub) = read_submission(out) else {
        return Ok(());
    };
    let Ok(tasks) = queued(&[&sub.array_job]) else {
        return Ok(());
    };
    if tasks.is_empty() {
        return Ok(());
    }
    Err(anyhow::anyhow!(
        "{}: tasks of Slurm array job {} (the last submission for this output) are still queued or running ({}); wait for them (`pipeline status {}`) or cancel them (`scancel {}`), then run again",
        out.display(),
        sub.array_job,
        tasks.join(" "),
        out.display(),
        sub.array_job
    ))
}

/// Ids among `ids` that squeue still lists (pending, running, completing).
pub fn queued(ids: &[&str]) -> anyhow::Result<Vec<String>> {
    let out = std::process::Command::new("squeue")
        .args(["-h", "-o", "%i", "-j", &ids.join(",")])
        .output()
        .map_err(|e| anyhow::anyhow!("cannot run squeue: {e}"))?;
    // squeue fails for ids it has forgotten: that means nothing is queued.
    if !out.status.success() {
        return Ok(Vec::new());
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.trim().to_string())
        .filter(|l| !l.is_empty())
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lock_is_exclusive_and_released() {
        let dir = tempfile::tempdir().unwrap();
        let a = OutputLock::acquire(dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join(".lock")).unwrap();
        assert_eq!(
            text,
            format!("{} {}\n", std::process::id(), format::pack::hostname())
        );
        assert!(matches!(
            OutputLock::acquire(dir.path()),
            Err(LockError::Held { .. })
        ));
        drop(a);
        assert!(!dir.path().join(".lock").exists());
        // Nothing but the lock was ever left in the directory.
        let _b = OutputLock::acquire(dir.path()).unwrap();
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from(".lock")]);
    }

    #[test]
    fn torn_locks_block_while_fresh_and_are_taken_over_when_old() {
        let dir = tempfile::tempdir().unwrap();
        let lock = dir.path().join(".lock");
        // What a kill between writing the pid and the host used to leave.
        for torn in ["", "3313", "3313 ", "0 host", "x y"] {
            std::fs::write(&lock, torn).unwrap();
            assert!(
                matches!(
                    OutputLock::acquire(dir.path()),
                    Err(LockError::Unreadable { .. })
                ),
                "{torn:?}"
            );
            let old = std::time::SystemTime::now() - TORN_LOCK_AGE - Duration::from_secs(1);
            std::fs::File::options()
                .write(true)
                .open(&lock)
                .unwrap()
                .set_modified(old)
                .unwrap();
            let l = OutputLock::acquire(dir.path()).unwrap();
            drop(l);
        }
    }

    #[test]
    fn a_dead_holder_here_is_taken_over_a_live_or_remote_one_is_not() {
        let dir = tempfile::tempdir().unwrap();
        let lock = dir.path().join(".lock");
        let host = format::pack::hostname();
        std::fs::write(&lock, format!("999999999 {host}\n")).unwrap();
        drop(OutputLock::acquire(dir.path()).unwrap());
        std::fs::write(&lock, format!("{} {host}\n", std::process::id())).unwrap();
        assert!(OutputLock::acquire(dir.path()).is_err());
        std::fs::write(&lock, "999999999 some-other-node\n").unwrap();
        assert!(matches!(
            OutputLock::acquire(dir.path()),
            Err(LockError::Held { pid: 999999999, .. })
        ));
    }

    /// Issue 19: the errors name the path and what was being done.
    #[test]
    fn output_dir_errors_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a-file");
        std::fs::write(&file, "x").unwrap();
        for out in [file.clone(), file.join("sub/deeper")] {
            let e = create_output_dir(&out).unwrap_err();
            assert!(
                matches!(&e, OutputDirError::NotADirectory { file: f, .. } if *f == file),
                "{e}"
            );
            let shown = e.to_string();
            assert!(
                shown.starts_with(&format!("{}: ", out.display())),
                "{shown}"
            );
            assert!(shown.contains("is a file, not a directory"), "{shown}");
        }
        let e = create_output_dir(std::path::Path::new("/proc/hexbake-out")).unwrap_err();
        let shown = e.to_string();
        assert!(
            shown.starts_with("/proc/hexbake-out: cannot create the output directory: "),
            "{shown}"
        );
        // New and existing directories are fine.
        let new = dir.path().join("x/y");
        create_output_dir(&new).unwrap();
        create_output_dir(&new).unwrap();
    }
}
