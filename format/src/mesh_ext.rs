//! Checks and hashes over [`Mesh`]: `validate()` (every test calls it after building a
//! mesh, STYLE.md's obvhs habit), content hashes for fingerprints, and topology
//! checks used by the procedural models' tests.

use crate::mesh::Mesh;
use std::collections::HashMap;

/// A broken [`Mesh`] invariant.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("{normals} normals and {albedo} albedo entries for {vertices} vertices")]
    AttributeCount {
        vertices: usize,
        normals: usize,
        albedo: usize,
    },
    #[error("vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition { vertex: usize, position: [f32; 3] },
    #[error("vertex {vertex} has a normal of length {length} (expected 1)")]
    NonUnitNormal { vertex: usize, length: f32 },
    #[error("vertex {vertex} has alpha {alpha} (expected 255)")]
    Alpha { vertex: usize, alpha: u8 },
    #[error("triangle {triangle} uses vertex {index}, but there are only {vertices} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    #[error("triangle {triangle} repeats vertex {index}")]
    Degenerate { triangle: usize, index: u32 },
}

/// Edge-topology summary of a mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EdgeTopology {
    /// Undirected edges used by exactly one triangle.
    pub boundary_edges: usize,
    /// Undirected edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Undirected edges whose two triangles run it in the same direction
    /// (inconsistent winding).
    pub misoriented_edges: usize,
}

impl EdgeTopology {
    /// Watertight, 2-manifold and consistently wound.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0 && self.misoriented_edges == 0
    }
}

impl Mesh {
    /// Checks the invariants every producer of a `Mesh` keeps: one normal and albedo
    /// per vertex, finite positions, unit normals (±1e-3), opaque albedo, indices in
    /// range, no triangle repeating a vertex.
    pub fn validate(&self) -> Result<(), MeshError> {
        let vertices = self.positions.len();
        if self.normals.len() != vertices || self.albedo.len() != vertices {
            return Err(MeshError::AttributeCount {
                vertices,
                normals: self.normals.len(),
                albedo: self.albedo.len(),
            });
        }
        for (vertex, p) in self.positions.iter().enumerate() {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(MeshError::NonFinitePosition {
                    vertex,
                    position: *p,
                });
            }
        }
        for (vertex, n) in self.normals.iter().enumerate() {
            let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if (length - 1.0).abs().is_nan() || (length - 1.0).abs() > 1e-3 {
                return Err(MeshError::NonUnitNormal { vertex, length });
            }
        }
        for (vertex, a) in self.albedo.iter().enumerate() {
            if a[3] != 255 {
                return Err(MeshError::Alpha {
                    vertex,
                    alpha: a[3],
                });
            }
        }
        for (triangle, t) in self.triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= vertices) {
                return Err(MeshError::IndexOutOfRange {
                    triangle,
                    index,
                    vertices,
                });
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                let index = if t[0] == t[1] || t[0] == t[2] {
                    t[0]
                } else {
                    t[1]
                };
                return Err(MeshError::Degenerate { triangle, index });
            }
        }
        Ok(())
    }

    /// blake3 over the whole mesh, little-endian: for each of positions, normals,
    /// albedo and triangles, its element count as u64 then its elements (f32 / u8 /
    /// u32 components in order). This is `Model::content_hash`.
    pub fn content_hash(&self) -> [u8; 32] {
        let mut h = blake3::Hasher::new();
        h.update(b"hexbake mesh v1");
        hash_triples(&mut h, &self.positions, f32::to_le_bytes);
        hash_triples(&mut h, &self.normals, f32::to_le_bytes);
        h.update(&(self.albedo.len() as u64).to_le_bytes());
        h.update(self.albedo.as_flattened());
        hash_triples(&mut h, &self.triangles, u32::to_le_bytes);
        *h.finalize().as_bytes()
    }

    /// blake3 over positions and triangles only (same layout as `content_hash`);
    /// seeds the procedural albedo of a file without colours.
    pub fn geometry_hash(&self) -> [u8; 32] {
        let mut h = blake3::Hasher::new();
        h.update(b"hexbake geometry v1");
        hash_triples(&mut h, &self.positions, f32::to_le_bytes);
        hash_triples(&mut h, &self.triangles, u32::to_le_bytes);
        *h.finalize().as_bytes()
    }

    /// Counts boundary, non-manifold and misoriented edges (deterministic).
    pub fn edge_topology(&self) -> EdgeTopology {
        // Directed edge counts keyed by (min, max) → (forward uses, backward uses).
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let e = edges.entry((a.min(b), a.max(b))).or_default();
                if a < b {
                    e.0 += 1;
                } else {
                    e.1 += 1;
                }
            }
        }
        let mut topo = EdgeTopology::default();
        for &(fwd, bwd) in edges.values() {
            match fwd + bwd {
                1 => topo.boundary_edges += 1,
                2 if fwd != 1 => topo.misoriented_edges += 1,
                2 => {}
                _ => topo.non_manifold_edges += 1,
            }
        }
        topo
    }

    /// Signed volume enclosed by the triangles (positive for a closed mesh wound
    /// counter-clockwise seen from outside).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize].map(f64::from));
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }
}

/// Hashes `values` as their count (u64) then every component as `to_le_bytes` of it.
fn hash_triples<T: Copy>(h: &mut blake3::Hasher, values: &[[T; 3]], to_le_bytes: fn(T) -> [u8; 4]) {
    h.update(&(values.len() as u64).to_le_bytes());
    let bytes: Vec<u8> = values
        .as_flattened()
        .iter()
        .flat_map(|&x| to_le_bytes(x))
        .collect();
    h.update(&bytes);
}
