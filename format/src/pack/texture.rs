//! Capture textures of proxy views (paper 000 §3.1.2: one capture per SV proxy, up to
//! seven per MV proxy). Decoded texels are RGBA8, sRGB. Two lossless, cheap-to-decode
//! encodings exist, and (format version 2, issue 15) two GPU block-compressed ones,
//! BC1 and BC3; the `textures` section is then zstd-compressed as a whole
//! (format/README.md, "Textures", has the measurements behind the choices).
//! Writer-side helpers: [`Texture::from_rgba8_smallest`] (lossless, what layered
//! impostors store), [`Texture::from_rgba8_bc1_coverage`] (what version-4 bakes store
//! for captures: BC1, with punch-through alpha where coverage is partial) and
//! [`Texture::from_rgba8_block`] (BC1 or BC3, versions 2–3).
//!
//! Block encodings need both sides to be multiples of 4: [`Texture::from_rgba8_block`]
//! pads the image on the right and bottom by replicating its last column and row
//! ([`block_padded_size`]), and the caller scales its texture coordinates by
//! `width / padded_width`, `height / padded_height` so that they address the same
//! texels as before (worker `capture::pack_texture` does it on the capture matrix).
//! The encoder is `block_compression`'s CPU path (a scalar port of Intel's ISPC
//! texture compressor; no SIMD dispatch, no threads, no fused multiply-add), so its
//! output is the same bytes on every CPU and thread count (`tests/pack_texture_bc.rs`
//! checks hashes).

use block_compression::CompressionVariant;

/// Largest texture side accepted by readers and writers.
pub const MAX_TEXTURE_SIDE: u32 = 16384;

super::code_enum! {
    /// How a texture's bytes encode its RGBA8 texels.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum TextureEncoding {
        /// Row-major RGBA8 sRGB, `width · height · 4` bytes; uploadable as is.
        Rgba8 = 0 => "rgba8",
        /// RGBA8 with a per-channel left predictor: byte i of a row stores
        /// `texel[i] - texel[i - 4]` (wrapping; the first texel of a row is stored as is).
        /// Same size, lossless, decoded with one add per byte; zstd compresses it better.
        Rgba8Left = 1 => "rgba8-left",
        /// BC1 (DXT1) blocks, 8 bytes per 4×4 texels, row-major blocks; both sides are
        /// multiples of 4. Format version 2. In versions 2–3 every texel decodes with
        /// alpha 255 (writers used it only for images whose alpha is all 255). From
        /// version 4 it is also the coverage encoding: blocks in three-colour mode carry
        /// punch-through alpha, an uncovered texel decodes as (0, 0, 0, 0), and colours are
        /// premultiplied by coverage ([`Texture::from_rgba8_bc1_coverage`]).
        Bc1 = 2 => "bc1",
        /// BC3 (DXT5) blocks, 16 bytes per 4×4 texels (8 alpha + 8 BC1 colour), row-major
        /// blocks; both sides are multiples of 4. For images with coverage in alpha.
        /// Format version 2; version-3 writers zeroed the blocks farther than one texel
        /// from coverage; version-4 writers no longer use it (BC1 with punch-through alpha
        /// takes half the bytes), readers still accept it. (BC7 was measured and rejected: its CPU encoder runs at
        /// 0.1–0.3 Mtexel/s against BC3's 39, README "Textures".)
        Bc3 = 3 => "bc3",
    }
}

impl TextureEncoding {
    /// The encodings a pack of format `version` may hold (the block encodings came
    /// with version 2).
    pub fn from_u32_in_version(v: u32, version: u32) -> Option<TextureEncoding> {
        TextureEncoding::from_u32(v).filter(|e| version >= 2 || !e.is_block())
    }

    /// Whether this is a GPU block-compressed encoding (sides multiples of 4).
    pub fn is_block(self) -> bool {
        matches!(self, TextureEncoding::Bc1 | TextureEncoding::Bc3)
    }

    /// Bytes of a `width × height` texture in this encoding (sides already checked).
    fn data_len(self, width: u32, height: u32) -> usize {
        let texels = width as usize * height as usize;
        match self {
            TextureEncoding::Rgba8 | TextureEncoding::Rgba8Left => texels * 4,
            TextureEncoding::Bc1 => texels / 2,
            TextureEncoding::Bc3 => texels,
        }
    }
}

/// One encoded texture.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub encoding: TextureEncoding,
    pub data: Vec<u8>,
}

impl Texture {
    /// Encodes `rgba` (row-major RGBA8, `width · height · 4` bytes).
    pub fn from_rgba8(
        width: u32,
        height: u32,
        rgba: &[u8],
        encoding: TextureEncoding,
    ) -> Result<Texture, String> {
        check_rgba8(width, height, rgba)?;
        let data = match encoding {
            TextureEncoding::Bc1 | TextureEncoding::Bc3 => {
                if !width.is_multiple_of(4) || !height.is_multiple_of(4) {
                    return Err(format!(
                        "{} needs sides that are multiples of 4, got {width}x{height} (use Texture::from_rgba8_block)",
                        encoding.name()
                    ));
                }
                let variant = match encoding {
                    TextureEncoding::Bc1 => CompressionVariant::BC1,
                    _ => CompressionVariant::BC3,
                };
                let mut out = vec![0u8; encoding.data_len(width, height)];
                block_compression::encode::compress_rgba8(
                    variant,
                    rgba,
                    &mut out,
                    width,
                    height,
                    width * 4,
                );
                out
            }
            TextureEncoding::Rgba8 => rgba.to_vec(),
            TextureEncoding::Rgba8Left => {
                let row = width as usize * 4;
                let mut out = rgba.to_vec();
                for r in out.chunks_exact_mut(row) {
                    for i in (4..row).rev() {
                        r[i] = r[i].wrapping_sub(r[i - 4]);
                    }
                }
                out
            }
        };
        Ok(Texture {
            width,
            height,
            encoding,
            data,
        })
    }

    /// Encodes `rgba` with whichever lossless encoding zstd compresses smaller for this
    /// image (trial compression at the writer's level; ties keep [`TextureEncoding::Rgba8`]).
    /// Neither wins everywhere: the left predictor helps smooth shading, plain RGBA8
    /// keeps long matches of hard procedural patterns (README "Textures").
    pub fn from_rgba8_smallest(width: u32, height: u32, rgba: &[u8]) -> Result<Texture, String> {
        let plain = Texture::from_rgba8(width, height, rgba, TextureEncoding::Rgba8)?;
        let left = Texture::from_rgba8(width, height, rgba, TextureEncoding::Rgba8Left)?;
        let size = |t: &Texture| {
            zstd::bulk::compress(&t.data, super::codec::ZSTD_LEVEL)
                .map(|c| c.len())
                .unwrap_or(usize::MAX)
        };
        Ok(if size(&left) < size(&plain) {
            left
        } else {
            plain
        })
    }

    /// Encodes `rgba` (row-major RGBA8, `width · height · 4` bytes) block-compressed:
    /// BC1 when every alpha is 255, BC3 otherwise, after padding the image to
    /// [`block_padded_size`] by replicating its last column and row. The texture's
    /// size is the padded size; texture coordinates must be scaled by
    /// `width / texture.width`, `height / texture.height` (module docs).
    pub fn from_rgba8_block(width: u32, height: u32, rgba: &[u8]) -> Result<Texture, String> {
        let (pw, ph, padded) = padded_for_blocks(width, height, rgba)?;
        let opaque = padded.chunks_exact(4).all(|t| t[3] == 255);
        let encoding = if opaque {
            TextureEncoding::Bc1
        } else {
            TextureEncoding::Bc3
        };
        Texture::from_rgba8(pw, ph, &padded, encoding)
    }

    /// Encodes `rgba` as BC1 whatever its alpha (format version 4, issue 15): padded as
    /// [`Texture::from_rgba8_block`] does; blocks whose texels are all covered (alpha
    /// ≥ 128) in BC1's four-colour mode by `block_compression`, blocks with uncovered
    /// texels in its three-colour mode with punch-through alpha
    /// ([`encode_bc1_punch_through`]): an uncovered texel decodes as (0, 0, 0, 0).
    /// Colours are therefore *premultiplied by coverage*: a bilinear sample's colour
    /// divided by its alpha is the mean of its covered taps (README "Textures"; the
    /// player's `project_view` divides). Half the bytes of BC3 before zstd; coverage
    /// becomes one bit per texel, which is all readers use (alpha < ½ = no data).
    pub fn from_rgba8_bc1_coverage(
        width: u32,
        height: u32,
        rgba: &[u8],
    ) -> Result<Texture, String> {
        let (pw, ph, padded) = padded_for_blocks(width, height, rgba)?;
        let mut texture = Texture::from_rgba8(pw, ph, &padded, TextureEncoding::Bc1)?;
        let (w, bw) = (pw as usize, pw as usize / 4);
        for by in 0..ph as usize / 4 {
            for bx in 0..bw {
                let mut texels = [[0u8; 4]; 16];
                for (i, t) in texels.iter_mut().enumerate() {
                    let o = ((by * 4 + i / 4) * w + bx * 4 + i % 4) * 4;
                    t.copy_from_slice(&padded[o..o + 4]);
                }
                let o = (by * bw + bx) * 8;
                let block = &mut texture.data[o..o + 8];
                let c0 = u16::from_le_bytes([block[0], block[1]]);
                let c1 = u16::from_le_bytes([block[2], block[3]]);
                // A fully covered block stays in four-colour mode unless the encoder
                // wrote colour0 ≤ colour1, which decoders read as three-colour mode
                // (index 3 transparent).
                if texels.iter().any(|t| t[3] < 128) || c0 <= c1 {
                    block.copy_from_slice(&encode_bc1_punch_through(&texels));
                }
            }
        }
        Ok(texture)
    }

    /// Whether the dimensions and data length agree.
    pub fn validate(&self) -> Result<(), String> {
        encoded_len(self.width, self.height)?;
        if self.encoding.is_block()
            && (!self.width.is_multiple_of(4) || !self.height.is_multiple_of(4))
        {
            return Err(format!(
                "{}x{} {} texture: block-compressed sides must be multiples of 4",
                self.width,
                self.height,
                self.encoding.name()
            ));
        }
        let expected = self.encoding.data_len(self.width, self.height);
        if self.data.len() != expected {
            return Err(format!(
                "{}x{} {} texture has {} bytes, expected {expected}",
                self.width,
                self.height,
                self.encoding.name(),
                self.data.len()
            ));
        }
        Ok(())
    }

    /// Decoded RGBA8 sRGB texels, row-major (`width × height`, the padded size for
    /// block encodings).
    pub fn to_rgba8(&self) -> Result<Vec<u8>, String> {
        self.validate()?;
        Ok(match self.encoding {
            TextureEncoding::Bc1 | TextureEncoding::Bc3 => {
                let variant = match self.encoding {
                    TextureEncoding::Bc1 => CompressionVariant::BC1,
                    _ => CompressionVariant::BC3,
                };
                let mut out = vec![0u8; self.width as usize * self.height as usize * 4];
                block_compression::decode::decompress_blocks_as_rgba8(
                    variant,
                    self.width,
                    self.height,
                    &self.data,
                    &mut out,
                );
                out
            }
            TextureEncoding::Rgba8 => self.data.clone(),
            TextureEncoding::Rgba8Left => {
                let row = self.width as usize * 4;
                let mut out = self.data.clone();
                for r in out.chunks_exact_mut(row) {
                    for i in 4..row {
                        r[i] = r[i].wrapping_add(r[i - 4]);
                    }
                }
                out
            }
        })
    }
}

/// `(width, height)` rounded up to multiples of 4.
pub fn block_padded_size(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(4) * 4, height.div_ceil(4) * 4)
}

/// Checks that `rgba` holds `width × height` RGBA8 texels and pads it to
/// [`block_padded_size`] ([`pad_edge`]): the input of both block writers.
fn padded_for_blocks(width: u32, height: u32, rgba: &[u8]) -> Result<(u32, u32, Vec<u8>), String> {
    check_rgba8(width, height, rgba)?;
    let (pw, ph) = block_padded_size(width, height);
    Ok((pw, ph, pad_edge(width, height, rgba, pw, ph)))
}

/// `rgba` (`width × height`) padded to `pw × ph` by replicating the last column and row.
fn pad_edge(width: u32, height: u32, rgba: &[u8], pw: u32, ph: u32) -> Vec<u8> {
    if (pw, ph) == (width, height) {
        return rgba.to_vec();
    }
    let (w, pw) = (width as usize, pw as usize);
    let mut out = Vec::with_capacity(pw * ph as usize * 4);
    for y in 0..ph as usize {
        let row = &rgba[y.min(height as usize - 1) * w * 4..][..w * 4];
        out.extend_from_slice(row);
        for _ in w..pw {
            out.extend_from_slice(&row[(w - 1) * 4..]);
        }
    }
    out
}

/// Checks that `rgba` holds exactly `width × height` RGBA8 texels of an allowed size.
fn check_rgba8(width: u32, height: u32, rgba: &[u8]) -> Result<(), String> {
    let expected = encoded_len(width, height)?;
    if rgba.len() != expected {
        return Err(format!(
            "{width}x{height} RGBA8 needs {expected} bytes, got {}",
            rgba.len()
        ));
    }
    Ok(())
}

fn encoded_len(width: u32, height: u32) -> Result<usize, String> {
    if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(format!(
            "texture size {width}x{height} outside 1..={MAX_TEXTURE_SIDE}"
        ));
    }
    Ok(width as usize * height as usize * 4)
}

/// Encodes one 4×4 block of `texels` (RGBA8 sRGB, row-major) as BC1 in its
/// three-colour mode ("punch-through alpha", colour0 ≤ colour1 as 5:6:5 integers):
/// palette {c0, c1, (c0 + c1)/2, transparent black}. Texels with alpha < 128 get
/// index 3 (they decode as (0, 0, 0, 0)); the others the nearest of the three
/// colours. Endpoints: the extremes of the covered texels' projections on their
/// principal axis (power iteration on the colour covariance), then one
/// least-squares refit of the endpoints to the chosen indices, kept if it lowers
/// the error. Scalar f32 arithmetic in a fixed order, so every CPU gives the same
/// bytes. `block_compression` has no three-colour mode (its BC1 encoder ignores
/// alpha), which is why this one is written here.
fn encode_bc1_punch_through(texels: &[[u8; 4]; 16]) -> [u8; 8] {
    let covered: Vec<[f32; 3]> = texels
        .iter()
        .filter(|t| t[3] >= 128)
        .map(|t| [t[0] as f32, t[1] as f32, t[2] as f32])
        .collect();
    if covered.is_empty() {
        // c0 = c1 = 0 (three-colour mode), every index 3.
        return [0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff];
    }
    let n = covered.len() as f32;
    let mut mean = [0.0f32; 3];
    for c in &covered {
        for k in 0..3 {
            mean[k] += c[k] / n;
        }
    }
    let mut cov = [[0.0f32; 3]; 3];
    for c in &covered {
        let d = [c[0] - mean[0], c[1] - mean[1], c[2] - mean[2]];
        for i in 0..3 {
            for j in 0..3 {
                cov[i][j] += d[i] * d[j];
            }
        }
    }
    let mut axis = [1.0f32, 1.0, 1.0];
    for _ in 0..8 {
        let v = [
            cov[0][0] * axis[0] + cov[0][1] * axis[1] + cov[0][2] * axis[2],
            cov[1][0] * axis[0] + cov[1][1] * axis[1] + cov[1][2] * axis[2],
            cov[2][0] * axis[0] + cov[2][1] * axis[1] + cov[2][2] * axis[2],
        ];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if len < 1e-6 {
            break;
        }
        axis = [v[0] / len, v[1] / len, v[2] / len];
    }
    let proj = |c: &[f32; 3]| {
        (c[0] - mean[0]) * axis[0] + (c[1] - mean[1]) * axis[1] + (c[2] - mean[2]) * axis[2]
    };
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for c in &covered {
        let t = proj(c);
        lo = lo.min(t);
        hi = hi.max(t);
    }
    let at = |t: f32| {
        [
            mean[0] + axis[0] * t,
            mean[1] + axis[1] * t,
            mean[2] + axis[2] * t,
        ]
    };
    let mut best = bc1_three_colour_block(texels, at(lo), at(hi));
    // Least-squares refit: minimise Σ |c_i − (w_i·e0 + (1 − w_i)·e1)|² over the
    // covered texels, w ∈ {1, 0, ½} from their indices.
    let (mut aa, mut ab, mut bb) = (0.0f32, 0.0f32, 0.0f32);
    let (mut ax, mut bx) = ([0.0f32; 3], [0.0f32; 3]);
    for (i, t) in texels.iter().enumerate() {
        if t[3] < 128 {
            continue;
        }
        let w = match (best.1 >> (2 * i)) & 3 {
            0 => 1.0,
            1 => 0.0,
            _ => 0.5,
        };
        let (a, b) = (w, 1.0 - w);
        aa += a * a;
        ab += a * b;
        bb += b * b;
        for k in 0..3 {
            ax[k] += a * t[k] as f32;
            bx[k] += b * t[k] as f32;
        }
    }
    let det = aa * bb - ab * ab;
    if det.abs() > 1e-6 {
        let e0 = [0, 1, 2].map(|k| (ax[k] * bb - bx[k] * ab) / det);
        let e1 = [0, 1, 2].map(|k| (bx[k] * aa - ax[k] * ab) / det);
        let refit = bc1_three_colour_block(texels, e0, e1);
        if refit.2 < best.2 {
            best = refit;
        }
    }
    let (ends, indices, _) = best;
    let mut out = [0u8; 8];
    out[0..2].copy_from_slice(&ends.0.to_le_bytes());
    out[2..4].copy_from_slice(&ends.1.to_le_bytes());
    out[4..8].copy_from_slice(&indices.to_le_bytes());
    out
}

/// 8-bit sRGB → 5:6:5, rounded.
fn pack_565(c: [f32; 3]) -> u16 {
    let q = |v: f32, max: f32| ((v.clamp(0.0, 255.0) * max / 255.0) + 0.5) as u16;
    (q(c[0], 31.0) << 11) | (q(c[1], 63.0) << 5) | q(c[2], 31.0)
}

/// 5:6:5 → 8-bit, as decoders expand it (bit replication).
fn unpack_565(c: u16) -> [f32; 3] {
    let (r, g, b) = ((c >> 11) & 31, (c >> 5) & 63, c & 31);
    [
        ((r << 3) | (r >> 2)) as f32,
        ((g << 2) | (g >> 4)) as f32,
        ((b << 3) | (b >> 2)) as f32,
    ]
}

/// The three-colour block with endpoints `e0`, `e1` (ordered so that colour0 ≤
/// colour1): ((colour0, colour1), indices, squared error over covered texels).
fn bc1_three_colour_block(
    texels: &[[u8; 4]; 16],
    e0: [f32; 3],
    e1: [f32; 3],
) -> ((u16, u16), u32, f32) {
    let (mut c0, mut c1) = (pack_565(e0), pack_565(e1));
    if c0 > c1 {
        std::mem::swap(&mut c0, &mut c1);
    }
    let (p0, p1) = (unpack_565(c0), unpack_565(c1));
    let palette = [p0, p1, [0, 1, 2].map(|k| (p0[k] + p1[k]) * 0.5)];
    let mut indices = 0u32;
    let mut error = 0.0f32;
    for (i, t) in texels.iter().enumerate() {
        let index = if t[3] < 128 {
            3
        } else {
            let d = |p: &[f32; 3]| {
                (0..3)
                    .map(|k| (p[k] - t[k] as f32) * (p[k] - t[k] as f32))
                    .sum::<f32>()
            };
            let (mut bi, mut bd) = (0u32, d(&palette[0]));
            for (j, p) in palette.iter().enumerate().skip(1) {
                let dj = d(p);
                if dj < bd {
                    bi = j as u32;
                    bd = dj;
                }
            }
            error += bd;
            bi
        };
        indices |= index << (2 * i);
    }
    ((c0, c1), indices, error)
}
