//! `pipeline`: the command a user runs. Exit codes: 0 success, 1 a failure while
//! working, 2 bad input (manifest, model, arguments).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "pipeline",
    version,
    about = "hexbake: bake huge static scenes into per-cell packs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Load a manifest's scene and print its models, instances, triangles and grid.
    Scene {
        manifest: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Bake a manifest: plan, bake the missing jobs (locally or on Slurm), assemble
    /// the index, write the report. Resumable: a rerun redoes only missing jobs.
    Run {
        manifest: PathBuf,
        /// Output directory (default: the manifest's `output`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads for the local executor (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Rebake every job, even those already done.
        #[arg(long)]
        force: bool,
        /// `local` (rayon in this process) or `slurm` (a job array + a finalize job).
        #[arg(long, value_enum, default_value_t = ExecutorArg::Local)]
        executor: ExecutorArg,
        /// No progress bar, only the summary line.
        #[arg(long)]
        quiet: bool,
        /// Print the summary as JSON (implies --quiet).
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        slurm: pipeline::slurm::SlurmArgs,
    },
    /// Show which jobs of a bake output are done, failed or pending.
    Status {
        out: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Rebuild and print the report of a bake output (also writes report.md/json/png).
    Report {
        out: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Assemble the index and report once every job is done (the Slurm finalize job).
    #[command(hide = true)]
    Finalize {
        manifest: PathBuf,
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Print a pack's header and sections and check every checksum.
    Inspect {
        /// A `base.pack`, `cells/<id>.pack` or `index.pack`.
        pack: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ExecutorArg {
    Local,
    Slurm,
}

/// An error with the exit code it maps to.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

fn bad_input(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 2,
        error: error.into(),
    }
}

fn from_run(e: pipeline::run::RunError) -> Failure {
    match e {
        pipeline::run::RunError::BadInput(error) => Failure { code: 2, error },
        pipeline::run::RunError::Failed(error) => Failure { code: 1, error },
    }
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {:#}", f.error);
            ExitCode::from(f.code)
        }
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Scene { manifest, json } => {
            let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
            let scene = plan.load_scene().map_err(bad_input)?;
            let summary = pipeline::scene_cmd::summarize(&plan, &scene);
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&summary).expect("summary serializes")
                );
            } else {
                print!("{}", pipeline::scene_cmd::render_text(&summary));
            }
            Ok(())
        }
        Command::Run {
            manifest,
            out,
            threads,
            force,
            executor,
            quiet,
            json,
            slurm,
        } => {
            let loaded = pipeline::run::load(&manifest, out.as_deref()).map_err(from_run)?;
            let summary = match executor {
                ExecutorArg::Local => pipeline::run::run_local(
                    &loaded,
                    force,
                    &pipeline::run::LocalOptions {
                        threads,
                        progress: !quiet && !json,
                    },
                ),
                ExecutorArg::Slurm => pipeline::slurm::run_slurm(&loaded, force, &slurm, !json),
            }
            .map_err(from_run)?;
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&summary).expect("summary serializes")
                );
            } else {
                println!("{}", summary.line());
            }
            if summary.complete {
                Ok(())
            } else {
                Err(Failure {
                    code: 1,
                    error: anyhow::anyhow!(
                        "{} job(s) failed or pending; `pipeline status {}` lists them",
                        summary.jobs_failed.len().max(1),
                        summary.out.display()
                    ),
                })
            }
        }
        Command::Status { out, json } => {
            let status = pipeline::status::status(&out).map_err(bad_input)?;
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&status).expect("status serializes")
                );
            } else {
                print!("{}", status.to_text());
            }
            Ok(())
        }
        Command::Report { out, json } => {
            let r =
                pipeline::report::write_report(&out).map_err(|error| Failure { code: 1, error })?;
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&r).expect("report serializes")
                );
            } else {
                print!("{}", pipeline::report::to_markdown(&r));
            }
            Ok(())
        }
        Command::Finalize { manifest, out } => {
            let loaded = pipeline::run::load(&manifest, out.as_deref()).map_err(from_run)?;
            pipeline::run::assemble(&loaded).map_err(from_run)?;
            pipeline::report::write_report(&loaded.out)
                .map_err(|error| Failure { code: 1, error })?;
            println!("assembled {}", loaded.out.join("index.pack").display());
            Ok(())
        }
        Command::Inspect { pack, json } => {
            // A pack that fails validation is a failure of the data (exit 1), not of
            // the command line; the message names the file and the bad section.
            let text = pipeline::inspect::inspect(&pack, json)
                .map_err(|error| Failure { code: 1, error })?;
            print!("{text}");
            Ok(())
        }
    }
}

/// Like other Unix tools, end quietly when stdout is a closed pipe (`| head`) instead
/// of panicking in `println!`: restore the default SIGPIPE action Rust ignores.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread starts; setting a
    // signal's disposition to SIG_DFL has no other precondition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
