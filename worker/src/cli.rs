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
