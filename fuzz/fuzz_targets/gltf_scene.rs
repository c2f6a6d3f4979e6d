//! Fuzz target: the glTF scene reader (`scene: Gltf(..)`, issue 18) on arbitrary
//! bytes, as a `.glb` or `.gltf` (JSON) file. Any panic outside the crate parsers'
//! `catch_unwind` guard, overflow or abort is a bug: it must return `LoadError`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // External URIs resolve against a folder that holds nothing.
    let _ = scene::load::parse_gltf_scene(Path::new("/nonexistent/fuzz.glb"), data);
});
