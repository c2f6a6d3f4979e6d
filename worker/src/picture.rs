//! PNG output for people (STYLE.md habit 13): captures, depth, class and weight maps.

use std::io::BufWriter;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: PNG encoding failed: {source}")]
    Encode {
        path: String,
        source: png::EncodingError,
    },
    #[error("{path}: {width}×{height} image needs {expected} pixels, got {found}")]
    Size {
        path: String,
        width: u32,
        height: u32,
        expected: usize,
        found: usize,
    },
}

/// Writes row-major RGBA8 pixels (row 0 at the top) as a PNG.
pub fn write_rgba(path: &Path, width: u32, height: u32, pixels: &[[u8; 4]]) -> Result<(), PictureError> {
    let name = path.display().to_string();
    let expected = width as usize * height as usize;
    if pixels.len() != expected {
        return Err(PictureError::Size {
            path: name,
            width,
            height,
            expected,
            found: pixels.len(),
        });
    }
    let file = std::fs::File::create(path).map_err(|source| PictureError::Io {
        path: name.clone(),
        source,
    })?;
    let mut enc = png::Encoder::new(BufWriter::new(file), width, height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    let encode = |source| PictureError::Encode {
        path: name.clone(),
        source,
    };
    let mut writer = enc.write_header().map_err(encode)?;
    writer
        .write_image_data(bytemuck_flatten(pixels))
        .map_err(encode)?;
    writer.finish().map_err(encode)
}

fn bytemuck_flatten(pixels: &[[u8; 4]]) -> &[u8] {
    pixels.as_flattened()
}

/// Maps `t ∈ [0, 1]` to a perceptually ordered colour ramp (dark blue → yellow).
pub fn ramp(t: f32) -> [u8; 4] {
    const STOPS: [[f32; 3]; 5] = [
        [0.05, 0.03, 0.25],
        [0.25, 0.15, 0.55],
        [0.75, 0.25, 0.45],
        [0.98, 0.55, 0.15],
        [0.99, 0.95, 0.35],
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c = |k: usize| ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0).round() as u8;
    [c(0), c(1), c(2), 255]
}
