//! Object captures and their projective textures (paper 000 §3.1.3 step (1): "capture
//! the image and depth image of O ... cell's center as the center of projection";
//! §3.1.4: the same from the centres of the neighbouring cells; §3.2: the textures are
//! mapped by projective texturing; DESIGN.md "Capture resolution").
//!
//! A capture renders **only** the object (or the members of a cluster) from an eye,
//! through a tight frustum around its world box at DESIGN.md's angular resolution
//! ([`View::tight_around`]: `image_res` pixels per 60°). Other objects of the scene do
//! not occlude it: the proxy texture must show the object's own surface wherever the
//! proxy is drawn, and the occlusion between objects is resolved at run time by the
//! depth buffer (the paper's object-based LOD meshes "avoid the holes due to occlusion
//! among objects", §3). The classes and weights (§3.1.3.1–2) are computed on the same
//! capture, as `classify.rs` asks.
//!
//! From the capture we keep a texture: the colour buffer cropped to the rectangle the
//! object covers, widened by [`TEXTURE_PAD_PX`] on every side; texels of the object
//! have alpha 255, the others alpha 0. Background texels within
//! [`TEXTURE_DILATE_PX`] of the object carry the colour of their covered neighbours
//! (texture padding), so that a bilinear lookup at the object's rim, or on a simplified
//! silhouette that pokes slightly past the original one, never blends in a foreign
//! colour; the remaining background texels (e.g. in gaps of the object) carry the
//! object's mean colour; the player's lookup and [`crate::raster::ProjectedTexture::sample`] use the
//! colour whatever the alpha. An object covering no pixel centre at all (smaller than
//! a pixel) gets a 1 × 1 texture of its lit mean albedo.
//!
//! The world → texture matrix `M` maps a world point `p` to `(s, t, z, q) = M·(p, 1)`
//! with `(s/q, t/q) ∈ [0, 1]²` over the texture, `t` growing downwards (texture row 0
//! is the top row of the capture): `M = T · proj · view`, where `T` takes clip space
//! to the pixel grid of the capture (NDC → pixels, y flipped) and then to the crop.

use crate::raster::View;
use crate::raster::{render, Capture, CullMode, DrawItem, ProjectedTexture, BACKGROUND_ID};
use crate::shade::{linear_to_srgb8, shade, srgb8_to_linear};
use crate::view::ViewError;
use glam::{Mat4, Vec3, Vec4};
use thiserror::Error;

/// Texels added around the covered rectangle on every side.
pub const TEXTURE_PAD_PX: u32 = 2;
/// Background texels within this many texels (4-neighbour steps) of the object take
/// the mean colour of their covered neighbours.
pub const TEXTURE_DILATE_PX: u32 = 3;

/// Why a capture cannot be made.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CaptureError {
    #[error("nothing to capture (no triangle with valid vertices)")]
    Empty,
    #[error("capture view from {eye:?}: {source}")]
    View {
        eye: [f32; 3],
        #[source]
        source: ViewError,
    },
}

/// One capture of an object (or a cluster) and its texture.
#[derive(Clone, Debug)]
pub struct ObjectCapture {
    /// The raw buffers (depth, colour, ids), for classes and weights.
    pub capture: Capture,
    /// The cropped, padded texture and its world → texture matrix.
    pub texture: ProjectedTexture,
    /// Pixels of the capture covered by the object.
    pub covered_pixels: usize,
}

/// World box of the items' referenced vertices (`None` when no triangle is valid).
pub fn items_aabb(items: &[DrawItem]) -> Option<(Vec3, Vec3)> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut any = false;
    for item in items {
        let mesh = item.mesh;
        let mut used = vec![false; mesh.positions.len()];
        let mut mark = |t: &[u32; 3]| {
            if t.iter().all(|&v| (v as usize) < used.len()) {
                for &v in t {
                    used[v as usize] = true;
                }
            }
        };
        match item.triangles {
            Some(subset) => subset
                .iter()
                .filter_map(|&t| mesh.triangles.get(t as usize))
                .for_each(&mut mark),
            None => mesh.triangles.iter().for_each(&mut mark),
        }
        for (p, _) in mesh.positions.iter().zip(&used).filter(|(_, &u)| u) {
            let w = item.transform.transform_point3(Vec3::from_array(*p));
            if w.is_finite() {
                lo = lo.min(w);
                hi = hi.max(w);
                any = true;
            }
        }
    }
    any.then_some((lo, hi))
}

/// The tight capture view from `eye` around `[lo, hi]` at `image_res` pixels per 60°.
pub fn capture_view(eye: Vec3, lo: Vec3, hi: Vec3, image_res: u32) -> Result<View, CaptureError> {
    View::tight_around(eye, lo, hi, image_res).map_err(|source| CaptureError::View {
        eye: eye.into(),
        source,
    })
}

/// Captures `items` (one object, or the members of a cluster, each with its own
/// `object_id`) alone from `eye` (module docs) and builds the texture.
pub fn capture_objects(
    eye: Vec3,
    items: &[DrawItem],
    image_res: u32,
) -> Result<ObjectCapture, CaptureError> {
    capture_objects_in(eye, items, items_aabb(items), image_res)
}

/// [`capture_objects`] with the items' box already known (`items_aabb(items)`), for
/// callers that capture the same items from several eyes.
pub fn capture_objects_in(
    eye: Vec3,
    items: &[DrawItem],
    aabb: Option<(Vec3, Vec3)>,
    image_res: u32,
) -> Result<ObjectCapture, CaptureError> {
    let (lo, hi) = aabb.ok_or(CaptureError::Empty)?;
    let view = capture_view(eye, lo, hi, image_res)?;
    let capture = render(&view, items, CullMode::Back);
    let member = |id: u32| id != BACKGROUND_ID && items.iter().any(|i| i.object_id == id);
    let (texture, covered_pixels) = texture_of(&capture, &member, || fallback_colour(items));
    Ok(ObjectCapture {
        capture,
        texture,
        covered_pixels,
    })
}

/// The lit mean albedo of the items seen from straight on (for sub-pixel objects).
fn fallback_colour(items: &[DrawItem]) -> [u8; 4] {
    let mut sum = Vec3::ZERO;
    let mut n = 0.0f32;
    for item in items {
        for c in &item.mesh.albedo {
            sum += srgb8_to_linear(*c) * item.tint;
            n += 1.0;
        }
    }
    let albedo = if n > 0.0 { sum / n } else { Vec3::ONE };
    linear_to_srgb8(shade(albedo, Vec3::Y))
}

/// Crops, pads and dilates the colour buffer of `capture` around the pixels whose
/// object id satisfies `member`; returns the texture and the covered pixel count.
pub fn texture_of(
    capture: &Capture,
    member: &dyn Fn(u32) -> bool,
    fallback: impl FnOnce() -> [u8; 4],
) -> (ProjectedTexture, usize) {
    let view = &capture.view;
    let (w, h) = (view.width as i64, view.height as i64);
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    let mut covered = 0usize;
    for y in 0..h {
        for x in 0..w {
            if member(capture.object_id[(y * w + x) as usize]) {
                covered += 1;
                x0 = x0.min(x);
                y0 = y0.min(y);
                x1 = x1.max(x);
                y1 = y1.max(y);
            }
        }
    }
    let view_proj = view.view_proj();
    if covered == 0 {
        // Sub-pixel object: one texel over the whole capture window.
        let c = fallback();
        let texture = ProjectedTexture {
            eye: view.eye,
            matrix: crop_matrix(w as f32, h as f32, 0.0, 0.0, w as f32, h as f32) * view_proj,
            width: 1,
            height: 1,
            rgba: vec![c[0], c[1], c[2], 255],
        };
        return (texture, 0);
    }
    let pad = TEXTURE_PAD_PX as i64;
    let (cx0, cy0) = (x0 - pad, y0 - pad);
    let (cw, ch) = (x1 - x0 + 1 + 2 * pad, y1 - y0 + 1 + 2 * pad);
    let mut rgba = vec![0u8; (cw * ch * 4) as usize];
    let mut filled = vec![false; (cw * ch) as usize];
    for ty in 0..ch {
        for tx in 0..cw {
            let (x, y) = (cx0 + tx, cy0 + ty);
            if x < 0 || y < 0 || x >= w || y >= h {
                continue;
            }
            let q = (y * w + x) as usize;
            if member(capture.object_id[q]) {
                let o = (ty * cw + tx) as usize;
                let c = capture.color[q];
                rgba[o * 4..o * 4 + 3].copy_from_slice(&c[..3]);
                rgba[o * 4 + 3] = 255;
                filled[o] = true;
            }
        }
    }
    // The object's mean colour, for texels beyond the dilation.
    let mut sum = [0u64; 3];
    let mut n = 0u64;
    for (texel, &f) in rgba.chunks_exact(4).zip(&filled) {
        if f {
            for k in 0..3 {
                sum[k] += texel[k] as u64;
            }
            n += 1;
        }
    }
    let mean = sum.map(|s| (s + n / 2).checked_div(n).unwrap_or(0) as u8);
    dilate(&mut rgba, &mut filled, cw as usize, ch as usize);
    for (texel, &f) in rgba.chunks_exact_mut(4).zip(&filled) {
        if !f {
            texel[..3].copy_from_slice(&mean);
        }
    }
    let texture = ProjectedTexture {
        eye: view.eye,
        matrix: crop_matrix(
            w as f32, h as f32, cx0 as f32, cy0 as f32, cw as f32, ch as f32,
        ) * view_proj,
        width: cw as u32,
        height: ch as u32,
        rgba,
    };
    (texture, covered)
}

/// Textures are shrunk only when the fitted size saves at least this share of texels
/// along each shrunk axis (a resampling for a 2 % saving costs more in blur than it
/// saves in bytes).
pub const FIT_MIN_SHRINK: f32 = 0.9;

/// The largest linear texel scale a viewer anywhere in a region can use, for a
/// capture taken from `eye` of an object inside `[lo, hi]` (issue 15 item 3, "texture
/// resolution fitted to need").
///
/// **Rule.** A capture has `image_res` pixels per 60° at its eye (DESIGN.md "Capture
/// resolution"), the angular resolution of the player's 1024², 60° frame; so a texel
/// seen at object point `p` spans `|eye − p| · θ` in the world and, from a viewer at
/// `q`, `|eye − p| / |q − p|` screen pixels. Where every viewer of the region is
/// farther from every point of the object than the eye is, the texels are smaller
/// than any screen pixel they will ever cover and the texture can shrink by
///
/// `s = max_p |eye − p| / min_{q, p} |q − p|` (clamped to 1),
///
/// after which a texel still covers at most one screen pixel from the *nearest* point
/// of the region. Both terms are bounded conservatively: the numerator is the largest
/// distance from the eye to the object's box (a corner), the denominator the distance
/// between the region's and the object's boxes (never more than the true distance),
/// so `s` is never smaller than the exact ratio. A capture from inside the region (the
/// cell centre, a group centre) always gets `s ≥ 1`: only the MVMesh's captures from
/// the neighbouring cells' centres (§3.1.4), which can stand closer to the object than
/// any point of the cell, shrink.
pub fn fitted_scale(eye: Vec3, lo: Vec3, hi: Vec3, region_lo: Vec3, region_hi: Vec3) -> f32 {
    let far = crate::view::box_corners(lo, hi)
        .iter()
        .map(|c| c.distance(eye))
        .fold(0.0f32, f32::max);
    let gap = (region_lo - hi)
        .max(lo - region_hi)
        .max(Vec3::ZERO)
        .length();
    if gap <= 0.0 || !far.is_finite() {
        return 1.0;
    }
    (far / gap).min(1.0)
}

/// Shrinks `texture` to `scale` (from [`fitted_scale`]) of its width and height when
/// that saves enough ([`FIT_MIN_SHRINK`]); otherwise returns it unchanged.
///
/// The new texels cover the same rectangle, so the world → texture matrix (which maps
/// to normalised coordinates over the crop) is unchanged. Each new texel is the
/// area-weighted mean of the source texels under it: over the covered ones (alpha
/// 255) when they cover at least half its area, which then gets alpha 255, else over
/// all of them with alpha 0 — coverage stays binary and the rim keeps the object's own
/// colours, as [`texture_of`]'s dilation intends.
pub fn fit_texture(texture: ProjectedTexture, scale: f32) -> ProjectedTexture {
    let (w, h) = (texture.width, texture.height);
    let nw = ((w as f32 * scale).ceil() as u32).clamp(1, w);
    let nh = ((h as f32 * scale).ceil() as u32).clamp(1, h);
    let shrinks = |n: u32, o: u32| (n as f32) <= FIT_MIN_SHRINK * o as f32;
    if !(shrinks(nw, w) || shrinks(nh, h)) || texture.rgba.len() != (w * h * 4) as usize {
        return texture;
    }
    // Source texel spans of each target column / row with their overlap weights.
    let spans = |n: u32, o: u32| -> Vec<Vec<(usize, f32)>> {
        let step = o as f64 / n as f64;
        (0..n)
            .map(|i| {
                let (a, b) = (i as f64 * step, (i + 1) as f64 * step);
                (a.floor() as usize..(b.ceil() as usize).min(o as usize))
                    .map(|k| {
                        let overlap = (b.min(k as f64 + 1.0) - a.max(k as f64)).max(0.0);
                        (k, overlap as f32)
                    })
                    .filter(|&(_, f)| f > 0.0)
                    .collect()
            })
            .collect()
    };
    let (xs, ys) = (spans(nw, w), spans(nh, h));
    let mut rgba = vec![0u8; (nw * nh * 4) as usize];
    for (ty, yspan) in ys.iter().enumerate() {
        for (tx, xspan) in xs.iter().enumerate() {
            // [covered rgb sum, covered area, all rgb sum, all area]
            let mut cov = [0.0f32; 4];
            let mut all = [0.0f32; 4];
            for &(sy, fy) in yspan {
                for &(sx, fx) in xspan {
                    let o = (sy * w as usize + sx) * 4;
                    let a = fx * fy;
                    let t = &texture.rgba[o..o + 4];
                    let acc = if t[3] >= 128 { &mut cov } else { &mut all };
                    for k in 0..3 {
                        acc[k] += t[k] as f32 * a;
                    }
                    acc[3] += a;
                }
            }
            let total = cov[3] + all[3];
            let (sum, alpha) = if cov[3] >= 0.5 * total {
                (cov, 255)
            } else {
                (
                    [cov[0] + all[0], cov[1] + all[1], cov[2] + all[2], total],
                    0,
                )
            };
            let o = (ty * nw as usize + tx) * 4;
            for k in 0..3 {
                rgba[o + k] = (sum[k] / sum[3]).round().clamp(0.0, 255.0) as u8;
            }
            rgba[o + 3] = alpha;
        }
    }
    ProjectedTexture {
        width: nw,
        height: nh,
        rgba,
        ..texture
    }
}

/// Clip space → texture coordinates of the crop `[x0, x0 + cw) × [y0, y0 + ch)` of a
/// `width × height` image (module docs).
fn crop_matrix(width: f32, height: f32, x0: f32, y0: f32, cw: f32, ch: f32) -> Mat4 {
    Mat4::from_cols(
        Vec4::new(width / (2.0 * cw), 0.0, 0.0, 0.0),
        Vec4::new(0.0, -height / (2.0 * ch), 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new((width / 2.0 - x0) / cw, (height / 2.0 - y0) / ch, 0.0, 1.0),
    )
}

/// [`TEXTURE_DILATE_PX`] passes: every unfilled texel with filled 4-neighbours takes
/// their mean colour (alpha stays 0).
fn dilate(rgba: &mut [u8], filled: &mut [bool], w: usize, h: usize) {
    // Each pass fills the unfilled texels next to a texel filled before the pass,
    // with the rounded mean of those neighbours. Only texels next to the previous
    // pass's new ones can change in the next pass: the first pass scans the image,
    // later ones only that frontier (same values as a full scan of every texel).
    let mut frontier: Vec<usize> = Vec::new();
    let mut updates: Vec<(usize, [u8; 3])> = Vec::new();
    let mut queued = vec![false; w * h];
    for pass in 0..TEXTURE_DILATE_PX {
        updates.clear();
        let fill = |o: usize, updates: &mut Vec<(usize, [u8; 3])>| {
            let (x, y) = (o % w, o / w);
            let mut sum = [0u32; 3];
            let mut n = 0u32;
            let mut add = |q: usize| {
                if filled[q] {
                    for k in 0..3 {
                        sum[k] += rgba[q * 4 + k] as u32;
                    }
                    n += 1;
                }
            };
            if x > 0 {
                add(o - 1);
            }
            if x + 1 < w {
                add(o + 1);
            }
            if y > 0 {
                add(o - w);
            }
            if y + 1 < h {
                add(o + w);
            }
            if n > 0 {
                updates.push((o, sum.map(|s| ((s + n / 2) / n) as u8)));
            }
        };
        if pass == 0 {
            for o in (0..w * h).filter(|&o| !filled[o]) {
                fill(o, &mut updates);
            }
        } else {
            for &o in &frontier {
                queued[o] = false;
                if !filled[o] {
                    fill(o, &mut updates);
                }
            }
        }
        for &(o, c) in &updates {
            rgba[o * 4..o * 4 + 3].copy_from_slice(&c);
            filled[o] = true;
        }
        if pass + 1 == TEXTURE_DILATE_PX {
            break;
        }
        frontier.clear();
        for &(o, _) in &updates {
            let (x, y) = (o % w, o / w);
            let near = [
                (x > 0).then(|| o - 1),
                (x + 1 < w).then(|| o + 1),
                (y > 0).then(|| o - w),
                (y + 1 < h).then(|| o + w),
            ];
            for q in near.into_iter().flatten() {
                if !filled[q] && !std::mem::replace(&mut queued[q], true) {
                    frontier.push(q);
                }
            }
        }
    }
}

/// Encodes a capture texture for a pack (issue 15): BC1, with punch-through alpha in
/// the blocks where coverage is partial (format version 4: uncovered texels decode as
/// transparent black, colours premultiplied by coverage), and returns it
/// with the world → texture matrix it is to be sampled with. Block textures are padded
/// to multiples of 4 by replicating the last column and row; the matrix's `s` and `t`
/// rows are scaled by `width / padded_width` and `height / padded_height`, so texture
/// coordinate 0…1 of the capture becomes 0…w/pw of the padded texture and every world
/// point samples the texel it sampled before. (Beyond the capture's rectangle the
/// player now reads the replicated edge instead of "no data"; the edge texels of a
/// capture are its padding, alpha 0, so that reads as "no data" too, except for the
/// 1 × 1 texture of a sub-pixel object, opaque by design.)
pub fn pack_texture(
    texture: &ProjectedTexture,
    memo: &crate::capture_memo::CaptureMemo,
) -> Result<(format::pack::Texture, [f32; 16]), String> {
    let (w, h, rgba) = (texture.width, texture.height, &texture.rgba);
    let t = memo.encoded(w, h, rgba, || {
        format::pack::Texture::from_rgba8_bc1_coverage(w, h, rgba)
    })?;
    let sx = texture.width as f32 / t.width as f32;
    let sy = texture.height as f32 / t.height as f32;
    let scale = Mat4::from_diagonal(Vec4::new(sx, sy, 1.0, 1.0));
    Ok((
        format::pack::Texture::clone(&t),
        matrix_array(&(scale * texture.matrix)),
    ))
}

/// The column-major matrix as stored in a pack.
pub fn matrix_array(m: &Mat4) -> [f32; 16] {
    m.to_cols_array()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain definition of [`dilate`]: every pass scans every texel.
    fn dilate_by_scan(rgba: &mut [u8], filled: &mut [bool], w: usize, h: usize) {
        for _ in 0..TEXTURE_DILATE_PX {
            let before = filled.to_vec();
            for y in 0..h {
                for x in 0..w {
                    let o = y * w + x;
                    if before[o] {
                        continue;
                    }
                    let (mut sum, mut n) = ([0u32; 3], 0u32);
                    let near = [
                        (x > 0).then(|| o - 1),
                        (x + 1 < w).then(|| o + 1),
                        (y > 0).then(|| o - w),
                        (y + 1 < h).then(|| o + w),
                    ];
                    for q in near.into_iter().flatten().filter(|&q| before[q]) {
                        for k in 0..3 {
                            sum[k] += rgba[q * 4 + k] as u32;
                        }
                        n += 1;
                    }
                    if n > 0 {
                        for k in 0..3 {
                            rgba[o * 4 + k] = (sum[k] + n / 2).checked_div(n).unwrap_or(0) as u8;
                        }
                        filled[o] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn dilate_equals_the_full_scan() {
        let mut seed = 12345u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        for (w, h) in [(1, 1), (1, 7), (9, 1), (13, 11), (40, 33)] {
            for density in [0, 3, 20, 60, 100] {
                let filled: Vec<bool> = (0..w * h).map(|_| next() % 100 < density).collect();
                let rgba: Vec<u8> = (0..w * h * 4).map(|_| next() as u8).collect();
                let (mut a, mut fa) = (rgba.clone(), filled.clone());
                let (mut b, mut fb) = (rgba, filled);
                dilate(&mut a, &mut fa, w, h);
                dilate_by_scan(&mut b, &mut fb, w, h);
                assert_eq!((a, fa), (b, fb), "{w} × {h}, {density} % filled");
            }
        }
    }
}
