//! The `pipeline` binary's subcommands, one module each: its flags (`Args`) and what
//! it does (`run`); below, what several of them share (exit codes of run errors,
//! summaries, JSON or text output).

pub mod export;
pub mod finalize;
pub mod inspect;
pub mod report;
pub mod run;
pub mod scene;
pub mod status;

pub use std::path::PathBuf;
pub use worker::cli::{bad_input, failed, Failure};

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExecutorArg {
    Local,
    Slurm,
}

pub fn from_run(e: pipeline::run::RunError) -> Failure {
    match e {
        pipeline::run::RunError::BadInput(error) => bad_input(error),
        pipeline::run::RunError::Failed(error) => failed(error),
    }
}

/// Prints the summary of a `--cells` run; Ok when every requested cell is baked.
pub fn finish_selected(
    summary: &pipeline::run::RunSummary,
    partial: Option<&pipeline::run::Partial>,
    json: bool,
) -> Result<(), Failure> {
    #[derive(serde::Serialize)]
    struct Selected<'a> {
        #[serde(flatten)]
        summary: &'a pipeline::run::RunSummary,
        partial: Option<&'a pipeline::run::Partial>,
    }
    if json {
        let text = serde_json::to_string_pretty(&Selected { summary, partial })
            .expect("summary serializes");
        println!("{text}");
    } else {
        println!("{}", summary.line());
        match partial {
            Some(p) => println!("{}", p.line()),
            None if summary.complete => println!("every cell of the grid is baked"),
            None => {}
        }
    }
    completed(summary, "requested job(s) failed")
}

/// Success when every job of the run is done (or, `--no-wait`/`--hold`, submitted),
/// else a failure that counts the jobs
/// (`jobs`: what they are) and points at `pipeline status`.
pub fn completed(summary: &pipeline::run::RunSummary, jobs: &str) -> Result<(), Failure> {
    if summary.succeeded() {
        return Ok(());
    }
    // What failed, in the user's terms (issue 29 item 4): the first few messages,
    // each naming its job, cell, instance and what to change.
    const SHOWN: usize = 3;
    for (_, message) in summary.jobs_failed.iter().take(SHOWN) {
        eprintln!("failed: {message}");
    }
    if summary.jobs_failed.len() > SHOWN {
        eprintln!("… and {} more", summary.jobs_failed.len() - SHOWN);
    }
    Err(failed(anyhow::anyhow!(
        "{} {jobs}; `pipeline status {}` lists them",
        summary.jobs_failed.len().max(1),
        summary.out.display()
    )))
}

/// Prints `value` as pretty JSON when `json`, else the text `text` makes (which ends
/// with its own newline).
pub fn print_json_or_text<T: serde::Serialize>(
    json: bool,
    value: &T,
    text: impl FnOnce() -> String,
) {
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(value).expect("a report value serializes")
        );
    } else {
        print!("{}", text());
    }
}
