//! `pipeline run --set KEY=VALUE`: override a manifest's bake and cell parameters from
//! the command line, for parameter sweeps like the paper's Tables 3–5 (000 §4.3:
//! T_s ∈ {3, 5, 7}, T_l ∈ {3.0, 4.5, 6.0}, cell size ∈ {50, 100}).
//!
//! The keys, their aliases (`T_s`, `T_l`, `T_C0`, `T_C1`, ...) and their application
//! are the manifest's (`format::manifest::overrides`): an override replaces the value
//! in the raw manifest before validation, so one validator checks the file's values
//! and the overrides alike, with the same messages ([`crate::run::load_with`]).

pub use format::manifest::overrides::{parse_override, Override, OverrideError, KEYS};

#[cfg(test)]
mod tests {
    use super::*;
    use format::manifest::{parse_manifest, parse_manifest_with, ManifestError, Plan};
    use std::path::{Path, PathBuf};

    fn demo_path() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../manifests/demo.ron")
    }

    fn demo() -> Plan {
        parse_manifest(&demo_path()).expect("demo manifest parses")
    }

    fn with(sets: &[&str]) -> Result<Plan, ManifestError> {
        let o: Vec<Override> = sets.iter().map(|s| parse_override(s).unwrap()).collect();
        parse_manifest_with(&demo_path(), &o)
    }

    #[test]
    fn paper_names_and_dotted_keys_set_the_same_field() {
        let a = with(&["T_s=3"]).unwrap();
        let b = with(&["bake.self_occluding_tolerance_px = 3"]).unwrap();
        assert_eq!(a.bake.self_occluding_tolerance_px, 3.0);
        assert_eq!(a, b);
        let c = with(&["T_l=6.0", "cells.cell_size=100", "cells_per_job=1"]).unwrap();
        assert_eq!(c.bake.edge_length_tolerance_px, 6.0);
        assert_eq!(c.cells.cell_size, 100.0);
        assert_eq!(c.cells_per_job, 1);
        assert_eq!(
            parse_override("T_l=6.0").unwrap().to_string(),
            "bake.edge_length_tolerance_px=6.0"
        );
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
        for (bad, says) in [
            ("T_s=-1", "must be > 0, found -1"),
            ("T_l=nan", "must be > 0, found NaN"),
            ("bake.image_res=8", "must be in 16..=16384, found 8"),
            ("cells_per_job=0", "must be >= 1, found 0"),
            ("bake.clustering=maybe", "expected true or false"),
            ("T_C0=abc", "expected a number, found `abc`"),
        ] {
            let e = with(&[bad]).unwrap_err();
            let key = parse_override(bad).unwrap().key;
            assert!(
                matches!(&e, ManifestError::Override { set, .. } if set.starts_with(key)),
                "{bad}: {e:?}"
            );
            assert!(e.to_string().contains(says), "{bad}: {e}");
        }
        let e = with(&["cells.min_eye_height=100"]).unwrap_err();
        assert!(e.to_string().contains("must be >= `min_eye_height`"), "{e}");
        assert!(
            e.to_string().contains("--set cells.min_eye_height=100"),
            "{e}"
        );
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
            let o = parse_override(bad).unwrap();
            let e = with(&[bad]).unwrap_err();
            let ManifestError::Override { set, .. } = &e else {
                panic!("{bad}: {e:?}")
            };
            assert_eq!(*set, o.to_string(), "{bad}");
            assert!(e.to_string().contains(says), "{bad}: {e}");
        }
        // A cell size only just small enough is accepted.
        with(&["cell_size=1"]).unwrap();
    }

    #[test]
    fn overrides_change_the_fingerprint() {
        let p = demo();
        let q = with(&["T_l=3.0"]).unwrap();
        assert_ne!(
            format::fingerprint::params_fingerprint(&p.bake, &p.cells),
            format::fingerprint::params_fingerprint(&q.bake, &q.cells)
        );
    }
}
