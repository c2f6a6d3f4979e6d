//! Fingerprints (DESIGN.md "Fingerprints"; bevy_asset-style cache keys): a job's
//! fingerprint hashes the pack format version, the bake revision ([`BAKE_REVISION`]),
//! the bake and cell parameters, the
//! content of every model and the instance table it reads, and the cells it bakes.
//! An unchanged fingerprint and a valid pack mean the job is done.
//!
//! Every job reads the whole scene (any object can be a proxy for any cell), so the
//! scene part is shared: `scene_fingerprint` hashes models + instances + ground, and
//! `job_fingerprint` adds the parameters and the job's cell list. Numbers are hashed
//! as their little-endian bytes, in a fixed order, with a domain tag per part.

use crate::manifest::{BakeParams, CellParams};
use crate::pack::FORMAT_VERSION;
use crate::Scene;

pub type Fingerprint = [u8; 32];

/// Revision of the bake's *output* for unchanged inputs, hashed into every job
/// fingerprint. Bump it in the same commit as any change to the worker that changes
/// the bytes a bake writes (an algorithm, a default, the writer's compression), so
/// that `pipeline run` on an old output rebakes instead of keeping stale packs.
/// History: 1 — session 1; 2 — zstd level 6, the one-pixel visibility tolerance;
/// 3 — the MVMesh's l′ also looks from the prism point nearest each edge;
/// 4 — the deviation bound of the edge collapse (`bake.max_deviation_px`);
/// 5 — collapses start from the models' LOD chains (`worker::lod_chain`), a moved
/// carrier stays when within tolerance;
/// 6 — the far field shared by 7-cell groups (`bake.far_field`, worker
/// `far_field.rs`);
/// 7 — capture textures stored as BC1/BC3 (a proxy reused by key from an older
/// pack would keep its lossless texture);
/// 8 — MVMesh textures from neighbouring centres fitted to the cell's need
/// (`worker::capture::fitted_scale`);
/// 9 — objective selection of representations with layered impostors (issue 16,
/// `bake.quality`, worker `select.rs`, `impostor.rs`);
/// 10 — the collapse and the speck tidying run on position-welded vertices, so
/// UV-seamed models simplify as closed meshes (issue 18, `worker::simplify`);
/// 11 — captures stored as BC1 with punch-through alpha (format version 4, issue 15,
/// `Texture::from_rgba8_bc1_coverage`);
/// 12 — coarser mesh candidates in the objective selection, and the quality check of
/// every bake in the job records (issue 16, worker `select.rs`);
/// 13 — with objective selection, objects under a pixel from the whole prism are
/// culled before clustering (issue 16, worker `bake.rs` step 2b);
/// 14 — the vertex depth test of a collapse started from an LOD-chain level looks up
/// the captured (full) mesh's triangle under the pixel, and a vertex on the tight
/// capture's border is in the image (worker `visibility.rs`);
/// 15 — levels of far-field groups, merged layered impostors beyond the first level
/// (issue 27, `bake.far_levels`, worker `far_field.rs`);
/// 16 — the quality measurement frames hold at most one 1024² screen of output
/// pixels (worker `select::MAX_MEASURED_PIXELS`): what `bake.quality` keeps can change;
/// 17 — an object whose footprint overlaps a cell's (or group's) hexagon is drawn as
/// an original whatever its height, and captures of boxes beside the eye turn
/// towards their nearest point (issue 29, worker `bake::draws_as_original`,
/// `view.rs`); glTF scenes keep uniform scales in the instances and group nodes by
/// hierarchy (`load::GltfObjects`).
pub const BAKE_REVISION: u32 = 17;

/// Hex form for file names, logs and reports.
pub fn to_hex(f: &Fingerprint) -> String {
    f.iter().map(|b| format!("{b:02x}")).collect()
}

/// The fingerprint of its [`to_hex`] form (exactly 64 hex digits), else `None`.
pub fn from_hex(text: &str) -> Option<Fingerprint> {
    if text.len() != 64 || !text.is_ascii() {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, b) in out.iter_mut().enumerate() {
        *b = u8::from_str_radix(&text[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

fn f32s(h: &mut blake3::Hasher, values: &[f32]) {
    for v in values {
        h.update(&v.to_le_bytes());
    }
}

/// Models (content hashes, in order), instances (model, transform, tint) and ground.
pub fn scene_fingerprint(scene: &Scene) -> Fingerprint {
    let mut h = blake3::Hasher::new();
    h.update(b"hexbake scene v1\0");
    h.update(&(scene.models.len() as u64).to_le_bytes());
    for m in &scene.models {
        h.update(&m.content_hash);
    }
    h.update(&(scene.instances.len() as u64).to_le_bytes());
    for i in &scene.instances {
        h.update(&i.model.to_le_bytes());
        f32s(&mut h, &i.transform.to_cols_array());
        f32s(&mut h, &i.tint.to_array());
    }
    f32s(&mut h, &scene.ground.min);
    f32s(&mut h, &scene.ground.max);
    *h.finalize().as_bytes()
}

/// Everything that decides a cell's bake except the scene: format version, bake and
/// cell parameters.
pub fn params_fingerprint(bake: &BakeParams, cells: &CellParams) -> Fingerprint {
    let mut h = blake3::Hasher::new();
    h.update(b"hexbake params v1\0");
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&BAKE_REVISION.to_le_bytes());
    // Destructure so a new parameter cannot be forgotten here.
    let BakeParams {
        image_res,
        self_occluding_tolerance_px,
        edge_length_tolerance_px,
        t_c0,
        t_c1,
        clustering,
        occlusion_culling,
        max_deviation_px,
        far_field,
        far_levels,
        merge_level,
        quality,
        // The check changes no pack: switching it does not rebake (a job's record
        // has the figures of the bake that made it).
        quality_check: _,
    } = bake;
    h.update(&image_res.to_le_bytes());
    f32s(
        &mut h,
        &[
            *self_occluding_tolerance_px,
            *edge_length_tolerance_px,
            *t_c0,
            *t_c1,
            *max_deviation_px,
        ],
    );
    h.update(&[
        *clustering as u8,
        *occlusion_culling as u8,
        *far_field as u8,
    ]);
    h.update(&far_levels.to_le_bytes());
    h.update(&merge_level.to_le_bytes());
    // Objective selection (issue 16): absent, or its floor.
    match quality {
        None => h.update(&[0]),
        Some(q) => {
            h.update(&[1]);
            h.update(&q.min_psnr_db.to_le_bytes());
            h.update(&q.min_ssim.to_le_bytes())
        }
    };
    let CellParams {
        cell_size,
        min_eye_height,
        max_eye_height,
    } = cells;
    f32s(&mut h, &[*cell_size, *min_eye_height, *max_eye_height]);
    *h.finalize().as_bytes()
}

/// The fingerprint of the job that bakes `cells` (ascending ids).
pub fn job_fingerprint(scene: &Fingerprint, params: &Fingerprint, cells: &[u32]) -> Fingerprint {
    ids_fingerprint(b"hexbake job v1\0", scene, params, cells)
}

/// The fingerprint of the far-field job that bakes `groups` (ascending ids; issue 13).
pub fn group_job_fingerprint(
    scene: &Fingerprint,
    params: &Fingerprint,
    groups: &[u32],
) -> Fingerprint {
    ids_fingerprint(b"hexbake far-field job v1\0", scene, params, groups)
}

/// A job's fingerprint: its kind's `tag`, the scene and parameter fingerprints, the
/// count of `ids` and each id (u64 and u32, little-endian).
fn ids_fingerprint(
    tag: &[u8],
    scene: &Fingerprint,
    params: &Fingerprint,
    ids: &[u32],
) -> Fingerprint {
    let mut h = blake3::Hasher::new();
    h.update(tag);
    h.update(scene);
    h.update(params);
    h.update(&(ids.len() as u64).to_le_bytes());
    for id in ids {
        h.update(&id.to_le_bytes());
    }
    *h.finalize().as_bytes()
}

/// The fingerprint of a whole build: scene, parameters and every job's fingerprint.
pub fn build_fingerprint(jobs: &[Fingerprint]) -> Fingerprint {
    let mut h = blake3::Hasher::new();
    h.update(b"hexbake build v1\0");
    for j in jobs {
        h.update(j);
    }
    *h.finalize().as_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_changes_the_fingerprint() {
        let cells = CellParams {
            cell_size: 50.0,
            min_eye_height: 4.0,
            max_eye_height: 12.0,
        };
        let base = params_fingerprint(&BakeParams::default(), &cells);
        type Change = fn(&mut BakeParams, &mut CellParams);
        let variants: Vec<Change> = vec![
            |b, _| b.image_res = 512,
            |b, _| b.self_occluding_tolerance_px = 3.0,
            |b, _| b.edge_length_tolerance_px = 6.0,
            |b, _| b.t_c0 = 1e-3,
            |b, _| b.t_c1 = 1e-3,
            |b, _| b.clustering = false,
            |b, _| b.occlusion_culling = true,
            |b, _| b.max_deviation_px = 0.0,
            |b, _| b.far_field = false,
            |b, _| b.far_levels = 1,
            |b, _| b.merge_level = 2,
            |b, _| b.quality = Some(Default::default()),
            |b, _| {
                b.quality = Some(crate::manifest::QualityFloor {
                    min_psnr_db: 35.0,
                    ..Default::default()
                })
            },
            |b, _| {
                b.quality = Some(crate::manifest::QualityFloor {
                    min_ssim: 0.95,
                    ..Default::default()
                })
            },
            |_, c| c.cell_size = 100.0,
            |_, c| c.min_eye_height = 2.0,
            |_, c| c.max_eye_height = 20.0,
        ];
        for (k, change) in variants.iter().enumerate() {
            let (mut b, mut c) = (BakeParams::default(), cells.clone());
            change(&mut b, &mut c);
            assert_ne!(params_fingerprint(&b, &c), base, "variant {k}");
        }
        let s = [7u8; 32];
        assert_ne!(
            job_fingerprint(&s, &base, &[1, 2]),
            job_fingerprint(&s, &base, &[1, 3])
        );
        assert_eq!(
            job_fingerprint(&s, &base, &[1, 2]),
            job_fingerprint(&s, &base, &[1, 2])
        );
    }
}
