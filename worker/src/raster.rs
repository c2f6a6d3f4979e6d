//! Software rasterizer for captures (paper 000 §3.1.3: depth, colour and ID
//! images from a cell centre; DESIGN.md "Capture resolution", "Shading").
//!
//! TODO(issue 3 item 1): the implementation. The types below are the contract the
//! other kernels (classify, weights, simplify, capture) are written against.

use format::Mesh;
use glam::{Mat4, Vec3};

/// Object/triangle id of a pixel nothing covers.
pub const BACKGROUND_ID: u32 = u32::MAX;

/// A perspective view through an arbitrary (possibly off-axis) window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Eye position in world space.
    pub eye: Vec3,
    /// World → eye-space transform (right-handed, looking down −z, y up).
    pub view: Mat4,
    /// Eye → clip transform (OpenGL-style clip space, z ∈ [−w, w]; may be off-axis).
    pub proj: Mat4,
    pub near: f32,
    pub far: f32,
    pub width: u32,
    pub height: u32,
}

/// Which faces to rasterize.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CullMode {
    None,
    /// Skip triangles whose winding is clockwise on screen (back-facing to the eye).
    Back,
}

/// One object to draw: a model mesh placed by a transform, optionally only a subset
/// of its triangles (indices into `mesh.triangles`).
#[derive(Clone, Copy, Debug)]
pub struct DrawItem<'a> {
    pub mesh: &'a Mesh,
    pub transform: Mat4,
    /// Linear RGB multiplier of the albedo (the instance's tint).
    pub tint: Vec3,
    /// Written to the object-ID buffer.
    pub object_id: u32,
    /// `None` = every triangle of the mesh.
    pub triangles: Option<&'a [u32]>,
}

/// The buffers of one capture, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    pub view: View,
    /// Eye-space depth (distance along the view axis, > 0); `f32::INFINITY` for background.
    pub depth: Vec<f32>,
    /// sRGB8 shaded colour (DESIGN.md formula); the sky colour for background.
    pub color: Vec<[u8; 4]>,
    /// `DrawItem::object_id` of the visible surface, or `BACKGROUND_ID`.
    pub object_id: Vec<u32>,
    /// Index into the mesh's `triangles` of the visible surface, or `BACKGROUND_ID`.
    pub triangle_id: Vec<u32>,
}
