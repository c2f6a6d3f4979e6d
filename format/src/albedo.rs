//! Albedo textures of models read from glTF scenes (issue 18): a base-colour
//! texture, its sampler's wrap modes and one UV per vertex. The one home of how a
//! texture is sampled, so the CPU rasterizer (worker `raster.rs`) and the player's
//! shader (an `Rgba8UnormSrgb` texture with a linear, non-mipmapped sampler) agree.
//!
//! Sampling (DESIGN.md "Shading", sRGB/linear rules): the texel grid has its centres
//! at `(i + ½) / width`; the UV is wrapped per axis by the sampler's mode, the four
//! nearest texels are decoded sRGB8 → linear **before** bilinear filtering (what a
//! GPU does with an sRGB texture format), and the result is a linear RGB factor of
//! the albedo: albedo = texture × base-colour factor × vertex colour × instance tint.
//! No mipmaps on either side (a texture seen from far aliases the same way on both).
//! Alpha is ignored (opaque materials; alpha masks and blending are not read).

use crate::srgb::srgb_to_linear;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Largest side of an albedo texture, in texels (the player's adapters guarantee
/// 8192; bigger textures are refused when loading).
pub const MAX_TEXTURE_SIDE: u32 = 8192;

/// How a texture coordinate outside [0, 1] maps into the texture (glTF sampler
/// `wrapS` / `wrapT`; wgpu `AddressMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Wrap {
    /// glTF's default.
    #[default]
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

impl Wrap {
    /// The code stored in packs (`format/README.md`, section `albedo-textures`).
    pub fn code(self) -> u32 {
        match self {
            Wrap::Repeat => 0,
            Wrap::MirroredRepeat => 1,
            Wrap::ClampToEdge => 2,
        }
    }

    pub fn from_code(code: u32) -> Option<Wrap> {
        match code {
            0 => Some(Wrap::Repeat),
            1 => Some(Wrap::MirroredRepeat),
            2 => Some(Wrap::ClampToEdge),
            _ => None,
        }
    }

    /// Texel index `i` (any integer) of a texture `n` texels wide, wrapped.
    fn texel(self, i: i64, n: u32) -> usize {
        let n = i64::from(n.max(1));
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        };
        k as usize
    }
}

/// An RGBA8 sRGB texture, row 0 at the top (glTF's image orientation: UV (0, 0) is
/// the first texel of the first row).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlbedoTexture {
    pub width: u32,
    pub height: u32,
    /// Row-major RGBA8 sRGB, `width · height · 4` bytes.
    pub rgba: Vec<u8>,
    /// Wrap modes along u (`wrapS`) and v (`wrapT`).
    pub wrap: [Wrap; 2],
}

impl AlbedoTexture {
    /// Checks the sizes: both sides in 1..=[`MAX_TEXTURE_SIDE`], `rgba` exactly
    /// `width · height · 4` bytes.
    pub fn validate(&self) -> Result<(), String> {
        let side = 1..=MAX_TEXTURE_SIDE;
        if !(side.contains(&self.width) && side.contains(&self.height)) {
            return Err(format!(
                "texture of {} × {} texels; sides must be in 1..={MAX_TEXTURE_SIDE}",
                self.width, self.height
            ));
        }
        let expected = self.width as usize * self.height as usize * 4;
        if self.rgba.len() != expected {
            return Err(format!(
                "texture of {} × {} texels has {} bytes of RGBA8, expected {expected}",
                self.width,
                self.height,
                self.rgba.len()
            ));
        }
        Ok(())
    }

    /// Linear RGB of the texture at `uv`, bilinearly filtered after sRGB decoding
    /// (module docs). A malformed texture samples as white.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        if self.validate().is_err() || !uv.is_finite() {
            return Vec3::ONE;
        }
        let (w, h) = (self.width, self.height);
        // Texel centres at +0.5; floor in f64 so huge UVs (repeating) stay exact enough.
        let x = f64::from(uv.x) * f64::from(w) - 0.5;
        let y = f64::from(uv.y) * f64::from(h) - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let texel = |i: i64, j: i64| {
            let tx = self.wrap[0].texel(i, w);
            let ty = self.wrap[1].texel(j, h);
            let o = (ty * w as usize + tx) * 4;
            Vec3::new(
                srgb_to_linear(self.rgba[o]),
                srgb_to_linear(self.rgba[o + 1]),
                srgb_to_linear(self.rgba[o + 2]),
            )
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// blake3 of the texture (sides, wrap codes, texels): part of a textured model's
    /// content hash.
    pub fn content_hash(&self) -> [u8; 32] {
        let mut h = blake3::Hasher::new();
        h.update(b"hexbake albedo texture v1");
        h.update(&self.width.to_le_bytes());
        h.update(&self.height.to_le_bytes());
        h.update(&self.wrap[0].code().to_le_bytes());
        h.update(&self.wrap[1].code().to_le_bytes());
        h.update(&self.rgba);
        *h.finalize().as_bytes()
    }
}

/// A model's albedo texture and its per-vertex texture coordinates (one UV per
/// vertex of the model's mesh).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlbedoMap {
    pub uvs: Vec<[f32; 2]>,
    pub texture: AlbedoTexture,
}

impl AlbedoMap {
    /// Linear RGB factor of the albedo at barycentrics `b` of triangle `t` (indices
    /// into the mesh's vertices); white where a UV is missing.
    pub fn sample_triangle(&self, t: [u32; 3], b: Vec3) -> Vec3 {
        let mut uv = Vec2::ZERO;
        for k in 0..3 {
            match self.uvs.get(t[k] as usize) {
                Some(&c) => uv += b[k] * Vec2::from_array(c),
                None => return Vec3::ONE,
            }
        }
        self.texture.sample(uv)
    }

    /// Vertex `v`'s sRGB8 `albedo` times the texture at its UV: a per-vertex
    /// stand-in for the texture where a renderer has no texture lookup — the
    /// player's proxies drawn lit (their capture has no texel there, or is not
    /// resident yet) interpolate it, instead of the untextured vertex colour.
    pub fn vertex_albedo(&self, albedo: [u8; 4], v: usize) -> [u8; 4] {
        let Some(uv) = self.uvs.get(v) else {
            return albedo;
        };
        let lit = crate::srgb::srgb8_to_linear(albedo) * self.texture.sample(Vec2::from_array(*uv));
        crate::srgb::linear_to_srgb8(lit)
    }

    /// The content hash of a textured model: the mesh's hash, the UVs and the
    /// texture's hash.
    pub fn model_hash(&self, mesh_hash: &[u8; 32]) -> [u8; 32] {
        let mut h = blake3::Hasher::new();
        h.update(b"hexbake textured model v1");
        h.update(mesh_hash);
        h.update(&(self.uvs.len() as u64).to_le_bytes());
        for uv in &self.uvs {
            h.update(&uv[0].to_le_bytes());
            h.update(&uv[1].to_le_bytes());
        }
        h.update(&self.texture.content_hash());
        *h.finalize().as_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> AlbedoTexture {
        // 2 × 2: black, white / white, black.
        AlbedoTexture {
            width: 2,
            height: 2,
            rgba: vec![
                0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255,
            ],
            wrap: [Wrap::Repeat, Wrap::Repeat],
        }
    }

    #[test]
    fn texel_centres_sample_exactly() {
        let t = checker();
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)), Vec3::ONE);
        // Repeat: one period further is the same texel.
        assert_eq!(t.sample(Vec2::new(1.75, -0.75)), Vec3::ONE);
        // Halfway between two texels: their linear mean (not the sRGB mean).
        let mid = t.sample(Vec2::new(0.5, 0.25));
        assert!((mid.x - 0.5).abs() < 1e-6, "{mid}");
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(Wrap::Repeat.texel(-1, 4), 3);
        assert_eq!(Wrap::ClampToEdge.texel(-1, 4), 0);
        assert_eq!(Wrap::ClampToEdge.texel(9, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.texel(4, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.texel(-1, 4), 0);
        assert_eq!(Wrap::MirroredRepeat.texel(8, 4), 0);
        for code in 0..3 {
            assert_eq!(Wrap::from_code(code).unwrap().code(), code);
        }
        assert_eq!(Wrap::from_code(3), None);
    }

    #[test]
    fn malformed_textures_sample_white() {
        let mut t = checker();
        t.rgba.pop();
        assert!(t.validate().is_err());
        assert_eq!(t.sample(Vec2::ZERO), Vec3::ONE);
    }
}
