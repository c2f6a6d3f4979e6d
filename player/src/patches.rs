//! Run-time patch selection for the objects a cell draws as originals (issue 17):
//! per instance and frame, the union of the nearest spherical samples' patch
//! bitfields (paper 002 §3.3) and the per-patch normal-cone back-face test (003
//! §4.1; Zhang & Hoff's normal masks at patch granularity), both from
//! [`format::patch_visibility::select_patches`], turn into a few index ranges of the
//! model's patch-ordered index buffer.
//!
//! Switches for measurements (environment, read once per process):
//! `HEXBAKE_PATCH_BITFIELDS=0` turns the bitfields off, `HEXBAKE_PATCH_BACKFACE=0` the
//! back-face test; with both off the originals are drawn whole as before.

use crate::gpu::{DrawList, InstanceRaw, PatchedDraw};
use format::pack::BasePack;
use format::patch_visibility::{
    select_patches, ModelPatchView, PatchBounds, PatchTests, SamplingSphere,
};
use glam::{Mat4, Vec3};

/// Which tests the environment leaves on (both unless set to `0`).
pub fn tests_from_env() -> PatchTests {
    let on = |name: &str| std::env::var(name).map_or(true, |v| v.trim() != "0");
    PatchTests {
        bitfields: on("HEXBAKE_PATCH_BITFIELDS"),
        backface: on("HEXBAKE_PATCH_BACKFACE"),
    }
}

/// One model's patch data in the form the per-frame test wants.
pub struct ModelRuntime {
    centre: Vec3,
    radius: f32,
    bounds: Vec<PatchBounds>,
    samples: Vec<u32>,
    /// Per patch its first index in the patch-ordered index buffer, plus the end.
    pub index_first: Vec<u32>,
}

/// The patch data of a bake (from `base.pack`'s optional sections).
pub struct PatchRuntime {
    sphere: SamplingSphere,
    shells: Vec<f32>,
    words: usize,
    pub models: Vec<ModelRuntime>,
    /// Per instance: world → object transform, and whether it mirrors (then the
    /// back-face test is skipped: the winding flips).
    inverse: Vec<(Mat4, bool)>,
    pub tests: PatchTests,
}

impl PatchRuntime {
    /// `None` when the base pack has no patch data or both tests are off.
    pub fn new(base: &BasePack, tests: PatchTests) -> Option<PatchRuntime> {
        let set = base.patches.as_ref()?;
        if !tests.bitfields && !tests.backface {
            return None;
        }
        let models = set
            .models
            .iter()
            .map(|m| {
                let mut index_first = Vec::with_capacity(m.patches.len() + 1);
                let mut first = 0u32;
                for p in &m.patches {
                    index_first.push(first);
                    first += 3 * p.triangle_count;
                }
                index_first.push(first);
                ModelRuntime {
                    centre: Vec3::from(m.centre),
                    radius: m.radius,
                    bounds: m.patches.iter().map(|p| p.bounds).collect(),
                    samples: m
                        .patches
                        .iter()
                        .flat_map(|p| p.samples.iter().copied())
                        .collect(),
                    index_first,
                }
            })
            .collect();
        let inverse = base
            .instances
            .iter()
            .map(|i| {
                let t = Mat4::from_cols_array(&i.transform);
                (t.inverse(), t.determinant() < 0.0)
            })
            .collect();
        Some(PatchRuntime {
            sphere: SamplingSphere::new(set.sample_level),
            shells: set.shell_radius.clone(),
            words: set.words_per_patch(),
            models,
            inverse,
            tests,
        })
    }

    /// The index ranges of instance `instance` (of model `model`) to draw from `eye`
    /// (world), merged where patches are adjacent; and the triangles they hold.
    pub fn ranges(
        &self,
        model: u32,
        instance: u32,
        eye: Vec3,
        keep: &mut Vec<bool>,
    ) -> Option<(Vec<(u32, u32)>, u64)> {
        let m = self.models.get(model as usize)?;
        let &(inv, mirrored) = self.inverse.get(instance as usize)?;
        let eye_obj = inv.transform_point3(eye);
        let tests = PatchTests {
            backface: self.tests.backface && !mirrored,
            ..self.tests
        };
        let view = ModelPatchView {
            centre: m.centre,
            radius: m.radius,
            patches: &m.bounds,
            samples: &m.samples,
            words: self.words,
        };
        select_patches(&view, &self.sphere, &self.shells, eye_obj, tests, keep);
        let mut ranges: Vec<(u32, u32)> = Vec::new();
        let mut indices = 0u64;
        for (p, &k) in keep.iter().enumerate() {
            if !k {
                continue;
            }
            let (a, b) = (m.index_first[p], m.index_first[p + 1]);
            if a == b {
                continue;
            }
            indices += (b - a) as u64;
            match ranges.last_mut() {
                Some(last) if last.1 == a => last.1 = b,
                _ => ranges.push((a, b)),
            }
        }
        Some((ranges, indices / 3))
    }
}

/// Moves every original of `list` whose model has patch data into
/// `list.patched`, with the ranges its visible patches make from `eye`. Instances
/// with nothing left to draw are dropped.
pub fn apply(
    runtime: &PatchRuntime,
    base: &BasePack,
    ids: &[u32],
    eye: Vec3,
    instances: &[InstanceRaw],
    list: &mut DrawList<'_>,
) {
    let mut keep = Vec::new();
    let mut moved: std::collections::BTreeSet<u32> = std::collections::BTreeSet::new();
    for &i in ids {
        let Some(inst) = base.instances.get(i as usize) else {
            continue;
        };
        let Some((ranges, triangles)) = runtime.ranges(inst.model, i, eye, &mut keep) else {
            continue;
        };
        moved.insert(i);
        if !ranges.is_empty() {
            list.patched.push(PatchedDraw {
                model: inst.model,
                instance: instances[i as usize],
                ranges,
                triangles,
            });
        }
    }
    if moved.is_empty() {
        return;
    }
    // Grouped by model like the full-geometry reference's instanced draws (instances
    // in id order within a model): the same draw order, the same depth ties.
    list.patched.sort_by_key(|p| p.model);
    // Rebuild the grouped originals without the moved instances.
    let mut by_model: std::collections::BTreeMap<u32, Vec<InstanceRaw>> = Default::default();
    for &i in ids {
        if moved.contains(&i) {
            continue;
        }
        if let Some(inst) = base.instances.get(i as usize) {
            by_model
                .entry(inst.model)
                .or_default()
                .push(instances[i as usize]);
        }
    }
    list.originals = by_model.into_iter().collect();
}
