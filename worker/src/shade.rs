//! Per-pixel shading shared by the CPU rasterizer and (mirrored in WGSL) the
//! player: DESIGN.md "Shading" — Lambert in linear space,
//! `albedo · (ambient + (1 − ambient) · max(0, n·L))`, sRGB8 output, fixed sky.

use glam::Vec3;
use std::sync::LazyLock;

/// Background colour (sRGB8, opaque).
pub const SKY: [u8; 4] = [150, 190, 235, 255];

/// Ambient term of the Lambert formula.
pub const AMBIENT: f32 = 0.3;

/// Direction *towards* the light, world space: normalize(0.4, 1.0, 0.3).
pub const LIGHT_DIR: Vec3 = Vec3::new(0.4 / 1.118_034, 1.0 / 1.118_034, 0.3 / 1.118_034);

/// Shaded linear colour of a surface point with linear `albedo_linear` and unit
/// world-space `normal`.
pub fn shade(albedo_linear: Vec3, normal: Vec3) -> Vec3 {
    let lambert = normal.dot(LIGHT_DIR).max(0.0);
    albedo_linear * (AMBIENT + (1.0 - AMBIENT) * lambert)
}

/// sRGB transfer function, decoded: one 8-bit channel → linear in [0, 1].
pub fn srgb_to_linear(c: u8) -> f32 {
    SRGB_TO_LINEAR[c as usize]
}

static SRGB_TO_LINEAR: LazyLock<[f32; 256]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        let c = i as f64 / 255.0;
        let l = if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        };
        l as f32
    })
});

/// sRGB transfer function, encoded: linear (clamped to [0, 1]) → 8-bit channel,
/// rounded to nearest.
pub fn linear_to_srgb(l: f32) -> u8 {
    let l = if l.is_nan() { 0.0 } else { l.clamp(0.0, 1.0) };
    let c = if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (c * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// A linear colour → opaque sRGB8.
pub fn linear_to_srgb8(rgb: Vec3) -> [u8; 4] {
    [
        linear_to_srgb(rgb.x),
        linear_to_srgb(rgb.y),
        linear_to_srgb(rgb.z),
        255,
    ]
}

/// An sRGB8 colour (alpha ignored) → linear RGB.
pub fn srgb8_to_linear(c: [u8; 4]) -> Vec3 {
    Vec3::new(
        srgb_to_linear(c[0]),
        srgb_to_linear(c[1]),
        srgb_to_linear(c[2]),
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
    fn srgb_round_trips_every_byte() {
        for c in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(c)), c);
        }
    }

    #[test]
    fn shade_applies_ambient_and_lambert() {
        let a = Vec3::splat(0.5);
        assert!((shade(a, -LIGHT_DIR) - a * AMBIENT).length() < 1e-6);
        assert!((shade(a, LIGHT_DIR) - a).length() < 1e-6);
    }
}
