//! `pipeline finalize` (hidden): assemble the index and report once every job is done (the Slurm finalize job).

use super::*;

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args { manifest, out } = args;
    let loaded = pipeline::run::load(&manifest, out.as_deref()).map_err(from_run)?;
    pipeline::run::assemble(&loaded).map_err(from_run)?;
    let _ = std::fs::remove_file(pipeline::run::partial_path(&loaded.out));
    pipeline::report::write_report(&loaded.out).map_err(failed)?;
    println!("assembled {}", loaded.out.join("index.pack").display());
    Ok(())
}
