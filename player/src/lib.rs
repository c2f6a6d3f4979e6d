//! hexbake player (paper 000 §3.2): streams cell packs and renders the hybrid scene
//! with wgpu — inside objects as original meshes, outside objects as projectively
//! textured SV/MV meshes — headless (`player render`, `player compare`).
//!
//! Modules:
//! - [`gpu`]: the wgpu renderer (offscreen `Rgba8UnormSrgb` + `Depth32Float`,
//!   DESIGN.md shading in WGSL, projective texturing, MvMesh two-view blending).
//! - [`bake`]: reading a bake directory; cell packs → upload-ready [`bake::PreparedCell`].
//! - [`stream`]: current cell, prefetch thread, timestamped priority queue, FIFO
//!   texture uploads under a per-frame budget, LRU eviction.
//! - [`frame`]: draw lists of configurations A (`full`), B (`frustum`), C (`hybrid`).
//! - [`grid`]: the current cell, on `format::grid::HexGrid` (the worker's own
//!   layout, from `format`: the player never links the worker); [`camera`]: camera,
//!   frustum culling.
//! - [`lod`]: the distance-LOD baseline (`--mode lod`, issue 8): meshoptimizer
//!   chains per model, level chosen by projected pixel error.
//! - [`metrics`]: PSNR on luminance and SSIM, over whole frames and over object
//!   pixels; the anti-aliased reference's linear-light downsampling.
//! - [`overlay`]: `player view`'s on-screen text and the representation colours.
//! - [`run`]: the `render`/`compare` commands.
//! - [`testdata`]: synthetic bakes for tests (`write_synthetic_bake`, `write_quad_bake`).
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
//! [--mode hybrid|full|frustum|lod] [--lod-pixel-error PX] [--png] [--no-prefetch]
//! [--size WxH]`, `player compare <out> --path <path.ron> [--mode hybrid|lod] [--json]
//! [--worst DIR] [--worst-count N] [--no-crossings] [--reference-ss N] [--size WxH]`,
//! `player view <out> [--mode hybrid|full|lod] [--lod-pixel-error PX] ...` (a window;
//! `--display-hz`, a path's display rate, is `render`'s and `compare`'s only),
//! `player synth <out>` (a synthetic bake of `manifests/demo.ron`). `view`, `render`
//! and `compare` also take the draw options ([`DrawOptions`]: `--no-patch-bitfields`,
//! `--no-backface`, `--no-frustum`, `--tile-triangles N`, `--no-bc`).

/// The switches of the frame model (culling tests, tile size, BC textures; issue
/// 28), passed explicitly to [`bake::Bake::open`] and [`gpu::Renderer::new`] (or
/// [`run::Player::open`]), never read from the environment.
pub use format::schema::frames::DrawOptions;

pub mod bake;
pub mod camera;
pub mod frame;
pub mod gpu;
pub mod grid;
pub mod lod;
pub mod metrics;
pub mod overlay;
pub mod patches;
pub mod run;
pub mod stream;
pub mod testdata;
pub mod vertex;
#[cfg(feature = "view")]
pub mod view;
