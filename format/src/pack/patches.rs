//! Optional `base.pack` sections of per-model patch data (issue 17): the tiling of
//! each model into polygonal patches (paper 002 §3.1), the patch-ID bitfields of the
//! spherical sampling (002 §3.2) and each patch's normal cone for run-time back-face
//! culling (003 §4.1's normal clusters; Zhang & Hoff's normal masks). Per model, not
//! per cell. Byte layouts: format/README.md, "base.pack", sections 0x010B–0x010D.
//! The run-time use of the data lives in [`crate::patch_visibility`].

use super::error::BadValue;
use super::layout::SectionKind;
use super::reader::{pod_vec, PackFile};
use super::writer::{SectionData, TRY_INDICES, TRY_ZSTD};
use crate::patch_visibility::{direction_count, PatchBounds, MAX_SAMPLE_LEVEL, MAX_SHELLS};
use bytemuck::{Pod, Zeroable};

/// The patch data of every model of a base pack.
#[derive(Clone, Debug, PartialEq)]
pub struct PatchSet {
    /// Subdivision level of the sampling sphere (002 §3.2.1).
    pub sample_level: u32,
    /// Shell radii as multiples of each model's bounding radius, increasing.
    pub shell_radius: Vec<f32>,
    /// One per model of the base pack, in model order.
    pub models: Vec<ModelPatches>,
}

impl PatchSet {
    /// Samples per model: directions × shells.
    pub fn sample_count(&self) -> usize {
        direction_count(self.sample_level) * self.shell_radius.len()
    }

    /// u32 words of sample bits per patch.
    pub fn words_per_patch(&self) -> usize {
        self.sample_count().div_ceil(32)
    }
}

/// One model's patches.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelPatches {
    /// Bounding sphere (model space) the sampling sphere is centred on.
    pub centre: [f32; 3],
    pub radius: f32,
    pub patches: Vec<ModelPatch>,
    /// The model's triangle indices grouped by patch (patch 0's first): a permutation
    /// of `0..triangle_count`.
    pub triangle_order: Vec<u32>,
}

/// One patch: its triangles are `triangle_order[first..first + triangle_count]`
/// where `first` is the sum of the earlier patches' counts.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelPatch {
    pub triangle_count: u32,
    pub bounds: PatchBounds,
    /// `words_per_patch` words; bit s (word s / 32, bit s % 32) = seen from sample s,
    /// s = direction + shell · directions.
    pub samples: Vec<u32>,
}

super::pod_records! {
    /// Head of section `patch-table` (32 bytes).
    pub struct PatchHeaderRecord[32] {
        pub sample_level: u32,
        pub shell_count: u32,
        pub shell_radius: [f32; 4],
        pub model_count: u32,
        pub patch_count: u32,
    }

    /// Per model, after the head of `patch-table` (32 bytes).
    pub struct PatchModelRecord[32] {
        pub centre: [f32; 3],
        pub radius: f32,
        pub patch_count: u32,
        pub reserved: [u32; 3],
    }

    /// Per patch, after the model records of `patch-table` (48 bytes).
    pub struct PatchRecord[48] {
        pub triangle_count: u32,
        pub cone_axis: [f32; 3],
        pub cone_cos: f32,
        pub centre: [f32; 3],
        pub offset: f32,
        pub reserved: [u32; 3],
    }
}

fn finite(v: &[f32]) -> bool {
    v.iter()
        .all(|x| x.is_finite() && x.abs() <= crate::manifest::MAX_COORDINATE)
}

/// Checks a patch set against the models' triangle counts; the section and byte
/// offset of the first bad value on failure (the writer refuses, the reader reports).
pub(super) fn check(set: &PatchSet, triangle_counts: &[u32]) -> Result<(), BadValue> {
    let table = SectionKind::PATCH_TABLE;
    if set.sample_level > MAX_SAMPLE_LEVEL {
        return Err(BadValue(
            table,
            0,
            format!("sample level {} above {MAX_SAMPLE_LEVEL}", set.sample_level),
        ));
    }
    let n = set.shell_radius.len();
    let shells_ok = (1..=MAX_SHELLS).contains(&n)
        && set
            .shell_radius
            .iter()
            .all(|r| r.is_finite() && *r >= 1.0 && *r <= 1e6)
        && set.shell_radius.windows(2).all(|w| w[0] < w[1]);
    if !shells_ok {
        return Err(BadValue(
            table,
            4,
            format!(
                "shells {:?}: expected 1 to {MAX_SHELLS} increasing radii in 1..=1e6",
                set.shell_radius
            ),
        ));
    }
    if set.models.len() != triangle_counts.len() {
        return Err(BadValue(
            table,
            24,
            format!(
                "{} models, the model table has {}",
                set.models.len(),
                triangle_counts.len()
            ),
        ));
    }
    let words = set.words_per_patch();
    let mut patch_index = 0usize;
    let mut tri_base = 0usize;
    let patch_base = 32 + 32 * set.models.len();
    for (i, (m, &tris)) in set.models.iter().zip(triangle_counts).enumerate() {
        let rec = (32 + 32 * i) as u64;
        if !(finite(&m.centre) && m.radius.is_finite() && m.radius > 0.0 && m.radius <= 1e7) {
            return Err(BadValue(
                table,
                rec,
                format!(
                    "model {i}: bounding sphere {:?} r {} is not finite and positive",
                    m.centre, m.radius
                ),
            ));
        }
        // The triangle order is a permutation of the model's triangles.
        if m.triangle_order.len() != tris as usize {
            return Err(BadValue(
                SectionKind::PATCH_TRIANGLES,
                (tri_base * 4) as u64,
                format!(
                    "model {i}: {} triangles in patch order, the model has {tris}",
                    m.triangle_order.len()
                ),
            ));
        }
        let mut seen = vec![false; tris as usize];
        for (k, &t) in m.triangle_order.iter().enumerate() {
            match seen.get_mut(t as usize) {
                Some(s) if !*s => *s = true,
                _ => {
                    return Err(BadValue(
                        SectionKind::PATCH_TRIANGLES,
                        ((tri_base + k) * 4) as u64,
                        format!("model {i}: triangle {t} out of range or listed twice"),
                    ))
                }
            }
        }
        let total: u64 = m.patches.iter().map(|p| p.triangle_count as u64).sum();
        if total != tris as u64 {
            return Err(BadValue(
                table,
                rec + 16,
                format!("model {i}: patches hold {total} triangles, the model has {tris}"),
            ));
        }
        for (k, p) in m.patches.iter().enumerate() {
            let off = (patch_base + 48 * (patch_index + k)) as u64;
            let b = &p.bounds;
            let axis_ok =
                finite(&b.cone_axis) && (glam::Vec3::from(b.cone_axis).length() - 1.0).abs() < 1e-3;
            if !(axis_ok && (-1.0..=1.0).contains(&b.cone_cos)) {
                return Err(BadValue(
                    table,
                    off + 4,
                    format!(
                        "model {i} patch {k}: normal cone {:?} cos {} is not a unit axis and a \
                         cosine",
                        b.cone_axis, b.cone_cos
                    ),
                ));
            }
            if !(finite(&b.centre) && b.offset.is_finite()) {
                return Err(BadValue(
                    table,
                    off + 20,
                    format!("model {i} patch {k}: centre or offset is not finite"),
                ));
            }
            if p.samples.len() != words {
                return Err(BadValue(
                    SectionKind::PATCH_SAMPLES,
                    ((patch_index + k) * words * 4) as u64,
                    format!(
                        "model {i} patch {k}: {} words of sample bits, expected {words}",
                        p.samples.len()
                    ),
                ));
            }
            let spare = words * 32 - set.sample_count();
            if spare > 0 && p.samples[words - 1] >> (32 - spare) != 0 {
                return Err(BadValue(
                    SectionKind::PATCH_SAMPLES,
                    ((patch_index + k) * words * 4 + (words - 1) * 4) as u64,
                    format!("model {i} patch {k}: bits set past the last sample"),
                ));
            }
        }
        patch_index += m.patches.len();
        tri_base += tris as usize;
    }
    Ok(())
}

/// The three sections of a checked set.
pub(super) fn sections(set: &PatchSet) -> Vec<SectionData> {
    let mut shell_radius = [0.0f32; 4];
    shell_radius[..set.shell_radius.len()].copy_from_slice(&set.shell_radius);
    let patch_count: usize = set.models.iter().map(|m| m.patches.len()).sum();
    let head = PatchHeaderRecord {
        sample_level: set.sample_level,
        shell_count: set.shell_radius.len() as u32,
        shell_radius,
        model_count: set.models.len() as u32,
        patch_count: patch_count as u32,
    };
    let mut table = bytemuck::bytes_of(&head).to_vec();
    for m in &set.models {
        table.extend_from_slice(bytemuck::bytes_of(&PatchModelRecord {
            centre: m.centre,
            radius: m.radius,
            patch_count: m.patches.len() as u32,
            reserved: [0; 3],
        }));
    }
    let (mut order, mut samples) = (Vec::new(), Vec::new());
    for m in &set.models {
        for p in &m.patches {
            let b = &p.bounds;
            table.extend_from_slice(bytemuck::bytes_of(&PatchRecord {
                triangle_count: p.triangle_count,
                cone_axis: b.cone_axis,
                cone_cos: b.cone_cos,
                centre: b.centre,
                offset: b.offset,
                reserved: [0; 3],
            }));
            samples.extend_from_slice(bytemuck::cast_slice::<u32, u8>(&p.samples));
        }
        order.extend_from_slice(bytemuck::cast_slice::<u32, u8>(&m.triangle_order));
    }
    vec![
        SectionData::new(SectionKind::PATCH_TABLE, table, TRY_ZSTD),
        SectionData::new(SectionKind::PATCH_TRIANGLES, order, TRY_INDICES),
        SectionData::new(SectionKind::PATCH_SAMPLES, samples, TRY_ZSTD),
    ]
}

/// Decodes the sections when `patch-table` is present (`None` when it is absent);
/// the structure is checked here, the values by [`check`].
pub(super) fn decode(pack: &PackFile, model_count: usize) -> Result<Option<PatchSet>, BadValue> {
    // 1. The patch table is optional; when present its 32-byte head is checked.
    let table = SectionKind::PATCH_TABLE;
    if pack.section_info(table).is_none() {
        return Ok(None);
    }
    let io = |kind: SectionKind| move |e: super::PackError| BadValue(kind, 0, e.to_string());
    let bytes = pack.section(table).map_err(io(table))?;
    if bytes.len() < 32 {
        return Err(BadValue(
            table,
            0,
            format!("{} bytes, shorter than the 32-byte head", bytes.len()),
        ));
    }
    let head: PatchHeaderRecord = bytemuck::pod_read_unaligned(&bytes[..32]);
    if head.shell_count as usize > MAX_SHELLS || head.shell_count == 0 {
        return Err(BadValue(
            table,
            4,
            format!("{} shells, expected 1 to {MAX_SHELLS}", head.shell_count),
        ));
    }
    if head.sample_level > MAX_SAMPLE_LEVEL {
        return Err(BadValue(
            table,
            0,
            format!(
                "sample level {} above {MAX_SAMPLE_LEVEL}",
                head.sample_level
            ),
        ));
    }
    if head.model_count as usize != model_count {
        return Err(BadValue(
            table,
            24,
            format!(
                "{} models, the model table has {model_count}",
                head.model_count
            ),
        ));
    }
    // 2. The model and patch records: sizes, counts and reserved fields.
    let expected = (head.model_count as u64) * 32 + (head.patch_count as u64) * 48 + 32;
    if bytes.len() as u64 != expected {
        return Err(BadValue(
            table,
            28,
            format!(
                "{} bytes, {} models and {} patches need {expected}",
                bytes.len(),
                head.model_count,
                head.patch_count
            ),
        ));
    }
    let model_end = 32 + 32 * model_count;
    let models: Vec<PatchModelRecord> =
        pod_vec(&bytes[32..model_end], pack.path(), table).map_err(io(table))?;
    let patches: Vec<PatchRecord> =
        pod_vec(&bytes[model_end..], pack.path(), table).map_err(io(table))?;
    let listed: u64 = models.iter().map(|m| m.patch_count as u64).sum();
    if listed != head.patch_count as u64 {
        return Err(BadValue(
            table,
            28,
            format!(
                "models list {listed} patches, the head says {}",
                head.patch_count
            ),
        ));
    }
    if let Some(i) = models.iter().position(|m| m.reserved != [0; 3]) {
        return Err(BadValue(
            table,
            (32 + 32 * i + 20) as u64,
            format!("model {i}: reserved field is not 0"),
        ));
    }
    if let Some(i) = patches.iter().position(|p| p.reserved != [0; 3]) {
        return Err(BadValue(
            table,
            (model_end + 48 * i + 36) as u64,
            format!("patch {i}: reserved field is not 0"),
        ));
    }
    // 3. The shells and the sampling sphere the bitfields refer to.
    let shell_radius = head.shell_radius[..head.shell_count as usize].to_vec();
    if head.shell_radius[head.shell_count as usize..]
        .iter()
        .any(|&r| r.to_bits() != 0)
    {
        return Err(BadValue(table, 8, "unused shell radius is not 0".into()));
    }
    let mut set = PatchSet {
        sample_level: head.sample_level,
        shell_radius,
        models: Vec::with_capacity(model_count),
    };
    // 4. The triangle order and sample bitfield sections, sized by the records.
    let words = set.words_per_patch();
    let order: Vec<u32> = pack
        .section_vec(SectionKind::PATCH_TRIANGLES)
        .map_err(io(SectionKind::PATCH_TRIANGLES))?;
    let samples: Vec<u32> = pack
        .section_vec(SectionKind::PATCH_SAMPLES)
        .map_err(io(SectionKind::PATCH_SAMPLES))?;
    if samples.len() as u64 != head.patch_count as u64 * words as u64 {
        return Err(BadValue(
            SectionKind::PATCH_SAMPLES,
            0,
            format!(
                "{} words, {} patches of {words} words need {}",
                samples.len(),
                head.patch_count,
                head.patch_count as u64 * words as u64
            ),
        ));
    }
    // 5. Each model's patches: ranges that tile its triangles, bounds and bits.
    let (mut p0, mut t0) = (0usize, 0usize);
    for (i, m) in models.iter().enumerate() {
        let p1 = p0 + m.patch_count as usize;
        let tris: u64 = patches[p0..p1]
            .iter()
            .map(|p| p.triangle_count as u64)
            .sum();
        let t1 = (t0 as u64).saturating_add(tris);
        if t1 > order.len() as u64 {
            return Err(BadValue(
                SectionKind::PATCH_TRIANGLES,
                (t0 * 4) as u64,
                format!(
                    "model {i}: patches hold {tris} triangles, {} are left in patch-triangles",
                    order.len() - t0
                ),
            ));
        }
        let t1 = t1 as usize;
        set.models.push(ModelPatches {
            centre: m.centre,
            radius: m.radius,
            patches: patches[p0..p1]
                .iter()
                .enumerate()
                .map(|(k, p)| ModelPatch {
                    triangle_count: p.triangle_count,
                    bounds: PatchBounds {
                        cone_axis: p.cone_axis,
                        cone_cos: p.cone_cos,
                        centre: p.centre,
                        offset: p.offset,
                    },
                    samples: samples[(p0 + k) * words..(p0 + k + 1) * words].to_vec(),
                })
                .collect(),
            triangle_order: order[t0..t1].to_vec(),
        });
        (p0, t0) = (p1, t1);
    }
    if t0 != order.len() {
        return Err(BadValue(
            SectionKind::PATCH_TRIANGLES,
            (t0 * 4) as u64,
            format!("{} triangle ids past the last patch", order.len() - t0),
        ));
    }
    Ok(Some(set))
}
