//! `worker`: runs one job of a manifest (what a Slurm array task calls) and the
//! per-cell diagnostic commands that write pictures.
//!
//! Exit codes: 0 success, 1 a failure while working, 2 bad input.

use anyhow::Context;
use clap::{Parser, Subcommand};
use glam::Vec3;
use std::path::PathBuf;
use std::process::ExitCode;
use worker::cli::{bad_input, exit_code, failed, restore_default_sigpipe, Failure};
use worker::raster::{render, CullMode, DrawItem};

#[derive(Parser)]
#[command(
    name = "worker",
    version,
    about = "hexbake bake kernels: one job, or pictures of one cell"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bake one job of a manifest into `<out>` (what a Slurm array task runs; the
    /// job id defaults to $SLURM_ARRAY_TASK_ID). Skips a job that is already done.
    Job {
        manifest: PathBuf,
        #[arg(long)]
        out: PathBuf,
        #[arg(long)]
        job: Option<u32>,
        /// Threads for this job's bake (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Bake one cell and compare its proxies with the original geometry from
    /// viewpoints spread over the cell's prism: PSNR on luminance per view, their
    /// mean, and the worst view's reference / proxy / difference PNGs.
    Check {
        manifest: PathBuf,
        #[arg(long)]
        cell: u32,
        #[arg(long, default_value_t = 16)]
        views: usize,
        /// Square image side of each view (60° FOV).
        #[arg(long, default_value_t = 1024)]
        res: u32,
        /// Where the worst view's PNGs go (default: no pictures).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override T_l (edge-length tolerance, pixels) of the manifest
        /// (`--set bake.edge_length_tolerance_px=V`: validated as in the manifest).
        #[arg(long)]
        edge_length_tolerance_px: Option<f32>,
        /// Override the deviation bound (pixels; 0 = the paper's algorithm as written).
        #[arg(long)]
        max_deviation_px: Option<f32>,
        /// Start every collapse from the full meshes instead of the models' LOD chains
        /// (the paper as written; for comparing the two).
        #[arg(long)]
        no_lod_chain: bool,
        /// Give the cell its own proxy of every outside object instead of sharing
        /// the far field of its 7-cell group (`bake.far_field: false`).
        #[arg(long)]
        no_far_field: bool,
        #[arg(long)]
        json: bool,
    },
    /// Capture one instance from a cell's centre and write colour, depth, class-map
    /// and weight-map PNGs (000 §3.1.3.1–3.1.3.2).
    Capture {
        manifest: PathBuf,
        #[arg(long)]
        cell: u32,
        #[arg(long)]
        instance: u32,
        #[arg(long)]
        out: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Render the whole scene of a manifest from a viewpoint to a PNG (a look at a scene).
    View {
        manifest: PathBuf,
        /// Eye position x,y,z (default: high above one corner of the ground).
        #[arg(long, value_parser = parse_vec3)]
        eye: Option<Vec3>,
        /// Point looked at x,y,z (default: the ground's centre).
        #[arg(long, value_parser = parse_vec3)]
        target: Option<Vec3>,
        /// Vertical field of view in degrees.
        #[arg(long, default_value_t = 60.0)]
        fov_deg: f32,
        /// The old name of `--fov-deg`: refused with a message naming it (issue 14).
        #[arg(long = "fov", hide = true, value_parser = renamed_fov)]
        fov_renamed: Option<f32>,
        #[arg(long, default_value_t = 1024)]
        size: u32,
        #[arg(long)]
        out: PathBuf,
    },
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

fn main() -> ExitCode {
    restore_default_sigpipe();
    exit_code(run(Cli::parse()))
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Job {
            manifest,
            out,
            job,
            threads,
        } => {
            let id = match job {
                Some(id) => id,
                None => std::env::var("SLURM_ARRAY_TASK_ID")
                    .ok()
                    .and_then(|v| v.parse().ok())
                    .ok_or_else(|| {
                        bad_input(anyhow::anyhow!(
                            "--job not given and SLURM_ARRAY_TASK_ID not set"
                        ))
                    })?,
            };
            let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
            let scene = scene::build_scene(&plan).map_err(bad_input)?;
            let build = worker::job::plan_jobs(&plan, &scene);
            let job = build.jobs.get(id as usize).ok_or_else(|| {
                bad_input(anyhow::anyhow!(
                    "job {id} does not exist ({} jobs)",
                    build.jobs.len()
                ))
            })?;
            if worker::job::done_record(&out, job).is_some() {
                println!("job {id}: already done");
                return Ok(());
            }
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads.unwrap_or(0))
                .build()
                .map_err(failed)?;
            let result = pool.install(|| {
                // The chains `pipeline run` prepared (or this task builds and caches).
                let (chains, _) = worker::lod_chain::LodChains::prepare(
                    &scene,
                    Some(&worker::job::lod_dir(&out)),
                )
                .map_err(|e| format!("job {id}: {}: {e}", worker::job::lod_dir(&out).display()))?;
                worker::job::bake_job(&out, &plan, &scene, &chains, &build, job, false, || {})
            });
            match result {
                Ok(record) => {
                    println!(
                        "job {id}: {} cells in {:.1} s",
                        record.cells.len(),
                        record.wall_s
                    );
                    Ok(())
                }
                Err(message) => {
                    // bake_job wrote it for a bake error; the chains' own error too.
                    let _ = std::fs::create_dir_all(out.join("jobs"));
                    let _ =
                        std::fs::write(worker::job::error_path(&out, id), format!("{message}\n"));
                    Err(failed(anyhow::anyhow!(message)))
                }
            }
        }
        Command::Check {
            manifest,
            cell,
            views,
            res,
            out,
            edge_length_tolerance_px,
            max_deviation_px,
            no_lod_chain,
            no_far_field,
            json,
        } => {
            // The overrides go through the manifest's one validator, like `--set`.
            let overrides = [
                edge_length_tolerance_px.map(|t| ("bake.edge_length_tolerance_px", t.to_string())),
                max_deviation_px.map(|d| ("bake.max_deviation_px", d.to_string())),
                no_far_field.then(|| ("bake.far_field", "false".to_string())),
            ]
            .into_iter()
            .flatten()
            .map(|(key, value)| format::manifest::parse_override(&format!("{key}={value}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(bad_input)?;
            let plan =
                format::manifest::parse_manifest_with(&manifest, &overrides).map_err(bad_input)?;
            let scene = scene::build_scene(&plan).map_err(bad_input)?;
            let grid = worker::grid::HexGrid::new(scene.ground, plan.cells.cell_size);
            let groups = worker::far_field::CellGroups::for_params(&grid, &plan.bake);
            // The chains of the manifest's output, as the bake uses them.
            let chains = if no_lod_chain {
                worker::lod_chain::LodChains::none()
            } else {
                let t = std::time::Instant::now();
                let (chains, stats) = worker::lod_chain::LodChains::prepare(
                    &scene,
                    Some(&worker::job::lod_dir(&plan.output)),
                )
                .map_err(failed)?;
                eprintln!(
                    "lod chains: {} built, {} loaded in {:.1} s",
                    stats.built,
                    stats.loaded,
                    t.elapsed().as_secs_f64()
                );
                chains
            };
            let t = std::time::Instant::now();
            // The cell's proxies and its group's far field, as the player draws them.
            let bake = worker::bake::bake_cell_hybrid(
                &scene,
                &chains,
                &grid,
                &groups,
                cell,
                &plan.cells,
                &plan.bake,
            )
            .map_err(bad_input)?;
            let s = &bake.stats;
            eprintln!(
                "bake of cell {cell}: {:.2} s wall ({:.0} ms capture, {:.0} ms weights, {:.0} ms simplify, summed over proxies)",
                t.elapsed().as_secs_f64(),
                s.times.capture_ms,
                s.times.weights_ms,
                s.times.simplify_ms
            );
            let r = worker::check::check_cell(
                &scene,
                &grid,
                cell,
                &plan.cells,
                &plan.bake,
                &bake,
                views,
                res,
            )
            .map_err(failed)?;
            if let Some(dir) = &out {
                std::fs::create_dir_all(dir).map_err(failed)?;
                let w = &r.worst;
                for (name, px) in [
                    ("reference", &w.reference),
                    ("proxy", &w.proxy),
                    ("diff", &w.diff),
                ] {
                    let path = dir.join(format!("cell{cell}-view{}-{name}.png", w.view));
                    worker::picture::write_rgba(&path, w.width, w.height, px).map_err(failed)?;
                }
            }
            let s = &bake.stats;
            if json {
                let v = serde_json::json!({
                    "cell": cell,
                    "per_view_psnr_y": r.per_view_psnr_y,
                    "mean_psnr_y": r.mean,
                    "pooled_psnr_y": r.pooled_psnr_y,
                    "empty_views": r.empty_views,
                    "worst_view": r.worst_view,
                    "originals": s.originals, "sv": s.sv_count, "mv": s.mv_count,
                    "clusters": s.cluster_count, "culled": s.culled,
                    "proxy_triangles": s.sv_polygons + s.mv_polygons + s.cluster_polygons,
                    "proxied_original_triangles": s.proxied_original_polygons,
                });
                println!("{}", serde_json::to_string_pretty(&v).expect("serializes"));
            } else {
                println!(
                    "cell {cell}: {} originals, {} SV, {} MV, {} clusters, {} culled; proxies {} of {} triangles",
                    s.originals, s.sv_count, s.mv_count, s.cluster_count, s.culled,
                    s.sv_polygons + s.mv_polygons + s.cluster_polygons, s.proxied_original_polygons
                );
                for (i, p) in r.per_view_psnr_y.iter().enumerate() {
                    println!("view {i:2}: PSNR(Y) {p:6.2} dB");
                }
                println!(
                    "mean {:.2} dB, pooled {:.2} dB ({} views show only sky), worst view {}",
                    r.mean, r.pooled_psnr_y, r.empty_views, r.worst_view
                );
            }
            Ok(())
        }
        Command::Capture {
            manifest,
            cell,
            instance,
            out,
            json,
        } => {
            let plan = format::manifest::parse_manifest(&manifest).map_err(bad_input)?;
            let scene = scene::build_scene(&plan).map_err(bad_input)?;
            let s = worker::diagnostics::capture_pictures(&plan, &scene, cell, instance, &out)
                .map_err(|e| match e {
                    worker::diagnostics::DiagnosticsError::Picture(_) => failed(e),
                    _ => bad_input(e),
                })?;
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
        Command::View {
            manifest,
            eye,
            target,
            fov_deg,
            // Always `None`: its parser refuses the old flag.
            fov_renamed: _,
            size,
            out,
        } => {
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
            let view = worker::raster::View::look_at_fov(
                eye,
                target,
                Vec3::Y,
                fov_deg,
                size,
                size,
                0.5,
                far,
            )
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
    }
}
