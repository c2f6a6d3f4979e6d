//! `pipeline inspect`: a pack's header and sections, or a whole bake checked against its index.

use super::*;

#[derive(clap::Args)]
pub struct Args {
    /// A `base.pack`, `cells/<id>.pack` or `index.pack`; or a bake directory, to
    /// verify every cell pack against `index.pack` and `base.pack`.
    pub pack: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args { pack, json } = args;
    if pack.is_dir() {
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
    } else {
        // A pack that fails validation is a failure of the data (exit 1), not of
        // the command line; the message names the file and the bad section.
        let text = pipeline::inspect::inspect(&pack, json).map_err(failed)?;
        print!("{text}");
        Ok(())
    }
}
