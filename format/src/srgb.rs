//! The sRGB transfer function (IEC 61966-2-1), the one home of its constants for
//! every renderer: the worker's CPU rasterizer and visibility oracle, the player's
//! metrics and sky clear colour, the loaders, and (through
//! [`crate::shading::wgsl_constants`]) the player's WGSL shader.
//!
//! Decoding has one formula in two precisions ([`srgb_to_linear`] is
//! [`srgb_to_linear_f64`] rounded to f32, from a table). Encoding has two
//! implementations, kept apart because bakes and loaded meshes are fingerprinted:
//! [`linear_to_srgb`] (exact round-to-nearest from f64 thresholds; renderers) and
//! [`linear_to_srgb_powf`] (the f32 `powf` formula, rounded; model loaders and the
//! player's downsampled reference). They agree except within an f32 rounding of a
//! code boundary.

use glam::Vec3;
use std::sync::LazyLock;

/// Encoded values at or below this are on the linear segment (decode side).
pub const DECODE_THRESHOLD: f64 = 0.04045;
/// Linear values at or below this are on the linear segment (encode side).
pub const ENCODE_THRESHOLD: f64 = 0.003_130_8;
/// Slope of the linear segment.
pub const LINEAR_SLOPE: f64 = 12.92;
/// Offset `a` of the power segment `(1 + a)·l^(1/γ) − a`.
pub const OFFSET: f64 = 0.055;
/// Scale `1 + a` of the power segment (written out: `1.0 + OFFSET` may round differently).
pub const SCALE: f64 = 1.055;
/// Exponent γ of the power segment.
pub const GAMMA: f64 = 2.4;

/// sRGB transfer function, decoded, in f64: encoded `s` in [0, 1] → linear.
pub fn decode(s: f64) -> f64 {
    if s <= DECODE_THRESHOLD {
        s / LINEAR_SLOPE
    } else {
        ((s + OFFSET) / SCALE).powf(GAMMA)
    }
}

/// One 8-bit channel → linear in [0, 1], in f64.
pub fn srgb_to_linear_f64(c: u8) -> f64 {
    decode(c as f64 / 255.0)
}

/// One 8-bit channel → linear in [0, 1] ([`srgb_to_linear_f64`] rounded to f32,
/// from a table).
#[inline]
pub fn srgb_to_linear(c: u8) -> f32 {
    SRGB_TO_LINEAR[c as usize]
}

static SRGB_TO_LINEAR: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|i| srgb_to_linear_f64(i as u8) as f32));

/// sRGB transfer function, encoded: linear (clamped to [0, 1]) → 8-bit channel,
/// rounded to nearest: the code c with decode((c − ½)/255) ≤ l < decode((c + ½)/255),
/// found from a table of those 255 thresholds (computed in f64) rather than `powf`.
#[inline]
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
    let threshold: [f32; 255] = std::array::from_fn(|c| decode((c as f64 + 0.5) / 255.0) as f32);
    let bucket_start = std::array::from_fn(|b| {
        let l = b as f32 / ENCODE_BUCKETS as f32;
        threshold.iter().filter(|&&t| t <= l).count() as u8
    });
    EncodeTable {
        threshold,
        bucket_start,
    }
});

/// Linear [0, 1] → sRGB8 by the f32 formula (`powf`), rounded to nearest; non-finite
/// input gives 0. The model loaders' and the player's reference encoder (see the
/// module docs for how it relates to [`linear_to_srgb`]).
pub fn linear_to_srgb_powf(x: f32) -> u8 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if x <= ENCODE_THRESHOLD as f32 {
        LINEAR_SLOPE as f32 * x
    } else {
        SCALE as f32 * x.powf(1.0 / GAMMA as f32) - OFFSET as f32
    };
    (s * 255.0).round().clamp(0.0, 255.0) as u8
}

/// A linear colour → opaque sRGB8 ([`linear_to_srgb`] per channel).
#[inline]
pub fn linear_to_srgb8(rgb: Vec3) -> [u8; 4] {
    [
        linear_to_srgb(rgb.x),
        linear_to_srgb(rgb.y),
        linear_to_srgb(rgb.z),
        255,
    ]
}

/// An sRGB8 colour (alpha ignored) → linear RGB.
#[inline]
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
    fn srgb_round_trips_every_byte() {
        for c in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(c)), c);
            assert_eq!(linear_to_srgb_powf(srgb_to_linear(c)), c);
            assert_eq!(srgb_to_linear(c), srgb_to_linear_f64(c) as f32);
        }
    }

    #[test]
    fn encode_rounds_to_nearest() {
        for i in 0..=10_000 {
            let l = i as f32 / 10_000.0;
            let exact = if (l as f64) <= ENCODE_THRESHOLD {
                l as f64 * 12.92
            } else {
                1.055 * (l as f64).powf(1.0 / 2.4) - 0.055
            } * 255.0;
            if (exact - exact.floor() - 0.5).abs() > 1e-3 {
                assert_eq!(linear_to_srgb(l), (exact + 0.5).floor() as u8, "{l}");
                assert_eq!(linear_to_srgb_powf(l), (exact + 0.5).floor() as u8, "{l}");
            }
        }
        assert_eq!(linear_to_srgb(-1.0), 0);
        assert_eq!(linear_to_srgb(f32::NAN), 0);
        assert_eq!(linear_to_srgb(2.0), 255);
        assert_eq!(linear_to_srgb_powf(f32::NAN), 0);
        assert_eq!(linear_to_srgb_powf(2.0), 255);
        assert_eq!(linear_to_srgb_powf(0.5), 188);
    }

    #[test]
    fn f32_casts_equal_the_f32_literals() {
        // linear_to_srgb_powf computes in f32 from these casts; they must be the
        // literals the copies it replaced used.
        assert_eq!(ENCODE_THRESHOLD as f32, 0.003_130_8f32);
        assert_eq!(LINEAR_SLOPE as f32, 12.92f32);
        assert_eq!(SCALE as f32, 1.055f32);
        assert_eq!(OFFSET as f32, 0.055f32);
        assert_eq!(1.0 / GAMMA as f32, 1.0 / 2.4f32);
        assert_eq!(DECODE_THRESHOLD as f32, 0.04045f32);
    }

    #[test]
    fn the_constants_are_the_standards() {
        // The encode threshold is the decode threshold's image (to 1e-7).
        assert!((decode(DECODE_THRESHOLD) - ENCODE_THRESHOLD).abs() < 1e-7);
        // The two segments meet (continuity at the threshold, to 1e-4).
        let power = SCALE * ENCODE_THRESHOLD.powf(1.0 / GAMMA) - OFFSET;
        assert!((power - LINEAR_SLOPE * ENCODE_THRESHOLD).abs() < 1e-4);
    }
}
