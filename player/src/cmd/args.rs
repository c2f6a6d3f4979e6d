//! The argument groups the subcommands share (clap): the stream settings
//! ([`StreamArgs`]), a camera path's walk ([`PathArgs`]: stream settings and display
//! rate), the frame model's switches ([`DrawArgs`] → [`crate::DrawOptions`]), and the
//! value parsers with their refusals of renamed flags (issue 14: units in names).

use crate::stream::{PendingDraw, StreamConfig};

#[derive(clap::Args, Clone)]
pub struct StreamArgs {
    /// Turn the prefetch thread off (cells load on demand; paper Fig. 14).
    #[arg(long)]
    pub no_prefetch: bool,
    /// Texture data uploaded per drawn frame from the FIFO queue, in MiB (fractions
    /// allowed: 0.25 is 256 KiB).
    #[arg(long, default_value_t = 4.0, value_parser = parse_mib)]
    pub upload_budget_mib: f64,
    /// The old name of `--upload-budget-mib` (bytes): refused with a message that
    /// names the new flag (issue 14, units in names).
    #[arg(long = "upload-budget", hide = true, value_parser = renamed_upload_budget)]
    pub upload_budget_renamed: Option<u64>,
    /// Resident cell data kept before LRU eviction, in MiB (the current cell's
    /// neighbours evicted last; a warning says when they do not fit).
    #[arg(long, default_value_t = 1024)]
    pub memory_budget_mib: u64,
    /// How a proxy whose textures are still queued is drawn: `stand-ins` (the
    /// previous cell's ready proxy of the same objects, else `originals`),
    /// `originals` (its member objects) or `lit` (the proxy mesh with vertex
    /// colours).
    #[arg(long, default_value = "stand-ins")]
    pub pending: PendingDraw,
    /// The cross-fade band at cell borders, as a share (0..=1) of the hexagon's
    /// apothem: within it a frame blends the current cell's representation with
    /// each neighbour's (dithered, issue 31). 0 turns it off.
    #[arg(long, default_value_t = crate::stream::DEFAULT_FADE, value_parser = parse_fade)]
    pub fade: f32,
    /// Override the path's resolution, e.g. 256x256.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// `lod` mode (`--mode lod`, or M in `view`): the projected error, in pixels,
    /// below which an instance may use a coarser level of its model's LOD chain.
    #[arg(long, default_value_t = crate::lod::DEFAULT_PIXEL_ERROR)]
    pub lod_pixel_error: f32,
    /// `cluster-lod` mode: τ, the projected error in pixels a drawn cluster may
    /// have (a cluster is drawn when its own error is ≤ τ and its parent group's
    /// > τ); 0 draws exactly the original triangles.
    #[arg(long, default_value_t = crate::clusterlod::DEFAULT_TAU_PX, value_parser = parse_tau)]
    pub cluster_tau: f32,
}

/// `--fade`: a share of the apothem in [0, 1].
pub(crate) fn parse_fade(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(x) if (0.0..=1.0).contains(&x) => Ok(x),
        _ => Err(format!("{s:?} is not a share of the apothem in [0, 1]")),
    }
}

/// `--cluster-tau`: a finite number of pixels ≥ 0.
pub(crate) fn parse_tau(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("{s:?} is not a finite number of pixels >= 0")),
    }
}

/// The frame model's switches ([`crate::DrawOptions`]; issue 28): every default is
/// what the player draws without flags. For measurements; the report and
/// `frames.csv` record them.
#[derive(clap::Args, Clone)]
pub struct DrawArgs {
    /// Originals: do not select patches by the bake's patch bitfields (paper 002).
    #[arg(long)]
    pub no_patch_bitfields: bool,
    /// Originals and proxies: draw tiles whose normal cone is wholly back-facing.
    #[arg(long)]
    pub no_backface: bool,
    /// Originals and proxies: no per-tile frustum test (instances and proxies are
    /// still culled whole).
    #[arg(long)]
    pub no_frustum: bool,
    /// Most triangles in one tile of a patch or proxy normal cluster.
    #[arg(long, default_value_t = format::schema::frames::DEFAULT_TILE_TRIANGLES,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub tile_triangles: u32,
    /// Decode BC1/BC3 capture textures to RGBA8 on the CPU instead of sampling
    /// them natively.
    #[arg(long)]
    pub no_bc: bool,
    /// Proxies: no run-time occlusion culling (tiles hidden behind the frame's
    /// originals are then drawn too).
    #[arg(long)]
    pub no_occlusion: bool,
}

impl DrawArgs {
    pub fn options(&self) -> crate::DrawOptions {
        crate::DrawOptions {
            patch_bitfields: !self.no_patch_bitfields,
            backface: !self.no_backface,
            frustum: !self.no_frustum,
            tile_triangles: self.tile_triangles,
            bc_textures: !self.no_bc,
            occlusion: !self.no_occlusion,
        }
    }
}

/// The walk of a camera path (`render`, `compare`): its stream settings and the
/// display rate it stands for. Not `view`'s: a window draws at its own rate.
#[derive(clap::Args, Clone)]
pub struct PathArgs {
    #[command(flatten)]
    pub stream: StreamArgs,
    /// The display rate a path stands for. A path frame is 1 / frame_rate seconds
    /// of walking (0.1 s on the parks' walk), in which a player drawing at this rate
    /// draws display_hz / frame_rate frames, each with its own upload budget: the
    /// frames not drawn advance the streaming only.
    #[arg(long, default_value_t = 60.0, value_parser = parse_hz)]
    pub display_hz: f32,
}

impl PathArgs {
    /// The stream settings for a headless walk of `path`: display_hz / frame_rate
    /// display frames per path frame (rounded, at least one).
    pub fn path_config(&self, path: &format::path::CameraPath) -> StreamConfig {
        let frames_per_step = (self.display_hz as f64 / path.frame_rate as f64).round();
        StreamConfig {
            display_frames_per_step: frames_per_step.clamp(1.0, 1e4) as u32,
            ..self.stream.config()
        }
    }
}

impl StreamArgs {
    pub fn config(&self) -> StreamConfig {
        StreamConfig {
            prefetch: !self.no_prefetch,
            upload_budget_bytes: mib_to_bytes(self.upload_budget_mib),
            memory_budget_bytes: self.memory_budget_mib << 20,
            pending: self.pending,
            fade: self.fade,
            ..Default::default()
        }
    }
}

pub fn parse_hz(s: &str) -> Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| format!("{s:?}: expected a positive number of frames per second"))
}

pub fn parse_mib(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v >= 0.0 && mib_to_bytes(*v) < u64::MAX)
        .ok_or_else(|| format!("{s:?}: expected a number of MiB >= 0"))
}

/// MiB (2^20 bytes) to whole bytes, rounded.
pub fn mib_to_bytes(mib: f64) -> u64 {
    (mib * (1u64 << 20) as f64).round() as u64
}

/// `--upload-budget BYTES` was renamed `--upload-budget-mib MIB`.
pub fn renamed_upload_budget(s: &str) -> Result<u64, String> {
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
pub fn renamed_yaw(_: &str) -> Result<f32, String> {
    Err("`--yaw` was renamed `--yaw-deg` (degrees)".into())
}

/// `--pitch` was renamed `--pitch-deg`.
#[cfg(feature = "view")]
pub fn renamed_pitch(_: &str) -> Result<f32, String> {
    Err("`--pitch` was renamed `--pitch-deg` (degrees)".into())
}

pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
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
pub fn parse_xz(s: &str) -> Result<(f32, f32), String> {
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

#[cfg(test)]
mod tests {
    use super::parse_fade;

    /// `--fade` takes a share of the apothem in [0, 1] and names what it expects
    /// otherwise.
    #[test]
    fn fade_is_a_share_of_the_apothem() {
        assert_eq!(parse_fade("0.15"), Ok(0.15));
        assert_eq!(parse_fade("0"), Ok(0.0));
        assert_eq!(parse_fade("1"), Ok(1.0));
        for bad in ["-0.1", "1.5", "NaN", "inf", "wide"] {
            let e = parse_fade(bad).unwrap_err();
            assert!(
                e.contains("share of the apothem in [0, 1]") && e.contains(bad),
                "{e}"
            );
        }
    }
}
