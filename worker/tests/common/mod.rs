//! Helpers shared by the worker's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use std::path::PathBuf;

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The downloaded models (`scripts/fetch-models.sh`): `$HEXBAKE_MODELS`, else
/// `models/` in the repository.
pub fn models_dir() -> PathBuf {
    std::env::var_os("HEXBAKE_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("models"))
}

/// Runs `f` in a rayon pool of `threads` threads (determinism across thread counts).
pub fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}
