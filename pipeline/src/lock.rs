//! The output directory's lock: one `pipeline run` at a time per output directory.
//! `<out>/.lock` holds the holder's pid and host; it is created with `create_new`
//! (atomic), removed on drop, and a lock left by a dead process on this host is
//! taken over (a crash must not block the next run).

use std::io::Write;
use std::path::{Path, PathBuf};

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
    #[error("{path}: cannot create the lock file: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl OutputLock {
    pub fn acquire(out: &Path) -> Result<OutputLock, LockError> {
        let path = out.join(".lock");
        let me = std::process::id();
        let host = format::pack::hostname();
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    writeln!(f, "{me} {host}").map_err(|source| LockError::Io {
                        path: path.clone(),
                        source,
                    })?;
                    return Ok(OutputLock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(&path).unwrap_or_default();
                    let mut parts = text.split_whitespace();
                    let pid: u32 = parts.next().and_then(|p| p.parse().ok()).unwrap_or(0);
                    let holder = parts.next().unwrap_or("").to_string();
                    if holder == host && (pid == 0 || !format::pack::process_alive(pid)) {
                        // Stale: its process is gone. Take it over.
                        let _ = std::fs::remove_file(&path);
                        continue;
                    }
                    return Err(LockError::Held {
                        path,
                        pid,
                        host: holder,
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
