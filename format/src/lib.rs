//! hexbake's on-disk contracts.
//!
//! Everything read from or written to disk lives here (DESIGN.md, "Crates and
//! folders"): the manifest schema (raw + validated), the model loaders, the scene
//! the bake reads, the base/cell pack layout with its writer and memory-mapped
//! reader, the index, and fingerprints.
//!
//! Scene input, in the order data flows:
//! - [`manifest`]: `parse_manifest(path) -> Plan` (raw serde structs → validated plan,
//!   errors with file:line:column and the field);
//! - [`load`]: `load_model(path) -> Mesh` for glTF/GLB, OBJ, PLY, OFF, STL, through
//!   [`cleanup`] (validation, welding, degenerate/duplicate removal, smooth normals,
//!   albedo);
//! - [`procedural`]: the demo's procedural models and the procedural albedo pattern;
//! - [`scene_build`]: `Plan::load_scene() -> Scene` (normalise each model, place the
//!   instances; parks via [`park`]);
//! - [`mesh_ext`]: `Mesh::validate`, `Mesh::content_hash`, topology checks.

pub mod albedo;
pub mod city;
pub mod cleanup;
mod field_positions;
pub mod fingerprint;
pub mod grid;
pub mod load;
pub mod lod;
pub mod manifest;
pub mod mesh;
pub mod mesh_ext;
pub mod metrics;
pub mod pack;
pub mod park;
pub mod patch_visibility;
pub mod path;
pub mod procedural;
pub mod scene;
pub mod scene_build;
pub mod schema;
pub mod shading;
pub mod srgb;

pub use mesh::Mesh;
pub use scene::{Ground, Instance, InstanceLabels, Model, Scene};
pub use scene_build::{build_scene, SceneError};
