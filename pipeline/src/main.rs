//! `pipeline`: the command a user runs. Exit codes: 0 success, 1 a failure while
//! working, 2 bad input (manifest, model, arguments).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use worker::cli::{bad_input, exit_code, failed, restore_default_sigpipe, Failure};

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
        /// Print the scene as an `Instances` manifest instead (a generated park as an
        /// editable list of instances; the same bake).
        #[arg(long, conflicts_with = "json")]
        as_instances: bool,
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
        /// Bake only the jobs holding these cells (local executor): a comma-separated
        /// list of cell ids, `path:FILE.ron` (the cells a camera path walks through
        /// and their neighbours), `at:X:Z`, `grid:SIZE:ID`. The index lists only baked
        /// cells; exit 0 when every requested cell is baked.
        #[arg(long, value_name = "SPEC")]
        cells: Option<String>,
        /// Override a manifest parameter, e.g. `--set T_s=3 --set cells.cell_size=100`
        /// (local executor; use a separate --out per setting).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
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
    /// Write one cell of a bake as glTF 2.0 binary (GLB): its originals and its
    /// SV / MV / cluster proxies and layered impostors with their capture textures.
    Export {
        /// The bake directory (output of `pipeline run`).
        out: PathBuf,
        /// The cell id.
        #[arg(long)]
        cell: u32,
        /// The GLB file to write.
        #[arg(short = 'o', long = "output", value_name = "FILE.glb")]
        output: PathBuf,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Serve a bake and the browser viewer over HTTP (range requests; issue 33).
    Serve(pipeline::serve::ServeArgs),
    /// Print a pack's header and sections and check every checksum.
    Inspect {
        /// A `base.pack`, `cells/<id>.pack` or `index.pack`; or a bake directory, to
        /// verify every cell pack against `index.pack` and `base.pack`.
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

fn from_run(e: pipeline::run::RunError) -> Failure {
    match e {
        pipeline::run::RunError::BadInput(error) => bad_input(error),
        pipeline::run::RunError::Failed(error) => failed(error),
    }
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    exit_code(run(Cli::parse()))
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Scene {
            manifest,
            json,
            as_instances,
        } => {
            let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
            if as_instances {
                print!(
                    "{}",
                    format::scene_build::instances_manifest(&plan).map_err(bad_input)?
                );
                return Ok(());
            }
            let scene = plan.load_scene().map_err(bad_input)?;
            let summary = pipeline::scene_cmd::summarize(&plan, &scene);
            print_json_or_text(json, &summary, || {
                pipeline::scene_cmd::render_text(&summary)
            });
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
            cells,
            set,
            slurm,
        } => {
            let overrides = set
                .iter()
                .map(|s| pipeline::overrides::parse_override(s))
                .collect::<Result<Vec<_>, _>>()
                .map_err(bad_input)?;
            if executor == ExecutorArg::Slurm && (cells.is_some() || !overrides.is_empty()) {
                return Err(bad_input(anyhow::anyhow!(
                    "--cells and --set work with the local executor only"
                )));
            }
            let loaded = pipeline::run::load_with(&manifest, out.as_deref(), &overrides)
                .map_err(from_run)?;
            // An output path that cannot hold a directory is bad input; the error names it.
            pipeline::lock::create_output_dir(&loaded.out).map_err(bad_input)?;
            if let Some(spec) = cells {
                let selection = pipeline::subset::Selection::new(&spec, &loaded.build.grid)
                    .map_err(bad_input)?;
                let (summary, partial) = pipeline::run::run_local_selected(
                    &loaded,
                    &selection,
                    force,
                    &pipeline::run::LocalOptions {
                        threads,
                        progress: !quiet && !json,
                    },
                )
                .map_err(from_run)?;
                return finish_selected(&summary, partial.as_ref(), json);
            }
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
            print_json_or_text(json, &summary, || format!("{}\n", summary.line()));
            completed(&summary, "job(s) failed or pending")
        }
        Command::Status { out, json } => {
            let status = pipeline::status::status(&out).map_err(bad_input)?;
            print_json_or_text(json, &status, || status.to_text());
            Ok(())
        }
        Command::Report { out, json } => {
            let r = pipeline::report::write_report(&out).map_err(failed)?;
            print_json_or_text(json, &r, || pipeline::report::to_markdown(&r));
            if let Some(jobs) = r.jobs_line() {
                eprintln!(
                    "note: the bake is not finished ({jobs}); the report covers its {} baked \
                     cell(s) only; `pipeline status {}` lists the jobs",
                    r.cells,
                    out.display()
                );
            }
            Ok(())
        }
        Command::Finalize { manifest, out } => {
            let loaded = pipeline::run::load(&manifest, out.as_deref()).map_err(from_run)?;
            pipeline::run::assemble(&loaded).map_err(from_run)?;
            let _ = std::fs::remove_file(pipeline::run::partial_path(&loaded.out));
            pipeline::report::write_report(&loaded.out).map_err(failed)?;
            println!("assembled {}", loaded.out.join("index.pack").display());
            Ok(())
        }
        Command::Export {
            out,
            cell,
            output,
            json,
        } => {
            let summary = pipeline::export::export_cell(&out, cell, &output).map_err(from_run)?;
            print_json_or_text(json, &summary, || format!("{}\n", summary.line()));
            Ok(())
        }
        Command::Serve(args) => pipeline::serve::serve(&args).map_err(bad_input),
        Command::Inspect { pack, json } if pack.is_dir() => {
            let check = pipeline::inspect::check_bake(&pack).map_err(bad_input)?;
            print_json_or_text(json, &check, || {
                pipeline::inspect::render_bake_check(&check)
            });
            if check.problems.is_empty() {
                Ok(())
            } else {
                Err(failed(anyhow::anyhow!(
                    "{}: {} of {} cell packs do not belong to this bake or are damaged",
                    pack.display(),
                    check.problems.len(),
                    check.cells_indexed
                )))
            }
        }
        Command::Inspect { pack, json } => {
            // A pack that fails validation is a failure of the data (exit 1), not of
            // the command line; the message names the file and the bad section.
            let text = pipeline::inspect::inspect(&pack, json).map_err(failed)?;
            print!("{text}");
            Ok(())
        }
    }
}

/// Prints the summary of a `--cells` run; Ok when every requested cell is baked.
fn finish_selected(
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
fn completed(summary: &pipeline::run::RunSummary, jobs: &str) -> Result<(), Failure> {
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
fn print_json_or_text<T: serde::Serialize>(json: bool, value: &T, text: impl FnOnce() -> String) {
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(value).expect("a report value serializes")
        );
    } else {
        print!("{}", text());
    }
}
