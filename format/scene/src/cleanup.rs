//! Mesh clean-up shared by every loader and procedural model (issue 2, "Model
//! loading"): validation, welding, degenerate and duplicate triangle removal, smooth
//! normals and albedo.
//!
//! [`finish_mesh`] reads as its steps:
//! 1. reject NaN/inf coordinates and coordinates beyond ±[`MAX_MODEL_COORDINATE`]
//!    (naming the vertex) and out-of-range indices (naming the face);
//! 2. weld vertices whose position is bit-identical (after `-0.0 → 0.0`) *and* whose
//!    file colour is equal — a colour seam stays a seam; new indices follow first use,
//!    so the result is deterministic (the hash map is only looked up, never iterated);
//! 3. drop triangles that repeat an index or have exactly zero area, and duplicate
//!    triangles (the same three vertices in either winding; the first one wins);
//! 4. drop vertices no triangle uses (keeping the order of the rest);
//! 5. always recompute smooth, area-weighted normals (the sum of the unnormalised face
//!    normals around a vertex, accumulated over every vertex at the same position so
//!    colour seams do not crease the shading); a vertex whose sum is zero gets +y;
//! 6. albedo: the file's sRGB8 colours when it has them, else the procedural pattern
//!    (`pattern::apply_albedo`) seeded from the mesh content.

use format::mesh::Mesh;
pub use format::mesh::{face_normal_f64, recompute_normals};
use std::collections::{HashMap, HashSet};

/// Largest absolute coordinate a model file may have, in the file's units (10¹²).
/// Normalising works in f64 and would take more, but f32 differences and squared
/// distances of such coordinates (up to ~10²⁵, far below f32's 3.4·10³⁸) stay finite
/// in every kernel, and no real model needs more: a city in micrometres is 10¹⁰.
pub const MAX_MODEL_COORDINATE: f32 = 1.0e12;

/// A mesh as a loader reads it, before clean-up.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawMesh {
    pub positions: Vec<[f32; 3]>,
    /// sRGB8 colour per vertex when the file has colours.
    pub colors: Option<Vec<[u8; 4]>>,
    /// Counter-clockwise triangles, indices into `positions` (unchecked).
    pub triangles: Vec<[u32; 3]>,
}

/// What clean-up rejected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CleanupError {
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite { vertex: usize, position: [f32; 3] },
    #[error("vertex {vertex} has a coordinate beyond ±{MAX_MODEL_COORDINATE}: {position:?}")]
    TooFar { vertex: usize, position: [f32; 3] },
    /// `face` counts triangles after the loader's triangulation.
    #[error("face {face} uses vertex {index}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        vertex_count: usize,
    },
    #[error("colour count {colors} differs from vertex count {vertices}")]
    ColorCount { colors: usize, vertices: usize },
    #[error("texture coordinate count {uvs} differs from vertex count {vertices}")]
    UvCount { uvs: usize, vertices: usize },
    #[error("no triangle left after removing degenerate ones (read {triangles} triangles)")]
    NoTriangles { triangles: usize },
    #[error("{vertices} vertices do not fit 32-bit indices")]
    TooManyVertices { vertices: usize },
}

/// What clean-up changed, for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanupStats {
    pub input_vertices: usize,
    pub input_triangles: usize,
    /// Vertices merged into an earlier identical one.
    pub welded_vertices: usize,
    /// Triangles with a repeated index or zero area.
    pub degenerate_triangles: usize,
    /// Triangles over the same three vertices as an earlier one.
    pub duplicate_triangles: usize,
    /// Vertices no triangle uses.
    pub unreferenced_vertices: usize,
}

/// Cleans `raw` into a [`Mesh`] (steps in the module docs).
pub fn finish_mesh(raw: RawMesh) -> Result<(Mesh, CleanupStats), CleanupError> {
    finish_mesh_with_uvs(raw, None).map(|(mesh, _, stats)| (mesh, stats))
}

/// [`finish_mesh`] for a mesh with texture coordinates (one per vertex of `raw`):
/// the weld also keeps UV seams (vertices weld only when position, colour and UV
/// bits are equal), and the UVs of the kept vertices come back in the mesh's vertex
/// order.
#[allow(clippy::type_complexity)]
pub fn finish_mesh_with_uvs(
    raw: RawMesh,
    uvs: Option<Vec<[f32; 2]>>,
) -> Result<(Mesh, Option<Vec<[f32; 2]>>, CleanupStats), CleanupError> {
    let RawMesh {
        positions,
        colors,
        triangles,
    } = raw;
    let mut stats = CleanupStats {
        input_vertices: positions.len(),
        input_triangles: triangles.len(),
        ..CleanupStats::default()
    };
    if u32::try_from(positions.len()).is_err() {
        return Err(CleanupError::TooManyVertices {
            vertices: positions.len(),
        });
    }

    // Step 1: validate.
    if let Some(c) = &colors {
        if c.len() != positions.len() {
            return Err(CleanupError::ColorCount {
                colors: c.len(),
                vertices: positions.len(),
            });
        }
    }
    if let Some((vertex, p)) = positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|x| x.is_finite()))
    {
        return Err(CleanupError::NonFinite {
            vertex,
            position: *p,
        });
    }
    if let Some((vertex, p)) = positions
        .iter()
        .enumerate()
        .find(|(_, p)| p.iter().any(|x| x.abs() > MAX_MODEL_COORDINATE))
    {
        return Err(CleanupError::TooFar {
            vertex,
            position: *p,
        });
    }
    for (face, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(CleanupError::IndexOutOfRange {
                face,
                index,
                vertex_count: positions.len(),
            });
        }
    }

    if let Some(u) = &uvs {
        if u.len() != positions.len() {
            return Err(CleanupError::UvCount {
                uvs: u.len(),
                vertices: positions.len(),
            });
        }
    }

    // Step 2: weld identical vertices (position bits + colour + UV bits), first use wins.
    let key_of = |p: [f32; 3]| p.map(|x| (x + 0.0).to_bits());
    let white = [255u8; 4];
    let mut weld: HashMap<([u32; 3], [u8; 4], [u32; 2]), u32> =
        HashMap::with_capacity(positions.len());
    let mut remap = Vec::with_capacity(positions.len());
    let mut welded_positions: Vec<[f32; 3]> = Vec::new();
    let mut welded_colors: Vec<[u8; 4]> = Vec::new();
    let mut welded_uvs: Vec<[f32; 2]> = Vec::new();
    for (i, p) in positions.iter().enumerate() {
        let color = colors.as_ref().map_or(white, |c| c[i]);
        let uv = uvs.as_ref().map_or([0.0; 2], |u| u[i]);
        let next = welded_positions.len() as u32;
        let id = *weld
            .entry((key_of(*p), color, uv.map(|x| (x + 0.0).to_bits())))
            .or_insert(next);
        if id == next {
            welded_positions.push(p.map(|x| x + 0.0));
            welded_colors.push(color);
            welded_uvs.push(uv);
        }
        remap.push(id);
    }
    stats.welded_vertices = positions.len() - welded_positions.len();
    drop(weld);

    // Step 3: drop degenerate and duplicate triangles.
    let mut kept: Vec<[u32; 3]> = Vec::with_capacity(triangles.len());
    let mut seen: HashSet<[u32; 3]> = HashSet::with_capacity(triangles.len());
    for t in &triangles {
        let t = t.map(|i| remap[i as usize]);
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            stats.degenerate_triangles += 1;
            continue;
        }
        let n = face_normal_f64(&welded_positions, t);
        if n == [0.0; 3] {
            stats.degenerate_triangles += 1;
            continue;
        }
        let mut sorted = t;
        sorted.sort_unstable();
        if !seen.insert(sorted) {
            stats.duplicate_triangles += 1;
            continue;
        }
        kept.push(t);
    }
    drop(seen);
    if kept.is_empty() {
        return Err(CleanupError::NoTriangles {
            triangles: triangles.len(),
        });
    }

    // Step 4: drop unreferenced vertices, keeping order.
    let mut used = vec![false; welded_positions.len()];
    for t in &kept {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let mut compact = vec![u32::MAX; welded_positions.len()];
    let mut out_positions = Vec::with_capacity(welded_positions.len());
    let mut out_colors = Vec::with_capacity(welded_positions.len());
    let mut out_uvs = Vec::with_capacity(welded_positions.len());
    for (i, &u) in used.iter().enumerate() {
        if u {
            compact[i] = out_positions.len() as u32;
            out_positions.push(welded_positions[i]);
            out_colors.push(welded_colors[i]);
            out_uvs.push(welded_uvs[i]);
        }
    }
    stats.unreferenced_vertices = welded_positions.len() - out_positions.len();
    for t in &mut kept {
        *t = t.map(|i| compact[i as usize]);
    }

    let mut mesh = Mesh {
        positions: out_positions,
        normals: Vec::new(),
        albedo: out_colors,
        triangles: kept,
    };
    // Step 5: smooth area-weighted normals.
    recompute_normals(&mut mesh);

    // Step 6: albedo.
    if colors.is_none() {
        let seed = u64::from_le_bytes(
            mesh.geometry_hash()[..8]
                .try_into()
                .expect("8 bytes of a 32-byte hash"),
        );
        crate::pattern::apply_albedo(&mut mesh, seed);
    }
    Ok((mesh, uvs.map(|_| out_uvs), stats))
}
