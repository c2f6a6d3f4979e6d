//! The indexed triangle mesh every loader produces and every kernel consumes.
//!
//! Positions are in the model's normalised object space (base on y = 0, centred in
//! x–z, scaled to the manifest's target height); `albedo` is sRGB8 per vertex
//! (the file's colours or the procedural pattern of DESIGN.md, "Shading").

use serde::{Deserialize, Serialize};
use std::collections::HashMap;

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
        recompute_normals(&mut mesh);
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

/// Unnormalised normal (twice the area) of triangle `t`, in f64.
pub fn face_normal_f64(positions: &[[f32; 3]], t: [u32; 3]) -> [f64; 3] {
    let p = t.map(|i| positions[i as usize].map(f64::from));
    let u = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let v = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// Replaces `mesh.normals` with smooth area-weighted normals (step 5 of `scene::cleanup`'s
/// clean-up; also [`Mesh::cuboid`]): faces are summed over all vertices sharing a position.
pub fn recompute_normals(mesh: &mut Mesh) {
    let key_of = |p: [f32; 3]| p.map(|x| (x + 0.0).to_bits());
    let mut group_of_position: HashMap<[u32; 3], u32> = HashMap::new();
    let group: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let next = group_of_position.len() as u32;
            *group_of_position.entry(key_of(*p)).or_insert(next)
        })
        .collect();
    let mut sums = vec![[0.0f64; 3]; group_of_position.len()];
    for &t in &mesh.triangles {
        let n = face_normal_f64(&mesh.positions, t);
        for &i in &t {
            let s = &mut sums[group[i as usize] as usize];
            for k in 0..3 {
                s[k] += n[k];
            }
        }
    }
    mesh.normals = group
        .iter()
        .map(|&g| {
            let s = sums[g as usize];
            let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                s.map(|x| (x / len) as f32)
            } else {
                [0.0, 1.0, 0.0]
            }
        })
        .collect();
}
