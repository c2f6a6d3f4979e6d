//! The indexed triangle mesh every loader produces and every kernel consumes.
//!
//! Positions are in the model's normalised object space (base on y = 0, centred in
//! x–z, scaled to the manifest's target height); `albedo` is sRGB8 per vertex
//! (the file's colours or the procedural pattern of DESIGN.md, "Shading").

use serde::{Deserialize, Serialize};

/// An indexed triangle mesh: one position, normal and albedo per vertex.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, one per vertex (smooth normals when the file has none).
    pub normals: Vec<[f32; 3]>,
    /// sRGB8 albedo per vertex; alpha is always 255.
    pub albedo: Vec<[u8; 4]>,
    /// Counter-clockwise triangles (front face seen from outside).
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Axis-aligned bounds `(min, max)`; `None` for a mesh without vertices.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = *self.positions.first()?;
        let mut lo = first;
        let mut hi = first;
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Some((lo, hi))
    }
}
