//! Adds (or replaces) the issue-17 patch sections of an existing bake's `base.pack`
//! (worker `patches.rs`, preset `PatchPreset::standard()`), leaving every cell pack
//! as it is: for measuring bakes made before the patch data existed without
//! rebaking them. `pipeline run` writes the same sections for new bakes.
//!
//! `cargo run --release -p worker --example add_patches -- <out>`

use format::pack::BasePack;
use std::time::Instant;
use worker::patches::{bake_patch_set, PatchPreset};

fn main() -> anyhow::Result<()> {
    let dir = std::env::args()
        .nth(1)
        .ok_or_else(|| anyhow::anyhow!("usage: add_patches <bake output dir>"))?;
    let path = std::path::Path::new(&dir).join("base.pack");
    let mut base = BasePack::read(&path)?;
    let before = std::fs::metadata(&path)?.len();
    let t0 = Instant::now();
    let meshes: Vec<&format::Mesh> = base.models.iter().map(|m| &m.mesh).collect();
    let set = bake_patch_set(&meshes, &PatchPreset::standard());
    let secs = t0.elapsed().as_secs_f64();
    let patches: usize = set.models.iter().map(|m| m.patches.len()).sum();
    let triangles: usize = base.models.iter().map(|m| m.mesh.triangles.len()).sum();
    base.patches = Some(set);
    base.write(&path)?;
    let after = std::fs::metadata(&path)?.len();
    println!(
        "{}: {} models, {triangles} triangles, {patches} patches; {secs:.1} s wall; \
         base.pack {before} -> {after} bytes",
        path.display(),
        base.models.len(),
    );
    Ok(())
}
