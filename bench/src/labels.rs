//! The contract between `scripts/bench.sh` and this tool, typed: the labels of the
//! work folder's files (`bake-<label>.txt`, `compare-<label>.txt`, ...) and so of the
//! run files' items ([`RunLabel`]), and the parameters swept over the fixed cell
//! sample ([`SweepParam`]: bench.sh's `sweep_points` lines and `sweep=PARAM:VALUE`).
//! bench.sh writes them in shell; `tests/bench_sh_contract.rs` checks that its
//! templates are the ones defined here.

use serde::{Deserialize, Serialize};
use std::fmt;

/// A parameter swept on the sweep scene (paper Tables 3–5, and our deviation bound,
/// which the paper does not have).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum SweepParam {
    /// Self-occluding-error tolerance (Table 3).
    #[serde(rename = "T_s")]
    Ts,
    /// Projected edge-length tolerance (Table 4).
    #[serde(rename = "T_l")]
    Tl,
    /// Cell size (Table 5).
    #[serde(rename = "cell_size")]
    CellSize,
    /// `bake.max_deviation_px` (not in the paper).
    #[serde(rename = "deviation")]
    Deviation,
}

impl SweepParam {
    pub const ALL: [SweepParam; 4] = [
        SweepParam::Ts,
        SweepParam::Tl,
        SweepParam::CellSize,
        SweepParam::Deviation,
    ];

    /// The name in bench.sh's `sweep=KEY:VALUE` lines and in run files.
    pub fn key(self) -> &'static str {
        match self {
            SweepParam::Ts => "T_s",
            SweepParam::Tl => "T_l",
            SweepParam::CellSize => "cell_size",
            SweepParam::Deviation => "deviation",
        }
    }

    pub fn from_key(key: &str) -> Option<SweepParam> {
        SweepParam::ALL.into_iter().find(|p| p.key() == key)
    }

    /// The prefix of a sweep point's label: `sweep-<prefix><value>`.
    pub fn label_prefix(self) -> &'static str {
        match self {
            SweepParam::Ts => "ts",
            SweepParam::Tl => "tl",
            SweepParam::CellSize => "c",
            SweepParam::Deviation => "dev",
        }
    }

    /// The manifest key bench.sh overrides (`pipeline run --set KEY=VALUE`).
    pub fn set_key(self) -> &'static str {
        match self {
            SweepParam::Ts => "T_s",
            SweepParam::Tl => "T_l",
            SweepParam::CellSize => "cells.cell_size",
            SweepParam::Deviation => "bake.max_deviation_px",
        }
    }

    /// The BENCHMARKS.md section (`<!-- bench:NAME begin -->`) of this sweep.
    pub fn section(self) -> &'static str {
        match self {
            SweepParam::Ts => "sweep-ts",
            SweepParam::Tl => "sweep-tl",
            SweepParam::CellSize => "sweep-cell",
            SweepParam::Deviation => "sweep-deviation",
        }
    }

    /// How the tables name the parameter.
    pub fn symbol(self) -> &'static str {
        match self {
            SweepParam::Ts => "T_s",
            SweepParam::Tl => "T_l",
            SweepParam::CellSize => "cell size",
            SweepParam::Deviation => "deviation px",
        }
    }
}

impl fmt::Display for SweepParam {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.key())
    }
}

/// The label of an item of a bench run (a bake, a compare, a render, a load timing),
/// as bench.sh names its files. `Display` writes it, [`RunLabel::parse`] reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunLabel<'a> {
    /// A whole scene baked (`--full` / BENCH_FULL_SCENES), and the player's cell
    /// load timing of a scene: `<scene>`.
    Scene(&'a str),
    /// A scene baked along the path only (`--cells path:`): `<scene>-path`.
    PathBake(&'a str),
    /// `player compare` (hybrid vs full) and `player render --mode hybrid`:
    /// `<scene>-hybrid`.
    Hybrid(&'a str),
    /// `player render --mode frustum`: `<scene>-frustum`.
    Frustum(&'a str),
    /// `player compare --mode lod`: `<scene>-lod` at the player's default threshold,
    /// `<scene>-lod-e<pixel error>` at a given `--lod-pixel-error` (as written in
    /// BENCH_LOD_ERRORS).
    Lod {
        scene: &'a str,
        pixel_error: Option<&'a str>,
    },
    /// The sweep bake at the manifest's settings (a point of every sweep):
    /// `sweep-base`.
    SweepBase,
    /// A sweep point other than the base: `sweep-<prefix><value>`, the value as
    /// written in BENCH_TS / BENCH_TL / ...
    SweepPoint { param: SweepParam, value: &'a str },
}

impl fmt::Display for RunLabel<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunLabel::Scene(s) => write!(f, "{s}"),
            RunLabel::PathBake(s) => write!(f, "{s}-path"),
            RunLabel::Hybrid(s) => write!(f, "{s}-hybrid"),
            RunLabel::Frustum(s) => write!(f, "{s}-frustum"),
            RunLabel::Lod {
                scene,
                pixel_error: None,
            } => write!(f, "{scene}-lod"),
            RunLabel::Lod {
                scene,
                pixel_error: Some(e),
            } => write!(f, "{scene}-lod-e{e}"),
            RunLabel::SweepBase => write!(f, "sweep-base"),
            RunLabel::SweepPoint { param, value } => {
                write!(f, "sweep-{}{value}", param.label_prefix())
            }
        }
    }
}

impl<'a> RunLabel<'a> {
    /// Reads a label; a scene name alone is [`RunLabel::Scene`]. The longest
    /// matching form wins (`sweep-dev0` is a deviation point, not a cell size).
    pub fn parse(label: &'a str) -> RunLabel<'a> {
        if label == "sweep-base" {
            return RunLabel::SweepBase;
        }
        if let Some(rest) = label.strip_prefix("sweep-") {
            let mut params = SweepParam::ALL;
            params.sort_by_key(|p| std::cmp::Reverse(p.label_prefix().len()));
            for param in params {
                if let Some(value) = rest.strip_prefix(param.label_prefix()) {
                    if value.starts_with(|c: char| c.is_ascii_digit() || c == '.') {
                        return RunLabel::SweepPoint { param, value };
                    }
                }
            }
        }
        if let Some((scene, e)) = label.rsplit_once("-lod-e") {
            return RunLabel::Lod {
                scene,
                pixel_error: Some(e),
            };
        }
        for (suffix, make) in [
            (
                "-lod",
                (|s| RunLabel::Lod {
                    scene: s,
                    pixel_error: None,
                }) as fn(&'a str) -> RunLabel<'a>,
            ),
            ("-path", RunLabel::PathBake),
            ("-hybrid", RunLabel::Hybrid),
            ("-frustum", RunLabel::Frustum),
        ] {
            if let Some(scene) = label.strip_suffix(suffix) {
                return make(scene);
            }
        }
        RunLabel::Scene(label)
    }

    /// The scene of a lod compare label, and its threshold as written.
    pub fn lod_of(label: &'a str) -> Option<(&'a str, Option<&'a str>)> {
        match RunLabel::parse(label) {
            RunLabel::Lod { scene, pixel_error } => Some((scene, pixel_error)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_read_back_what_they_write() {
        let labels = [
            RunLabel::Scene("park-2m"),
            RunLabel::PathBake("park-4m"),
            RunLabel::Hybrid("park-2m"),
            RunLabel::Frustum("park-8m"),
            RunLabel::Lod {
                scene: "park-2m",
                pixel_error: None,
            },
            RunLabel::Lod {
                scene: "park-2m",
                pixel_error: Some("0.0625"),
            },
            RunLabel::SweepBase,
            RunLabel::SweepPoint {
                param: SweepParam::Tl,
                value: "3.0",
            },
            RunLabel::SweepPoint {
                param: SweepParam::Deviation,
                value: "0",
            },
            RunLabel::SweepPoint {
                param: SweepParam::CellSize,
                value: "100",
            },
        ];
        let written: Vec<String> = labels.iter().map(ToString::to_string).collect();
        assert_eq!(
            written,
            [
                "park-2m",
                "park-4m-path",
                "park-2m-hybrid",
                "park-8m-frustum",
                "park-2m-lod",
                "park-2m-lod-e0.0625",
                "sweep-base",
                "sweep-tl3.0",
                "sweep-dev0",
                "sweep-c100"
            ]
        );
        for (l, w) in labels.iter().zip(&written) {
            assert_eq!(RunLabel::parse(w), *l, "{w}");
        }
        assert_eq!(
            RunLabel::lod_of("park-2m-lod-e4"),
            Some(("park-2m", Some("4")))
        );
        assert_eq!(RunLabel::lod_of("park-2m-hybrid"), None);
    }

    #[test]
    fn sweep_params_have_one_name_each() {
        for p in SweepParam::ALL {
            assert_eq!(SweepParam::from_key(p.key()), Some(p));
            let json = serde_json::to_string(&p).unwrap();
            assert_eq!(json, format!("\"{}\"", p.key()));
        }
        assert_eq!(SweepParam::from_key("cell size"), None);
    }
}
