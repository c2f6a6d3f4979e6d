//! `worker view`: the whole scene of a manifest rendered from a viewpoint.

use anyhow::Context;
use glam::Vec3;
use std::path::PathBuf;
use worker::cli::{bad_input, failed, Failure};
use worker::raster::{render, CullMode, DrawItem};

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    /// Eye position x,y,z (default: high above one corner of the ground).
    #[arg(long, value_parser = parse_vec3)]
    pub eye: Option<Vec3>,
    /// Point looked at x,y,z (default: the ground's centre).
    #[arg(long, value_parser = parse_vec3)]
    pub target: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 60.0)]
    pub fov_deg: f32,
    /// The old name of `--fov-deg`: refused with a message naming it (issue 14).
    #[arg(long = "fov", hide = true, value_parser = renamed_fov)]
    pub fov_renamed: Option<f32>,
    #[arg(long, default_value_t = 1024)]
    pub size: u32,
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
        manifest,
        eye,
        target,
        fov_deg,
        // Always `None`: its parser refuses the old flag.
        fov_renamed: _,
        size,
        out,
    } = args;
    let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
    let scene = scene::build_scene(&plan).map_err(bad_input)?;
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
    let view =
        worker::raster::View::look_at_fov(eye, target, Vec3::Y, fov_deg, size, size, 0.5, far)
            .map_err(bad_input)?;
    let ground = scene.ground.mesh();
    let items = DrawItem::scene_with_ground(&scene, &ground);
    let instances = scene.instances.len();
    let capture = render(&view, &items, CullMode::Back);
    worker::picture::write_rgba(&out, size, size, &capture.color)
        .with_context(|| format!("writing {}", out.display()))
        .map_err(failed)?;
    println!("{}: {instances} instances drawn", out.display());
    Ok(())
}

/// `view --fov` was renamed `--fov-deg`.
fn renamed_fov(_: &str) -> Result<f32, String> {
    Err("`--fov` was renamed `--fov-deg` (degrees)".into())
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| t.trim().parse::<f32>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!(
            "expected x,y,z with three finite numbers, got {s:?}"
        )),
    }
}
