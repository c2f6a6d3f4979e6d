//! Image metrics shared by the worker's bake check and the player's compare
//! (DESIGN.md "Quality"): luminance `Y = 0.299 R + 0.587 G + 0.114 B` (Rec. 601) of the
//! sRGB8 values, mean squared error and PSNR on Y. One home for the coefficients and
//! the 100 dB cap, and of SSIM (used by the player's compare and, issue 16, by the
//! worker's objective selection); the object-pixel masks stay with the player.

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

// ---- SSIM (Wang et al. 2004) on Y: an 11 × 11 Gaussian window with σ = 1.5,
// K1 = 0.01, K2 = 0.03, L = 255, over the positions where the window fits (images
// smaller than the window use a window clipped to the image). Shared by the player's
// compare and the worker's objective selection (issue 16); moved here from the player.

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

/// The SSIM map of two equally sized RGBA8 images on Y: one value per position
/// where the (possibly clipped) window fits, `(map, map_width, map_height, radius)`;
/// map position (x, y) is the window centred on pixel (x + radius, y + radius).
fn ssim_map_y(a: &[u8], b: &[u8], width: usize, height: usize) -> (Vec<f64>, usize, usize, usize) {
    let ya: Vec<f64> = luminance_f32(a).into_iter().map(f64::from).collect();
    let yb: Vec<f64> = luminance_f32(b).into_iter().map(f64::from).collect();
    let radius = 5.min((width.min(height) - 1) / 2);
    let k = gaussian(radius, 1.5);
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let (mu_a, ow, oh) = filter_valid(&ya, width, height, &k);
    let (mu_b, _, _) = filter_valid(&yb, width, height, &k);
    let sq = |v: &[f64], u: &[f64]| -> Vec<f64> { v.iter().zip(u).map(|(x, y)| x * y).collect() };
    let (aa, _, _) = filter_valid(&sq(&ya, &ya), width, height, &k);
    let (bb, _, _) = filter_valid(&sq(&yb, &yb), width, height, &k);
    let (ab, _, _) = filter_valid(&sq(&ya, &yb), width, height, &k);
    let map = (0..ow * oh)
        .map(|i| {
            let (ma, mb) = (mu_a[i], mu_b[i]);
            let va = aa[i] - ma * ma;
            let vb = bb[i] - mb * mb;
            let cov = ab[i] - ma * mb;
            ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2))
        })
        .collect();
    (map, ow, oh, radius)
}

/// Mean SSIM of two equally sized RGBA8 images (`width × height`) on Y.
pub fn ssim_y(a: &[u8], b: &[u8], width: usize, height: usize) -> f64 {
    if width == 0 || height == 0 {
        return 1.0;
    }
    let (map, _, _, _) = ssim_map_y(a, b, width, height);
    map.iter().sum::<f64>() / map.len() as f64
}

/// Mean SSIM on Y over the window positions centred on a pixel of `mask`; `None`
/// when there is none.
pub fn masked_ssim_y(
    a: &[u8],
    b: &[u8],
    width: usize,
    height: usize,
    mask: &[bool],
) -> Option<f64> {
    if width == 0 || height == 0 {
        return None;
    }
    // The SSIM map of `ssim_map_y` evaluated only where the mask asks for it: the
    // horizontal pass on the rows some masked window covers, the vertical pass and
    // the SSIM formula at the masked positions (the same sums in the same order, so
    // the same values as the whole map).
    let ya: Vec<f64> = luminance_f32(a).into_iter().map(f64::from).collect();
    let yb: Vec<f64> = luminance_f32(b).into_iter().map(f64::from).collect();
    let radius = 5.min((width.min(height) - 1) / 2);
    let k = gaussian(radius, 1.5);
    let n = k.len();
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let (ow, oh) = (width + 1 - n, height + 1 - n);
    let masked = |x: usize, y: usize| mask[(y + radius) * width + x + radius];
    let row_used: Vec<bool> = (0..oh).map(|y| (0..ow).any(|x| masked(x, y))).collect();
    let mut tmp_needed = vec![false; height];
    for y in (0..oh).filter(|&y| row_used[y]) {
        tmp_needed[y..y + n].iter_mut().for_each(|t| *t = true);
    }
    // Horizontal pass of the five images (Y_a, Y_b, Y_a², Y_b², Y_a·Y_b) on the
    // needed rows.
    let images: [&dyn Fn(usize) -> f64; 5] = [
        &|i| ya[i],
        &|i| yb[i],
        &|i| ya[i] * ya[i],
        &|i| yb[i] * yb[i],
        &|i| ya[i] * yb[i],
    ];
    let mut tmp = vec![[0.0f64; 5]; ow * height];
    let mut row = vec![0.0f64; width];
    for y in (0..height).filter(|&y| tmp_needed[y]) {
        for (m, image) in images.iter().enumerate() {
            for (x, r) in row.iter_mut().enumerate() {
                *r = image(y * width + x);
            }
            for x in 0..ow {
                tmp[y * ow + x][m] = k.iter().zip(&row[x..x + n]).map(|(a, b)| a * b).sum();
            }
        }
    }
    let (mut sum, mut count) = (0.0, 0usize);
    for y in (0..oh).filter(|&y| row_used[y]) {
        for x in (0..ow).filter(|&x| masked(x, y)) {
            let v: [f64; 5] =
                std::array::from_fn(|m| (0..n).map(|j| k[j] * tmp[(y + j) * ow + x][m]).sum());
            let (ma, mb) = (v[0], v[1]);
            let va = v[2] - ma * ma;
            let vb = v[3] - mb * mb;
            let cov = v[4] - ma * mb;
            sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
                / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            count += 1;
        }
    }
    (count > 0).then(|| sum / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `masked_ssim_y` as first written: the whole map, then the masked mean.
    fn masked_ssim_by_map(a: &[u8], b: &[u8], w: usize, h: usize, mask: &[bool]) -> Option<f64> {
        let (map, ow, oh, r) = ssim_map_y(a, b, w, h);
        let (sum, n) = (0..oh)
            .flat_map(|y| (0..ow).map(move |x| (x, y)))
            .filter(|&(x, y)| mask[(y + r) * w + x + r])
            .fold((0.0, 0usize), |(s, n), (x, y)| (s + map[y * ow + x], n + 1));
        (n > 0).then(|| sum / n as f64)
    }

    #[test]
    fn masked_ssim_equals_the_mean_over_the_whole_map() {
        let mut seed = 99u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        for (w, h) in [(1, 1), (3, 9), (12, 11), (37, 29)] {
            for density in [0, 5, 50, 100] {
                let a: Vec<u8> = (0..w * h * 4).map(|_| next() as u8).collect();
                let b: Vec<u8> = a
                    .iter()
                    .map(|&v| v.wrapping_add((next() % 9) as u8))
                    .collect();
                let mask: Vec<bool> = (0..w * h).map(|_| next() % 100 < density).collect();
                let (x, y) = (
                    masked_ssim_y(&a, &b, w, h, &mask),
                    masked_ssim_by_map(&a, &b, w, h, &mask),
                );
                assert_eq!(
                    x.map(f64::to_bits),
                    y.map(f64::to_bits),
                    "{w} × {h}, {density} %"
                );
            }
        }
    }

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
