//! Scene building: from a validated manifest ([`format::manifest::Plan`]) to the
//! [`format::Scene`] a bake reads. Everything here makes geometry; what it makes is
//! defined by the `format` crate's contracts.
//!
//! In the order data flows:
//! - [`load`]: `load_model(path) -> Mesh` for glTF/GLB, OBJ, PLY, OFF, STL, and glTF
//!   files read as whole scenes, through [`cleanup`] (validation, welding,
//!   degenerate/duplicate removal, smooth normals, albedo);
//! - [`procedural`]: the demo's procedural models; [`pattern`]: the procedural albedo
//!   pattern of models without colours;
//! - [`park`] and [`city`]: the generated layouts (the paper's statuary parks, issue
//!   17's city);
//! - [`build`]: `build_scene(plan) -> Scene` (normalise each model, place the
//!   instances, tile), then [`chunk`]: objects wider than two cells split into one
//!   chunk per cell.

pub mod build;
pub mod chunk;
pub mod city;
pub mod cleanup;
pub mod load;
pub mod park;
pub mod pattern;
pub mod procedural;

pub use build::{build_scene, SceneError};
