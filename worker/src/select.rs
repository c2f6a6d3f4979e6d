//! Objective selection of representations (paper 004, Jehaes et al., §3.2–3.3;
//! DESIGN.md "Representations"; issue 16): instead of a distance rule, each outside
//! object (or cluster) gets the cheapest candidate representation whose image
//! quality, measured against the original, meets the manifest's floor
//! (`bake.quality`) from every sample viewpoint of the region it serves.
//!
//! - **Candidates**: Culled when the object covers less than one pixel from the
//!   whole region ([`subpixel_from_region`]); layered impostors ([`crate::impostor`],
//!   paper 001) at half and full capture resolution (004 §3.2–3.3: the image-based
//!   representation at the lowest resolution that meets the target); the mesh proxy
//!   the paper's algorithm derives (SvMesh / Cluster / MvMesh, 000 §3.1), which is
//!   kept when nothing cheaper passes (004 §3.3: "polygonal rendering is used for
//!   that object"), and the same proxy derived again under a looser deviation bound
//!   ([`COARSER_BOUND_FACTORS`] × `bake.max_deviation_px`: 004's polygonal
//!   representation at more than one resolution; none without a bound).
//! - **Cost** ([`cost`]): what a proxy adds to a frame and to a pack, in triangle
//!   equivalents: `triangles + texels / TEXELS_PER_TRIANGLE + DRAW_CALL_COST` per
//!   draw call. A triangle of a textured proxy costs a vertex fetch and transform
//!   and 12 index bytes; [`TEXELS_PER_TRIANGLE`] = 64 texels (256 bytes of RGBA8,
//!   32 of BC1) are counted as one triangle, so a texture cannot grow without
//!   bound to save a few triangles; every proxy is one draw call
//!   ([`DRAW_CALL_COST`] = 16), which only matters against culling. The walk's
//!   figure of merit is triangles per frame, which the triangle term dominates.
//! - **Sample viewpoints** ([`sample_viewpoints`], K = 20): the 12 corners of the
//!   region's prism (both eye heights), the centres of its 6 side faces (mid
//!   height) and the hexagon's centre at both eye heights. 004 §3.2 samples the
//!   viewing sphere around an object; our viewer is confined to the region, so the
//!   region's extreme points are where a candidate departs most from its capture.
//! - **Metric**: from each viewpoint both the original and the candidate are drawn
//!   alone by the CPU rasterizer through a tight frustum around the object at
//!   [`SUPERSAMPLE`]² samples per pixel of the output resolution (`image_res` per
//!   60°), box-filtered in linear light (anti-aliased, DESIGN.md "Measuring quality
//!   honestly" — without it a quarter-pixel shift of a silhouette reads as sky
//!   against object and swamps every other error), and compared over the object's
//!   own pixels (where either image has a covered sample): PSNR on luminance
//!   ([`format::metrics`]) and SSIM over the windows centred on those pixels. A
//!   frame holds at most [`MAX_MEASURED_PIXELS`] output pixels (one 1024² screen):
//!   an object that would cover more from a viewpoint (a near one, seen from the
//!   region's corner) is measured at the resolution that frames it in one screen,
//!   which is as many pixels as a viewer can see of it at once. Before, such a
//!   frame took up to 4096² samples × 16 bytes for the original and as much for
//!   the candidate, per thread: the check was most of a park bake's peak memory. A
//!   measurement's `passed` says whether its PSNR of the squared errors pooled over
//!   the views and its mean SSIM reach the floor; which candidate is kept is
//!   decided per view ("Acceptance" below), and the worst view's figures are
//!   reported.
//! - **The check of every bake** (issue 16 item 3, [`check_viewpoints`]): without
//!   `bake.quality`, and for a mesh proxy the selection kept without measuring it
//!   (no cheaper candidate), the mesh is measured the same way from the
//!   [`CHECK_VIEWS`] sample viewpoints farthest from its capture eye, for the
//!   report's per-cell worst view and error histogram; nothing is chosen.
//! - **Acceptance.** The paper's mesh proxy is measured first, in every view. Its
//!   own figures on this metric are often below an absolute floor (on the demo,
//!   object-pixel PSNR of 15–33 dB: the paper allows T_s = 5 px of
//!   self-occlusion error), so in each view the threshold of a cheaper candidate
//!   is `min(floor, the mesh's figure in that view)`, per metric (PSNR, SSIM): a
//!   candidate is kept when, from every sample viewpoint, it reaches the
//!   manifest's floor or is no worse than the paper's own representation
//!   ([`select_among`]). Views are measured farthest from the capture eye first
//!   (where image-based candidates are worst) and a candidate is dropped at its
//!   first failing view, so a rejection costs about one view. The mesh itself is
//!   always acceptable (004 §3.3: polygonal rendering when nothing image-based
//!   meets the target); its measurement is what the bake's quality report shows.

use crate::capture::items_aabb;
use crate::grid::Prism;
use crate::impostor::{composite_impostors, ImpostorDraw, LayeredImpostor};
use crate::raster::{
    render, render_with, Capture, CullMode, DrawItem, ProjectiveTextures, Shading, View,
    BACKGROUND_ID,
};
use format::manifest::QualityFloor;
use format::metrics::{capped_psnr_of_mse, luminance, masked_ssim_y};
use glam::Vec3;

/// The coarser mesh candidates: the proxy derived again with the deviation bound
/// (`bake.max_deviation_px`) multiplied by these (module docs, "Candidates").
pub const COARSER_BOUND_FACTORS: [f32; 2] = [2.0, 4.0];

/// Texels counted as one triangle in [`cost`] (module docs).
pub const TEXELS_PER_TRIANGLE: u64 = 64;
/// Triangle equivalents of one draw call in [`cost`] (module docs).
pub const DRAW_CALL_COST: u64 = 16;

/// Measurement frames are rendered this many times wider and higher than the
/// output resolution and box-filtered in linear light before comparing
/// (DESIGN.md "Measuring quality honestly": against anti-aliased references).
pub const SUPERSAMPLE: u32 = 2;

/// Largest measurement frame in output pixels (before [`SUPERSAMPLE`]): one
/// 1024 × 1024 screen. An object that would cover more from a sample viewpoint
/// is measured at the resolution that frames it in that many pixels (module docs,
/// "Metric").
pub const MAX_MEASURED_PIXELS: u64 = 1024 * 1024;

/// A candidate's cost in triangle equivalents (module docs).
pub fn cost(triangles: u64, texels: u64, draw_calls: u64) -> u64 {
    triangles + texels.div_ceil(TEXELS_PER_TRIANGLE) + DRAW_CALL_COST * draw_calls
}

/// The K = 20 sample viewpoints of `prism` (module docs), in a fixed order.
pub fn sample_viewpoints(prism: &Prism) -> Vec<Vec3> {
    let corners = prism.corners();
    let mut eyes: Vec<Vec3> = corners.to_vec();
    for face in prism.side_faces() {
        eyes.push(0.25 * (face[0] + face[1] + face[2] + face[3]));
    }
    let c = prism.centre3();
    eyes.push(Vec3::new(c.x, prism.min_y, c.z));
    eyes.push(Vec3::new(c.x, prism.max_y, c.z));
    eyes
}

/// Sample viewpoints of the quality check every bake runs (issue 16 item 3;
/// [`check_viewpoints`]).
pub const CHECK_VIEWS: usize = 1;

/// The [`CHECK_VIEWS`] sample viewpoints of `prism` farthest from `capture_eye`:
/// where a proxy departs most from its capture, so the check's worst view is the
/// selection's (farthest-first order, ties by index).
pub fn check_viewpoints(prism: &Prism, capture_eye: Vec3) -> Vec<Vec3> {
    let eyes = sample_viewpoints(prism);
    farthest_first(&eyes, capture_eye)
        .into_iter()
        .take(CHECK_VIEWS)
        .map(|k| eyes[k])
        .collect()
}

/// Whether the box `[lo, hi]` subtends less than one pixel (of `image_res` per 60°)
/// from every point of `prism`: its bounding sphere seen from the prism point
/// nearest its centre, minus the radius (conservative: never smaller than the true
/// nearest distance).
pub fn subpixel_from_region(lo: Vec3, hi: Vec3, prism: &Prism, image_res: u32) -> bool {
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let nearest = prism.closest_point(centre).distance(centre) - radius;
    if nearest <= 0.0 {
        return false;
    }
    let pixel = std::f32::consts::FRAC_PI_3 / image_res.max(1) as f32;
    2.0 * (radius / nearest).atan() < pixel
}

/// Image quality of a candidate over the sample views it was measured in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measured {
    /// Smallest PSNR(Y) over the object's pixels of a measured view (capped).
    pub worst_psnr_db: f64,
    /// Smallest object-pixel SSIM of a measured view.
    pub worst_ssim: f64,
    /// PSNR(Y) of the squared errors pooled over every measured view's object
    /// pixels (capped): the region-wide quality the acceptance uses.
    pub pooled_psnr_db: f64,
    /// Mean object-pixel SSIM over the measured views.
    pub mean_ssim: f64,
    /// Views rendered (fewer than K when it failed early).
    pub views: u32,
    /// Met the thresholds ([`Thresholds`]).
    pub passed: bool,
    /// Histogram of |ΔY| over the object's pixels of every measured view, bins of
    /// 8 levels (the last bin: ≥ 56).
    pub error_histogram: [u64; 8],
}

impl Measured {
    /// The job record's form ([`format::schema::job::ProxyQuality`]).
    pub fn to_report(&self) -> format::schema::job::ProxyQuality {
        format::schema::job::ProxyQuality {
            worst_psnr_db: self.worst_psnr_db,
            worst_ssim: self.worst_ssim,
            pooled_psnr_db: self.pooled_psnr_db,
            mean_ssim: self.mean_ssim,
            views: self.views,
            passed: self.passed,
            error_histogram: self.error_histogram,
        }
    }

    /// Back from the job record's form.
    pub fn from_report(q: &format::schema::job::ProxyQuality) -> Measured {
        Measured {
            worst_psnr_db: q.worst_psnr_db,
            worst_ssim: q.worst_ssim,
            pooled_psnr_db: q.pooled_psnr_db,
            mean_ssim: q.mean_ssim,
            views: q.views,
            passed: q.passed,
            error_histogram: q.error_histogram,
        }
    }

    /// Before any view: capped PSNR, SSIM 1, passed.
    fn unmeasured() -> Measured {
        Measured {
            worst_psnr_db: format::metrics::PSNR_CAP,
            worst_ssim: 1.0,
            pooled_psnr_db: format::metrics::PSNR_CAP,
            mean_ssim: 1.0,
            views: 0,
            passed: true,
            error_histogram: [0; 8],
        }
    }
}

/// How a candidate is drawn for measuring.
pub enum Candidate<'a> {
    /// A layered impostor.
    Impostor(&'a LayeredImpostor),
    /// Simplified meshes with projective textures (`items`' object ids index
    /// `textures.by_object`).
    Mesh {
        items: &'a [DrawItem<'a>],
        textures: &'a ProjectiveTextures,
    },
}

/// The original's renders from the sample viewpoints, farthest from `capture_eye`
/// first (ties by index: deterministic); viewpoints from which the object's box
/// cannot be framed (inside it) are left out.
pub fn references(
    originals: &[DrawItem],
    eyes: &[Vec3],
    capture_eye: Vec3,
    image_res: u32,
) -> Vec<(Vec3, Reference)> {
    let Some((lo, hi)) = items_aabb(originals) else {
        return Vec::new();
    };
    farthest_first(eyes, capture_eye)
        .into_iter()
        .filter_map(|k| {
            let view = sample_view(eyes[k], lo, hi, image_res)?;
            let image = Filtered::of(&render(&view, originals, CullMode::Back));
            Some((eyes[k], Reference { view, image }))
        })
        .collect()
}

/// The original drawn from one sample viewpoint: the supersampled view it was
/// drawn through and its box-filtered image (the full-resolution capture is not
/// kept: at most one is alive per thread).
#[derive(Clone, Debug)]
pub struct Reference {
    pub view: View,
    pub image: Filtered,
}

/// A capture box-filtered [`SUPERSAMPLE`]² in linear light ([`box_filter`]): the
/// output-resolution image a measurement compares.
#[derive(Clone, Debug, PartialEq)]
pub struct Filtered {
    pub width: usize,
    pub height: usize,
    /// sRGB8 pixels.
    pub pixels: Vec<[u8; 4]>,
    /// Whether any sample of the pixel was covered by an object.
    pub covered: Vec<bool>,
}

impl Filtered {
    pub fn of(c: &Capture) -> Filtered {
        let (width, height, pixels, covered) = box_filter(c, SUPERSAMPLE);
        Filtered {
            width,
            height,
            pixels,
            covered,
        }
    }
}

/// The indices of `eyes`, farthest from `capture_eye` first (ties by index:
/// deterministic).
fn farthest_first(eyes: &[Vec3], capture_eye: Vec3) -> Vec<usize> {
    let mut order: Vec<usize> = (0..eyes.len()).collect();
    order.sort_by(|&a, &b| {
        let (da, db) = (
            eyes[a].distance_squared(capture_eye),
            eyes[b].distance_squared(capture_eye),
        );
        db.total_cmp(&da).then(a.cmp(&b))
    });
    order
}

/// The supersampled view from `eye` framing the box `lo`..`hi`, at most
/// [`MAX_MEASURED_PIXELS`] output pixels (module docs, "Metric"); `None` when it
/// cannot be framed (the eye inside it).
pub fn sample_view(eye: Vec3, lo: Vec3, hi: Vec3, image_res: u32) -> Option<View> {
    let cap = MAX_MEASURED_PIXELS * u64::from(SUPERSAMPLE * SUPERSAMPLE);
    let mut res = image_res.max(1);
    loop {
        let view = View::tight_around(eye, lo, hi, res * SUPERSAMPLE).ok()?;
        let samples = view.width as u64 * view.height as u64;
        if samples <= cap || res == 1 {
            return Some(view);
        }
        // The side scales with the resolution (plus one for the rounding up).
        let scale = (cap as f64 / samples as f64).sqrt();
        res = ((f64::from(res) * scale).floor() as u32).clamp(1, res - 1);
    }
}

/// The thresholds a candidate must reach in every view (PSNR dB, SSIM).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    pub psnr_db: f64,
    pub ssim: f64,
}

impl Thresholds {
    /// The floor, lowered to what the paper's mesh proxy measured where that is
    /// less (module docs, "Acceptance").
    pub fn for_candidates(floor: &QualityFloor, mesh: &Measured) -> Thresholds {
        Thresholds {
            psnr_db: floor.min_psnr_db.min(mesh.pooled_psnr_db),
            ssim: floor.min_ssim.min(mesh.mean_ssim),
        }
    }
}

/// Measures `candidate` against the original's `references` in every view; it
/// passes when its pooled PSNR and mean SSIM reach `thresholds` (module docs).
pub fn measure_against(
    references: &[(Vec3, Reference)],
    candidate: &Candidate,
    thresholds: &Thresholds,
) -> Measured {
    let mut m = Measured::unmeasured();
    let (mut sse, mut pixels, mut ssim_sum) = (0.0f64, 0usize, 0.0f64);
    for (eye, reference) in references {
        let frame = Filtered::of(&draw_candidate(&reference.view, candidate, *eye));
        let c = compare_filtered(&reference.image, &frame, &mut m.error_histogram);
        add_view(&mut m, &c, (&mut sse, &mut pixels, &mut ssim_sum));
    }
    m.passed = m.pooled_psnr_db >= thresholds.psnr_db && m.mean_ssim >= thresholds.ssim;
    m
}

/// [`references`] then [`measure_against`] with the floor as thresholds.
pub fn measure(
    originals: &[DrawItem],
    candidate: &Candidate,
    eyes: &[Vec3],
    capture_eye: Vec3,
    image_res: u32,
    floor: &QualityFloor,
) -> Measured {
    let refs = references(originals, eyes, capture_eye, image_res);
    let t = Thresholds {
        psnr_db: floor.min_psnr_db,
        ssim: floor.min_ssim,
    };
    measure_against(&refs, candidate, &t)
}

/// The objective selection of one object (module docs, "Acceptance"): `mesh` (the
/// paper's proxy) and the cheaper `candidates` (cheapest first) are measured
/// together, view by view, farthest from `capture_eye` first; a candidate is
/// dropped at the first view where its PSNR or SSIM falls below `min(floor, the
/// mesh's in that view)`, and measuring stops when none is left. Returns the
/// mesh's measurement over the views rendered, and the cheapest candidate that
/// met every view with its measurement. With no candidate nothing is rendered.
pub fn select_among(
    originals: &[DrawItem],
    mesh: &Candidate,
    candidates: &[Candidate],
    eyes: &[Vec3],
    capture_eye: Vec3,
    image_res: u32,
    floor: &QualityFloor,
) -> (Measured, Option<(usize, Measured)>) {
    let fresh = Measured::unmeasured;
    let mut mesh_m = fresh();
    if candidates.is_empty() {
        mesh_m.views = 0;
        return (mesh_m, None);
    }
    let Some((lo, hi)) = items_aabb(originals) else {
        return (mesh_m, None);
    };
    let mut alive: Vec<Option<(Measured, f64, usize, f64)>> = candidates
        .iter()
        .map(|_| Some((fresh(), 0.0, 0, 0.0)))
        .collect();
    let (mut m_sse, mut m_px, mut m_ssim) = (0.0f64, 0usize, 0.0f64);
    for k in farthest_first(eyes, capture_eye) {
        if alive.iter().all(Option::is_none) {
            break;
        }
        let Some(view) = sample_view(eyes[k], lo, hi, image_res) else {
            continue;
        };
        let reference = Filtered::of(&render(&view, originals, CullMode::Back));
        let frame = Filtered::of(&draw_candidate(&view, mesh, eyes[k]));
        let c = compare_filtered(&reference, &frame, &mut mesh_m.error_histogram);
        add_view(&mut mesh_m, &c, (&mut m_sse, &mut m_px, &mut m_ssim));
        let psnr_needed = floor.min_psnr_db.min(c.psnr_db);
        let ssim_needed = floor.min_ssim.min(c.ssim);
        for (cand, slot) in candidates.iter().zip(alive.iter_mut()) {
            let Some((m, sse, px, ssim_sum)) = slot else {
                continue;
            };
            let f = Filtered::of(&draw_candidate(&view, cand, eyes[k]));
            let cc = compare_filtered(&reference, &f, &mut m.error_histogram);
            add_view(m, &cc, (sse, px, ssim_sum));
            if cc.psnr_db < psnr_needed || cc.ssim < ssim_needed {
                *slot = None;
            }
        }
    }
    mesh_m.passed =
        mesh_m.pooled_psnr_db >= floor.min_psnr_db && mesh_m.mean_ssim >= floor.min_ssim;
    let winner = alive
        .into_iter()
        .enumerate()
        .find_map(|(i, a)| a.map(|(m, ..)| (i, m)));
    (mesh_m, winner)
}

/// Adds one view's comparison to a measurement (pooled PSNR and mean SSIM so far).
fn add_view(m: &mut Measured, c: &Compared, (sse, px, ssim_sum): (&mut f64, &mut usize, &mut f64)) {
    m.views += 1;
    m.worst_psnr_db = m.worst_psnr_db.min(c.psnr_db);
    m.worst_ssim = m.worst_ssim.min(c.ssim);
    *sse += c.sq_error;
    *px += c.pixels;
    *ssim_sum += c.ssim;
    if *px > 0 {
        m.pooled_psnr_db = capped_psnr_of_mse(*sse / *px as f64);
    }
    m.mean_ssim = *ssim_sum / m.views as f64;
}

/// Draws the candidate alone from `view` (viewer at `eye`).
pub fn draw_candidate(view: &View, candidate: &Candidate, eye: Vec3) -> Capture {
    match candidate {
        Candidate::Impostor(imp) => {
            let mut frame = render(view, &[], CullMode::Back);
            composite_impostors(
                &mut frame,
                &[ImpostorDraw {
                    texture: &imp.texture,
                    layers: &imp.layers,
                    object_id: 0,
                }],
            );
            frame
        }
        Candidate::Mesh { items, textures } => {
            let t = ProjectiveTextures {
                viewer: eye,
                by_object: textures.by_object.clone(),
            };
            render_with(view, items, CullMode::Back, Shading::Projective(&t))
        }
    }
}

/// One view's comparison over the object pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compared {
    pub psnr_db: f64,
    pub ssim: f64,
    /// Σ ΔY² and the object pixels it is over.
    pub sq_error: f64,
    pub pixels: usize,
}

/// PSNR(Y) and SSIM over the object pixels of a reference / candidate pair (where
/// either is not background); identical or empty → the caps. Adds |ΔY| of those
/// pixels to `histogram`.
pub fn compare(reference: &Capture, frame: &Capture, histogram: &mut [u64; 8]) -> Compared {
    compare_filtered(&Filtered::of(reference), &Filtered::of(frame), histogram)
}

/// [`compare`] of two images already box-filtered (of the same view).
pub fn compare_filtered(
    reference: &Filtered,
    frame: &Filtered,
    histogram: &mut [u64; 8],
) -> Compared {
    let (w, h) = (reference.width, reference.height);
    let (ref_px, frame_px) = (&reference.pixels, &frame.pixels);
    let mask: Vec<bool> = reference
        .covered
        .iter()
        .zip(&frame.covered)
        .map(|(&a, &b)| a || b)
        .collect();
    let (mut sum, mut n) = (0.0f64, 0usize);
    for ((a, b), &m) in ref_px.iter().zip(frame_px.iter()).zip(&mask) {
        if m {
            let d = luminance(*a) - luminance(*b);
            sum += d * d;
            n += 1;
            histogram[((d.abs() / 8.0) as usize).min(7)] += 1;
        }
    }
    if n == 0 {
        return Compared {
            psnr_db: format::metrics::PSNR_CAP,
            ssim: 1.0,
            sq_error: 0.0,
            pixels: 0,
        };
    }
    let psnr = capped_psnr_of_mse(sum / n as f64);
    let flat = |c: &[[u8; 4]]| -> Vec<u8> { c.iter().flatten().copied().collect() };
    let ssim = masked_ssim_y(&flat(ref_px), &flat(frame_px), w, h, &mask).unwrap_or(1.0);
    Compared {
        psnr_db: psnr,
        ssim,
        sq_error: sum,
        pixels: n,
    }
}

/// The capture box-filtered `f × f` in linear light (partial blocks at the right and
/// bottom edges average what they have): width, height, sRGB8 pixels, and per pixel
/// whether any of its samples was covered.
pub fn box_filter(c: &Capture, f: u32) -> (usize, usize, Vec<[u8; 4]>, Vec<bool>) {
    let (w, h) = (c.view.width as usize, c.view.height as usize);
    let f = f.max(1) as usize;
    let (ow, oh) = (w.div_ceil(f), h.div_ceil(f));
    let mut px = Vec::with_capacity(ow * oh);
    let mut cov = Vec::with_capacity(ow * oh);
    for oy in 0..oh {
        for ox in 0..ow {
            let (ys, xs) = (oy * f..((oy + 1) * f).min(h), ox * f..((ox + 1) * f).min(w));
            let mut covered = false;
            let first = c.color[ys.start * w + xs.start];
            let mut uniform = true;
            for y in ys.clone() {
                for q in y * w + xs.start..y * w + xs.end {
                    covered |= c.object_id[q] != BACKGROUND_ID;
                    uniform &= c.color[q][..3] == first[..3];
                }
            }
            if uniform {
                // Samples of one colour (the sky, flat shading) average to it:
                // sRGB8 → linear → sRGB8 gives every byte back (format::srgb).
                px.push([first[0], first[1], first[2], 255]);
            } else {
                let mut sum = Vec3::ZERO;
                let mut n = 0.0f32;
                for y in ys {
                    for q in y * w + xs.start..y * w + xs.end {
                        sum += format::srgb::srgb8_to_linear(c.color[q]);
                        n += 1.0;
                    }
                }
                px.push(format::srgb::linear_to_srgb8(sum / n));
            }
            cov.push(covered);
        }
    }
    (ow, oh, px, cov)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `box_filter` copies a block of one colour instead of averaging it: the same
    /// bytes as the average for every byte and every block size it meets (1 to 4
    /// samples at `SUPERSAMPLE` = 2, partial blocks included).
    #[test]
    fn a_uniform_block_averages_to_its_own_colour() {
        for c in 0..=255u8 {
            let l = format::srgb::srgb8_to_linear([c, c, c, 255]);
            for n in 1..=(SUPERSAMPLE * SUPERSAMPLE) {
                let mut sum = Vec3::ZERO;
                for _ in 0..n {
                    sum += l;
                }
                assert_eq!(
                    format::srgb::linear_to_srgb8(sum / n as f32),
                    [c, c, c, 255],
                    "byte {c}, {n} samples"
                );
            }
        }
    }
}
