//! Regional conservative back-face culling (paper 000 §3.1.5; 003 §4.1.2).
//!
//! A triangle with outward normal `N` (counter-clockwise winding, `format::Mesh`) and a
//! point `P` on its plane faces away from a viewpoint `X` when `N · (P − X) > 0`.
//! The function `X ↦ N · (P − X)` is affine, so if it is positive at every corner of a
//! convex region it is positive at every convex combination of them, i.e. everywhere in
//! the region. A cell's view region is the hexagonal prism between the minimum and the
//! maximum eye height (DESIGN.md "Hex grid"): a convex polyhedron whose 12 corners are
//! the hexagon's 6 corners at both heights. The paper states the test for the hexagon's
//! 6 corners (its eye is at one height); we apply it to the prism's 12.
//!
//! The paper prints the test as `N · vector(C_i, P.center) < 0` for "back-facing"; with
//! `vector(C_i, P) = P − C_i` that inequality describes a *front*-facing polygon, so we
//! use the geometric condition above (back-facing ⇔ the eye is behind the plane).
//!
//! The test is strict: a triangle seen exactly edge-on from some corner, or a
//! degenerate one (zero normal), is kept. Plane values are computed in f64 from the
//! f32 world positions so that rounding cannot flip a sign the f32 inputs determine.

use format::Mesh;
use glam::{DVec3, Mat4, Vec3};

/// World-space plane of one triangle: unnormalised normal `(b − a) × (c − a)` and the
/// centroid, both in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrianglePlane {
    pub normal: DVec3,
    pub centroid: DVec3,
}

impl TrianglePlane {
    /// The plane of the counter-clockwise triangle `a`, `b`, `c`.
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> TrianglePlane {
        TrianglePlane {
            normal: (b - a).cross(c - a),
            centroid: (a + b + c) / 3.0,
        }
    }

    /// `N · (P − X)`: positive when the triangle faces away from `eye`, negative when it
    /// faces it, zero edge-on.
    pub fn away_from(&self, eye: DVec3) -> f64 {
        self.normal.dot(self.centroid - eye)
    }

    /// Strictly front-facing from `eye` (`N · (X − P) > 0`).
    pub fn faces(&self, eye: DVec3) -> bool {
        self.away_from(eye) < 0.0
    }

    /// Strictly back-facing from `eye` (`N · (P − X) > 0`).
    pub fn faces_away_from(&self, eye: DVec3) -> bool {
        self.away_from(eye) > 0.0
    }
}

/// Mesh positions placed in the world by `transform`. Indices out of range are the
/// caller's to avoid: every function here skips (never culls, never calls
/// front-facing) a triangle with an index past the vertex count.
pub fn world_positions(mesh: &Mesh, transform: Mat4) -> Vec<Vec3> {
    mesh.positions
        .iter()
        .map(|&p| transform.transform_point3(Vec3::from(p)))
        .collect()
}

/// The world-space plane of every triangle (`None` for a triangle with an index out of
/// range).
pub fn triangle_planes(
    mesh: &Mesh,
    triangles: &[[u32; 3]],
    transform: Mat4,
) -> Vec<Option<TrianglePlane>> {
    let world = world_positions(mesh, transform);
    planes_of(&world, triangles)
}

pub(crate) fn planes_of(world: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Option<TrianglePlane>> {
    triangles
        .iter()
        .map(|tri| {
            let a = world.get(tri[0] as usize)?.as_dvec3();
            let b = world.get(tri[1] as usize)?.as_dvec3();
            let c = world.get(tri[2] as usize)?.as_dvec3();
            Some(TrianglePlane::new(a, b, c))
        })
        .collect()
}

/// Per triangle: strictly front-facing from `eye` (000 §3.1.3: "polygons front-facing
/// to the cell's center"). Degenerate and out-of-range triangles are `false`.
pub fn front_facing_from(mesh: &Mesh, transform: Mat4, eye: Vec3) -> Vec<bool> {
    front_facing_of(mesh, &mesh.triangles, transform, eye)
}

/// [`front_facing_from`] for `triangles` over `mesh`'s vertices (a LOD chain level).
pub fn front_facing_of(
    mesh: &Mesh,
    triangles: &[[u32; 3]],
    transform: Mat4,
    eye: Vec3,
) -> Vec<bool> {
    let eye = eye.as_dvec3();
    triangle_planes(mesh, triangles, transform)
        .iter()
        .map(|plane| plane.is_some_and(|p| p.faces(eye)))
        .collect()
}

/// Per triangle: `true` = culled for the cell, i.e. strictly back-facing from all 12
/// corners of the cell's prism, hence from every point inside it (module docs).
pub fn regional_backface_cull(
    mesh: &Mesh,
    transform: Mat4,
    prism_corners: &[Vec3; 12],
) -> Vec<bool> {
    regional_backface_cull_of(mesh, &mesh.triangles, transform, prism_corners)
}

/// [`regional_backface_cull`] for `triangles` over `mesh`'s vertices (a LOD chain
/// level).
pub fn regional_backface_cull_of(
    mesh: &Mesh,
    triangles: &[[u32; 3]],
    transform: Mat4,
    prism_corners: &[Vec3; 12],
) -> Vec<bool> {
    let corners: Vec<DVec3> = prism_corners.iter().map(|c| c.as_dvec3()).collect();
    triangle_planes(mesh, triangles, transform)
        .iter()
        .map(|plane| plane.is_some_and(|p| corners.iter().all(|&c| p.faces_away_from(c))))
        .collect()
}

/// Whether the whole instance is culled for the cell: every triangle is culled by
/// [`regional_backface_cull`] (and the mesh has one). Stops at the first triangle that
/// is not, so on a closed mesh it costs a few triangles, not the whole model (the
/// split step of every cell asks this of every outside instance).
pub fn all_culled(mesh: &Mesh, transform: Mat4, prism_corners: &[Vec3; 12]) -> bool {
    let corners: Vec<DVec3> = prism_corners.iter().map(|c| c.as_dvec3()).collect();
    let world = |v: u32| {
        mesh.positions
            .get(v as usize)
            .map(|&p| transform.transform_point3(Vec3::from(p)).as_dvec3())
    };
    !mesh.triangles.is_empty()
        && mesh.triangles.iter().all(|tri| {
            let (Some(a), Some(b), Some(c)) = (world(tri[0]), world(tri[1]), world(tri[2])) else {
                return false;
            };
            let plane = TrianglePlane::new(a, b, c);
            corners.iter().all(|&x| plane.faces_away_from(x))
        })
}

/// Per vertex: some incident triangle is strictly front-facing from `eye`. The others
/// are the paper's back-facing vertices (000 §3.1.3.2: "all polygons incident to it
/// are back-facing"), including vertices no triangle references.
pub fn front_facing_vertices(mesh: &Mesh, transform: Mat4, eye: Vec3) -> Vec<bool> {
    front_facing_vertices_of(&world_positions(mesh, transform), &mesh.triangles, eye)
}

pub(crate) fn front_facing_vertices_of(
    world: &[Vec3],
    triangles: &[[u32; 3]],
    eye: Vec3,
) -> Vec<bool> {
    let eye = eye.as_dvec3();
    let mut front = vec![false; world.len()];
    for (tri, plane) in triangles.iter().zip(planes_of(world, triangles)) {
        if plane.is_some_and(|p| p.faces(eye)) {
            for &v in tri {
                front[v as usize] = true;
            }
        }
    }
    front
}
