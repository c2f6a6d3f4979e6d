//! `worker`: runs one job of a manifest (what a Slurm array task calls) and the
//! per-cell diagnostic commands that write pictures.
//!
//! Exit codes: 0 success, 1 a failure while working, 2 bad input.

use anyhow::Context;
use clap::{Parser, Subcommand};
use glam::Vec3;
use std::path::PathBuf;
use std::process::ExitCode;
use worker::raster::{render, CullMode, DrawItem};

#[derive(Parser)]
#[command(name = "worker", version, about = "hexbake bake kernels: one job, or pictures of one cell")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render the whole scene of a manifest from a viewpoint to a PNG (a look at a scene).
    View {
        manifest: PathBuf,
        /// Eye position x,y,z (default: high above one corner of the ground).
        #[arg(long, value_parser = parse_vec3)]
        eye: Option<Vec3>,
        /// Point looked at x,y,z (default: the ground's centre).
        #[arg(long, value_parser = parse_vec3)]
        target: Option<Vec3>,
        #[arg(long, default_value_t = 60.0)]
        fov: f32,
        #[arg(long, default_value_t = 1024)]
        size: u32,
        #[arg(long)]
        out: PathBuf,
    },
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| t.trim().parse::<f32>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("expected x,y,z with three finite numbers, got {s:?}")),
    }
}

struct Failure {
    code: u8,
    error: anyhow::Error,
}

fn bad_input(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 2,
        error: error.into(),
    }
}

fn failed(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 1,
        error: error.into(),
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {:#}", f.error);
            ExitCode::from(f.code)
        }
    }
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::View {
            manifest,
            eye,
            target,
            fov,
            size,
            out,
        } => {
            let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
            let scene = plan.load_scene().map_err(bad_input)?;
            let [w, d] = scene.ground.size();
            let centre = Vec3::new(
                scene.ground.min[0] + w / 2.0,
                0.0,
                scene.ground.min[1] + d / 2.0,
            );
            let target = target.unwrap_or(centre);
            let eye = eye.unwrap_or(Vec3::new(
                scene.ground.min[0] - 0.15 * w,
                0.6 * w.max(d),
                scene.ground.max[1] + 0.15 * d,
            ));
            let far = 4.0 * (w + d + eye.y);
            let view = worker::raster::View::look_at_fov(eye, target, Vec3::Y, fov, size, size, 0.5, far)
                .map_err(bad_input)?;
            let items: Vec<DrawItem> = scene
                .instances
                .iter()
                .enumerate()
                .map(|(i, inst)| DrawItem {
                    mesh: &scene.models[inst.model as usize].mesh,
                    transform: inst.transform,
                    tint: inst.tint,
                    object_id: i as u32,
                    triangles: None,
                })
                .collect();
            let capture = render(&view, &items, CullMode::Back);
            worker::picture::write_rgba(&out, size, size, &capture.color)
                .with_context(|| format!("writing {}", out.display()))
                .map_err(failed)?;
            println!("{}: {} instances drawn", out.display(), items.len());
            Ok(())
        }
    }
}
