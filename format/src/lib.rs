//! hexbake's contracts: what is read from or written to disk, and the conventions
//! every renderer shares (DESIGN.md "Crates and folders", "Conventions").
//! Building a scene from models (loaders, clean-up, generators) is the `scene` crate's
//! (`format/scene/`), which depends on this one.
//!
//! On disk:
//! - [`manifest`] (+ [`model_source`], [`limits`]): `parse_manifest(path) -> Plan`,
//!   raw serde structs → validated plan, errors with file:line:column and the field;
//! - [`scene`], [`mesh`] (+ `mesh_ext` checks and hashes), [`albedo`]: the scene a
//!   bake reads and the base pack stores;
//! - [`pack`]: base/cell/group pack layout, writer, memory-mapped reader, index, the
//!   golden samples; [`lod`]: LOD chain cache files;
//! - [`schema`]: job records, reports, `frames.csv`, compare reports; [`path`]: camera
//!   paths; [`fingerprint`]: job fingerprints and the bake revision.
//!
//! Shared conventions, one small module each: [`grid`] (the hex grid), [`shading`] and
//! [`srgb`] (the shading formula), [`metrics`] (PSNR(Y), SSIM), [`patch_visibility`]
//! (the meaning of a patch bitfield's bits and the run-time patch choice), [`rng`]
//! (the generators' PRNG).

pub mod albedo;
mod field_positions;
pub mod fingerprint;
pub mod grid;
pub mod limits;
pub mod lod;
pub mod manifest;
pub mod mesh;
pub mod mesh_ext;
pub mod metrics;
pub mod model_source;
pub mod pack;
pub mod patch_visibility;
pub mod path;
pub mod rng;
pub mod scene;
pub mod schema;
pub mod shading;
pub mod srgb;

pub use mesh::Mesh;
pub use scene::{Ground, Instance, InstanceLabels, Model, Scene};
