//! `pipeline run`: plan, bake the missing jobs (local or Slurm), assemble, report.

use super::*;

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    /// Output directory (default: the manifest's `output`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads for the local executor (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Rebake every job, even those already done.
    #[arg(long)]
    pub force: bool,
    /// `local` (rayon in this process) or `slurm` (a job array + a finalize job).
    #[arg(long, value_enum, default_value_t = ExecutorArg::Local)]
    pub executor: ExecutorArg,
    /// No progress bar, only the summary line.
    #[arg(long)]
    pub quiet: bool,
    /// Print the summary as JSON (implies --quiet).
    #[arg(long)]
    pub json: bool,
    /// Bake only the jobs holding these cells (local executor): a comma-separated
    /// list of cell ids, `path:FILE.ron` (the cells a camera path walks through
    /// and their neighbours), `at:X:Z`, `grid:SIZE:ID`. The index lists only baked
    /// cells; exit 0 when every requested cell is baked.
    #[arg(long, value_name = "SPEC")]
    pub cells: Option<String>,
    /// Override a manifest parameter, e.g. `--set T_s=3 --set cells.cell_size=100`
    /// (local executor; use a separate --out per setting).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    #[command(flatten)]
    pub slurm: pipeline::slurm::SlurmArgs,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
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
    } = args;
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
    let loaded =
        pipeline::run::load_with(&manifest, out.as_deref(), &overrides).map_err(from_run)?;
    // An output path that cannot hold a directory is bad input; the error names it.
    pipeline::lock::create_output_dir(&loaded.out).map_err(bad_input)?;
    if let Some(spec) = cells {
        let selection =
            pipeline::subset::Selection::new(&spec, &loaded.build.grid).map_err(bad_input)?;
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
