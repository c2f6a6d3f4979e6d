//! Per-pixel shading of the CPU rasterizer (DESIGN.md "Shading"): the convention
//! and its constants live in [`format::shading`] and [`format::srgb`], shared with
//! the player's WGSL shader; re-exported here under the names the worker's stages use.

pub use format::shading::{shade, AMBIENT, LIGHT_DIR, SKY};
pub use format::srgb::{linear_to_srgb, linear_to_srgb8, srgb8_to_linear, srgb_to_linear};
