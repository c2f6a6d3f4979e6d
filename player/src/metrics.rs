//! Image quality between the hybrid frame and the full-geometry frame (paper 000 §4.2:
//! PSNR on luminance Y = 0.299R + 0.587G + 0.114B over the sRGB8 values; DESIGN.md
//! "Quality": also SSIM).
//!
//! SSIM is the standard single-scale index of Wang et al. (2004) on Y: an 11 × 11
//! Gaussian window with σ = 1.5, K1 = 0.01, K2 = 0.03, L = 255, averaged over the
//! positions where the window fits inside the image (images smaller than the window
//! use a window clipped to the image). Implemented here rather than taken from
//! `dssim-core`, whose AGPL-3.0 licence does not fit this MIT/Apache project.

/// Luminance of RGBA8 pixels (alpha ignored).
pub fn luminance(rgba: &[u8]) -> Vec<f32> {
    rgba.chunks_exact(4)
        .map(|p| 0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32)
        .collect()
}

/// PSNR in dB of two equally sized RGBA8 images on Y; `f64::INFINITY` when equal.
pub fn psnr_y(a: &[u8], b: &[u8]) -> f64 {
    let (ya, yb) = (luminance(a), luminance(b));
    let n = ya.len().min(yb.len());
    if n == 0 {
        return f64::INFINITY;
    }
    let mse: f64 = ya
        .iter()
        .zip(&yb)
        .map(|(&x, &y)| {
            let d = x as f64 - y as f64;
            d * d
        })
        .sum::<f64>()
        / n as f64;
    if mse <= 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

fn gaussian(radius: usize, sigma: f64) -> Vec<f64> {
    let w: Vec<f64> = (0..=2 * radius)
        .map(|i| {
            let x = i as f64 - radius as f64;
            (-x * x / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let s: f64 = w.iter().sum();
    w.into_iter().map(|v| v / s).collect()
}

/// Separable "valid" filtering: output is (w − k + 1) × (h − k + 1).
fn filter_valid(img: &[f64], w: usize, h: usize, k: &[f64]) -> (Vec<f64>, usize, usize) {
    let n = k.len();
    let (ow, oh) = (w + 1 - n, h + 1 - n);
    let mut tmp = vec![0.0; ow * h];
    for y in 0..h {
        let row = &img[y * w..(y + 1) * w];
        for x in 0..ow {
            tmp[y * ow + x] = k.iter().zip(&row[x..x + n]).map(|(a, b)| a * b).sum();
        }
    }
    let mut out = vec![0.0; ow * oh];
    for y in 0..oh {
        for x in 0..ow {
            out[y * ow + x] = (0..n).map(|j| k[j] * tmp[(y + j) * ow + x]).sum();
        }
    }
    (out, ow, oh)
}

/// Mean SSIM of two equally sized RGBA8 images (`width × height`) on Y.
pub fn ssim_y(a: &[u8], b: &[u8], width: usize, height: usize) -> f64 {
    if width == 0 || height == 0 {
        return 1.0;
    }
    let ya: Vec<f64> = luminance(a).into_iter().map(f64::from).collect();
    let yb: Vec<f64> = luminance(b).into_iter().map(f64::from).collect();
    let radius = 5.min((width.min(height) - 1) / 2);
    let k = gaussian(radius, 1.5);
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let (mu_a, ow, oh) = filter_valid(&ya, width, height, &k);
    let (mu_b, _, _) = filter_valid(&yb, width, height, &k);
    let sq = |v: &[f64], u: &[f64]| -> Vec<f64> { v.iter().zip(u).map(|(x, y)| x * y).collect() };
    let (aa, _, _) = filter_valid(&sq(&ya, &ya), width, height, &k);
    let (bb, _, _) = filter_valid(&sq(&yb, &yb), width, height, &k);
    let (ab, _, _) = filter_valid(&sq(&ya, &yb), width, height, &k);
    let mut sum = 0.0;
    for i in 0..ow * oh {
        let (ma, mb) = (mu_a[i], mu_b[i]);
        let va = aa[i] - ma * ma;
        let vb = bb[i] - mb * mb;
        let cov = ab[i] - ma * mb;
        sum +=
            ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
    }
    sum / (ow * oh) as f64
}

/// A visual difference image: |ΔY| × 4, grey, opaque.
pub fn diff_image(a: &[u8], b: &[u8]) -> Vec<u8> {
    luminance(a)
        .iter()
        .zip(luminance(b))
        .flat_map(|(x, y)| {
            let d = ((x - y).abs() * 4.0).min(255.0) as u8;
            [d, d, d, 255]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(w: usize, h: usize, seed: u32) -> Vec<u8> {
        let mut s = seed;
        (0..w * h * 4)
            .map(|_| {
                s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (s >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn identical_images_are_perfect() {
        let a = noise(40, 30, 1);
        assert_eq!(psnr_y(&a, &a), f64::INFINITY);
        assert!((ssim_y(&a, &a, 40, 30) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn psnr_matches_hand_value() {
        // Y differs by 0.299·10 = 2.99 on every pixel: MSE 8.9401.
        let a = [100u8, 50, 50, 255].repeat(16);
        let b = [110u8, 50, 50, 255].repeat(16);
        let expected = 10.0 * (255.0f64 * 255.0 / (2.99f64 * 2.99)).log10();
        assert!((psnr_y(&a, &b) - expected).abs() < 1e-3);
    }

    #[test]
    fn ssim_drops_with_noise_and_inversion() {
        let a = noise(48, 48, 2);
        let b: Vec<u8> = a.iter().map(|&v| 255 - v).collect();
        let c: Vec<u8> = a
            .iter()
            .zip(noise(48, 48, 3))
            .map(|(&x, n)| x.saturating_add(n / 8))
            .collect();
        let s_inv = ssim_y(&a, &b, 48, 48);
        let s_noise = ssim_y(&a, &c, 48, 48);
        assert!(s_inv < 0.0, "{s_inv}");
        assert!(s_noise < 1.0 && s_noise > s_inv, "{s_noise}");
    }
}
