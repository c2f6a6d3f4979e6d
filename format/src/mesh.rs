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
    /// The closed axis-aligned box `[lo, hi]`: 8 vertices of colour `albedo`, 12
    /// outward, counter-clockwise triangles, smooth normals (tests and scenes of
    /// blocks).
    pub fn cuboid(lo: [f32; 3], hi: [f32; 3], albedo: [u8; 4]) -> Mesh {
        let positions: Vec<[f32; 3]> = (0..8)
            .map(|k: usize| {
                [
                    if k & 1 == 0 { lo[0] } else { hi[0] },
                    if k & 2 == 0 { lo[1] } else { hi[1] },
                    if k & 4 == 0 { lo[2] } else { hi[2] },
                ]
            })
            .collect();
        let triangles = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ];
        let mut mesh = Mesh {
            positions,
            normals: vec![[0.0, 1.0, 0.0]; 8],
            albedo: vec![albedo; 8],
            triangles,
        };
        crate::cleanup::recompute_normals(&mut mesh);
        mesh
    }

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
