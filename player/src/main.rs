//! `player`: walks through a bake (paper 000 §3.2) — `render` a camera path headless
//! in one configuration (A full, B frustum, C hybrid, or the distance-LOD baseline),
//! `compare` the hybrid (or the LOD baseline) with the full-geometry reference (PSNR on luminance, SSIM, over whole frames and over object pixels, also against an anti-aliased reference; triangle and frame-time ratios).

use clap::{Parser, Subcommand};
use player::frame::Mode;
use player::run::{compare, crossing_stats, render, CompareOptions, RenderOptions};
use player::stream::{PendingDraw, StreamConfig};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "player",
    version,
    about = "hexbake player: renders baked cell packs with wgpu"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args, Clone)]
struct StreamArgs {
    /// Turn the prefetch thread off (cells load on demand; paper Fig. 14).
    #[arg(long)]
    no_prefetch: bool,
    /// Texture data uploaded per drawn frame from the FIFO queue, in MiB (fractions
    /// allowed: 0.25 is 256 KiB).
    #[arg(long, default_value_t = 4.0, value_parser = parse_mib)]
    upload_budget_mib: f64,
    /// The old name of `--upload-budget-mib` (bytes): refused with a message that
    /// names the new flag (issue 14, units in names).
    #[arg(long = "upload-budget", hide = true, value_parser = renamed_upload_budget)]
    upload_budget_renamed: Option<u64>,
    /// Resident cell data kept before LRU eviction, in MiB.
    #[arg(long, default_value_t = 512)]
    memory_budget_mib: u64,
    /// How a proxy whose textures are still queued is drawn: `stand-ins` (the
    /// previous cell's ready proxy of the same objects, else `originals`),
    /// `originals` (its member objects) or `lit` (the proxy mesh with vertex
    /// colours).
    #[arg(long, default_value = "stand-ins")]
    pending: PendingDraw,
    /// Override the path's resolution, e.g. 256x256.
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// `lod` mode (`--mode lod`, or M in `view`): the projected error, in pixels,
    /// below which an instance may use a coarser level of its model's LOD chain.
    #[arg(long, default_value_t = player::lod::DEFAULT_PIXEL_ERROR)]
    lod_pixel_error: f32,
}

/// The frame model's switches ([`player::DrawOptions`]; issue 28): every default is
/// what the player draws without flags. For measurements; the report and
/// `frames.csv` record them.
#[derive(clap::Args, Clone)]
struct DrawArgs {
    /// Originals: do not select patches by the bake's patch bitfields (paper 002).
    #[arg(long)]
    no_patch_bitfields: bool,
    /// Originals and proxies: draw tiles whose normal cone is wholly back-facing.
    #[arg(long)]
    no_backface: bool,
    /// Originals and proxies: no per-tile frustum test (instances and proxies are
    /// still culled whole).
    #[arg(long)]
    no_frustum: bool,
    /// Most triangles in one tile of a patch or proxy normal cluster.
    #[arg(long, default_value_t = format::schema::frames::DEFAULT_TILE_TRIANGLES,
          value_parser = clap::value_parser!(u32).range(1..))]
    tile_triangles: u32,
    /// Decode BC1/BC3 capture textures to RGBA8 on the CPU instead of sampling
    /// them natively.
    #[arg(long)]
    no_bc: bool,
}

impl DrawArgs {
    fn options(&self) -> player::DrawOptions {
        player::DrawOptions {
            patch_bitfields: !self.no_patch_bitfields,
            backface: !self.no_backface,
            frustum: !self.no_frustum,
            tile_triangles: self.tile_triangles,
            bc_textures: !self.no_bc,
        }
    }
}

/// The walk of a camera path (`render`, `compare`): its stream settings and the
/// display rate it stands for. Not `view`'s: a window draws at its own rate.
#[derive(clap::Args, Clone)]
struct PathArgs {
    #[command(flatten)]
    stream: StreamArgs,
    /// The display rate a path stands for. A path frame is 1 / frame_rate seconds
    /// of walking (0.1 s on the parks' walk), in which a player drawing at this rate
    /// draws display_hz / frame_rate frames, each with its own upload budget: the
    /// frames not drawn advance the streaming only.
    #[arg(long, default_value_t = 60.0, value_parser = parse_hz)]
    display_hz: f32,
}

impl PathArgs {
    /// The stream settings for a headless walk of `path`: display_hz / frame_rate
    /// display frames per path frame (rounded, at least one).
    fn path_config(&self, path: &format::path::CameraPath) -> StreamConfig {
        let frames_per_step = (self.display_hz as f64 / path.frame_rate as f64).round();
        StreamConfig {
            display_frames_per_step: frames_per_step.clamp(1.0, 1e4) as u32,
            ..self.stream.config()
        }
    }
}

impl StreamArgs {
    fn config(&self) -> StreamConfig {
        StreamConfig {
            prefetch: !self.no_prefetch,
            upload_budget_bytes: mib_to_bytes(self.upload_budget_mib),
            memory_budget_bytes: self.memory_budget_mib << 20,
            pending: self.pending,
            ..Default::default()
        }
    }
}

fn parse_hz(s: &str) -> Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| format!("{s:?}: expected a positive number of frames per second"))
}

fn parse_mib(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v >= 0.0 && mib_to_bytes(*v) < u64::MAX)
        .ok_or_else(|| format!("{s:?}: expected a number of MiB >= 0"))
}

/// MiB (2^20 bytes) to whole bytes, rounded.
fn mib_to_bytes(mib: f64) -> u64 {
    (mib * (1u64 << 20) as f64).round() as u64
}

/// `--upload-budget BYTES` was renamed `--upload-budget-mib MIB`.
fn renamed_upload_budget(s: &str) -> Result<u64, String> {
    let hint = s
        .parse::<u64>()
        .map(|bytes| {
            format!(
                ": {bytes} bytes is `--upload-budget-mib {}`",
                bytes as f64 / (1u64 << 20) as f64
            )
        })
        .unwrap_or_default();
    Err(format!(
        "`--upload-budget` (bytes) was renamed `--upload-budget-mib` (MiB per drawn frame){hint}"
    ))
}

/// `--yaw` was renamed `--yaw-deg`.
#[cfg(feature = "view")]
fn renamed_yaw(_: &str) -> Result<f32, String> {
    Err("`--yaw` was renamed `--yaw-deg` (degrees)".into())
}

/// `--pitch` was renamed `--pitch-deg`.
#[cfg(feature = "view")]
fn renamed_pitch(_: &str) -> Result<f32, String> {
    Err("`--pitch` was renamed `--pitch-deg` (degrees)".into())
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT"))?;
    let p = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("{s:?}: bad size"))
    };
    Ok((p(w)?, p(h)?))
}

#[cfg(feature = "view")]
fn parse_xz(s: &str) -> Result<(f32, f32), String> {
    let (x, z) = s
        .split_once(',')
        .ok_or_else(|| format!("{s:?}: expected X,Z"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<f32>()
            .ok()
            .filter(|f| f.is_finite())
            .ok_or_else(|| format!("{s:?}: bad coordinate"))
    };
    Ok((p(x)?, p(z)?))
}

#[derive(Subcommand)]
enum Command {
    /// Render a camera path headless; writes frames.csv (and PNGs) into --frames.
    Render {
        /// Bake output directory (base.pack, index.pack, cells/).
        out: PathBuf,
        #[arg(long)]
        path: PathBuf,
        #[arg(long)]
        frames: PathBuf,
        #[arg(long, default_value = "hybrid")]
        mode: Mode,
        /// Also write one PNG per frame.
        #[arg(long)]
        png: bool,
        #[command(flatten)]
        walk: PathArgs,
        #[command(flatten)]
        draw: DrawArgs,
    },
    /// Walk through a bake in a window (WASD, arrows or left-drag to turn, Q/E eye
    /// height, Esc quits).
    #[cfg(feature = "view")]
    View {
        out: PathBuf,
        /// Start at (x, z), e.g. 150,120; default: the ground's centre.
        #[arg(long, value_parser = parse_xz)]
        start: Option<(f32, f32)>,
        /// Quit after this many frames.
        #[arg(long)]
        exit_after: Option<u64>,
        /// Save the last frame (overlay included) as PNG on exit.
        #[arg(long)]
        screenshot: Option<PathBuf>,
        /// Start heading in degrees (0 = +x, 90 = +z).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        yaw_deg: f32,
        /// Start pitch in degrees (positive = up).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        pitch_deg: f32,
        /// The old names of `--yaw-deg` and `--pitch-deg`: refused with a message
        /// that names the new flag (issue 14, units in names).
        #[arg(long = "yaw", hide = true, allow_hyphen_values = true, value_parser = renamed_yaw)]
        yaw_renamed: Option<f32>,
        #[arg(long = "pitch", hide = true, allow_hyphen_values = true, value_parser = renamed_pitch)]
        pitch_renamed: Option<f32>,
        /// Start mode (M flips hybrid → full → lod): hybrid, full or lod.
        #[arg(long, default_value = "hybrid")]
        mode: Mode,
        /// Start with the colouring by representation on (C flips it).
        #[arg(long)]
        colours: bool,
        /// Start with the overlay hidden (H flips it).
        #[arg(long)]
        no_overlay: bool,
        /// No window: draw --exit-after frames (default 30) offscreen at the start
        /// pose and write the last one to --screenshot.
        #[arg(long, requires = "screenshot")]
        headless: bool,
        #[command(flatten)]
        stream: StreamArgs,
        #[command(flatten)]
        draw: DrawArgs,
    },
    /// Write a synthetic bake of manifests/demo.ron (hand-made proxies, flat
    /// textures) for trying the player without a bake.
    Synth { out: PathBuf },
    /// Compare the hybrid (or the LOD baseline) with full geometry along a camera path.
    Compare {
        out: PathBuf,
        #[arg(long)]
        path: PathBuf,
        /// What to compare with the full-geometry reference: hybrid or lod.
        #[arg(long, default_value = "hybrid")]
        mode: Mode,
        /// Print the report as JSON on stdout.
        #[arg(long)]
        json: bool,
        /// Write the worst frames by object-pixel PSNR (reference, hybrid,
        /// difference, anti-aliased reference) here.
        #[arg(long)]
        worst: Option<PathBuf>,
        /// How many worst frames to write.
        #[arg(long, default_value_t = 3)]
        worst_count: usize,
        /// Skip the extra no-prefetch pass (crossing frame times).
        #[arg(long)]
        no_crossings: bool,
        /// Measure the pop at each cell crossing: the crossing pose drawn with the
        /// outgoing and with the incoming cell, compared over object pixels, beside
        /// the change a one-pixel camera turn makes (issue 31); with --worst, the
        /// worst crossing's pair as PNGs.
        #[arg(long)]
        pops: bool,
        /// Supersampling per axis of the anti-aliased reference (full geometry
        /// rendered N times wider and higher, box-filtered in linear light); 1 = none.
        #[arg(long, default_value_t = player::run::DEFAULT_REFERENCE_SS,
              value_parser = clap::value_parser!(u32).range(1..=player::run::MAX_REFERENCE_SS as i64))]
        reference_ss: u32,
        /// Draw each configuration's frame this many times and time it by the
        /// fastest draw (robust to a busy machine; above 1 the hybrid's time leaves
        /// out the texture uploads its first draw submits).
        #[arg(long, default_value_t = 1,
              value_parser = clap::value_parser!(u32).range(1..=100))]
        repeat: u32,
        #[command(flatten)]
        walk: PathArgs,
        #[command(flatten)]
        draw: DrawArgs,
    },
}

/// The environment variables that switched the frame model before issue 28, with
/// the flag that replaced each. The player reads none of them; one left set would
/// silently measure the defaults, so `main` refuses to start while one is set.
const REPLACED_ENV: [(&str, &str); 5] = [
    ("HEXBAKE_PATCH_BITFIELDS", "--no-patch-bitfields"),
    ("HEXBAKE_PATCH_BACKFACE", "--no-backface"),
    ("HEXBAKE_PATCH_FRUSTUM", "--no-frustum"),
    ("HEXBAKE_CLUSTER_TRIANGLES", "--tile-triangles N"),
    ("HEXBAKE_NO_BC", "--no-bc"),
];

/// The message for the replaced variables among `set`, if any.
fn replaced_env_message(set: impl Fn(&str) -> bool) -> Option<String> {
    let found: Vec<String> = REPLACED_ENV
        .iter()
        .filter(|(name, _)| set(name))
        .map(|(name, flag)| format!("{name} (now `{flag}`)"))
        .collect();
    (!found.is_empty()).then(|| {
        format!(
            "the environment no longer configures the player: unset {} and pass the flag instead",
            found.join(", ")
        )
    })
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    let cli = Cli::parse();
    if let Some(msg) = replaced_env_message(|name| std::env::var_os(name).is_some()) {
        eprintln!("player: error: {msg}");
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Render {
            out,
            path,
            frames,
            mode,
            png,
            walk,
            draw,
        } => format::path::CameraPath::load(&path)
            .map_err(player::run::RunError::from)
            .and_then(|p| {
                let opts = RenderOptions {
                    mode,
                    frames_dir: frames.clone(),
                    png,
                    stream: walk.path_config(&p),
                    size: walk.stream.size,
                    lod_pixel_error: walk.stream.lod_pixel_error,
                    draw: draw.options(),
                };
                render(&out, &p, &opts)
            })
            .map(|(records, _)| {
                let n = records.len().max(1) as f64;
                let ms: f64 = records.iter().map(|r| r.frame_ms).sum::<f64>() / n;
                let tris: f64 = records.iter().map(|r| r.triangles as f64).sum::<f64>() / n;
                let c = crossing_stats(&records);
                println!(
                    "{} frames ({}): mean {ms:.2} ms, {tris:.0} triangles; {} crossings, max after crossing {:.2} ms vs in-cell median {:.2} ms; {}",
                    records.len(),
                    mode.name(),
                    c.crossings,
                    c.max_after_crossing_ms,
                    c.in_cell_median_ms,
                    frames.join("frames.csv").display()
                );
            }),
        #[cfg(feature = "view")]
        Command::View {
            out,
            start,
            exit_after,
            screenshot,
            yaw_deg,
            pitch_deg,
            // Always `None`: their parsers refuse the old flags.
            yaw_renamed: _,
            pitch_renamed: _,
            mode,
            colours,
            no_overlay,
            headless,
            stream,
            draw,
        } => {
            let opts = player::view::ViewOptions {
                size: stream.size.unwrap_or((1024, 768)),
                stream: stream.config(),
                lod_pixel_error: stream.lod_pixel_error,
                start,
                yaw_deg,
                pitch_deg,
                mode,
                colours,
                overlay: !no_overlay,
                exit_after,
                screenshot,
                draw: draw.options(),
                ..player::view::ViewOptions::new(out.clone())
            };
            if headless {
                player::view::run_view_headless(&opts)
            } else {
                player::view::run_view(opts)
                    .map_err(|what| player::run::RunError::Write { path: out, what })
            }
        }
        Command::Synth { out } => player::testdata::write_synthetic_bake(&out)
            .map(|b| {
                println!(
                    "{}: {} cells, {} instances, {} triangles",
                    out.display(),
                    b.cells,
                    b.instances,
                    b.triangles
                )
            })
            .map_err(|e| player::run::RunError::Write {
                path: out.clone(),
                what: e.to_string(),
            }),
        Command::Compare {
            out,
            path,
            mode,
            json,
            worst,
            worst_count,
            no_crossings,
            pops,
            reference_ss,
            repeat,
            walk,
            draw,
        } => format::path::CameraPath::load(&path)
            .map_err(player::run::RunError::from)
            .and_then(|p| {
                compare(
                    &out,
                    &p,
                    &CompareOptions {
                        worst_dir: worst,
                        worst_count,
                        size: walk.stream.size,
                        crossings: !no_crossings,
                        pops,
                        stream: walk.path_config(&p),
                        mode,
                        lod_pixel_error: walk.stream.lod_pixel_error,
                        reference_ss,
                        repeat,
                        draw: draw.options(),
                    },
                )
            })
            .map(|r| {
                if json {
                    println!(
                        "{}",
                        serde_json::to_string_pretty(&r).unwrap_or_else(|e| e.to_string())
                    );
                } else {
                    let db = |v: Option<f64>| v.map_or("      –".to_string(), |v| format!("{v:7.2}"));
                    for f in &r.per_frame {
                        let aa = f.aa_reference.as_ref().map_or(String::new(), |a| {
                            format!(
                                " | vs AA: object {} dB (full geometry {} dB)",
                                db(a.compared.object_psnr_y_db),
                                db(a.full.object_psnr_y_db)
                            )
                        });
                        println!(
                            "frame {:4} cell {:>4} psnr_y {:7.2} dB ssim {:.4} object {} dB ssim {} ({} px) triangles {} / {}{aa}",
                            f.frame,
                            f.cell.map_or(-1, |c| c as i64),
                            f.psnr_y,
                            f.ssim,
                            db(f.object_psnr_y_db),
                            f.object_ssim.map_or("     –".to_string(), |s| format!("{s:.4}")),
                            f.object_pixels,
                            f.triangles,
                            f.reference_triangles
                        );
                    }
                    println!(
                        "{} frames ({}): mean PSNR(Y) {:.2} dB (min {:.2}), mean SSIM {:.4}, triangles {:.0} / {:.0} ({:.3}), frame time ratio {:.3} vs full, {:.3} vs frustum",
                        r.frames,
                        r.mode,
                        r.mean_psnr_y,
                        r.min_psnr_y,
                        r.mean_ssim,
                        r.mean_triangles,
                        r.reference_triangles,
                        r.mean_triangles / r.reference_triangles.max(1.0),
                        r.frame_time_ratio,
                        r.frame_time_ratio_frustum
                    );
                    let object = |o: &player::metrics::ObjectQuality| {
                        format!(
                            "object pixels ({:.1}% of all): PSNR(Y) {:.2} dB pooled, worst frame {} at {:.2} dB, mean SSIM {:.4}",
                            100.0 * o.object_pixel_fraction,
                            o.object_psnr_y_db,
                            o.worst_object_frame.map_or(-1, |f| f as i64),
                            o.min_object_psnr_y_db,
                            o.mean_object_ssim
                        )
                    };
                    println!("{} vs full geometry: {}", r.mode, object(&r.object));
                    if let Some(aa) = &r.aa_reference {
                        for (name, q) in [(r.mode.as_str(), &aa.compared), ("full geometry", &aa.full)] {
                            println!(
                                "{name} vs anti-aliased reference ({0}×{0} samples): mean PSNR(Y) {1:.2} dB (min {2:.2}), mean SSIM {3:.4}; {4}",
                                aa.supersampling_factor,
                                q.mean_psnr_y_db,
                                q.min_psnr_y_db,
                                q.mean_ssim,
                                object(&q.object)
                            );
                        }
                    }
                    if !r.fallback_cells.is_empty() {
                        println!(
                            "fallback: cells {:?} were drawn with original geometry (pack missing, corrupt or off the index); their frames count full geometry as the hybrid",
                            r.fallback_cells
                        );
                    }
                    if let Some(p) = &r.pops {
                        println!(
                            "pops at {} crossings: object-pixel PSNR(Y) of outgoing vs incoming cell mean {:.2} dB, worst {:.2} dB (frame {}); a one-pixel turn: mean {:.2} dB; {} crossings no larger than the turn",
                            p.crossings.len(),
                            p.mean_pop_psnr_y_db,
                            p.worst_pop_psnr_y_db,
                            p.worst_frame.map_or("-".to_string(), |f| f.to_string()),
                            p.mean_shift_psnr_y_db,
                            p.below_shift
                        );
                    }
                    for (name, c) in [
                        ("prefetch on", &r.crossing_prefetch),
                        ("prefetch off", &r.crossing_no_prefetch),
                    ] {
                        if let Some(c) = c {
                            println!(
                                "crossings ({name}): {} — max frame time in the 10 frames after a crossing {:.2} ms = {:.2} × in-cell median {:.2} ms",
                                c.crossings, c.max_after_crossing_ms, c.ratio, c.in_cell_median_ms
                            );
                        }
                    }
                }
            }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("player: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Like other Unix tools, end quietly when stdout is a closed pipe (`| head`) instead
/// of panicking in `println!`: restore the default SIGPIPE action Rust ignores.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread starts; setting a
    // signal's disposition to SIG_DFL has no other precondition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stream_args(args: &[&str]) -> Result<StreamArgs, clap::Error> {
        Ok(path_args(args)?.stream)
    }

    fn path_args(args: &[&str]) -> Result<PathArgs, clap::Error> {
        let mut argv = vec![
            "player", "render", "out", "--path", "p.ron", "--frames", "f",
        ];
        argv.extend_from_slice(args);
        match Cli::try_parse_from(argv)?.command {
            Command::Render { walk, .. } => Ok(walk),
            _ => unreachable!("parsed a render command"),
        }
    }

    /// Issue 28: `view --lod-pixel-error` sets the pixel error of its `lod` mode
    /// (start mode or M); `--display-hz`, a path's display rate, is not a `view`
    /// flag (a window draws at its own rate) and is refused, not ignored.
    #[cfg(feature = "view")]
    #[test]
    fn view_takes_the_lod_pixel_error_and_refuses_a_display_rate() {
        let Command::View { stream, .. } =
            Cli::try_parse_from(["player", "view", "out", "--lod-pixel-error", "3.5"])
                .unwrap()
                .command
        else {
            panic!("a view command")
        };
        assert_eq!(stream.lod_pixel_error, 3.5);
        let e = Cli::try_parse_from(["player", "view", "out", "--display-hz", "30"])
            .err()
            .expect("--display-hz is refused for view")
            .to_string();
        assert!(e.contains("--display-hz"), "{e}");
        assert!(path_args(&["--display-hz", "30"]).is_ok());
    }

    /// Issue 14: `view`'s angles carry their unit; the old flags name the new ones.
    #[cfg(feature = "view")]
    #[test]
    fn view_angles_are_in_degrees_and_the_old_flags_name_the_new_ones() {
        let ok = Cli::try_parse_from([
            "player",
            "view",
            "out",
            "--yaw-deg",
            "-16",
            "--pitch-deg",
            "5",
        ])
        .unwrap();
        let Command::View {
            yaw_deg, pitch_deg, ..
        } = ok.command
        else {
            panic!("a view command")
        };
        assert_eq!((yaw_deg, pitch_deg), (-16.0, 5.0));
        for (old, new) in [("--yaw", "`--yaw-deg`"), ("--pitch", "`--pitch-deg`")] {
            let e = Cli::try_parse_from(["player", "view", "out", old, "-16"])
                .err()
                .expect("the old flag is refused")
                .to_string();
            assert!(e.contains(&format!("was renamed {new} (degrees)")), "{e}");
        }
    }

    /// Issue 14: the upload budget is given in MiB like the memory budget; the old
    /// byte flag is refused with a message naming the new one.
    #[test]
    fn the_upload_budget_is_in_mib_and_the_old_flag_names_the_new_one() {
        let s = stream_args(&["--upload-budget-mib", "0.25"]).unwrap();
        assert_eq!(s.config().upload_budget_bytes, 256 << 10);
        let s = stream_args(&["--upload-budget-mib", "1024"]).unwrap();
        assert_eq!(s.config().upload_budget_bytes, 1 << 30);
        assert_eq!(
            stream_args(&[]).unwrap().config().upload_budget_bytes,
            4 << 20
        );
        for bad in ["-1", "nan", "lots"] {
            let arg = format!("--upload-budget-mib={bad}");
            assert!(stream_args(&[&arg]).is_err(), "{bad}");
        }
        let e = stream_args(&["--upload-budget", "1073741824"])
            .err()
            .expect("the old flag is refused")
            .to_string();
        assert!(
            e.contains("was renamed `--upload-budget-mib`")
                && e.contains("`--upload-budget-mib 1024`"),
            "{e}"
        );
    }

    /// Issue 28: the frame model's switches are flags (no environment variable),
    /// on every command that draws; none given is the library's default.
    #[test]
    fn draw_flags_set_the_draw_options() {
        let draw = |args: &[&str]| -> Result<player::DrawOptions, clap::Error> {
            let mut argv = vec!["player", "compare", "out", "--path", "p.ron"];
            argv.extend_from_slice(args);
            match Cli::try_parse_from(argv)?.command {
                Command::Compare { draw, .. } => Ok(draw.options()),
                _ => unreachable!("parsed a compare command"),
            }
        };
        assert_eq!(draw(&[]).unwrap(), player::DrawOptions::default());
        let all = draw(&[
            "--no-patch-bitfields",
            "--no-backface",
            "--no-frustum",
            "--tile-triangles",
            "1000000",
            "--no-bc",
        ])
        .unwrap();
        assert_eq!(
            all,
            player::DrawOptions {
                patch_bitfields: false,
                backface: false,
                frustum: false,
                tile_triangles: 1_000_000,
                bc_textures: false,
            }
        );
        assert!(draw(&["--tile-triangles", "0"]).is_err());
        // The old variables are refused by name, with the flag that replaced each.
        assert_eq!(replaced_env_message(|_| false), None);
        let msg = replaced_env_message(|n| n == "HEXBAKE_NO_BC").unwrap();
        assert!(msg.contains("HEXBAKE_NO_BC (now `--no-bc`)"), "{msg}");
        let Command::Render { draw, .. } = Cli::try_parse_from([
            "player",
            "render",
            "out",
            "--path",
            "p.ron",
            "--frames",
            "f",
            "--no-frustum",
        ])
        .unwrap()
        .command
        else {
            panic!("a render command")
        };
        assert!(!draw.options().frustum);
        #[cfg(feature = "view")]
        {
            let Command::View { draw, .. } =
                Cli::try_parse_from(["player", "view", "out", "--no-bc"])
                    .unwrap()
                    .command
            else {
                panic!("a view command")
            };
            assert!(!draw.options().bc_textures);
        }
    }

    #[test]
    fn a_path_frame_stands_for_the_display_frames_of_its_time_step() {
        let path = format::path::CameraPath::parse(
            "(eye_height: 8.0, fov_y_deg: 60.0, resolution: (8, 8), max_speed: 30.0, \
             max_turn_deg_per_s: 45.0, frame_rate: 10.0, waypoints: [(0.0, 0.0), (9.0, 0.0)])",
            std::path::Path::new("p.ron"),
        )
        .unwrap();
        let s = path_args(&[]).unwrap();
        assert_eq!(s.stream.config().display_frames_per_step, 1);
        let c = s.path_config(&path);
        assert_eq!(
            (c.display_frames_per_step, c.upload_budget_bytes),
            (6, 4 << 20)
        );
        let s = path_args(&["--display-hz", "5"]).unwrap();
        assert_eq!(
            s.path_config(&path).display_frames_per_step,
            1,
            "at least the drawn one"
        );
        for bad in ["0", "-60", "nan", "fast"] {
            let arg = format!("--display-hz={bad}");
            let e = path_args(&[&arg]).err().expect("refused");
            assert!(e.to_string().contains("frames per second"), "{e}");
        }
    }
}
