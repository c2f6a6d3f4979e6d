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
    /// Print a pack's header and sections and check every checksum.
    Inspect {
        /// A `base.pack`, `cells/<id>.pack` or `index.pack`.
        pack: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
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

fn main() -> ExitCode {
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
