//! `pipeline run --set KEY=VALUE`: override a manifest's bake and cell parameters from
//! the command line, for parameter sweeps like the paper's Tables 3–5 (000 §4.3:
//! T_s ∈ {3, 5, 7}, T_l ∈ {3.0, 4.5, 6.0}, cell size ∈ {50, 100}).
//!
//! Keys are the manifest's dotted field names (`bake.self_occluding_tolerance_px`,
//! `cells.cell_size`, `cells_per_job`, ...) plus the paper's short names `T_s`, `T_l`,
//! `T_C0`, `T_C1` (with or without `bake.`). Values are range-checked like the
//! manifest's (format::manifest); the cell parameters by the manifest's own rule,
//! `format::manifest::check_cells` (grid size, eye heights), so `--set cell_size=0.001`
//! is refused exactly as the same value in the manifest is. Job fingerprints include
//! every parameter, so a bake with overrides never passes for one without: give it
//! its own `--out`.

use format::manifest::{check_cells, Plan};

/// One `KEY=VALUE`.
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    /// Canonical dotted key, e.g. `bake.self_occluding_tolerance_px`.
    pub key: &'static str,
    pub value: String,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OverrideError {
    #[error("--set {text:?}: expected KEY=VALUE")]
    Syntax { text: String },
    #[error("--set {key}: unknown key; known keys: {known}")]
    UnknownKey { key: String, known: String },
    #[error("--set {key}={value}: {reason}")]
    BadValue {
        key: String,
        value: String,
        reason: String,
    },
}

/// The keys `--set` accepts: (canonical key, aliases).
const KEYS: &[(&str, &[&str])] = &[
    ("bake.image_res", &[]),
    (
        "bake.self_occluding_tolerance_px",
        &["T_s", "bake.T_s", "ts"],
    ),
    ("bake.edge_length_tolerance", &["T_l", "bake.T_l", "tl"]),
    ("bake.t_c0", &["T_C0", "bake.T_C0"]),
    ("bake.t_c1", &["T_C1", "bake.T_C1"]),
    ("bake.clustering", &[]),
    ("bake.occlusion_culling", &[]),
    ("bake.far_field", &[]),
    ("bake.quality", &[]),
    ("bake.quality.min_psnr_db", &["min_psnr_db"]),
    ("bake.quality.min_ssim", &["min_ssim"]),
    ("bake.max_deviation_px", &["deviation"]),
    ("cells.cell_size", &["cell_size"]),
    ("cells.min_eye_height", &[]),
    ("cells.max_eye_height", &[]),
    ("cells_per_job", &[]),
];

/// Parses one `KEY=VALUE` (the value is checked when applied).
pub fn parse_override(text: &str) -> Result<Override, OverrideError> {
    let (key, value) = text
        .split_once('=')
        .map(|(k, v)| (k.trim(), v.trim()))
        .filter(|(k, v)| !k.is_empty() && !v.is_empty())
        .ok_or_else(|| OverrideError::Syntax {
            text: text.to_string(),
        })?;
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
    fn bad(&self, reason: impl Into<String>) -> OverrideError {
        OverrideError::BadValue {
            key: self.key.to_string(),
            value: self.value.clone(),
            reason: reason.into(),
        }
    }

    fn positive(&self) -> Result<f32, OverrideError> {
        match self.value.parse::<f32>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
            _ => Err(self.bad("must be a finite number > 0")),
        }
    }

    fn non_negative(&self) -> Result<f32, OverrideError> {
        match self.value.parse::<f32>() {
            Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
            _ => Err(self.bad("must be a finite number >= 0")),
        }
    }

    fn boolean(&self) -> Result<bool, OverrideError> {
        match self.value.as_str() {
            "true" | "on" | "1" => Ok(true),
            "false" | "off" | "0" => Ok(false),
            _ => Err(self.bad("must be true or false")),
        }
    }

    fn count(&self, range: std::ops::RangeInclusive<u32>) -> Result<u32, OverrideError> {
        match self.value.parse::<u32>() {
            Ok(v) if range.contains(&v) => Ok(v),
            _ => Err(self.bad(format!(
                "must be an integer in {}..={}",
                range.start(),
                range.end()
            ))),
        }
    }
}

/// Applies the overrides in order to `plan` and re-checks what the manifest checks
/// (`check_cells`: the grid's size on the ground, eye heights in range and ordered).
pub fn apply_overrides(plan: &mut Plan, overrides: &[Override]) -> Result<(), OverrideError> {
    for o in overrides {
        match o.key {
            "bake.image_res" => plan.bake.image_res = o.count(16..=16384)?,
            "bake.self_occluding_tolerance_px" => {
                plan.bake.self_occluding_tolerance_px = o.positive()?
            }
            "bake.edge_length_tolerance" => plan.bake.edge_length_tolerance = o.positive()?,
            "bake.t_c0" => plan.bake.t_c0 = o.positive()?,
            "bake.t_c1" => plan.bake.t_c1 = o.positive()?,
            "bake.clustering" => plan.bake.clustering = o.boolean()?,
            "bake.occlusion_culling" => plan.bake.occlusion_culling = o.boolean()?,
            "bake.far_field" => plan.bake.far_field = o.boolean()?,
            // `off` bakes without objective selection (every outside object a mesh
            // proxy, as before issue 16); `on` restores the default floor.
            "bake.quality" => {
                plan.bake.quality = o.boolean()?.then(format::manifest::QualityFloor::default)
            }
            "bake.quality.min_psnr_db" | "bake.quality.min_ssim" => {
                let v: f64 = o.value.parse().map_err(|_| o.bad("must be a number"))?;
                let q = plan.bake.quality.get_or_insert_with(Default::default);
                if o.key.ends_with("min_psnr_db") {
                    q.min_psnr_db = v;
                } else {
                    q.min_ssim = v;
                }
                format::manifest::check_quality(q.min_psnr_db, q.min_ssim)
                    .map_err(|(_, what)| o.bad(what))?;
            }
            "bake.max_deviation_px" => plan.bake.max_deviation_px = o.non_negative()?,
            "cells.cell_size" => plan.cells.cell_size = o.positive()?,
            "cells.min_eye_height" => plan.cells.min_eye_height = o.non_negative()?,
            "cells.max_eye_height" => plan.cells.max_eye_height = o.non_negative()?,
            "cells_per_job" => plan.cells_per_job = o.count(1..=u32::MAX)?,
            other => unreachable!("parse_override only yields known keys, got {other}"),
        }
    }
    // The manifest's rule for the cells, charged to the override that set the field
    // it names, else to the last cell override (eye heights out of order name the
    // max, but setting the min may be what broke them).
    if let Err(v) = check_cells(&plan.ground, &plan.cells) {
        let cell_overrides = || {
            overrides
                .iter()
                .rev()
                .filter(|o| o.key.starts_with("cells."))
        };
        let culprit = cell_overrides()
            .find(|o| o.key == v.field)
            .or_else(|| cell_overrides().next());
        if let Some(o) = culprit {
            return Err(o.bad(v.to_string()));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn demo() -> Plan {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../manifests/demo.ron");
        format::manifest::parse_manifest(&path).expect("demo manifest parses")
    }

    #[test]
    fn paper_names_and_dotted_keys_set_the_same_field() {
        let mut a = demo();
        let mut b = demo();
        apply_overrides(&mut a, &[parse_override("T_s=3").unwrap()]).unwrap();
        apply_overrides(
            &mut b,
            &[parse_override("bake.self_occluding_tolerance_px = 3").unwrap()],
        )
        .unwrap();
        assert_eq!(a.bake.self_occluding_tolerance_px, 3.0);
        assert_eq!(a, b);
        let mut c = demo();
        let sets = ["T_l=6.0", "cells.cell_size=100", "cells_per_job=1"]
            .map(|s| parse_override(s).unwrap());
        apply_overrides(&mut c, &sets).unwrap();
        assert_eq!(c.bake.edge_length_tolerance, 6.0);
        assert_eq!(c.cells.cell_size, 100.0);
        assert_eq!(c.cells_per_job, 1);
        assert_eq!(sets[0].to_string(), "bake.edge_length_tolerance=6.0");
    }

    #[test]
    fn bad_overrides_are_typed_errors() {
        assert!(matches!(
            parse_override("T_s"),
            Err(OverrideError::Syntax { .. })
        ));
        assert!(matches!(
            parse_override("bake.T_x=3"),
            Err(OverrideError::UnknownKey { .. })
        ));
        let mut p = demo();
        for bad in ["T_s=-1", "T_l=nan", "bake.image_res=8", "cells_per_job=0"] {
            let o = parse_override(bad).unwrap();
            let e = apply_overrides(&mut p, &[o]).unwrap_err();
            assert!(matches!(e, OverrideError::BadValue { .. }), "{bad}: {e:?}");
        }
        let o = parse_override("cells.min_eye_height=100").unwrap();
        let e = apply_overrides(&mut p, &[o]).unwrap_err();
        assert!(e.to_string().contains("must be >= `min_eye_height`"), "{e}");
    }

    /// Issue 19: `--set` obeys the manifest's cell rule (`format::manifest::check_cells`):
    /// a cell size too small for the ground (which panicked in the worker's grid) and
    /// absurd eye heights are refused, naming the override.
    #[test]
    fn cell_overrides_obey_the_manifest_limits() {
        for (bad, says) in [
            ("cell_size=0.001", "more than 1000000"),
            ("cells.cell_size=1e30", "at most"),
            ("cells.max_eye_height=1e30", "at most"),
        ] {
            let mut p = demo();
            let o = parse_override(bad).unwrap();
            let e = apply_overrides(&mut p, std::slice::from_ref(&o)).unwrap_err();
            let OverrideError::BadValue { key, .. } = &e else {
                panic!("{bad}: {e:?}")
            };
            assert_eq!(key, o.key, "{bad}");
            assert!(e.to_string().contains(says), "{bad}: {e}");
        }
        // A cell size only just small enough is accepted.
        let mut p = demo();
        apply_overrides(&mut p, &[parse_override("cell_size=1").unwrap()]).unwrap();
    }

    #[test]
    fn overrides_change_the_fingerprint() {
        let p = demo();
        let mut q = demo();
        apply_overrides(&mut q, &[parse_override("T_l=3.0").unwrap()]).unwrap();
        assert_ne!(
            format::fingerprint::params_fingerprint(&p.bake, &p.cells),
            format::fingerprint::params_fingerprint(&q.bake, &q.cells)
        );
    }
}
