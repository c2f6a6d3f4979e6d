//! Block-compressed capture textures (issue 15): deterministic bytes (hashes of a fixed
//! input, the same from several threads), padding, the encoder choice, round-trip
//! error, and decoding of arbitrary block bytes without a panic.

use format::pack::texture::block_padded_size;
use format::pack::{Texture, TextureEncoding};

/// A capture-like image: a shaded blob with coverage in alpha (255 inside, 0 outside,
/// the colour dilated outwards), `w × h`.
fn capture_like(w: u32, h: u32, opaque: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity((w * h * 4) as usize);
    let (cx, cy) = (w as f32 * 0.5, h as f32 * 0.45);
    let r = w.min(h) as f32 * 0.4;
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            let d = (dx * dx + dy * dy).sqrt() / r;
            let shade = (1.0 - 0.6 * d.min(1.0)) * 255.0;
            let stripe = if (x / 3 + y / 5) % 2 == 0 { 30 } else { 0 };
            out.extend_from_slice(&[
                (shade as u32).min(255) as u8,
                ((shade * 0.8) as u32 + stripe).min(255) as u8,
                ((x * 7 + y * 3) % 256) as u8,
                if opaque || d < 1.0 { 255 } else { 0 },
            ]);
        }
    }
    out
}

fn hash(t: &Texture) -> String {
    blake3::hash(&t.data).to_hex().to_string()
}

#[test]
fn block_encodings_are_byte_identical_everywhere() {
    let (w, h) = (61, 38);
    let alpha = capture_like(w, h, false);
    let opaque = capture_like(w, h, true);
    let bc3 = Texture::from_rgba8_block(w, h, &alpha).unwrap();
    let bc1 = Texture::from_rgba8_block(w, h, &opaque).unwrap();
    assert_eq!(bc3.encoding, TextureEncoding::Bc3);
    assert_eq!(bc1.encoding, TextureEncoding::Bc1);
    assert_eq!((bc3.width, bc3.height), (64, 40));
    assert_eq!(bc3.data.len(), 64 * 40);
    assert_eq!(bc1.data.len(), 64 * 40 / 2);
    // The same bytes from 4 threads at once.
    let threads: Vec<_> = (0..4)
        .map(|_| {
            let (a, o) = (alpha.clone(), opaque.clone());
            std::thread::spawn(move || {
                (
                    Texture::from_rgba8_block(w, h, &a).unwrap(),
                    Texture::from_rgba8_block(w, h, &o).unwrap(),
                )
            })
        })
        .collect();
    for t in threads {
        let (a, o) = t.join().unwrap();
        assert_eq!(a, bc3);
        assert_eq!(o, bc1);
    }
    // Fixed hashes: a change of encoder, settings or padding shows here (and changes
    // every bake's pack bytes, so it must be deliberate).
    assert_eq!(
        (hash(&bc1).as_str(), hash(&bc3).as_str()),
        (
            "9d63638fe56020e8b78b944e7638bd11235b19bc3ebc1e5f51fb970b9bdc022e",
            "9e8f7dfae4c4541aca2280c652de3f7f5c7c925a7fb117b8daf14b1cedcd291b"
        ),
        "block encoder output changed"
    );
}

#[test]
fn padding_replicates_the_last_column_and_row() {
    assert_eq!(block_padded_size(1, 1), (4, 4));
    assert_eq!(block_padded_size(4, 5), (4, 8));
    // A 1x1 texture: every decoded texel is (nearly) its colour.
    let t = Texture::from_rgba8_block(1, 1, &[200, 100, 50, 255]).unwrap();
    assert_eq!(
        (t.width, t.height, t.encoding),
        (4, 4, TextureEncoding::Bc1)
    );
    for texel in t.to_rgba8().unwrap().chunks_exact(4) {
        for (a, b) in texel.iter().zip([200u8, 100, 50, 255]) {
            assert!(a.abs_diff(b) <= 4, "{texel:?}");
        }
    }
    // Two colours left | right in a 5x3 image: column 4 is replicated into 5..8.
    let mut img = Vec::new();
    for _ in 0..3 {
        for x in 0..5 {
            img.extend_from_slice(if x < 4 {
                &[0, 0, 0, 0]
            } else {
                &[255, 255, 255, 255]
            });
        }
    }
    let t = Texture::from_rgba8_block(5, 3, &img).unwrap();
    assert_eq!(
        (t.width, t.height, t.encoding),
        (8, 4, TextureEncoding::Bc3)
    );
    let d = t.to_rgba8().unwrap();
    for y in 0..4 {
        for x in 0..8 {
            let v = d[(y * 8 + x) * 4];
            assert_eq!(v > 127, x >= 4, "texel {x},{y} = {v}");
        }
    }
}

fn psnr(a: &[u8], b: &[u8]) -> f64 {
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    10.0 * (255.0f64 * 255.0 / mse.max(1e-9)).log10()
}

#[test]
fn block_round_trip_error_is_small_and_coverage_survives() {
    let (w, h) = (128, 96);
    for opaque in [true, false] {
        let img = capture_like(w, h, opaque);
        let t = Texture::from_rgba8_block(w, h, &img).unwrap();
        let d = t.to_rgba8().unwrap();
        let p = psnr(&img, &d);
        assert!(p > 30.0, "opaque {opaque}: PSNR {p:.1} dB");
        // Coverage (alpha ≥ 128) is kept texel for texel.
        for (a, b) in img.chunks_exact(4).zip(d.chunks_exact(4)) {
            assert_eq!(a[3] >= 128, b[3] >= 128);
        }
    }
}

#[test]
fn arbitrary_block_bytes_decode_without_panic() {
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    for encoding in [TextureEncoding::Bc1, TextureEncoding::Bc3] {
        for _ in 0..64 {
            let data: Vec<u8> = (0..16 * 32)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    x as u8
                })
                .collect();
            let len = if encoding == TextureEncoding::Bc1 {
                16 * 32 / 2
            } else {
                16 * 32
            };
            let t = Texture {
                width: 16,
                height: 32,
                encoding,
                data: data[..len].to_vec(),
            };
            assert_eq!(t.to_rgba8().unwrap().len(), 16 * 32 * 4);
        }
    }
}

#[test]
fn bad_block_sizes_are_refused() {
    for (width, encoding, bytes, says) in [
        (6, TextureEncoding::Bc1, 12, "multiples of 4"),
        (8, TextureEncoding::Bc3, 16, "expected 32"),
    ] {
        let t = Texture {
            width,
            height: 4,
            encoding,
            data: vec![0; bytes],
        };
        let e = t.validate().unwrap_err();
        assert!(e.contains(says), "expected {says:?} in: {e}");
    }
    assert!(Texture::from_rgba8(6, 4, &[0; 96], TextureEncoding::Bc1).is_err());
    assert!(Texture::from_rgba8_block(0, 4, &[]).is_err());
    assert!(Texture::from_rgba8_block(4, 4, &[0; 12]).is_err());
}

/// Encoder speed and quality of the candidate settings (run by hand:
/// `cargo test --release -p format --test pack_texture_bc -- --ignored --nocapture`).
#[test]
#[ignore]
fn encoder_candidates() {
    use block_compression::{encode::compress_rgba8, BC7Settings, CompressionVariant};
    let (w, h) = (256u32, 256u32);
    let img = capture_like(w, h, false);
    let cands: Vec<(&str, CompressionVariant)> = vec![
        ("bc3", CompressionVariant::BC3),
        (
            "bc7 alpha_very_fast",
            CompressionVariant::BC7(BC7Settings::alpha_very_fast()),
        ),
        (
            "bc7 alpha_fast",
            CompressionVariant::BC7(BC7Settings::alpha_fast()),
        ),
        (
            "bc7 alpha_basic",
            CompressionVariant::BC7(BC7Settings::alpha_basic()),
        ),
        ("bc1", CompressionVariant::BC1),
    ];
    for (name, v) in cands {
        let mut out = vec![0u8; v.blocks_byte_size(w, h)];
        let t = std::time::Instant::now();
        for _ in 0..4 {
            compress_rgba8(v, &img, &mut out, w, h, w * 4);
        }
        let s = t.elapsed().as_secs_f64() / 4.0;
        let mut d = vec![0u8; (w * h * 4) as usize];
        block_compression::decode::decompress_blocks_as_rgba8(v, w, h, &out, &mut d);
        let rgb = |x: &[u8]| {
            x.chunks_exact(4)
                .flat_map(|t| t[..3].to_vec())
                .collect::<Vec<_>>()
        };
        let z = zstd::bulk::compress(&out, 6).unwrap().len();
        println!(
            "{name}: {:.1} Mtexel/s, RGB PSNR {:.2} dB, {} B -> zstd {} B",
            (w * h) as f64 / s / 1e6,
            psnr(&rgb(&img), &rgb(&d)),
            out.len(),
            z
        );
    }
    // Format 4's writer: BC1 with punch-through alpha where coverage is partial.
    let t = std::time::Instant::now();
    let mut tex = None;
    for _ in 0..4 {
        tex = Some(Texture::from_rgba8_bc1_coverage(w, h, &img).unwrap());
    }
    let s = t.elapsed().as_secs_f64() / 4.0;
    let tex = tex.unwrap();
    let t = std::time::Instant::now();
    for _ in 0..4 {
        Texture::from_rgba8_block(w, h, &img).unwrap();
    }
    let s3 = t.elapsed().as_secs_f64() / 4.0;
    println!(
        "bc1 coverage (format 4): {:.1} Mtexel/s (from_rgba8_block, BC3 here: {:.1}), zstd {} B",
        (w * h) as f64 / s / 1e6,
        (w * h) as f64 / s3 / 1e6,
        zstd::bulk::compress(&tex.data, 6).unwrap().len()
    );
}

/// Encoder cost and texture error on real cell packs of a lossless bake (run by hand:
/// `HEXBAKE_BC_PACKS="a.pack b.pack" cargo test --release -p format --test
/// pack_texture_bc real_packs -- --ignored --nocapture`): per pack, the lossless
/// writer's time (both encodings + zstd trials) against BC's, the `textures` bytes
/// after zstd, and the PSNR of the covered texels' RGB.
#[test]
#[ignore]
fn real_packs() {
    use format::pack::CellPack;
    let Some(list) = std::env::var_os("HEXBAKE_BC_PACKS") else {
        return;
    };
    let (mut t_lossless, mut t_bc, mut z_lossless, mut z_bc) = (0.0, 0.0, 0usize, 0usize);
    let (mut se, mut n, mut texels) = (0f64, 0u64, 0u64);
    for path in list.to_str().unwrap().split_whitespace() {
        let cell = CellPack::read(std::path::Path::new(path)).unwrap();
        let (mut raw_l, mut raw_b) = (Vec::new(), Vec::new());
        for v in cell.proxies.iter().flat_map(|p| &p.views) {
            let (w, h) = (v.texture.width, v.texture.height);
            let rgba = v.texture.to_rgba8().unwrap();
            texels += u64::from(w * h);
            let t = std::time::Instant::now();
            let l = Texture::from_rgba8_smallest(w, h, &rgba).unwrap();
            t_lossless += t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let b = Texture::from_rgba8_block(w, h, &rgba).unwrap();
            t_bc += t.elapsed().as_secs_f64();
            raw_l.extend_from_slice(&l.data);
            raw_b.extend_from_slice(&b.data);
            let d = b.to_rgba8().unwrap();
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let (i, j) = ((y * w as usize + x) * 4, (y * b.width as usize + x) * 4);
                    if rgba[i + 3] == 255 {
                        for k in 0..3 {
                            se += (rgba[i + k] as f64 - d[j + k] as f64).powi(2);
                        }
                        n += 3;
                    }
                }
            }
        }
        let t = std::time::Instant::now();
        z_lossless += zstd::bulk::compress(&raw_l, 6).unwrap().len();
        t_lossless += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        z_bc += zstd::bulk::compress(&raw_b, 6).unwrap().len();
        t_bc += t.elapsed().as_secs_f64();
    }
    println!(
        "{texels} texels: lossless {t_lossless:.2} s -> {z_lossless} B; BC {t_bc:.2} s -> {z_bc} B; covered RGB PSNR {:.2} dB",
        10.0 * (255.0f64.powi(2) / (se / n as f64)).log10()
    );
}

/// BC1 with punch-through alpha (format version 4, README "Textures"): the same bytes
/// from several threads and a fixed hash; coverage survives texel for texel, an
/// uncovered texel decodes as (0, 0, 0, 0) and a covered one with alpha 255; the
/// covered colours stay close to the input; half of BC3's bytes.
#[test]
fn bc1_coverage_textures_are_deterministic_and_keep_coverage() {
    let (w, h) = (61, 38);
    let img = capture_like(w, h, false);
    let t = Texture::from_rgba8_bc1_coverage(w, h, &img).unwrap();
    assert_eq!(t.encoding, TextureEncoding::Bc1);
    assert_eq!((t.width, t.height), (64, 40));
    assert_eq!(t.data.len(), 64 * 40 / 2);
    let threads: Vec<_> = (0..4)
        .map(|_| {
            let a = img.clone();
            std::thread::spawn(move || Texture::from_rgba8_bc1_coverage(w, h, &a).unwrap())
        })
        .collect();
    for th in threads {
        assert_eq!(th.join().unwrap(), t);
    }
    assert_eq!(
        hash(&t),
        "704766faf070e3b095530ca694b35a33702951ca5a44fd45f13748a0e8a6528d",
        "BC1 coverage encoder output changed"
    );
    let d = t.to_rgba8().unwrap();
    let pw = t.width as usize;
    let (mut se, mut n) = (0.0f64, 0usize);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let a = &img[(y * w as usize + x) * 4..][..4];
            let b = &d[(y * pw + x) * 4..][..4];
            if a[3] >= 128 {
                assert_eq!(b[3], 255, "covered texel ({x}, {y})");
                se += (0..3)
                    .map(|k| (a[k] as f64 - b[k] as f64).powi(2))
                    .sum::<f64>();
                n += 3;
            } else {
                assert_eq!(b, [0, 0, 0, 0], "uncovered texel ({x}, {y})");
            }
        }
    }
    let p = 10.0 * (255.0f64.powi(2) / (se / n as f64)).log10();
    assert!(p > 30.0, "covered RGB PSNR {p:.1} dB");
    // Fully covered images keep the four-colour encoder's blocks.
    let opaque = capture_like(w, h, true);
    let a = Texture::from_rgba8_bc1_coverage(w, h, &opaque).unwrap();
    assert!(a.to_rgba8().unwrap().chunks(4).all(|t| t[3] == 255));
}

proptest::proptest! {
    /// Any 4 × 4 image: coverage is kept exactly (also for fully covered blocks whose
    /// four-colour endpoints came out equal, which decoders would read as
    /// three-colour mode), and a block of one covered colour decodes within 5:6:5
    /// rounding of it.
    #[test]
    fn bc1_coverage_blocks_keep_coverage(
        texels in proptest::collection::vec(proptest::prelude::any::<[u8; 4]>(), 16),
        flat in proptest::prelude::any::<bool>(),
    ) {
        let mut rgba: Vec<u8> = texels.concat();
        if flat {
            for t in rgba.chunks_exact_mut(4) {
                t[..3].copy_from_slice(&texels[0][..3]);
            }
        }
        let t = Texture::from_rgba8_bc1_coverage(4, 4, &rgba).unwrap();
        let d = t.to_rgba8().unwrap();
        for (a, b) in rgba.chunks_exact(4).zip(d.chunks_exact(4)) {
            if a[3] >= 128 {
                proptest::prop_assert_eq!(b[3], 255);
                if flat {
                    for k in 0..3 {
                        proptest::prop_assert!((a[k] as i32 - b[k] as i32).abs() <= 8);
                    }
                }
            } else {
                proptest::prop_assert_eq!(b, &[0u8, 0, 0, 0][..]);
            }
        }
    }
}
