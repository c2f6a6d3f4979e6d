//! `pipeline report`: rebuild and print a bake's report.

use super::*;

#[derive(clap::Args)]
pub struct Args {
    pub out: PathBuf,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args { out, json } = args;
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
