//! `pipeline`: the command a user runs. Exit codes: 0 success, 1 a failure while
//! working, 2 bad input (manifest, model, arguments).

mod cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use worker::cli::{bad_input, exit_code, limit_malloc_arenas, restore_default_sigpipe, Failure};

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
    Scene(cmd::scene::Args),
    /// Bake a manifest: plan, bake the missing jobs (locally or on Slurm), assemble
    /// the index, write the report. Resumable: a rerun redoes only missing jobs.
    Run(cmd::run::Args),
    /// Show which jobs of a bake output are done, failed or pending.
    Status(cmd::status::Args),
    /// Rebuild and print the report of a bake output (also writes report.md/json/png).
    Report(cmd::report::Args),
    /// Assemble the index and report once every job is done (the Slurm finalize job).
    #[command(hide = true)]
    Finalize(cmd::finalize::Args),
    /// Write one cell of a bake as glTF 2.0 binary (GLB): its originals and its
    /// SV / MV / cluster proxies and layered impostors with their capture textures.
    Export(cmd::export::Args),
    /// Serve a bake and the browser viewer over HTTP (range requests; issue 33).
    Serve(pipeline::serve::ServeArgs),
    /// Print a pack's header and sections and check every checksum.
    Inspect(cmd::inspect::Args),
    /// Write each pack's `.vertices` and `.textures` beside it, for serving a bake to
    /// the browser viewer from a static host (`pipeline serve` derives them itself).
    WebExport(pipeline::serve::WebExportArgs),
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    limit_malloc_arenas();
    exit_code(run(Cli::parse()))
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Scene(args) => cmd::scene::run(args),
        Command::Run(args) => cmd::run::run(args),
        Command::Status(args) => cmd::status::run(args),
        Command::Report(args) => cmd::report::run(args),
        Command::Finalize(args) => cmd::finalize::run(args),
        Command::Export(args) => cmd::export::run(args),
        Command::Serve(args) => pipeline::serve::serve(&args).map_err(bad_input),
        Command::Inspect(args) => cmd::inspect::run(args),
        Command::WebExport(args) => match pipeline::serve::web_export(&args) {
            Ok((files, bytes)) => {
                println!(
                    "web-export {}: {files} files, {bytes} bytes",
                    args.out.display()
                );
                Ok(())
            }
            Err(e) => Err(bad_input(e)),
        },
    }
}
