//! The output directory's lock: one `pipeline run` at a time per output directory.
//! `<out>/.lock` holds the holder's pid and host. It is published whole
//! ([`format::pack::create_new_atomic`]: a temp file hard-linked to `.lock`, which
//! fails when `.lock` exists), so a SIGKILL at any moment leaves either no lock or a
//! complete one, never a torn one. A lock left by a dead process on this host is
//! taken over (a crash must not block the next run). The temp file a kill may leave
//! is swept with the other stale temp files.

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
}
