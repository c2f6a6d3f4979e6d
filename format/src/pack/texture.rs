//! Capture textures of proxy views (paper 000 §3.1.2: one capture per SV proxy, up to
//! seven per MV proxy). Decoded texels are RGBA8, sRGB. Two lossless, cheap-to-decode
//! encodings exist; the `textures` section is then zstd-compressed as a whole
//! (format/README.md, "Textures", has the measurements behind the choice); the
//! writer-side helper [`Texture::from_rgba8_smallest`] picks the encoding per image.

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
}

impl TextureEncoding {
    pub fn from_u32(v: u32) -> Option<TextureEncoding> {
        match v {
            0 => Some(TextureEncoding::Rgba8),
            1 => Some(TextureEncoding::Rgba8Left),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            TextureEncoding::Rgba8 => "rgba8",
            TextureEncoding::Rgba8Left => "rgba8-left",
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

    /// Whether the dimensions and data length agree.
    pub fn validate(&self) -> Result<(), String> {
        let expected = encoded_len(self.width, self.height)?;
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

    /// Decoded RGBA8 sRGB texels, row-major.
    pub fn to_rgba8(&self) -> Result<Vec<u8>, String> {
        self.validate()?;
        Ok(match self.encoding {
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

fn encoded_len(width: u32, height: u32) -> Result<usize, String> {
    if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(format!(
            "texture size {width}x{height} outside 1..={MAX_TEXTURE_SIDE}"
        ));
    }
    Ok(width as usize * height as usize * 4)
}
