//! The rendering configurations of the paper's evaluation (000 §4.1) as the CLI
//! names them ([`Mode`]), and the parser of named CLI values ([`parse_named`]).
//! Plain data: the draw list of each configuration is built in `frame`.

/// Rendering configuration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Config A: every instance as original geometry.
    Full,
    /// Config B: originals with per-instance frustum culling.
    Frustum,
    /// Config C: the current cell's pack, frustum-culled.
    #[default]
    Hybrid,
    /// Baseline: originals, frustum-culled, at a distance-chosen level of detail.
    Lod,
    /// Nanite-style cluster LOD (issue 30): every instance frustum-culled, drawn as
    /// the cut of its model's cluster DAG at `--cluster-tau` pixels, each cluster
    /// cone- and frustum-culled ([`crate::clusterlod`]).
    ClusterLod,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Full => "full",
            Mode::Frustum => "frustum",
            Mode::Hybrid => "hybrid",
            Mode::Lod => "lod",
            Mode::ClusterLod => "cluster-lod",
        }
    }
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Mode, String> {
        let modes = [
            Mode::Full,
            Mode::Frustum,
            Mode::Hybrid,
            Mode::Lod,
            Mode::ClusterLod,
        ];
        parse_named("mode", s, modes.map(|m| (m.name(), m)))
    }
}

/// The value named `s` in `names`; else an error naming `what` and listing the names,
/// e.g. `unknown mode "x" (full, frustum, hybrid, lod, cluster-lod)`.
pub(crate) fn parse_named<T: Copy, const N: usize>(
    what: &str,
    s: &str,
    names: [(&str, T); N],
) -> Result<T, String> {
    match names.iter().find(|(name, _)| *name == s) {
        Some(&(_, value)) => Ok(value),
        None => {
            let list: Vec<&str> = names.iter().map(|(name, _)| *name).collect();
            Err(format!("unknown {what} {s:?} ({})", list.join(", ")))
        }
    }
}
