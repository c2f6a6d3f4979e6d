//! Procedural models (for `manifests/demo.ron`) and the procedural albedo pattern
//! of DESIGN.md "Shading".

/// Names `build` knows.
pub const NAMES: &[&str] = &["torus_knot", "sphere", "box", "column", "vase", "torus"];
