//! hexbake player (paper 000 §3.2): streams cell packs and renders the hybrid scene
//! with wgpu — inside objects as original meshes, outside objects as projectively
//! textured SV/MV meshes — headless (`player render`, `player compare`).
//!
//! Modules, in layers: each imports only modules of the layers before it (no import
//! circle, issue 28).
//! 1. Plain data, no GPU type: [`vertex`] (GPU records), [`camera`] (camera, frustum,
//!    boxes), [`grid`] (the current cell on `format::grid::HexGrid`: the player never
//!    links the worker), [`metrics`] (PSNR/SSIM), [`mode`] (configurations A/B/C and
//!    `lod`, `cluster-lod`), [`representation`] (the debug colours), [`transition`]
//!    (the cross-fade weights at cell borders, issue 31), [`DrawOptions`] (the culling
//!    switches, from `format`).
//! 2. CPU algorithms: [`patches`] (per-tile patch and cluster culling, issue 17),
//!    [`occlusion`] (the run-time occlusion map, 000 §3.2 step 3).
//! 3. The bake in memory: [`bake`] (a bake directory → [`bake::PreparedCell`]),
//!    [`lod`] (the distance-LOD baseline's chains, issue 8), [`clusterlod`]
//!    (cluster LOD's DAGs, their cache beside the bake and per-frame cut, issue 30).
//! 4. The GPU: [`gpu`] (resources and submission; its `frame_model` turns a
//!    [`gpu::DrawList`] into what one frame uploads and encodes).
//! 5. Streaming: [`stream`] (current cell, prefetch thread, priority queue, upload
//!    budget, LRU eviction; uploads through the renderer).
//! 6. Frames: [`frame`] (the draw list of each configuration).
//! 7. Commands: [`run`] (`render`), [`compare`] (`compare`, with [`table`]), [`view`] (the window), [`overlay`]
//!    (the view's text panel), [`cmd`] (one function per `player` subcommand, with
//!    its flags), [`testdata`] (synthetic bakes for tests).
//!
//! Conventions the bake must follow (what the player assumes):
//! - `ProxyView::matrix` maps world points to homogeneous texture coordinates:
//!   `uv = (M·p).xy / (M·p).w`, u to the right, v downwards, texel row 0 at v = 0
//!   (the worker's pixel convention; [`testdata::texture_matrix`] builds it from an
//!   OpenGL-style view-projection: `bias · clip_from_world` with
//!   u = (x/w + 1)/2, v = (1 − y/w)/2). A texel with alpha < 0.5 means "nothing
//!   captured here" and falls back to the other view or the lit vertex colour.
//! - Proxy triangles are counter-clockwise seen from outside (back faces are culled).
//! - MvMesh view masks: bit i = view i sees the triangle; the two views of the mask
//!   whose direction to the triangle's centroid is closest to the viewer's are blended
//!   with weights inversely proportional to those angles.
//!
//! CLI: `player render <out> --path <path.ron> --frames DIR
//! [--mode hybrid|full|frustum|lod|cluster-lod] [--lod-pixel-error PX] [--cluster-tau PX] [--png] [--no-prefetch]
//! [--size WxH]`, `player compare <out> --path <path.ron> [--mode hybrid|lod|cluster-lod] [--json]
//! [--worst DIR] [--worst-count N] [--no-crossings] [--reference-ss N] [--size WxH]`,
//! `player view <out> [--mode hybrid|full|lod|cluster-lod] [--lod-pixel-error PX] ...` (a window;
//! `--display-hz`, a path's display rate, is `render`'s and `compare`'s only),
//! `player synth <out>` (a synthetic bake of `manifests/demo.ron`). `view`, `render`
//! and `compare` also take the draw options ([`DrawOptions`]: `--no-patch-bitfields`,
//! `--no-backface`, `--no-frustum`, `--tile-triangles N`, `--no-bc`, `--no-occlusion`).

/// The switches of the frame model (culling tests, tile size, BC textures; issue
/// 28), passed explicitly to [`bake::Bake::open`] and [`gpu::Renderer::new`] (or
/// [`run::Player::open`]), never read from the environment.
pub use format::schema::frames::DrawOptions;

pub mod bake;
pub mod camera;
pub mod clusterlod;
pub mod cmd;
pub mod compare;
pub mod frame;
pub mod gpu;
pub mod grid;
pub mod lod;
pub mod metrics;
pub mod mode;
pub mod occlusion;
pub mod overlay;
pub mod patches;
pub mod representation;
pub mod run;
pub mod stream;
pub mod table;
pub mod testdata;
pub mod transition;
pub mod vertex;
#[cfg(feature = "view")]
pub mod view;
