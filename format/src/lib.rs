//! hexbake's on-disk contracts.
//!
//! Everything read from or written to disk lives here (DESIGN.md, "Crates and
//! folders"): the manifest schema (raw + validated), the model loaders, the scene
//! the bake reads, the base/cell pack layout with its writer and memory-mapped
//! reader, the index, and fingerprints.

pub mod load;
pub mod manifest;
pub mod mesh;
pub mod pack;
pub mod procedural;
pub mod scene;

pub use mesh::Mesh;
pub use scene::{Ground, Instance, Model, Scene};
