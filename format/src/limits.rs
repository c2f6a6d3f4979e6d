//! The limits every reader and generator enforces, in one place (STYLE.md habit 5:
//! never trust input): a manifest's size, coordinates, grid and tiling
//! (`manifest`), the views an MV mesh may blend (`pack::cell`, the shader's
//! `MAX_VIEWS`) and a generated city's size (`scene::city`). Each limit is far above
//! any real input and low enough that what it bounds fits in memory.

/// Largest manifest file read, in bytes (16 MiB; the paper's 8M park is 2 KB).
pub const MAX_MANIFEST_BYTES: u64 = 16 << 20;

/// Largest absolute value of any coordinate or length in a manifest, in scene units.
pub const MAX_COORDINATE: f32 = 1.0e6;

/// Smallest object height (`target_height`, times `scale` for an instance).
pub const MIN_LENGTH: f32 = 1.0e-3;

/// Most cells a grid may have.
pub const MAX_CELLS: u64 = 1_000_000;

/// Largest tint component.
pub const MAX_TINT: f32 = 100.0;

/// Most levels of far-field groups (`bake.far_levels`; 7⁸ ≈ 5.8M cells in one top
/// group).
pub const MAX_FAR_LEVELS: u32 = 8;

/// Most tiles per side of a `Tiled` scene.
pub const MAX_TILES: u32 = 15;

/// Most views an MvMesh may have: the centre and the six neighbours (paper 000 §3.2)
/// and one spare; view masks are one byte per triangle.
pub const MAX_MV_VIEWS: usize = 8;

/// Most blocks a city may have.
pub const MAX_BLOCKS: u64 = 100_000;

/// Most windows one façade of one building may have.
pub const MAX_WINDOWS_PER_FACADE: u64 = 20_000;

/// Most instances one glTF scene may place (issue 32 item 4; `scene::load`'s
/// `GltfCaps`): a node is placed once per base-colour texture of its mesh, and a
/// file of a few megabytes can list millions of nodes.
pub const MAX_GLTF_INSTANCES: u64 = 1 << 24;

/// Most triangles read from one glTF file, over every primitive read (issue 32 item
/// 4): a mesh that nodes place at several non-uniform scales is read once per scale
/// (the scale is baked into a model each time), so a small file can make one mesh's
/// triangles many times over. 2²⁷ ≈ 134M: ten times the largest scenes we read.
pub const MAX_GLTF_TRIANGLES: u64 = 1 << 27;

/// Most vertices (POSITION elements) read from one glTF file, counted as
/// [`MAX_GLTF_TRIANGLES`] are; it also bounds a sparse accessor without a buffer
/// view, whose count no bytes bound.
pub const MAX_GLTF_VERTICES: u64 = 1 << 27;
