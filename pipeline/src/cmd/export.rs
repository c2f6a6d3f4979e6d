//! `pipeline export`: one cell of a bake as glTF 2.0 binary.

use super::*;

#[derive(clap::Args)]
pub struct Args {
    /// The bake directory (output of `pipeline run`).
    pub out: PathBuf,
    /// The cell id.
    #[arg(long)]
    pub cell: u32,
    /// The GLB file to write.
    #[arg(short = 'o', long = "output", value_name = "FILE.glb")]
    pub output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
        out,
        cell,
        output,
        json,
    } = args;
    let summary = pipeline::export::export_cell(&out, cell, &output).map_err(from_run)?;
    print_json_or_text(json, &summary, || format!("{}\n", summary.line()));
    Ok(())
}
