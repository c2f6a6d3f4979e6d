//! Capture textures of proxy views (paper 000 §3.1.2: one capture per SV proxy, up to
//! seven per MV proxy). Decoded texels are RGBA8, sRGB. Two lossless, cheap-to-decode
//! encodings exist, and (format version 2, issue 15) two GPU block-compressed ones,
//! BC1 for opaque images and BC3 for images whose alpha (coverage) is not all 255;
//! the `textures` section is then zstd-compressed as a whole (format/README.md,
//! "Textures", has the measurements behind the choices). Writer-side helpers:
//! [`Texture::from_rgba8_smallest`] (lossless) and [`Texture::from_rgba8_block`] (BC).
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

/// Sets to zero (alpha 0, colour black) every BC3 block none of whose texels lies
/// within one texel (8-neighbourhood) of a texel with alpha ≥ 128 (issue 15; README
/// "Textures"). Readers treat a bilinear sample whose alpha is below one half as "no
/// data" (the player's `project_view`); such a sample has no covered texel among its
/// four taps, and every tap of a sample that has one lies within one texel of it. So
/// the colours of these blocks never reach an image; zeroed, they cost next to
/// nothing after zstd (they were half of a park-2m cell's blocks: the background of
/// a statue's bounding rectangle).
fn clear_unsampled_blocks(width: u32, height: u32, rgba: &[u8], blocks: &mut [u8]) {
    let (w, h) = (width as usize, height as usize);
    let covered = |x: usize, y: usize| rgba[(y * w + x) * 4 + 3] >= 128;
    let bw = w / 4;
    for by in 0..h / 4 {
        for bx in 0..bw {
            let (x0, x1) = ((bx * 4).saturating_sub(1), (bx * 4 + 4).min(w - 1));
            let (y0, y1) = ((by * 4).saturating_sub(1), (by * 4 + 4).min(h - 1));
            let near = (y0..=y1).any(|y| (x0..=x1).any(|x| covered(x, y)));
            if !near {
                let o = (by * bw + bx) * 16;
                blocks[o..o + 16].fill(0);
            }
        }
    }
}

/// Largest texture side accepted by readers and writers.
pub const MAX_TEXTURE_SIDE: u32 = 16384;

/// How a texture's bytes encode its RGBA8 texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureEncoding {
    /// Row-major RGBA8 sRGB, `width · height · 4` bytes; uploadable as is.
    Rgba8 = 0,
    /// RGBA8 with a per-channel left predictor: byte i of a row stores
    /// `texel[i] - texel[i - 4]` (wrapping; the first texel of a row is stored as is).
    /// Same size, lossless, decoded with one add per byte; zstd compresses it better.
    Rgba8Left = 1,
    /// BC1 (DXT1) blocks, 8 bytes per 4×4 texels, row-major blocks; both sides are
    /// multiples of 4; every texel decodes with alpha 255 (writers use it only for
    /// images whose alpha is all 255). Format version 2.
    Bc1 = 2,
    /// BC3 (DXT5) blocks, 16 bytes per 4×4 texels (8 alpha + 8 BC1 colour), row-major
    /// blocks; both sides are multiples of 4. For images with coverage in alpha.
    /// Format version 2. (BC7 was measured and rejected: its CPU encoder runs at
    /// 0.1–0.3 Mtexel/s against BC3's 39, README "Textures".)
    Bc3 = 3,
}

impl TextureEncoding {
    pub fn from_u32(v: u32) -> Option<TextureEncoding> {
        match v {
            0 => Some(TextureEncoding::Rgba8),
            1 => Some(TextureEncoding::Rgba8Left),
            2 => Some(TextureEncoding::Bc1),
            3 => Some(TextureEncoding::Bc3),
            _ => None,
        }
    }

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

    pub fn name(self) -> &'static str {
        match self {
            TextureEncoding::Rgba8 => "rgba8",
            TextureEncoding::Rgba8Left => "rgba8-left",
            TextureEncoding::Bc1 => "bc1",
            TextureEncoding::Bc3 => "bc3",
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
        let expected = encoded_len(width, height)?;
        if rgba.len() != expected {
            return Err(format!(
                "{width}x{height} RGBA8 needs {expected} bytes, got {}",
                rgba.len()
            ));
        }
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
        let expected = encoded_len(width, height)?;
        if rgba.len() != expected {
            return Err(format!(
                "{width}x{height} RGBA8 needs {expected} bytes, got {}",
                rgba.len()
            ));
        }
        let (pw, ph) = block_padded_size(width, height);
        let padded = pad_edge(width, height, rgba, pw, ph);
        let opaque = padded.chunks_exact(4).all(|t| t[3] == 255);
        let encoding = if opaque {
            TextureEncoding::Bc1
        } else {
            TextureEncoding::Bc3
        };
        Texture::from_rgba8(pw, ph, &padded, encoding)
    }

    /// As [`Texture::from_rgba8_block`], with the BC3 blocks that no accepted sample
    /// can read set to zero (format version 3 writers; README "Textures": colours
    /// farther than one texel from a texel of alpha ≥ 128 are undefined). What bakes
    /// store.
    pub fn from_rgba8_block_trimmed(
        width: u32,
        height: u32,
        rgba: &[u8],
    ) -> Result<Texture, String> {
        let mut texture = Texture::from_rgba8_block(width, height, rgba)?;
        if texture.encoding == TextureEncoding::Bc3 {
            let (pw, ph) = (texture.width, texture.height);
            let padded = pad_edge(width, height, rgba, pw, ph);
            clear_unsampled_blocks(pw, ph, &padded, &mut texture.data);
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

fn encoded_len(width: u32, height: u32) -> Result<usize, String> {
    if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(format!(
            "texture size {width}x{height} outside 1..={MAX_TEXTURE_SIDE}"
        ));
    }
    Ok(width as usize * height as usize * 4)
}
