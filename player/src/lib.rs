//! hexbake player (paper 000 §3.2): streams cell packs and renders the hybrid scene
//! with wgpu — inside objects as original meshes, outside objects as projectively
//! textured SV/MV meshes — headless (`player render`, `player compare`).

pub mod bake;
pub mod camera;
pub mod frame;
pub mod gpu;
pub mod grid;
pub mod metrics;
pub mod run;
pub mod stream;
pub mod testdata;
