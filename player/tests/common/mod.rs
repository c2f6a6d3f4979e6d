//! Helpers shared by the player's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use format::path::CameraPath;
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
