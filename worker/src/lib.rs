//! hexbake's bake kernels, one file per algorithm (STYLE.md habit 1), following
//! paper 000 §3.1 (Chen et al. 2003) and its precursor 003 §4.1.

pub mod backface;
pub mod bake;
pub mod capture;
pub mod check;
pub mod classify;
pub mod cluster;
pub mod diagnostics;
pub mod grid;
pub mod job;
pub mod mvmesh;
pub mod picture;
pub mod raster;
pub mod selfocc;
pub mod shade;
pub mod simplify;
pub mod svmesh;
pub mod view;
pub mod visibility;
pub mod weights;
