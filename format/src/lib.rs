//! hexbake's on-disk contracts.
//!
//! Everything read from or written to disk lives here (DESIGN.md, "Crates and
//! folders"): the manifest schema (raw + validated), the model loaders, the scene
//! the bake reads, the base/cell pack layout with its writer and memory-mapped
//! reader, the index, and fingerprints.

pub mod cleanup;
mod field_positions;
pub mod load;
pub mod manifest;
pub mod mesh;
pub mod mesh_ext;
pub mod park;
pub mod procedural;
pub mod scene;
pub mod scene_build;

pub use mesh::Mesh;
pub use scene::{Ground, Instance, Model, Scene};
pub use scene_build::{build_scene, SceneError};
