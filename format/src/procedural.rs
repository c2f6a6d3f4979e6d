//! Procedural models (for `manifests/demo.ron`) and the procedural albedo pattern
//! of DESIGN.md "Shading".
//!
//! TODO(issue 2).
