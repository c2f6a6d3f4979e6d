//! `worker capture`: one instance captured from a cell centre, with its pixel classes and vertex weights (000 §3.1.3.1–3.1.3.2).

use std::path::PathBuf;
use worker::cli::{bad_input, failed, Failure};

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    #[arg(long)]
    pub cell: u32,
    #[arg(long)]
    pub instance: u32,
    #[arg(long)]
    pub out: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
        manifest,
        cell,
        instance,
        out,
        json,
    } = args;
    let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
    let scene = scene::build_scene(&plan).map_err(bad_input)?;
    let s = worker::diagnostics::capture_pictures(&plan, &scene, cell, instance, &out).map_err(
        |e| match e {
            worker::diagnostics::DiagnosticsError::Picture(_) => failed(e),
            _ => bad_input(e),
        },
    )?;
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&s).expect("summary serializes")
        );
    } else {
        println!(
            "instance {} ({}) from cell {} at ({:.1}, {:.1}, {:.1}): {}×{} px",
            s.instance, s.model, s.cell, s.eye[0], s.eye[1], s.eye[2], s.width, s.height
        );
        println!(
            "pixel classes: exterior silhouette {:.1}%, interior silhouette {:.1}%, sharp edge {:.1}%, interior {:.1}%",
            s.class_percent[0], s.class_percent[1], s.class_percent[2], s.class_percent[3]
        );
        println!(
            "vertices: {} back-facing (w 0.5), {} visible (class weight), {} hidden (w 0.05)",
            s.vertex_states[0], s.vertex_states[1], s.vertex_states[2]
        );
        for f in &s.files {
            println!("wrote {}", f.display());
        }
    }
    Ok(())
}
