//! `player view`: the interactive walk through a bake in a window, or with
//! `--headless` a screenshot drawn offscreen ([`crate::view`]).

use super::args::{parse_xz, renamed_pitch, renamed_yaw, DrawArgs, StreamArgs};
use crate::frame::Mode;
use crate::run::RunError;
use std::path::PathBuf;

// The flags of `player view` (its help text is the `Command::View` doc in main.rs).
#[derive(clap::Args, Clone)]
pub struct ViewArgs {
    pub out: PathBuf,
    /// Start at (x, z), e.g. 150,120; default: the ground's centre.
    #[arg(long, value_parser = parse_xz)]
    pub start: Option<(f32, f32)>,
    /// Quit after this many frames.
    #[arg(long)]
    pub exit_after: Option<u64>,
    /// Save the last frame (overlay included) as PNG on exit.
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// Start heading in degrees (0 = +x, 90 = +z).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw_deg: f32,
    /// Start pitch in degrees (positive = up).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub pitch_deg: f32,
    /// The old names of `--yaw-deg` and `--pitch-deg`: refused with a message
    /// that names the new flag (issue 14, units in names).
    #[arg(long = "yaw", hide = true, allow_hyphen_values = true, value_parser = renamed_yaw)]
    pub yaw_renamed: Option<f32>,
    #[arg(long = "pitch", hide = true, allow_hyphen_values = true, value_parser = renamed_pitch)]
    pub pitch_renamed: Option<f32>,
    /// Start mode (M flips hybrid → full → lod → cluster-lod): hybrid, full, lod or
    /// cluster-lod.
    #[arg(long, default_value = "hybrid")]
    pub mode: Mode,
    /// Start with the colouring by representation on (C flips it).
    #[arg(long)]
    pub colours: bool,
    /// Start with the overlay hidden (H flips it).
    #[arg(long)]
    pub no_overlay: bool,
    /// No window: draw --exit-after frames (default 30) offscreen at the start
    /// pose and write the last one to --screenshot.
    #[arg(long, requires = "screenshot")]
    pub headless: bool,
    #[command(flatten)]
    pub stream: StreamArgs,
    #[command(flatten)]
    pub draw: DrawArgs,
}

/// Opens the window (or the headless session) at the start pose of `args`.
pub fn view(args: ViewArgs) -> Result<(), RunError> {
    let ViewArgs {
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
    } = args;
    let opts = crate::view::ViewOptions {
        size: stream.size.unwrap_or((1024, 768)),
        stream: stream.config(),
        lod_pixel_error: stream.lod_pixel_error,
        cluster_tau: stream.cluster_tau,
        start,
        yaw_deg,
        pitch_deg,
        mode,
        colours,
        overlay: !no_overlay,
        exit_after,
        screenshot,
        draw: draw.options(),
        ..crate::view::ViewOptions::new(out.clone())
    };
    if headless {
        crate::view::run_view_headless(&opts)
    } else {
        crate::view::run_view(opts).map_err(|what| RunError::Write { path: out, what })
    }
}
