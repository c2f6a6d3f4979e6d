//! The one place where a hexbake test decides to skip (issue 28, item 5).
//!
//! A test that needs something the machine may lack — a wgpu adapter, the fetched
//! models, a running Slurm, the Khronos glTF-Validator, valgrind, headless
//! Chromium — calls [`skip`] when it is missing and returns. What happens then
//! depends on `HEXBAKE_REQUIRE_<X>`:
//!
//! - `1`, `true` or `yes` (any case): the resource is required, and [`skip`]
//!   panics with the reason, so the test fails.
//! - unset, empty, `0`, `false` or `no`: [`skip`] prints `SKIP <test>: <reason>` to
//!   stderr and, when `HEXBAKE_SKIP_LOG` names a file, appends the line
//!   `<test>\t<reason>` to it (`scripts/test.sh` prints that file at the end).
//! - any other value panics: a typo must not turn a requirement into a skip.
//!
//! `<test>` is the caller's source file and the test's name (libtest names each
//! test's thread after the test), e.g. `player/tests/render.rs::render_bc`.
//! Helpers that call [`skip`] or [`model`] for a test are `#[track_caller]` so the
//! file is the test's.

use std::fmt::Display;
use std::io::Write;
use std::panic::Location;
use std::path::PathBuf;

/// Something a test may need that the machine may not have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Need {
    /// A wgpu adapter (`HEXBAKE_REQUIRE_GPU`; Mesa's lavapipe in CI). Only "no
    /// adapter" is a reason to skip: any other renderer error fails the test.
    Gpu,
    /// The real meshes under [`models_dir`] (`HEXBAKE_REQUIRE_MODELS`;
    /// `scripts/fetch-models.sh`).
    Models,
    /// A running Slurm that `sinfo` reaches (`HEXBAKE_REQUIRE_SLURM`;
    /// `scripts/slurm-local.sh start` and `SLURM_CONF`).
    Slurm,
    /// The Khronos glTF-Validator (`HEXBAKE_REQUIRE_GLTF_VALIDATOR`;
    /// `scripts/install-gltf-validator.sh`).
    GltfValidator,
    /// valgrind's cachegrind, which counts the guard sample's instructions
    /// (`HEXBAKE_REQUIRE_VALGRIND`; the Debian package `valgrind`).
    Valgrind,
    /// Headless Chromium with WebGPU, node and the viewer's npm packages
    /// (`HEXBAKE_REQUIRE_WEB`; the Debian package `chromium` and
    /// `scripts/install-web.sh`, issue 33).
    Chromium,
}

impl Need {
    /// Every need, in the order the docs list them.
    pub const ALL: [Need; 6] = [
        Need::Gpu,
        Need::Models,
        Need::Slurm,
        Need::GltfValidator,
        Need::Valgrind,
        Need::Chromium,
    ];

    /// The variable that makes this need required.
    pub fn var(self) -> &'static str {
        match self {
            Need::Gpu => "HEXBAKE_REQUIRE_GPU",
            Need::Models => "HEXBAKE_REQUIRE_MODELS",
            Need::Slurm => "HEXBAKE_REQUIRE_SLURM",
            Need::GltfValidator => "HEXBAKE_REQUIRE_GLTF_VALIDATOR",
            Need::Valgrind => "HEXBAKE_REQUIRE_VALGRIND",
            Need::Chromium => "HEXBAKE_REQUIRE_WEB",
        }
    }
}

/// The variable that names the file [`skip`] appends to.
pub const SKIP_LOG: &str = "HEXBAKE_SKIP_LOG";

/// What a `HEXBAKE_REQUIRE_<X>` value means: `Some(true)` required, `Some(false)`
/// not, `None` not a value this crate knows.
pub fn parse_required(value: Option<&str>) -> Option<bool> {
    let Some(v) = value else { return Some(false) };
    match v.trim().to_ascii_lowercase().as_str() {
        "1" | "true" | "yes" => Some(true),
        "" | "0" | "false" | "no" => Some(false),
        _ => None,
    }
}

/// Whether `need` is required here (its variable is `1`, `true` or `yes`).
/// Panics on a value that is neither a yes nor a no.
pub fn required(need: Need) -> bool {
    let value = std::env::var(need.var()).ok();
    parse_required(value.as_deref()).unwrap_or_else(|| {
        panic!(
            "{}={:?}: expected 1/true/yes (required) or 0/false/no/unset (may skip)",
            need.var(),
            value.unwrap_or_default()
        )
    })
}

/// The running test's name as `<caller file>::<test>`.
#[track_caller]
pub fn test_name() -> String {
    let file = Location::caller().file();
    match std::thread::current().name() {
        Some(t) if t != "main" => format!("{file}::{t}"),
        _ => file.to_string(),
    }
}

/// `need` is missing for the running test, because of `reason`: panics when it is
/// required, else prints `SKIP <test>: <reason>` and logs it to `HEXBAKE_SKIP_LOG`.
/// The caller then returns (the test passes as skipped).
#[track_caller]
pub fn skip(need: Need, reason: impl Display) {
    let name = test_name();
    // One line in the log, whatever the reason says.
    let reason = reason.to_string().replace(['\t', '\n', '\r'], " ");
    if required(need) {
        let value = std::env::var(need.var()).unwrap_or_default();
        panic!("{name}: {}={value} but {reason}", need.var());
    }
    eprintln!(
        "SKIP {name}: {reason} (set {}=1 to fail instead)",
        need.var()
    );
    if let Some(log) = std::env::var_os(SKIP_LOG).filter(|l| !l.is_empty()) {
        // One write per line: tests skip from several threads at once.
        let line = format!("{name}\t{reason}\n");
        let written = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .and_then(|mut f| f.write_all(line.as_bytes()));
        if let Err(e) = written {
            panic!(
                "{name}: cannot append to {SKIP_LOG}={}: {e}",
                log.to_string_lossy()
            );
        }
    }
}

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Where the fetched models are: `$HEXBAKE_MODELS`, else `<repo>/models`
/// (`scripts/fetch-models.sh`). It may not exist: see [`model`].
pub fn models_dir() -> PathBuf {
    std::env::var_os("HEXBAKE_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("models"))
}

/// The fetched model file `name` under [`models_dir`], or `None` after a
/// [`skip`] (`Need::Models`) when it is not there.
#[track_caller]
pub fn model(name: &str) -> Option<PathBuf> {
    let path = models_dir().join(name);
    if path.is_file() {
        Some(path)
    } else {
        skip(
            Need::Models,
            format_args!(
                "{} not fetched (run scripts/fetch-models.sh or set HEXBAKE_MODELS)",
                path.display()
            ),
        );
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_of_a_require_variable() {
        for v in ["1", "true", "TRUE", "yes", "Yes", " 1 "] {
            assert_eq!(parse_required(Some(v)), Some(true), "{v:?}");
        }
        for v in ["", "0", "false", "no", "NO"] {
            assert_eq!(parse_required(Some(v)), Some(false), "{v:?}");
        }
        assert_eq!(parse_required(None), Some(false));
        for v in ["2", "y", "on", "required"] {
            assert_eq!(parse_required(Some(v)), None, "{v:?}");
        }
    }

    #[test]
    fn the_test_name_is_the_file_and_the_thread() {
        let n = test_name();
        assert!(
            n.starts_with("tests/testkit/src/lib.rs") || n.contains("lib.rs"),
            "{n}"
        );
        assert!(
            n.ends_with("::tests::the_test_name_is_the_file_and_the_thread"),
            "{n}"
        );
    }

    #[test]
    fn every_need_has_its_own_variable() {
        let mut vars: Vec<_> = Need::ALL.iter().map(|n| n.var()).collect();
        vars.sort();
        vars.dedup();
        assert_eq!(vars.len(), Need::ALL.len());
        assert!(vars.iter().all(|v| v.starts_with("HEXBAKE_REQUIRE_")));
    }
}
