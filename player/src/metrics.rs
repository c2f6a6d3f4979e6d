//! Image quality between the hybrid frame and the full-geometry frame (paper 000 §4.2:
//! PSNR on luminance Y = 0.299R + 0.587G + 0.114B over the sRGB8 values; DESIGN.md
//! "Quality": also SSIM; DESIGN.md "Measuring quality honestly": also over object
//! pixels, and against an anti-aliased reference).
//!
//! SSIM is the standard single-scale index of Wang et al. (2004) on Y: an 11 × 11
//! Gaussian window with σ = 1.5, K1 = 0.01, K2 = 0.03, L = 255, averaged over the
//! positions where the window fits inside the image (images smaller than the window
//! use a window clipped to the image). Implemented here rather than taken from
//! `dssim-core`, whose AGPL-3.0 licence does not fit this MIT/Apache project.
//!
//! Object pixels (issue 14): the frames compared here are rendered with coverage
//! alpha ([`crate::gpu::Renderer::set_coverage_alpha`]): the sky is cleared with
//! alpha 0 and every pipeline writes alpha 1 without blending, so alpha ≠ 0 means
//! "a triangle was drawn here" — a mask from the renderer itself rather than a match
//! on the sky colour, which a lit or textured surface may happen to share (and which
//! an anti-aliased edge pixel does not keep). A pixel is an object pixel when it is
//! one in either frame of the pair. Object PSNR is over those pixels' MSE; object
//! SSIM is the mean of the SSIM map over the window positions centred on one (the
//! windows themselves still see their sky neighbours, as SSIM must). Frames without
//! object pixels have no object figures (`None`).
//!
//! The anti-aliased reference is the full-geometry frame rendered `f` times wider and
//! higher and box-filtered `f × f` in linear light ([`downsample_linear`]); its alpha
//! is the coverage, kept ≥ 1 where any sample was covered so that partly covered
//! edge pixels count as object pixels.

// PSNR cap, luminance, PSNR and sRGB decoding are format's, shared with the worker's
// bake check (format::metrics, format::srgb); re-exported under the player's names.
pub use format::metrics::{luminance_f32 as luminance, psnr_of_mse, PSNR_CAP};
pub use format::srgb::srgb_to_linear_f64 as srgb_to_linear;

/// PSNR in dB of two equally sized RGBA8 images on Y; `f64::INFINITY` when equal.
pub fn psnr_y(a: &[u8], b: &[u8]) -> f64 {
    format::metrics::mse_y_rgba(a, b).map_or(f64::INFINITY, psnr_of_mse)
}

/// Whether an RGBA8 pixel rendered with coverage alpha shows geometry.
pub fn is_object_pixel(px: &[u8]) -> bool {
    px[3] != 0
}

/// The object pixels of a frame pair rendered with coverage alpha: where either
/// frame is not background.
pub fn object_mask(a: &[u8], b: &[u8]) -> Vec<bool> {
    a.chunks_exact(4)
        .zip(b.chunks_exact(4))
        .map(|(p, q)| is_object_pixel(p) || is_object_pixel(q))
        .collect()
}

/// Sum of squared Y differences over the pixels of `mask`, and their count.
pub fn masked_sq_error_y(a: &[u8], b: &[u8], mask: &[bool]) -> (f64, usize) {
    luminance(a)
        .iter()
        .zip(luminance(b))
        .zip(mask)
        .filter(|(_, &m)| m)
        .fold((0.0, 0), |(s, n), ((&x, y), _)| {
            let d = x as f64 - y as f64;
            (s + d * d, n + 1)
        })
}

// SSIM (Wang et al. 2004 on Y) lives in format::metrics, shared with the worker's
// objective selection (issue 16).
pub use format::metrics::{masked_ssim_y, ssim_y};

// The per-frame and per-path quality figures are part of `player compare --json`:
// their schema is `format::schema::compare`, measured here.
pub use format::schema::compare::{FrameQuality, ObjectQuality};

/// Image quality of one frame against one reference (both rendered with coverage
/// alpha, `width × height` RGBA8).
pub fn measure_frame(reference: &[u8], frame: &[u8], width: usize, height: usize) -> FrameQuality {
    let mask = object_mask(reference, frame);
    let (sq, n) = masked_sq_error_y(reference, frame, &mask);
    FrameQuality {
        psnr_y_db: psnr_y(reference, frame).min(PSNR_CAP),
        ssim: ssim_y(reference, frame, width, height),
        object_pixels: n,
        object_psnr_y_db: (n > 0).then(|| psnr_of_mse(sq / n as f64).min(PSNR_CAP)),
        object_ssim: masked_ssim_y(reference, frame, width, height, &mask),
        object_sq_error: sq,
        pixels: width * height,
    }
}

/// Object-pixel quality over a path: summary of per-frame figures; `frames` yields
/// (frame number, quality).
pub fn summarize_objects<'a>(
    frames: impl IntoIterator<Item = (usize, &'a FrameQuality)>,
) -> ObjectQuality {
    let (mut sq, mut n, mut pixels) = (0.0, 0usize, 0usize);
    let (mut ssim_sum, mut ssim_n) = (0.0, 0usize);
    let mut worst: Option<(f64, usize)> = None;
    for (i, q) in frames {
        sq += q.object_sq_error;
        n += q.object_pixels;
        pixels += q.pixels;
        if let Some(s) = q.object_ssim {
            ssim_sum += s;
            ssim_n += 1;
        }
        if let Some(p) = q.object_psnr_y_db {
            if worst.is_none_or(|(w, _)| p < w) {
                worst = Some((p, i));
            }
        }
    }
    ObjectQuality {
        object_psnr_y_db: if n == 0 {
            PSNR_CAP
        } else {
            psnr_of_mse(sq / n as f64).min(PSNR_CAP)
        },
        min_object_psnr_y_db: worst.map_or(PSNR_CAP, |w| w.0),
        worst_object_frame: worst.map(|w| w.1),
        mean_object_ssim: if ssim_n == 0 {
            1.0
        } else {
            ssim_sum / ssim_n as f64
        },
        object_pixel_fraction: if pixels == 0 {
            0.0
        } else {
            n as f64 / pixels as f64
        },
    }
}

/// Box-filters an RGBA8 sRGB image `factor × factor` in linear light: output
/// (width / factor) × (height / factor) (remainders dropped); colour is the mean of
/// the decoded samples, encoded back to sRGB8; alpha (linear coverage) is the mean,
/// at least 1 where any sample had alpha ≠ 0.
pub fn downsample_linear(rgba: &[u8], width: usize, height: usize, factor: usize) -> Vec<u8> {
    let factor = factor.max(1);
    let (ow, oh) = (width / factor, height / factor);
    let decode: [f64; 256] = std::array::from_fn(|c| srgb_to_linear(c as u8));
    let n = (factor * factor) as f64;
    let mut out = Vec::with_capacity(ow * oh * 4);
    for oy in 0..oh {
        for ox in 0..ow {
            let (mut rgb, mut alpha, mut covered) = ([0.0f64; 3], 0u32, false);
            for y in oy * factor..(oy + 1) * factor {
                let row = &rgba[(y * width + ox * factor) * 4..(y * width + (ox + 1) * factor) * 4];
                for p in row.chunks_exact(4) {
                    for (c, &v) in rgb.iter_mut().zip(p) {
                        *c += decode[v as usize];
                    }
                    alpha += p[3] as u32;
                    covered |= p[3] != 0;
                }
            }
            for c in rgb {
                out.push(format::srgb::linear_to_srgb_powf((c / n) as f32));
            }
            let a = (alpha as f64 / n).round() as u8;
            out.push(if covered { a.max(1) } else { 0 });
        }
    }
    out
}

/// A copy with every alpha set to 255 (frames rendered with coverage alpha, for
/// writing PNGs a viewer shows as they looked).
pub fn opaque(rgba: &[u8]) -> Vec<u8> {
    let mut v = rgba.to_vec();
    for p in v.chunks_exact_mut(4) {
        p[3] = 255;
    }
    v
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

    /// A `w × h` frame of sky (alpha 0) in `sky` with the pixels of `objects` drawn
    /// (alpha 255) in `colour`.
    fn frame(
        w: usize,
        h: usize,
        sky: [u8; 3],
        objects: &[(usize, usize)],
        colour: [u8; 3],
    ) -> Vec<u8> {
        let mut px = [sky[0], sky[1], sky[2], 0].repeat(w * h);
        for &(x, y) in objects {
            let i = (y * w + x) * 4;
            px[i..i + 4].copy_from_slice(&[colour[0], colour[1], colour[2], 255]);
        }
        px
    }

    fn block(x0: usize, y0: usize, n: usize) -> Vec<(usize, usize)> {
        (y0..y0 + n)
            .flat_map(|y| (x0..x0 + n).map(move |x| (x, y)))
            .collect()
    }

    #[test]
    fn object_psnr_is_over_the_pixels_where_either_frame_is_not_sky() {
        // 16 × 16; a 4 × 4 object in both frames, R differs by 10 (ΔY = 2.99); 4 more
        // pixels are object only in `b` and sky in `a`: R 120 vs 100 with G, B
        // equal (ΔY = 5.98). The sky differs by 100 in B (ΔY = 11.4) and must not
        // count.
        let common = block(4, 4, 4);
        let only_b = block(10, 10, 2);
        let a = frame(16, 16, [100, 50, 50], &common, [100, 50, 50]);
        let mut objects_b = common.clone();
        objects_b.extend(&only_b);
        let mut b = frame(16, 16, [100, 50, 150], &common, [110, 50, 50]);
        for &(x, y) in &only_b {
            let i = (y * 16 + x) * 4;
            b[i..i + 4].copy_from_slice(&[120, 50, 50, 255]);
        }
        let mask = object_mask(&a, &b);
        assert_eq!(mask.iter().filter(|&&m| m).count(), 20);
        let (sq, n) = masked_sq_error_y(&a, &b, &mask);
        let expected_mse = (16.0 * 2.99f64.powi(2) + 4.0 * 5.98f64.powi(2)) / 20.0;
        assert_eq!(n, 20);
        assert!(
            (sq / n as f64 - expected_mse).abs() < 1e-3,
            "{}",
            sq / n as f64
        );
        let q = measure_frame(&a, &b, 16, 16);
        let expected = 10.0 * (255.0f64 * 255.0 / expected_mse).log10();
        assert_eq!(q.object_pixels, 20);
        assert!((q.object_psnr_y_db.unwrap() - expected).abs() < 1e-3);
        // The whole frame is dominated by the sky's error here.
        assert!(q.psnr_y_db < q.object_psnr_y_db.unwrap());
        // Object pixels of the same colour in both frames: no error wherever the sky is.
        let c = frame(16, 16, [100, 50, 150], &common, [100, 50, 50]);
        let q = measure_frame(&a, &c, 16, 16);
        assert_eq!(q.object_psnr_y_db, Some(PSNR_CAP));
        assert!(q.psnr_y_db < 30.0, "{}", q.psnr_y_db);
        // Only sky: no object figures.
        let sky = frame(16, 16, [100, 50, 50], &[], [0, 0, 0]);
        let q = measure_frame(&sky, &sky, 16, 16);
        assert_eq!(
            (q.object_pixels, q.object_psnr_y_db, q.object_ssim),
            (0, None, None)
        );
    }

    #[test]
    fn object_ssim_averages_the_windows_centred_on_object_pixels() {
        // Object 4 × 4 at (4, 4), identical; the sky differs only at x ≥ 24, more than
        // a window radius (5) from every object pixel.
        let objects = block(4, 4, 4);
        let a = frame(32, 32, [100, 100, 100], &objects, [200, 30, 30]);
        let mut b = a.clone();
        for y in 0..32 {
            for x in 24..32 {
                b[(y * 32 + x) * 4 + 1] = (x * 7 + y * 13) as u8;
            }
        }
        let q = measure_frame(&a, &b, 32, 32);
        assert!(
            (q.object_ssim.unwrap() - 1.0).abs() < 1e-12,
            "{:?}",
            q.object_ssim
        );
        assert_eq!(q.object_psnr_y_db, Some(PSNR_CAP));
        assert!(q.ssim < 0.99, "{}", q.ssim);
    }

    #[test]
    fn path_summary_pools_the_mse_and_names_the_worst_frame() {
        let objects = block(2, 2, 4);
        let a = frame(8, 8, [0, 0, 0], &objects, [100, 50, 50]);
        let b1 = frame(8, 8, [0, 0, 0], &objects, [110, 50, 50]); // ΔY 2.99 on 16 px
        let b2 = frame(8, 8, [0, 0, 0], &block(2, 2, 2), [130, 50, 50]); // 4 px ΔY 8.97, 12 px object → sky
        let sky = frame(8, 8, [0, 0, 0], &[], [0, 0, 0]);
        let q = [
            measure_frame(&a, &b1, 8, 8),
            measure_frame(&a, &b2, 8, 8),
            measure_frame(&sky, &sky, 8, 8),
        ];
        let s = summarize_objects(q.iter().enumerate());
        let y_obj = 0.299 * 100.0 + 0.587 * 50.0 + 0.114 * 50.0;
        let sq2 = 4.0 * 8.97f64.powi(2) + 12.0 * y_obj * y_obj;
        let pooled = (16.0 * 2.99f64.powi(2) + sq2) / 32.0;
        assert!((s.object_psnr_y_db - psnr_of_mse(pooled)).abs() < 1e-3);
        assert_eq!(s.worst_object_frame, Some(1));
        assert!((s.min_object_psnr_y_db - psnr_of_mse(sq2 / 16.0)).abs() < 1e-3);
        assert!((s.object_pixel_fraction - 32.0 / (3.0 * 64.0)).abs() < 1e-12);
        let mean = (q[0].object_ssim.unwrap() + q[1].object_ssim.unwrap()) / 2.0;
        assert!(
            (s.mean_object_ssim - mean).abs() < 1e-12,
            "the all-sky frame is left out"
        );
    }

    #[test]
    fn downsampling_averages_in_linear_light_and_keeps_partial_coverage() {
        // 2 × 2 → 1: black and white average to linear 0.5 = sRGB 188, not 128.
        let px = [
            [0u8, 0, 0, 0],
            [255, 255, 255, 255],
            [0, 0, 0, 0],
            [255, 255, 255, 0],
        ]
        .concat();
        let d = downsample_linear(&px, 2, 2, 2);
        assert_eq!(d, vec![188, 188, 188, 64]);
        assert_eq!(format::srgb::linear_to_srgb_powf(0.5), 188);
        // One covered sample of 8 × 8 still marks the pixel as an object pixel.
        let mut big = [150u8, 190, 235, 0].repeat(64);
        big[4 * 9 + 3] = 255;
        let d = downsample_linear(&big, 8, 8, 8);
        assert_eq!(&d[..3], &[150, 190, 235], "uniform sky is kept exactly");
        assert_eq!(d[3], 4);
        assert!(is_object_pixel(&d));
        // Every byte survives a 1 × 1 box.
        let all: Vec<u8> = (0..=255u8).flat_map(|v| [v, v, v, v]).collect();
        assert_eq!(downsample_linear(&all, 256, 1, 1), all);
    }
}
