//! Merged far field (issue 27; DESIGN.md "Far away, cells share — at every
//! scale"): the objects a group of a merged level serves (`bake.merge_level` and
//! above, default every level; [`crate::far_field::served_instances`]) are drawn as
//! a bounded number of merged layered impostors (paper 001, [`crate::impostor`])
//! instead of one proxy each. DESIGN.md merges "beyond the first level"; merging
//! the 7-cell groups too was chosen by measurement (BENCHMARKS.md "Scale").
//!
//! # Merging: sectors and depth bands
//!
//! Seen from the group centre, the served objects are split by the azimuth of their
//! box centre into [`SECTORS`] sectors of 60° (the cell hexagon's side faces, the
//! capture's angular unit), and each sector, in order of distance, into depth bands:
//! a band grows while 001 §3.3's layer count for its inverse-depth range, viewers up
//! to the group prism's farthest corner and an error of one output pixel stays
//! within [`BAND_LAYERS`] (below [`MERGED_MAX_LAYERS`], the format's 64, so the
//! impostor builder never clamps, and its error bound of one pixel holds; the depth
//! range a band's capture measures is within the boxes' range used here). One band
//! of one sector is one capture (colour + depth code, the members alone) and one
//! impostor of at most `MERGED_MAX_LAYERS` quads, drawn with one draw call: more
//! layers per band mean fewer bands, i.e. fewer draw calls for a few more quads.
//!
//! # Why the count is bounded
//!
//! A merged level's group serves only objects at least
//! [`merged_min_distance`] from its centre, a distance `D`
//! proportional to its prism's size `e`: 1/d over its objects spans at most
//! 1/D = [`MAX_BANDS`] × the inverse-depth span one band of [`BAND_LAYERS`] layers
//! covers at viewer offset `e`, so a sector needs at most `MAX_BANDS` bands,
//! whatever the number of objects in the annulus (up to objects whose box
//! estimate of depth misses the capture's: one more band at most). A group draws
//! at most `SECTORS × (MAX_BANDS + 1)` impostors of at most 64 quads; levels grow
//! as log₇ of the world's cell count.
//!
//! # Error bound
//!
//! Every served object passed the paper's tests for the whole group region (outside
//! its prism, regional back-face, self-occluding error below T_s from the group
//! centre with c = the region's size), as the level-1 groups' objects do. The
//! impostor adds 001's parallax error, at most one output pixel for every viewer in
//! the group prism (`BAND_LAYERS` layers per band), and draws the capture's texels
//! (one texel per output pixel seen from the centre). Objects under a pixel from the
//! whole region are dropped ([`crate::select::subpixel_from_region`]), the one
//! object-dropping rule of every level; nothing is clipped by distance.

use crate::grid::Prism;
use crate::impostor::build_layered_impostor_up_to;
use crate::proxy::BakedProxy;
use crate::raster::DrawItem;
use crate::select::subpixel_from_region;
use format::Scene;

/// Azimuth sectors of a merged level (60° each).
pub const SECTORS: usize = 6;

/// Most layers a merged impostor gets: the format's limit
/// ([`format::pack::MAX_IMPOSTOR_LAYERS`]).
pub const MERGED_MAX_LAYERS: usize = format::pack::MAX_IMPOSTOR_LAYERS;

/// Depth bands per sector the distance rule of a merged level allows
/// ([`merged_min_distance`]).
pub const MAX_BANDS: usize = 2;

/// Most layers a depth band may need (module docs, "Merging"): a margin below
/// [`MERGED_MAX_LAYERS`] for depths the boxes' estimate misses.
pub const BAND_LAYERS: f64 = 48.0;

/// One merged impostor to build: its members, in ascending instance order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Band {
    pub sector: usize,
    pub members: Vec<u32>,
}

/// 001's viewer offset `e` of a group: from its centre, the capture eye, to its
/// prism's farthest corner.
pub fn max_offset(prism: &Prism) -> f32 {
    crate::impostor::max_offset(prism, prism.centre3())
}

/// The nearest an object may be to the centre of a group of a merged level
/// (`bake.merge_level`) to be far for it: `e / (2θ · L · B)`
/// for the prism's largest viewer offset `e`, one output pixel θ, `L` =
/// [`BAND_LAYERS`] layers per band and `B` =
/// [`MAX_BANDS`] bands. From there on, 001's parallax error stays
/// within one pixel with at most `B` depth bands per sector, and since `e` grows by
/// √7 per level, so does this distance: the annuli the merged levels serve are
/// scaled copies of each other ([`crate::far_field`]'s module docs, "Levels").
pub fn merged_min_distance(prism: &Prism, image_res: u32) -> f32 {
    let theta = std::f64::consts::FRAC_PI_3 / f64::from(image_res.max(1));
    let bands = BAND_LAYERS * MAX_BANDS as f64;
    (f64::from(max_offset(prism)) / (2.0 * theta * bands)) as f32
}

/// 001 §3.3's layer count, unclamped, for depths `near..far` (module docs).
fn layers_needed(near: f32, far: f32, offset: f32, image_res: u32) -> f64 {
    let pixel_angle = std::f64::consts::FRAC_PI_3 / f64::from(image_res.max(1));
    let span = (1.0 / f64::from(near.max(1e-6)) - 1.0 / f64::from(far.max(near))).max(0.0);
    f64::from(offset) * span / (2.0 * pixel_angle)
}

/// Splits `served` (instance ids, ascending) into sectors and depth bands seen from
/// the prism's centre (module docs, "Merging"). Objects under a pixel from the whole
/// prism are left out (second value). Deterministic: sectors in order, bands by
/// distance, ties by instance id.
pub fn bands(
    scene: &Scene,
    prism: &Prism,
    served: &[u32],
    image_res: u32,
) -> (Vec<Band>, Vec<u32>) {
    let eye = prism.centre3();
    let offset = max_offset(prism);
    let mut sectors: Vec<Vec<(f32, f32, u32)>> = vec![Vec::new(); SECTORS];
    let mut dropped = Vec::new();
    for &i in served {
        let (lo, hi) = scene.instance_bounds(i as usize);
        if subpixel_from_region(lo, hi, prism, image_res) {
            dropped.push(i);
            continue;
        }
        let mid = 0.5 * (lo + hi) - eye;
        let turn = mid.z.atan2(mid.x).rem_euclid(std::f32::consts::TAU);
        let sector = ((turn / std::f32::consts::TAU * SECTORS as f32) as usize).min(SECTORS - 1);
        // Nearest point of the box, and its farthest corner.
        let near = eye.clamp(lo, hi).distance(eye);
        let far = (eye - lo).abs().max((hi - eye).abs()).length();
        sectors[sector].push((near, far, i));
    }
    let mut out = Vec::new();
    for (sector, mut objects) in sectors.into_iter().enumerate() {
        objects.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
        let mut band: Vec<u32> = Vec::new();
        let (mut near, mut far) = (f32::INFINITY, 0.0f32);
        for (n, f, i) in objects {
            let (nn, ff) = (near.min(n), far.max(f));
            if !band.is_empty() && layers_needed(nn, ff, offset, image_res) > BAND_LAYERS {
                band.sort_unstable();
                out.push(Band {
                    sector,
                    members: std::mem::take(&mut band),
                });
                (near, far) = (n, f);
            } else {
                (near, far) = (nn, ff);
            }
            band.push(i);
        }
        if !band.is_empty() {
            band.sort_unstable();
            out.push(Band {
                sector,
                members: band,
            });
        }
    }
    (out, dropped)
}

/// Builds the merged impostor of one band, captured from the prism's centre at
/// `image_res` for viewers anywhere in the prism; `None` when it covers no pixel.
pub fn merged_impostor(
    scene: &Scene,
    prism: &Prism,
    band: &Band,
    image_res: u32,
    key: crate::proxy::ProxyKey,
) -> Result<Option<BakedProxy>, crate::capture::CaptureError> {
    let items: Vec<DrawItem> = band
        .members
        .iter()
        .map(|&i| DrawItem::instance(scene, i))
        .collect();
    let built = build_layered_impostor_up_to(
        prism.centre3(),
        &items,
        image_res,
        image_res,
        max_offset(prism),
        MERGED_MAX_LAYERS,
    )?;
    Ok(built.map(|imp| BakedProxy::impostor(&band.members, imp, key, None)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use format::{Ground, Instance, Mesh, Model};
    use glam::{Mat4, Vec2, Vec3};
    use proptest::prelude::*;

    fn prism(size: f32) -> Prism {
        Prism {
            centre: Vec2::new(0.0, 0.0),
            cell_size: size,
            min_y: 2.0,
            max_y: 6.0,
        }
    }

    /// Unit cuboids (2 × 4 × 2) at the given (x, z).
    fn scene_at(points: &[(f32, f32)]) -> Scene {
        let model = Model::new(
            "c".into(),
            "test".into(),
            Mesh::cuboid([-1.0, 0.0, -1.0], [1.0, 4.0, 1.0], [200, 200, 200, 255]),
            None,
        );
        Scene {
            models: vec![model],
            instances: points
                .iter()
                .map(|&(x, z)| Instance {
                    model: 0,
                    transform: Mat4::from_translation(Vec3::new(x, 0.0, z)),
                    tint: Vec3::ONE,
                })
                .collect(),
            ground: Ground {
                min: [-1e6, -1e6],
                max: [1e6, 1e6],
            },
            model_bounds: Default::default(),
            instance_labels: Default::default(),
        }
    }

    proptest! {
        /// Objects at least `merged_min_distance` from the centre (what a merged
        /// level serves) fall into at most MAX_BANDS + 1 bands per sector (one more
        /// for the boxes' extent), every object in exactly one band of its own
        /// sector, members ascending; the split is deterministic.
        #[test]
        fn far_objects_make_few_bands_per_sector(
            size in 100.0f32..3000.0,
            polar in proptest::collection::vec((0.0f32..1.0, 1.0f32..40.0), 1..60),
        ) {
            let p = prism(size);
            let image_res = 1024;
            let min = merged_min_distance(&p, image_res);
            let points: Vec<(f32, f32)> = polar
                .iter()
                .map(|&(turn, scale)| {
                    let a = turn * std::f32::consts::TAU;
                    let d = min * scale + 2.0;
                    (d * a.cos(), d * a.sin())
                })
                .collect();
            let scene = scene_at(&points);
            let served: Vec<u32> = (0..points.len() as u32).collect();
            let (bands_a, dropped) = bands(&scene, &p, &served, image_res);
            let (bands_b, _) = bands(&scene, &p, &served, image_res);
            prop_assert_eq!(&bands_a, &bands_b);
            let mut seen = vec![0u32; points.len()];
            for b in &bands_a {
                prop_assert!(b.members.windows(2).all(|w| w[0] < w[1]));
                for &m in &b.members {
                    seen[m as usize] += 1;
                }
            }
            for &d in &dropped {
                seen[d as usize] += 1;
            }
            prop_assert!(seen.iter().all(|&n| n == 1));
            for sector in 0..SECTORS {
                let n = bands_a.iter().filter(|b| b.sector == sector).count();
                prop_assert!(n <= MAX_BANDS + 1, "sector {} has {} bands", sector, n);
            }
        }
    }

    #[test]
    fn layer_need_shrinks_with_distance_and_grows_with_offset() {
        let a = layers_needed(100.0, 200.0, 50.0, 1024);
        assert!(layers_needed(200.0, 400.0, 50.0, 1024) < a);
        assert!(layers_needed(100.0, 200.0, 100.0, 1024) > a);
        // Scale invariance (module docs): everything ×√7 needs the same count.
        let s = 7f32.sqrt();
        let b = layers_needed(100.0 * s, 200.0 * s, 50.0 * s, 1024);
        assert!((a - b).abs() < 1e-6 * a);
    }
}
