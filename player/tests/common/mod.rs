//! Helpers shared by the player's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use format::path::CameraPath;
use player::gpu::{GpuError, Renderer};
use player::run::{Player, RunError};
use std::path::PathBuf;

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `manifests/paths/demo-walk.ron`.
pub fn demo_walk() -> CameraPath {
    CameraPath::load(&repo().join("manifests/paths/demo-walk.ron")).unwrap()
}

/// The keys every `player compare` report has.
pub const COMPARE_KEYS: [&str; 8] = format::schema::compare::REQUIRED_KEYS;

/// Asserts that the JSON object `json` has each of `keys`.
pub fn assert_has_keys<'a>(json: &serde_json::Value, keys: impl IntoIterator<Item = &'a str>) {
    for key in keys {
        assert!(json.get(key).is_some(), "missing {key}");
    }
}

/// A GPU test's skip (through `testkit`: a failure under `HEXBAKE_REQUIRE_GPU=1`)
/// for the adapter error `e`. Only "no adapter" may skip; callers fail on any other
/// renderer error.
#[track_caller]
pub fn skip_no_adapter(e: impl std::fmt::Display) {
    testkit::skip(
        testkit::Need::Gpu,
        format_args!("no graphics adapter ({e}); install mesa-vulkan-drivers for lavapipe"),
    );
}

/// [`Player::open`] of `dir` at `size`, printing the adapter; `None` after
/// [`skip_no_adapter`] when there is no adapter. Any other error fails the test.
#[track_caller]
pub fn open_player(
    dir: &std::path::Path,
    size: (u32, u32),
    options: &player::DrawOptions,
) -> Option<Player> {
    match Player::open(dir, size, options) {
        Ok(p) => {
            eprintln!("adapter: {}", p.renderer.adapter());
            Some(p)
        }
        Err(RunError::Gpu(GpuError::NoAdapter(e))) => {
            skip_no_adapter(e);
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// A `w` × `h` [`Renderer`]; `None` after [`skip_no_adapter`] when there is no
/// adapter. Any other error fails the test.
#[track_caller]
pub fn renderer(w: u32, h: u32) -> Option<Renderer> {
    match Renderer::new(w, h, &player::DrawOptions::default()) {
        Ok(r) => Some(r),
        Err(GpuError::NoAdapter(e)) => {
            skip_no_adapter(e);
            None
        }
        Err(e) => panic!("{e}"),
    }
}
