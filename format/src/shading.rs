//! The shading convention shared by the worker's CPU rasterizer and visibility
//! oracle and the player's GPU shader (DESIGN.md "Shading"): Lambert in linear space,
//! `albedo · (ambient + (1 − ambient) · max(0, n·L))`, sRGB8 output ([`crate::srgb`]),
//! fixed sky.
//!
//! The WGSL shader does not repeat these numbers: the player prepends
//! [`wgsl_constants`] to its source, so the GPU reads the same f32 values.

use glam::Vec3;

/// Background colour (sRGB8, opaque).
pub const SKY: [u8; 4] = [150, 190, 235, 255];

/// Albedo of the ground rectangle (sRGB8, opaque; [`crate::scene::Ground::mesh`]):
/// a muted grass-grey, drawn lit like any surface by both renderers (issue 18).
pub const GROUND: [u8; 4] = [124, 132, 104, 255];

/// Ambient term of the Lambert formula.
pub const AMBIENT: f32 = 0.3;

/// Direction *towards* the light, world space: normalize(0.4, 1.0, 0.3).
pub const LIGHT_DIR: Vec3 = Vec3::new(0.4 / 1.118_034, 1.0 / 1.118_034, 0.3 / 1.118_034);

/// Shaded linear colour of a surface point with linear `albedo_linear` and unit
/// world-space `normal`.
#[inline]
pub fn shade(albedo_linear: Vec3, normal: Vec3) -> Vec3 {
    let lambert = normal.dot(LIGHT_DIR).max(0.0);
    albedo_linear * (AMBIENT + (1.0 - AMBIENT) * lambert)
}

/// WGSL declarations of the shading and sRGB-decode constants, to prepend to a
/// shader: `AMBIENT`, `LIGHT`, `SRGB_DECODE_THRESHOLD`, `SRGB_LINEAR_SLOPE`,
/// `SRGB_OFFSET`, `SRGB_SCALE`, `SRGB_GAMMA` (`f32`) and `MAX_VIEWS` (`u32`, the
/// pack's [`crate::limits::MAX_MV_VIEWS`]). Numbers are written with
/// Rust's shortest round-trip formatting, so WGSL parses them to the same f32.
pub fn wgsl_constants() -> String {
    use crate::srgb;
    let f = |x: f32| format!("{x:?}");
    format!(
        "// Generated from format::shading and format::srgb (the one home of these numbers).\n\
         const AMBIENT: f32 = {};\n\
         const LIGHT: vec3<f32> = vec3<f32>({}, {}, {});\n\
         const SRGB_DECODE_THRESHOLD: f32 = {};\n\
         const SRGB_LINEAR_SLOPE: f32 = {};\n\
         const SRGB_OFFSET: f32 = {};\n\
         const SRGB_SCALE: f32 = {};\n\
         const SRGB_GAMMA: f32 = {};\n\
         const MAX_VIEWS: u32 = {}u;\n\n",
        f(AMBIENT),
        f(LIGHT_DIR.x),
        f(LIGHT_DIR.y),
        f(LIGHT_DIR.z),
        f(srgb::DECODE_THRESHOLD as f32),
        f(srgb::LINEAR_SLOPE as f32),
        f(srgb::OFFSET as f32),
        f(srgb::SCALE as f32),
        f(srgb::GAMMA as f32),
        crate::limits::MAX_MV_VIEWS,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_dir_is_unit_and_matches_design() {
        let expected = Vec3::new(0.4, 1.0, 0.3).normalize();
        assert!((LIGHT_DIR - expected).length() < 1e-6);
    }

    #[test]
    fn shade_applies_ambient_and_lambert() {
        let a = Vec3::new(0.5, 0.25, 1.0);
        assert!((shade(a, -LIGHT_DIR) - a * AMBIENT).length() < 1e-6);
        assert!((shade(a, LIGHT_DIR) - a).length() < 1e-6);
    }

    #[test]
    fn wgsl_constants_parse_back_to_the_rust_values() {
        let text = wgsl_constants();
        let value = |name: &str| -> Vec<f32> {
            let line = text
                .lines()
                .find(|l| l.starts_with(&format!("const {name}:")))
                .unwrap_or_else(|| panic!("{name} missing"));
            let rhs = line.split('=').nth(1).unwrap().trim().trim_end_matches(';');
            let rhs = rhs.trim_start_matches("vec3<f32>(").trim_end_matches(')');
            rhs.split(',').map(|v| v.trim().parse().unwrap()).collect()
        };
        assert_eq!(value("AMBIENT"), [AMBIENT]);
        assert_eq!(value("LIGHT"), LIGHT_DIR.to_array());
        assert_eq!(value("SRGB_LINEAR_SLOPE"), [12.92f32]);
        assert_eq!(value("SRGB_GAMMA"), [2.4f32]);
    }
}
