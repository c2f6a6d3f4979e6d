//! What the command-line tools on the worker library (`worker`, `pipeline`) share:
//! a failure with the exit code it maps to, the way it is printed, and Unix pipe
//! manners.

use std::process::ExitCode;

/// An error with the exit code it maps to: 2 for bad input, 1 for a failure.
pub struct Failure {
    pub code: u8,
    pub error: anyhow::Error,
}

/// Bad input (exit code 2): a manifest, flag or file the command cannot use.
pub fn bad_input(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 2,
        error: error.into(),
    }
}

/// A failure (exit code 1): the input was fine, the work did not succeed.
pub fn failed(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 1,
        error: error.into(),
    }
}

/// The exit code of a command's outcome; a failure is first printed to stderr as
/// `error: ` and its [`error_text`](crate::error_text).
pub fn exit_code(outcome: Result<(), Failure>) -> ExitCode {
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", crate::error_text(f.error.as_ref()));
            ExitCode::from(f.code)
        }
    }
}

/// glibc's malloc arenas a bake process may use, unless `MALLOC_ARENA_MAX` says
/// otherwise ([`limit_malloc_arenas`]).
pub const MALLOC_ARENAS: i32 = 2;

/// Caps glibc's malloc arenas at [`MALLOC_ARENAS`] (issue 27 item 4, memory). By
/// default glibc gives threads up to 8 arenas per core, and each keeps the memory
/// its thread freed: on park-2m's cell-275 sample bake the heap peaked at 228 MB
/// (massif) while the process held 298 MB; with two arenas it holds 254 MB, at the
/// same CPU time (mimalloc held 417 MB); city-2m's cell-231 sample 992 → 871 MB. Call it first thing in `main`, before any
/// thread starts. A `MALLOC_ARENA_MAX` in the environment wins; other allocators
/// and platforms are left alone.
pub fn limit_malloc_arenas() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if std::env::var_os("MALLOC_ARENA_MAX").is_none() {
        // SAFETY: mallopt only sets an allocator parameter; called before any
        // thread starts.
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, MALLOC_ARENAS);
        }
    }
}

/// Like other Unix tools, end quietly when stdout is a closed pipe (`| head`) instead
/// of panicking in `println!`: restore the default SIGPIPE action Rust ignores.
/// Call it first thing in `main`.
pub fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread starts; setting a
    // signal's disposition to SIG_DFL has no other precondition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
