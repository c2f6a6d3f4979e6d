//! `pipeline status`: which jobs of a bake are done, failed or pending.

use super::*;

#[derive(clap::Args)]
pub struct Args {
    pub out: PathBuf,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args { out, json } = args;
    let status = pipeline::status::status(&out).map_err(bad_input)?;
    print_json_or_text(json, &status, || status.to_text());
    Ok(())
}
