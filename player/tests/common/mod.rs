//! Helpers shared by the player's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use format::path::CameraPath;
use player::gpu::{GpuError, Renderer};
use player::run::{Player, RunError};
use std::path::PathBuf;

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `manifests/paths/demo-walk.ron`.
pub fn demo_walk() -> CameraPath {
    CameraPath::load(&repo().join("manifests/paths/demo-walk.ron")).unwrap()
}

/// The keys every `player compare` report has.
pub const COMPARE_KEYS: [&str; 8] = format::schema::compare::REQUIRED_KEYS;

/// Asserts that the JSON object `json` has each of `keys`.
pub fn assert_has_keys<'a>(json: &serde_json::Value, keys: impl IntoIterator<Item = &'a str>) {
    for key in keys {
        assert!(json.get(key).is_some(), "missing {key}");
    }
}

/// A GPU test's skip (through `testkit`: a failure under `HEXBAKE_REQUIRE_GPU=1`)
/// for the adapter error `e`. Only "no adapter" may skip; callers fail on any other
/// renderer error.
#[track_caller]
pub fn skip_no_adapter(e: impl std::fmt::Display) {
    testkit::skip(
        testkit::Need::Gpu,
        format_args!("no graphics adapter ({e}); install mesa-vulkan-drivers for lavapipe"),
    );
}

/// [`Player::open`] of `dir` at `size`, printing the adapter; `None` after
/// [`skip_no_adapter`] when there is no adapter. Any other error fails the test.
#[track_caller]
pub fn open_player(
    dir: &std::path::Path,
    size: (u32, u32),
    options: &player::DrawOptions,
) -> Option<Player> {
    match Player::open(dir, size, options) {
        Ok(p) => {
            eprintln!("adapter: {}", p.renderer.adapter());
            Some(p)
        }
        Err(RunError::Gpu(GpuError::NoAdapter(e))) => {
            skip_no_adapter(e);
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// A `w` × `h` [`Renderer`]; `None` after [`skip_no_adapter`] when there is no
/// adapter. Any other error fails the test.
#[track_caller]
pub fn renderer(w: u32, h: u32) -> Option<Renderer> {
    match Renderer::new(w, h, &player::DrawOptions::default()) {
        Ok(r) => Some(r),
        Err(GpuError::NoAdapter(e)) => {
            skip_no_adapter(e);
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// Patch data for `base` written with format code only (the player never links the
/// worker): one patch per triangle, its exact normal as a zero-width cone, every
/// sample bit set (tests/patches.rs, tests/fair_culling.rs).
pub fn per_triangle_patches(base: &format::pack::BasePack) -> format::pack::PatchSet {
    use format::pack::{ModelPatch, ModelPatches, PatchSet};
    use format::patch_visibility::{direction_count, PatchBounds};
    use glam::Vec3;
    let (level, shells) = (0u32, vec![1.5f32, 64.0]);
    let samples = direction_count(level) * shells.len();
    let words = samples.div_ceil(32);
    let all = |w: usize| {
        if w + 1 < words || samples.is_multiple_of(32) {
            u32::MAX
        } else {
            u32::MAX >> (32 - samples % 32)
        }
    };
    let models = base
        .models
        .iter()
        .map(|m| {
            let mesh = &m.mesh;
            let p = |i: u32| Vec3::from(mesh.positions[i as usize]);
            let (lo, hi) = mesh.positions.iter().fold(
                (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
                |(lo, hi), q| (lo.min(Vec3::from(*q)), hi.max(Vec3::from(*q))),
            );
            let centre = (lo + hi) * 0.5;
            let patches = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(p);
                    let n = (b - a).cross(c - a);
                    let centroid = (a + b + c) / 3.0;
                    let bounds = if n.length() > 1e-12 {
                        PatchBounds {
                            cone_axis: n.normalize().to_array(),
                            cone_cos: 1.0,
                            centre: centroid.to_array(),
                            offset: 1e-4,
                        }
                    } else {
                        PatchBounds {
                            cone_axis: [0.0, 0.0, 1.0],
                            cone_cos: -1.0,
                            centre: centroid.to_array(),
                            offset: 0.0,
                        }
                    };
                    ModelPatch {
                        triangle_count: 1,
                        bounds,
                        samples: (0..words).map(all).collect(),
                    }
                })
                .collect();
            ModelPatches {
                centre: centre.to_array(),
                radius: ((hi - lo).length() * 0.5).max(1e-3),
                patches,
                triangle_order: (0..mesh.triangles.len() as u32).collect(),
            }
        })
        .collect();
    PatchSet {
        sample_level: level,
        shell_radius: shells,
        models,
    }
}
