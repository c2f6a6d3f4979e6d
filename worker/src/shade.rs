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
/// rounded to nearest: the code c with decode((c − ½)/255) ≤ l < decode((c + ½)/255),
/// found from a table of those 255 thresholds (computed in f64) rather than `powf`.
pub fn linear_to_srgb(l: f32) -> u8 {
    let t = &*ENCODE;
    if l.is_nan() || l <= 0.0 {
        return 0;
    }
    let bucket = ((l.min(1.0) * ENCODE_BUCKETS as f32) as usize).min(ENCODE_BUCKETS - 1);
    let mut c = t.bucket_start[bucket] as usize;
    while c < 255 && l >= t.threshold[c] {
        c += 1;
    }
    c as u8
}

const ENCODE_BUCKETS: usize = 4096;

struct EncodeTable {
    /// `threshold[c]`: the smallest linear value that encodes to at least c + 1.
    threshold: [f32; 255],
    /// The code of the bucket's lower end `b / ENCODE_BUCKETS`.
    bucket_start: [u8; ENCODE_BUCKETS],
}

static ENCODE: LazyLock<EncodeTable> = LazyLock::new(|| {
    let threshold: [f32; 255] = std::array::from_fn(|c| {
        let s = (c as f64 + 0.5) / 255.0;
        let l = if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        };
        l as f32
    });
    let bucket_start = std::array::from_fn(|b| {
        let l = b as f32 / ENCODE_BUCKETS as f32;
        threshold.iter().filter(|&&t| t <= l).count() as u8
    });
    EncodeTable {
        threshold,
        bucket_start,
    }
});

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
    fn encoding_matches_the_formula_away_from_ties() {
        for i in 0..=100_000 {
            let l = i as f32 / 100_000.0;
            let exact = if l <= 0.003_130_8 {
                l as f64 * 12.92
            } else {
                1.055 * (l as f64).powf(1.0 / 2.4) - 0.055
            } * 255.0;
            if (exact - exact.floor() - 0.5).abs() > 1e-4 {
                assert_eq!(linear_to_srgb(l), (exact + 0.5).floor() as u8, "{l}");
            }
        }
        assert_eq!(linear_to_srgb(-1.0), 0);
        assert_eq!(linear_to_srgb(f32::NAN), 0);
        assert_eq!(linear_to_srgb(2.0), 255);
    }

    #[test]
    fn shade_applies_ambient_and_lambert() {
        let a = Vec3::splat(0.5);
        assert!((shade(a, -LIGHT_DIR) - a * AMBIENT).length() < 1e-6);
        assert!((shade(a, LIGHT_DIR) - a).length() < 1e-6);
    }
}
