//! `--set KEY=VALUE`: overrides of a manifest's bake and cell parameters from the
//! command line (`pipeline run --set`, for parameter sweeps like the paper's Tables
//! 3–5, 000 §4.3: T_s ∈ {3, 5, 7}, T_l ∈ {3.0, 4.5, 6.0}, cell size ∈ {50, 100}).
//!
//! Keys are the manifest's dotted field names (`bake.self_occluding_tolerance_px`,
//! `cells.cell_size`, `cells_per_job`, ...) plus the paper's short names `T_s`, `T_l`,
//! `T_C0`, `T_C1` (with or without `bake.`). An override replaces the value in the
//! **raw** manifest (stage 1, after ron has read the file) and only its type is
//! checked here; the validator (stage 2) then checks it with the file's own rules, so
//! `--set cells.cell_size=0.001` is refused with exactly the message the same value
//! in the file gets ([`super::ManifestError::Override`]). A renamed key
//! ([`super::RENAMED`]) is refused with a message naming the new one. Job
//! fingerprints include every parameter, so a bake with overrides never passes for
//! one without: give it its own `--out`.

use super::{RawManifest, RawQuality};

/// One `KEY=VALUE`.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    /// Canonical dotted key, e.g. `bake.self_occluding_tolerance_px`: the field's
    /// path in the manifest, as validation errors name it.
    pub key: &'static str,
    pub value: String,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OverrideError {
    #[error("--set {text:?}: expected KEY=VALUE")]
    Syntax { text: String },
    #[error("--set {key}: unknown key; known keys: {known}")]
    UnknownKey { key: String, known: String },
    /// A key renamed to carry its unit (`message` names the new one).
    #[error("--set {key}: {message}")]
    Renamed { key: String, message: String },
}

/// The keys `--set` accepts: (canonical key, aliases).
pub const KEYS: &[(&str, &[&str])] = &[
    ("bake.image_res", &[]),
    (
        "bake.self_occluding_tolerance_px",
        &["T_s", "bake.T_s", "ts"],
    ),
    ("bake.edge_length_tolerance_px", &["T_l", "bake.T_l", "tl"]),
    ("bake.t_c0", &["T_C0", "bake.T_C0"]),
    ("bake.t_c1", &["T_C1", "bake.T_C1"]),
    ("bake.clustering", &[]),
    ("bake.occlusion_culling", &[]),
    ("bake.far_field", &[]),
    ("bake.far_levels", &["far_levels"]),
    ("bake.merge_level", &["merge_level"]),
    ("bake.quality", &[]),
    ("bake.quality.min_psnr_db", &["min_psnr_db"]),
    ("bake.quality.min_ssim", &["min_ssim"]),
    ("bake.quality_check", &[]),
    ("bake.max_deviation_px", &["deviation"]),
    ("cells.cell_size", &["cell_size"]),
    ("cells.min_eye_height", &[]),
    ("cells.max_eye_height", &[]),
    ("cells_per_job", &[]),
    ("split_wide_objects", &[]),
];

/// Parses one `KEY=VALUE` (the value is checked when applied and validated).
pub fn parse_override(text: &str) -> Result<Override, OverrideError> {
    let (key, value) = text
        .split_once('=')
        .map(|(k, v)| (k.trim(), v.trim()))
        .filter(|(k, v)| !k.is_empty() && !v.is_empty())
        .ok_or_else(|| OverrideError::Syntax {
            text: text.to_string(),
        })?;
    if let Some(message) = super::renamed_message(key) {
        return Err(OverrideError::Renamed {
            key: key.to_string(),
            message,
        });
    }
    let canonical = KEYS
        .iter()
        .find(|(k, aliases)| *k == key || aliases.contains(&key))
        .map(|(k, _)| *k)
        .ok_or_else(|| OverrideError::UnknownKey {
            key: key.to_string(),
            known: KEYS
                .iter()
                .map(|(k, a)| {
                    if a.is_empty() {
                        k.to_string()
                    } else {
                        format!("{k} ({})", a.join(", "))
                    }
                })
                .collect::<Vec<_>>()
                .join(", "),
        })?;
    Ok(Override {
        key: canonical,
        value: value.to_string(),
    })
}

impl std::fmt::Display for Override {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}={}", self.key, self.value)
    }
}

impl Override {
    /// A number (any f32 ron would read; ranges are the validator's).
    fn number(&self) -> Result<f32, String> {
        self.value
            .parse::<f32>()
            .map_err(|_| format!("expected a number, found `{}`", self.value))
    }

    fn number_f64(&self) -> Result<f64, String> {
        self.value
            .parse::<f64>()
            .map_err(|_| format!("expected a number, found `{}`", self.value))
    }

    fn integer(&self) -> Result<u32, String> {
        self.value
            .parse::<u32>()
            .map_err(|_| format!("expected an integer >= 0, found `{}`", self.value))
    }

    fn boolean(&self) -> Result<bool, String> {
        match self.value.as_str() {
            "true" | "on" | "1" => Ok(true),
            "false" | "off" | "0" => Ok(false),
            _ => Err(format!(
                "expected true or false (on/off, 1/0), found `{}`",
                self.value
            )),
        }
    }
}

/// Writes `o`'s value into the raw manifest; an error is a value that does not
/// parse as the field's type.
pub(super) fn apply(raw: &mut RawManifest, o: &Override) -> Result<(), String> {
    let bake = &mut raw.bake;
    match o.key {
        "bake.image_res" => bake.image_res = o.integer()?,
        "bake.self_occluding_tolerance_px" => bake.self_occluding_tolerance_px = o.number()?,
        "bake.edge_length_tolerance_px" => bake.edge_length_tolerance_px = o.number()?,
        "bake.t_c0" => bake.t_c0 = o.number()?,
        "bake.t_c1" => bake.t_c1 = o.number()?,
        "bake.clustering" => bake.clustering = o.boolean()?,
        "bake.occlusion_culling" => bake.occlusion_culling = o.boolean()?,
        "bake.far_field" => bake.far_field = o.boolean()?,
        "bake.far_levels" => bake.far_levels = o.integer()?,
        "bake.merge_level" => bake.merge_level = o.integer()?,
        // `off` bakes without objective selection (every outside object a mesh
        // proxy, as before issue 16); `on` the default floor.
        "bake.quality" => bake.quality = o.boolean()?.then(RawQuality::default),
        // Setting part of the floor turns the selection on.
        "bake.quality.min_psnr_db" => {
            bake.quality
                .get_or_insert_with(RawQuality::default)
                .min_psnr_db = o.number_f64()?
        }
        "bake.quality.min_ssim" => {
            bake.quality
                .get_or_insert_with(RawQuality::default)
                .min_ssim = o.number_f64()?
        }
        "bake.max_deviation_px" => bake.max_deviation_px = o.number()?,
        "bake.quality_check" => bake.quality_check = o.boolean()?,
        "cells.cell_size" => raw.cells.cell_size = o.number()?,
        "cells.min_eye_height" => raw.cells.min_eye_height = o.number()?,
        "cells.max_eye_height" => raw.cells.max_eye_height = o.number()?,
        "cells_per_job" => raw.cells_per_job = Some(o.integer()?),
        "split_wide_objects" => raw.split_wide_objects = Some(o.boolean()?),
        other => unreachable!("parse_override only yields known keys, got {other}"),
    }
    Ok(())
}
