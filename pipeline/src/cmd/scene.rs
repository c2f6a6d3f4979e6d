//! `pipeline scene`: a manifest's scene summarised, or written back as a manifest of instances.

use super::*;

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Print the scene as an `Instances` manifest instead (a generated park as an
    /// editable list of instances; the same bake).
    #[arg(long, conflicts_with = "json")]
    pub as_instances: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
        manifest,
        json,
        as_instances,
    } = args;
    let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
    if as_instances {
        print!(
            "{}",
            ::scene::build::instances_manifest(&plan).map_err(bad_input)?
        );
        return Ok(());
    }
    let (scene, chunks) = ::scene::build::build_scene_with_chunks(&plan).map_err(bad_input)?;
    let summary = pipeline::scene_cmd::summarize(&plan, &scene, chunks);
    print_json_or_text(json, &summary, || {
        pipeline::scene_cmd::render_text(&summary)
    });
    Ok(())
}
