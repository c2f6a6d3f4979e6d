//! Image metrics shared by the worker's bake check and the player's compare
//! (DESIGN.md "Quality"): luminance `Y = 0.299 R + 0.587 G + 0.114 B` (Rec. 601) of the
//! sRGB8 values, mean squared error and PSNR on Y. One home for the coefficients and
//! the 100 dB cap; SSIM and the object-pixel masks stay with the player, their only
//! user.

/// Rec. 601 luma coefficients of R, G, B.
pub const LUMA: [f64; 3] = [0.299, 0.587, 0.114];

/// PSNR reported for identical images, and the cap of every PSNR in reports (so
/// means stay finite and JSON never holds infinity).
pub const PSNR_CAP: f64 = 100.0;

/// Luminance of an sRGB8 pixel (alpha ignored), in f64.
pub fn luminance(c: [u8; 4]) -> f64 {
    LUMA[0] * c[0] as f64 + LUMA[1] * c[1] as f64 + LUMA[2] * c[2] as f64
}

/// Luminance of each pixel of a row-major RGBA8 buffer (alpha ignored), in f32.
pub fn luminance_f32(rgba: &[u8]) -> Vec<f32> {
    let [r, g, b] = LUMA.map(|k| k as f32);
    rgba.chunks_exact(4)
        .map(|p| r * p[0] as f32 + g * p[1] as f32 + b * p[2] as f32)
        .collect()
}

/// PSNR in dB of a mean squared error in 8-bit levels²; `f64::INFINITY` for 0.
pub fn psnr_of_mse(mse: f64) -> f64 {
    if mse <= 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

/// [`psnr_of_mse`] capped at [`PSNR_CAP`] (also for an MSE of 0).
pub fn capped_psnr_of_mse(mse: f64) -> f64 {
    psnr_of_mse(mse).min(PSNR_CAP)
}

/// Mean squared luminance difference of two images of equal size, one `[u8; 4]` per
/// pixel (`None` when the sizes differ or are zero).
pub fn mse_y(a: &[[u8; 4]], b: &[[u8; 4]]) -> Option<f64> {
    if a.is_empty() || a.len() != b.len() {
        return None;
    }
    let sum = a
        .iter()
        .zip(b)
        .map(|(&p, &q)| {
            let d = luminance(p) - luminance(q);
            d * d
        })
        .sum::<f64>();
    Some(sum / a.len() as f64)
}

/// Mean squared luminance difference of two row-major RGBA8 buffers over their
/// common length, luminance in f32 ([`luminance_f32`]); `None` when either is empty.
pub fn mse_y_rgba(a: &[u8], b: &[u8]) -> Option<f64> {
    let (ya, yb) = (luminance_f32(a), luminance_f32(b));
    let n = ya.len().min(yb.len());
    if n == 0 {
        return None;
    }
    let sum = ya
        .iter()
        .zip(&yb)
        .map(|(&x, &y)| {
            let d = x as f64 - y as f64;
            d * d
        })
        .sum::<f64>();
    Some(sum / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_coefficients_are_the_f32_literals() {
        assert_eq!(LUMA.map(|k| k as f32), [0.299f32, 0.587, 0.114]);
    }

    #[test]
    fn psnr_of_known_errors() {
        assert_eq!(psnr_of_mse(0.0), f64::INFINITY);
        assert_eq!(capped_psnr_of_mse(0.0), PSNR_CAP);
        assert!((psnr_of_mse(255.0 * 255.0) - 0.0).abs() < 1e-12);
        assert!((psnr_of_mse(255.0 * 255.0 / 100.0) - 20.0).abs() < 1e-12);
        assert_eq!(capped_psnr_of_mse(1e-20), PSNR_CAP);
    }

    #[test]
    fn luminance_weights_sum_to_one_and_psnr_y_sees_only_y() {
        assert!((luminance([255, 255, 255, 0]) - 255.0).abs() < 1e-9);
        let a = [[10, 20, 30, 255]; 4];
        let mut b = a;
        b[0] = [11, 20, 30, 0]; // +0.299 in Y on one of 4 pixels; alpha ignored
        let mse = mse_y(&a, &b).unwrap();
        assert!((mse - 0.299f64.powi(2) / 4.0).abs() < 1e-12);
        let flat = |img: &[[u8; 4]]| img.concat();
        let mse32 = mse_y_rgba(&flat(&a), &flat(&b)).unwrap();
        assert!((mse32 - mse).abs() < 1e-6);
        assert_eq!(mse_y(&a, &a), Some(0.0));
        assert_eq!(mse_y(&a, &b[..3]), None);
        assert_eq!(mse_y_rgba(&[], &[]), None);
    }
}
