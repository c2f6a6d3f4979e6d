//! Layered impostors (paper 001, Schaufler 1998, §3–4; DESIGN.md "Representations";
//! issue 16): an object (or a cluster) is captured once, colour and depth, from the
//! centre of the region it serves, and drawn as a stack of textured quads — layers —
//! perpendicular to the capture axis, each showing only the texels whose depth lies
//! in its depth interval (001 §3.1–3.2, the alpha test of §4). Layers are written to
//! the depth buffer, so they composite with meshes (001 §7, "approximate z-values
//! are written into the depth buffer").
//!
//! **Layer count (001 §3.3–3.4).** When the viewer moves by `e` from the capture eye,
//! a surface point at depth `d` drawn on a layer at depth `d_l` is seen off by the
//! error angle `θ ≈ e · |1/d − 1/d_l|` (the parallax difference of the two depths).
//! Slicing the inverse-depth range `S = 1/near − 1/far` of the object into `n`
//! equal intervals with each layer at the middle of its interval bounds the error
//! by `e · S / (2n)` — "the incurred error ... is halved by doubling the layers"
//! (§3.3). As in 001 §6, the tolerable error angle is the angle of one pixel of the
//! final image (DESIGN.md: `image_res` pixels per 60°), and `e` is the largest
//! distance from the capture eye to the region's corners, so
//! `n = ceil(e · S / (2 · θ_pixel))`, clamped to `1..=MAX_LAYERS` (001 §6 used up to
//! 32). Neighbouring layers overlap by one depth code so that no crack opens
//! between them (001 Fig. 2).
//!
//! **Storage** ([`format::pack::ImpostorLayers`]): the capture's colour texture
//! (cropped, dilated as every capture, [`crate::capture::texture_of`]) with the
//! alpha channel replaced by the depth code of the texel (0 = nothing captured),
//! stored losslessly; depth codes are uniform in inverse depth over `near..far`.
//!
//! **Drawing** ([`composite_impostors`], the CPU side; the player's shader does the
//! same with quads and `discard`): per pixel and layer, the ray through the pixel
//! centre meets the layer's plane; the texel there (nearest) is drawn if its code lies
//! in the layer's interval, with the bilinear colour of the texture, at the depth of
//! the hit, if nearer than what the depth buffer holds. Only the front side of a
//! layer (seen from the capture eye's side) is drawn, like a back-face-culled quad.

use crate::capture::{capture_objects, CaptureError};
use crate::raster::{Capture, DrawItem, ProjectedTexture, BACKGROUND_ID};
use format::pack::{code_of_depth, ImpostorLayer, ImpostorLayers};
use glam::{Mat3, Mat4, Vec3, Vec4};
use rayon::prelude::*;

/// Most layers the builder uses (001 §6: "up to 32 layers are used per impostor").
pub const MAX_LAYERS: usize = 32;

/// A layered impostor as the bake holds it before packing.
#[derive(Clone, Debug, PartialEq)]
pub struct LayeredImpostor {
    /// RGBA8: RGB the capture's colour, alpha the depth code (module docs); `matrix`
    /// maps world points to its texture coordinates, `q` being the eye-space depth.
    pub texture: ProjectedTexture,
    pub layers: ImpostorLayers,
}

impl LayeredImpostor {
    /// Quads drawn (two triangles per layer).
    pub fn triangle_count(&self) -> u64 {
        2 * self.layers.layers.len() as u64
    }

    pub fn texels(&self) -> u64 {
        u64::from(self.texture.width) * u64::from(self.texture.height)
    }
}

/// 001's viewer offset `e` for a region: the largest distance from the capture eye
/// to the prism's 12 corners.
pub fn max_offset(prism: &crate::grid::Prism, eye: Vec3) -> f32 {
    prism
        .corners()
        .iter()
        .map(|c| c.distance(eye))
        .fold(0.0f32, f32::max)
}

/// 001 §3.3's layer count for an object whose depths from the capture eye span
/// `near..far`, served to viewers up to `max_offset` from the eye, with one pixel
/// of `image_res` per 60° as the tolerable error angle (module docs).
pub fn layer_count(near: f32, far: f32, max_offset: f32, image_res: u32) -> usize {
    layer_count_up_to(near, far, max_offset, image_res, MAX_LAYERS)
}

/// [`layer_count`] clamped to `1..=max_layers` instead of [`MAX_LAYERS`] (merged
/// impostors of the far field, `crate::levels`, go up to the format's 64).
pub fn layer_count_up_to(
    near: f32,
    far: f32,
    max_offset: f32,
    image_res: u32,
    max_layers: usize,
) -> usize {
    let pixel_angle = std::f64::consts::FRAC_PI_3 / f64::from(image_res.max(1));
    let span = (1.0 / f64::from(near) - 1.0 / f64::from(far)).max(0.0);
    let n = (f64::from(max_offset) * span / (2.0 * pixel_angle)).ceil();
    if n.is_finite() {
        (n as usize).clamp(1, max_layers)
    } else {
        max_layers
    }
}

/// `n` layers over codes `1..=255`: equal intervals in code (= inverse depth), each
/// widened by one code on either side (001 Fig. 2), the quad at the interval's middle
/// in inverse depth.
pub fn split_layers(near: f32, far: f32, n: usize) -> Vec<ImpostorLayer> {
    let n = n.clamp(1, 255);
    (0..n)
        .map(|i| {
            let lo = 1 + (i * 255) / n;
            let hi = ((i + 1) * 255) / n;
            let mid_code = 0.5 * (lo + hi) as f64;
            let t = (mid_code - 1.0) / 254.0;
            let inv = 1.0 / f64::from(near) - t * (1.0 / f64::from(near) - 1.0 / f64::from(far));
            ImpostorLayer {
                depth: (1.0 / inv) as f32,
                code_lo: lo.saturating_sub(1).max(1) as u8,
                code_hi: (hi + 1).min(255) as u8,
            }
        })
        .collect()
}

/// The world-space rays from the eye of `matrix` (a capture's world → texture
/// matrix whose `q` is the eye-space depth) to texture corners (0,0), (1,0), (1,1),
/// (0,1) at depth 1; `None` if the matrix is singular.
pub fn corner_rays(matrix: &Mat4) -> Option<[[f32; 3]; 4]> {
    let m = matrix.transpose(); // rows as columns
    let (rs, rt, rq) = (m.x_axis, m.y_axis, m.w_axis);
    let a = Mat3::from_cols(rs.truncate(), rt.truncate(), rq.truncate()).transpose();
    if a.determinant().abs() < 1e-20 || !a.is_finite() {
        return None;
    }
    let inv = a.inverse();
    let ray = |s: f32, t: f32| (inv * Vec3::new(s, t, 1.0)).to_array();
    Some([ray(0.0, 0.0), ray(1.0, 0.0), ray(1.0, 1.0), ray(0.0, 1.0)])
}

/// Builds the layered impostor of `items` captured from `eye` at `image_res` pixels
/// per 60° (the capture's resolution), its layer count chosen for viewers up to
/// `max_offset` from the eye and an error of one pixel of `output_res` per 60°.
/// `None` when the object covers no pixel of the capture (nothing to slice).
pub fn build_layered_impostor(
    eye: Vec3,
    items: &[DrawItem],
    image_res: u32,
    output_res: u32,
    max_offset: f32,
) -> Result<Option<LayeredImpostor>, CaptureError> {
    build_layered_impostor_up_to(eye, items, image_res, output_res, max_offset, MAX_LAYERS)
}

/// [`build_layered_impostor`] with at most `max_layers` layers.
pub fn build_layered_impostor_up_to(
    eye: Vec3,
    items: &[DrawItem],
    image_res: u32,
    output_res: u32,
    max_offset: f32,
    max_layers: usize,
) -> Result<Option<LayeredImpostor>, CaptureError> {
    // 1. The capture and its texture, as for any proxy.
    let capture = capture_objects(eye, items, image_res)?;
    if capture.covered_pixels == 0 {
        return Ok(None);
    }
    let cap = &capture.capture;
    let member = |id: u32| id != BACKGROUND_ID && items.iter().any(|i| i.object_id == id);
    // 2. Depth range of the covered pixels.
    let (mut near, mut far) = (f32::INFINITY, 0.0f32);
    for (d, &id) in cap.depth.iter().zip(&cap.object_id) {
        if member(id) && d.is_finite() {
            near = near.min(*d);
            far = far.max(*d);
        }
    }
    if !(near.is_finite() && near > 0.0) {
        return Ok(None);
    }
    let far = far.max(near);
    // 3. Texel → capture pixel: the texture matrix is crop · view_proj, the crop an
    //    affine map of NDC (capture.rs), recovered as crop = matrix · view_proj⁻¹.
    let mut texture = capture.texture;
    let crop = texture.matrix * cap.view.view_proj().inverse();
    let (w, h) = (cap.view.width as f32, cap.view.height as f32);
    // s = crop_xx · ndc_x + crop_xw, ndc_x = 2 px / W − 1 (likewise t, y flipped).
    let (sx, s0) = (crop.x_axis.x, crop.w_axis.x);
    let (ty, t0) = (crop.y_axis.y, crop.w_axis.y);
    let (tw, th) = (texture.width as usize, texture.height as usize);
    for y in 0..th {
        for x in 0..tw {
            let s = (x as f32 + 0.5) / tw as f32;
            let t = (y as f32 + 0.5) / th as f32;
            let ndc_x = (s - s0) / sx;
            let ndc_y = (t - t0) / ty;
            let px = ((ndc_x + 1.0) * 0.5 * w).floor();
            let py = ((1.0 - ndc_y) * 0.5 * h).floor();
            let o = (y * tw + x) * 4 + 3;
            texture.rgba[o] = 0;
            if px >= 0.0 && py >= 0.0 && px < w && py < h {
                let q = cap.index(px as u32, py as u32);
                if member(cap.object_id[q]) {
                    texture.rgba[o] = code_of_depth(near, far, cap.depth[q]);
                }
            }
        }
    }
    // 4. Layers by 001 §3.3's error angle, corner rays from the matrix.
    let n = layer_count_up_to(near, far, max_offset, output_res, max_layers);
    let Some(corner_rays) = corner_rays(&texture.matrix) else {
        return Ok(None);
    };
    Ok(Some(LayeredImpostor {
        texture,
        layers: ImpostorLayers {
            corner_rays,
            near,
            far,
            layers: split_layers(near, far, n),
        },
    }))
}

/// One impostor to composite into a frame.
#[derive(Clone, Copy, Debug)]
pub struct ImpostorDraw<'a> {
    pub texture: &'a ProjectedTexture,
    pub layers: &'a ImpostorLayers,
    /// Written to the frame's object-ID buffer where the impostor is visible.
    pub object_id: u32,
}

/// Draws `impostors` into `frame` (module docs, "Drawing"): depth-tested against
/// what the frame holds, writing colour, depth and object id (triangle id = layer).
/// Deterministic: each pixel is computed on its own, in a fixed order of impostors
/// and layers.
pub fn composite_impostors(frame: &mut Capture, impostors: &[ImpostorDraw<'_>]) {
    let view = frame.view;
    let (w, h) = (view.width as usize, view.height as usize);
    if w == 0 || h == 0 || impostors.is_empty() {
        return;
    }
    let inv_vp = view.view_proj().inverse();
    let forward = -view.view.inverse().z_axis.truncate().normalize_or_zero();
    let eye = view.eye;
    type Hit = (usize, f32, [u8; 4], u32, u32);
    let rows: Vec<Vec<Hit>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = Vec::new();
            for x in 0..w {
                let ndc_x = 2.0 * (x as f32 + 0.5) / w as f32 - 1.0;
                let ndc_y = 1.0 - 2.0 * (y as f32 + 0.5) / h as f32;
                let p = inv_vp * Vec4::new(ndc_x, ndc_y, 1.0, 1.0);
                let dir = (p.truncate() / p.w - eye).normalize_or_zero();
                let mut best: Option<(f32, [u8; 4], u32, u32)> = None;
                for imp in impostors {
                    if let Some((depth, colour, layer)) = hit(imp, eye, dir, forward) {
                        if best.is_none_or(|b| depth < b.0) {
                            best = Some((depth, colour, imp.object_id, layer));
                        }
                    }
                }
                let q = y * w + x;
                if let Some((depth, colour, object, layer)) = best {
                    if depth < frame.depth[q] {
                        row.push((q, depth, colour, object, layer));
                    }
                }
            }
            row
        })
        .collect();
    for (q, depth, colour, object, layer) in rows.into_iter().flatten() {
        frame.depth[q] = depth;
        frame.color[q] = colour;
        frame.object_id[q] = object;
        frame.triangle_id[q] = layer;
    }
}

/// The nearest layer of `imp` the ray `eye + λ·dir` hits: the viewer's eye-space
/// depth of the hit (along `forward`), its colour, and the layer index.
fn hit(imp: &ImpostorDraw<'_>, eye: Vec3, dir: Vec3, forward: Vec3) -> Option<(f32, [u8; 4], u32)> {
    let t = imp.texture;
    let m = t.matrix;
    let row = |r: usize| Vec4::new(m.col(0)[r], m.col(1)[r], m.col(2)[r], m.col(3)[r]);
    let (rs, rt, rq) = (row(0), row(1), row(3));
    let q_eye = rq.dot(eye.extend(1.0));
    let q_dir = rq.dot(dir.extend(0.0));
    let (tw, th) = (t.width as usize, t.height as usize);
    if tw == 0 || th == 0 || t.rgba.len() != tw * th * 4 || q_dir <= 0.0 {
        return None;
    }
    let mut best: Option<(f32, [u8; 4], u32)> = None;
    for (li, layer) in imp.layers.layers.iter().enumerate() {
        // Front side only: the viewer is nearer the capture eye's side of the plane.
        if q_eye >= layer.depth {
            continue;
        }
        let lambda = (layer.depth - q_eye) / q_dir;
        if lambda <= 0.0 || !lambda.is_finite() {
            continue;
        }
        let p = eye + lambda * dir;
        let s = rs.dot(p.extend(1.0)) / layer.depth;
        let tt = rt.dot(p.extend(1.0)) / layer.depth;
        if !(0.0..1.0).contains(&s) || !(0.0..1.0).contains(&tt) {
            continue;
        }
        let tx = ((s * tw as f32) as usize).min(tw - 1);
        let ty = ((tt * th as f32) as usize).min(th - 1);
        let code = t.rgba[(ty * tw + tx) * 4 + 3];
        if code == 0 || code < layer.code_lo || code > layer.code_hi {
            continue;
        }
        let depth = lambda * dir.dot(forward);
        if best.is_some_and(|b| b.0 <= depth) {
            continue;
        }
        let rgb = t.sample(p)?;
        let c = |v: f32| (v + 0.5).clamp(0.0, 255.0) as u8;
        best = Some((depth, [c(rgb.x), c(rgb.y), c(rgb.z), 255], li as u32));
    }
    best
}
