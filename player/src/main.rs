//! `player`: walks through a bake (paper 000 §3.2) — `render` a camera path headless
//! in one configuration (A full, B frustum, C hybrid, or the distance-LOD baseline),
//! `compare` the hybrid (or the LOD baseline) with the full-geometry reference (PSNR on luminance, SSIM, over whole frames and over object pixels, also against an anti-aliased reference; triangle and frame-time ratios).
//!
//! This file is the clap entry point and the dispatch: each subcommand's flags and
//! function live in `player::cmd` (`src/cmd/`). `main` is the one place that reads
//! the environment (it refuses the replaced `HEXBAKE_*` variables).

use clap::{Parser, Subcommand};
use player::cmd;
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

#[derive(Subcommand)]
enum Command {
    /// Render a camera path headless; writes frames.csv (and PNGs) into --frames.
    Render(cmd::RenderArgs),
    /// Walk through a bake in a window (WASD, arrows or left-drag to turn, Q/E eye
    /// height, Esc quits).
    #[cfg(feature = "view")]
    View(cmd::ViewArgs),
    /// Write a synthetic bake of manifests/demo.ron (hand-made proxies, flat
    /// textures) for trying the player without a bake.
    Synth(cmd::SynthArgs),
    /// Compare the hybrid (or the LOD baseline) with full geometry along a camera path.
    Compare(cmd::CompareArgs),
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
        Command::Render(args) => cmd::render(args),
        #[cfg(feature = "view")]
        Command::View(args) => cmd::view(args),
        Command::Synth(args) => cmd::synth(args),
        Command::Compare(args) => cmd::compare(args),
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
    use player::cmd::args::{PathArgs, StreamArgs};

    fn stream_args(args: &[&str]) -> Result<StreamArgs, clap::Error> {
        Ok(path_args(args)?.stream)
    }

    fn path_args(args: &[&str]) -> Result<PathArgs, clap::Error> {
        let mut argv = vec![
            "player", "render", "out", "--path", "p.ron", "--frames", "f",
        ];
        argv.extend_from_slice(args);
        match Cli::try_parse_from(argv)?.command {
            Command::Render(a) => Ok(a.walk),
            _ => unreachable!("parsed a render command"),
        }
    }

    /// Issue 28: `view --lod-pixel-error` sets the pixel error of its `lod` mode
    /// (start mode or M); `--display-hz`, a path's display rate, is not a `view`
    /// flag (a window draws at its own rate) and is refused, not ignored.
    #[cfg(feature = "view")]
    #[test]
    fn view_takes_the_lod_pixel_error_and_refuses_a_display_rate() {
        let Command::View(cmd::ViewArgs { stream, .. }) =
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

    /// Issue 30: `--mode cluster-lod` and `--cluster-tau PX` (default 1, ≥ 0 and
    /// finite) for render, compare and view.
    #[test]
    fn cluster_lod_mode_and_tau_parse() {
        assert_eq!(stream_args(&[]).unwrap().cluster_tau, 1.0);
        assert_eq!(
            stream_args(&["--cluster-tau", "0"]).unwrap().cluster_tau,
            0.0
        );
        assert_eq!(
            stream_args(&["--cluster-tau", "2.5"]).unwrap().cluster_tau,
            2.5
        );
        for bad in ["-1", "nan", "inf", "x"] {
            assert!(
                stream_args(&["--cluster-tau", bad]).is_err(),
                "--cluster-tau {bad}"
            );
        }
        let cli = Cli::try_parse_from([
            "player",
            "compare",
            "out",
            "--path",
            "p.ron",
            "--mode",
            "cluster-lod",
        ])
        .unwrap();
        let Command::Compare(a) = cli.command else {
            panic!("a compare command")
        };
        assert_eq!(a.mode, player::frame::Mode::ClusterLod);
        let e = "clusterlod".parse::<player::frame::Mode>().unwrap_err();
        assert!(e.contains("cluster-lod"), "{e}");
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
        let Command::View(cmd::ViewArgs {
            yaw_deg, pitch_deg, ..
        }) = ok.command
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
                Command::Compare(a) => Ok(a.draw.options()),
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
            "--no-occlusion",
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
                occlusion: false,
            }
        );
        assert!(draw(&["--tile-triangles", "0"]).is_err());
        // The old variables are refused by name, with the flag that replaced each.
        assert_eq!(replaced_env_message(|_| false), None);
        let msg = replaced_env_message(|n| n == "HEXBAKE_NO_BC").unwrap();
        assert!(msg.contains("HEXBAKE_NO_BC (now `--no-bc`)"), "{msg}");
        let Command::Render(cmd::RenderArgs { draw, .. }) = Cli::try_parse_from([
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
            let Command::View(cmd::ViewArgs { draw, .. }) =
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
