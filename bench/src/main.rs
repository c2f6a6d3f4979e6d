//! `hexbake-bench`: the benchmark plumbing `scripts/bench.sh` calls (collect a work
//! folder into a run file, time cell loads, write the sweeps' check-viewpoint paths,
//! regenerate BENCHMARKS.md's tables and plots). Not a command users run: it lives
//! beside the product (STYLE.md habit 16). Exit codes: 0 success, 1 a failure, 2 bad
//! arguments (clap).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "hexbake-bench",
    version,
    about = "hexbake's benchmark tool: the pieces scripts/bench.sh calls"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Turn a bench.sh work folder into one run file (docs/bench/run-<id>.json).
    Collect {
        work: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// Time loading the cell packs of a bake (open + validate + decode).
    Load {
        out: PathBuf,
        /// Label of the bake in the results.
        #[arg(long, default_value = "")]
        label: String,
        /// Cells to time, spread over the index (0: all).
        #[arg(long, default_value_t = 64)]
        sample: usize,
    },
    /// Write a camera path of explicit views: `worker check`'s viewpoints in each
    /// cell of a (partial) bake, so the player can measure it cell by cell.
    Views {
        out: PathBuf,
        /// Cells (comma-separated ids; default: the cells of `<out>/partial.json`).
        #[arg(long, value_delimiter = ',')]
        cells: Option<Vec<u32>>,
        /// Views per cell.
        #[arg(long, default_value_t = 16)]
        per_cell: usize,
        /// Frame size, WIDTHxHEIGHT.
        #[arg(long, default_value = "1024x1024")]
        size: String,
        /// The path file to write.
        #[arg(long)]
        path: PathBuf,
    },
    /// Regenerate the marked tables of a document from the run files, and the plots.
    Tables {
        /// Folder of run files (and where the plots go).
        #[arg(long, default_value = "docs/bench")]
        results: PathBuf,
        /// The document to rewrite between its `<!-- bench:NAME -->` markers.
        #[arg(long, default_value = "docs/bench/paper.md")]
        write: PathBuf,
        /// How the document links the plots (default: "." when the document lies in
        /// --results, else --results as given).
        #[arg(long)]
        plot_prefix: Option<String>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", worker::error_text(e.as_ref()));
            ExitCode::from(1)
        }
    }
}

fn run(cmd: Command) -> anyhow::Result<()> {
    use anyhow::Context;
    match cmd {
        Command::Collect { work, out } => {
            let run = hexbake_bench::results::collect(&work)?;
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
            }
            let text = serde_json::to_vec_pretty(&run)?;
            format::pack::write_atomic(&out, &text).with_context(|| out.display().to_string())?;
            println!(
                "{}: {} bakes, {} compares, {} renders, {} load timings, {} commands",
                out.display(),
                run.bakes.len(),
                run.compares.len(),
                run.renders.len(),
                run.load_times.len(),
                run.commands.len()
            );
        }
        Command::Load { out, label, sample } => {
            let t = hexbake_bench::results::time_cell_loads(&out, &label, sample)?;
            println!("{}", serde_json::to_string_pretty(&t)?);
        }
        Command::Views {
            out,
            cells,
            per_cell,
            size,
            path,
        } => {
            let resolution = size
                .split_once('x')
                .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                .filter(|&(w, h): &(u32, u32)| w > 0 && h > 0)
                .with_context(|| {
                    format!("--size {size:?}: expected WIDTHxHEIGHT, e.g. 1024x1024")
                })?;
            let p = hexbake_bench::results::check_view_path(&out, cells, per_cell, resolution)?;
            let text = ron::ser::to_string_pretty(&p, ron::ser::PrettyConfig::default())?;
            format::pack::write_atomic(&path, text.as_bytes())
                .with_context(|| path.display().to_string())?;
            println!("{}: {} views", path.display(), p.views.len());
        }
        Command::Tables {
            results,
            write,
            plot_prefix,
        } => {
            let prefix = plot_prefix.unwrap_or_else(|| {
                if write.parent() == Some(results.as_path()) {
                    ".".to_string()
                } else {
                    results.display().to_string()
                }
            });
            let r = hexbake_bench::tables::regenerate(&results, &write, &prefix)?;
            println!(
                "{}: {} sections from {} run file(s) in {}; {} plot(s)",
                write.display(),
                r.sections,
                r.runs,
                results.display(),
                r.plots.len()
            );
        }
    }
    Ok(())
}
