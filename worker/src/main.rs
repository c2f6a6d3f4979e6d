//! `worker`: runs one job of a manifest (what a Slurm array task calls) and the
//! per-cell diagnostic commands that write pictures.
//!
//! Exit codes: 0 success, 1 a failure while working, 2 bad input.

mod cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use worker::cli::{exit_code, limit_malloc_arenas, restore_default_sigpipe, Failure};

#[derive(Parser)]
#[command(
    name = "worker",
    version,
    about = "hexbake bake kernels: one job, or pictures of one cell"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bake one job of a manifest into `<out>` (what a Slurm array task runs; the
    /// job id defaults to $SLURM_ARRAY_TASK_ID). Skips a job that is already done.
    Job(cmd::job::Args),
    /// Bake one cell and compare its proxies with the original geometry from
    /// viewpoints spread over the cell's prism: PSNR on luminance per view, their
    /// mean, and the worst view's reference / proxy / difference PNGs.
    Check(cmd::check::Args),
    /// Capture one instance from a cell's centre and write colour, depth, class-map
    /// and weight-map PNGs (000 §3.1.3.1–3.1.3.2).
    Capture(cmd::capture::Args),
    /// Render the whole scene of a manifest from a viewpoint to a PNG (a look at a scene).
    View(cmd::view::Args),
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    limit_malloc_arenas();
    exit_code(run(Cli::parse()))
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Job(args) => cmd::job::run(args),
        Command::Check(args) => cmd::check::run(args),
        Command::Capture(args) => cmd::capture::run(args),
        Command::View(args) => cmd::view::run(args),
    }
}
