//! The plain-old-data records the player hands to the GPU: model and proxy vertices,
//! per-instance data and the two uniform blocks, with their vertex-buffer layouts.
//! Their byte layouts are a contract with `shader.wgsl` (the vertex inputs by
//! `@location`, the uniform structs field by field), so each size and each
//! attribute offset is asserted at compile time, as `format`'s on-disk records are.
//!
//! Their own module (issue 14 item 5) so that the bake model ([`crate::bake`]), the
//! LOD baseline ([`crate::lod`]) and the renderer ([`crate::gpu`]) share them without
//! importing one another.

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4, Vec3};
use std::mem::{offset_of, size_of};

/// Most views a proxy may have: the pack's limit.
pub const MAX_VIEWS: usize = format::pack::cell::MAX_MV_VIEWS;

/// One vertex of an original model (model space).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ModelVertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
    /// sRGB8.
    pub albedo: [u8; 4],
    /// Texture coordinate of the model's albedo texture (0 without one).
    pub uv: [f32; 2],
}

impl ModelVertex {
    /// `vs_lit`'s per-vertex inputs: position, normal, albedo, uv at locations 0, 1,
    /// 2 and 11.
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 4] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4, 11 => Float32x2
    ];

    /// Buffer 0 of the lit pipelines.
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: size_of::<ModelVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES,
        }
    }
}

const _: () = assert!(size_of::<ModelVertex>() == 36);
const _: () = assert!(ModelVertex::ATTRIBUTES[1].offset == offset_of!(ModelVertex, normal) as u64);
const _: () = assert!(ModelVertex::ATTRIBUTES[2].offset == offset_of!(ModelVertex, albedo) as u64);
const _: () = assert!(ModelVertex::ATTRIBUTES[3].offset == offset_of!(ModelVertex, uv) as u64);

/// Per-instance data of an original.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct InstanceRaw {
    pub model: [[f32; 4]; 4],
    /// Inverse-transpose of the linear part (normals → world), columns.
    pub normal: [[f32; 4]; 3],
    /// Linear RGB multiplier, w unused.
    pub tint: [f32; 4],
}

impl InstanceRaw {
    pub fn new(transform: Mat4, tint: Vec3) -> InstanceRaw {
        let n = normal_matrix(&transform);
        InstanceRaw {
            model: transform.to_cols_array_2d(),
            normal: [
                n.x_axis.extend(0.0).to_array(),
                n.y_axis.extend(0.0).to_array(),
                n.z_axis.extend(0.0).to_array(),
            ],
            tint: tint.extend(1.0).to_array(),
        }
    }

    /// `vs_lit`'s per-instance inputs: the model matrix's columns (3–6), the normal
    /// matrix's (7–9), the tint (10).
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 8] = wgpu::vertex_attr_array![
        3 => Float32x4, 4 => Float32x4, 5 => Float32x4, 6 => Float32x4,
        7 => Float32x4, 8 => Float32x4, 9 => Float32x4, 10 => Float32x4
    ];

    /// Buffer 1 of the lit pipelines.
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: size_of::<InstanceRaw>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &Self::ATTRIBUTES,
        }
    }
}

const _: () = assert!(size_of::<InstanceRaw>() == 128);
const _: () = assert!(InstanceRaw::ATTRIBUTES[4].offset == offset_of!(InstanceRaw, normal) as u64);
const _: () = assert!(InstanceRaw::ATTRIBUTES[7].offset == offset_of!(InstanceRaw, tint) as u64);

/// Inverse-transpose of a transform's linear part (as the worker's rasterizer).
pub fn normal_matrix(m: &Mat4) -> Mat3 {
    let linear = Mat3::from_mat4(*m);
    if linear.determinant().abs() > 1e-30 {
        linear.inverse().transpose()
    } else {
        linear
    }
}

/// One vertex of a proxy triangle list (world space).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ProxyVertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
    /// sRGB8.
    pub albedo: [u8; 4],
    /// Linear RGB multiplier.
    pub tint: [f32; 3],
    /// Views that see this vertex's triangle (bit i = view i).
    pub mask: u32,
    /// The triangle's centroid (chooses the views, §3.2).
    pub centroid: [f32; 3],
    /// The proxy's kind (`format::pack::ProxyKind` as u32) for the representation
    /// colouring ([`crate::overlay::Representation`]).
    pub kind: u32,
}

impl ProxyVertex {
    /// `vs_proxy`'s inputs, locations 0–6 in field order.
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 7] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4, 3 => Float32x3, 4 => Uint32, 5 => Float32x3,
        6 => Uint32
    ];

    /// All zeros: what an empty proxy's one-vertex buffer holds.
    pub const ZERO: ProxyVertex = ProxyVertex {
        pos: [0.0; 3],
        normal: [0.0; 3],
        albedo: [0; 4],
        tint: [0.0; 3],
        mask: 0,
        centroid: [0.0; 3],
        kind: 0,
    };

    /// The proxy pipeline's only buffer.
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: size_of::<ProxyVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES,
        }
    }
}

const _: () = assert!(size_of::<ProxyVertex>() == 60);
const _: () = assert!(ProxyVertex::ATTRIBUTES[2].offset == offset_of!(ProxyVertex, albedo) as u64);
const _: () = assert!(ProxyVertex::ATTRIBUTES[3].offset == offset_of!(ProxyVertex, tint) as u64);
const _: () = assert!(ProxyVertex::ATTRIBUTES[4].offset == offset_of!(ProxyVertex, mask) as u64);
const _: () =
    assert!(ProxyVertex::ATTRIBUTES[5].offset == offset_of!(ProxyVertex, centroid) as u64);
const _: () = assert!(ProxyVertex::ATTRIBUTES[6].offset == offset_of!(ProxyVertex, kind) as u64);

/// View slots of a proxy's uniform (shader.wgsl `PROXY_SLOTS`): a lone proxy uses
/// its first [`MAX_VIEWS`]; a batch of proxies sharing one atlas up to all of them,
/// member by member at consecutive slots (`gpu::upload`, `create_batch`), so that one
/// bind group and one draw serve several multi-view proxies. On lavapipe each
/// switch to another bind group costs about 0.7 ms of frame time whatever it holds
/// (measured on the city walk: BENCHMARKS.md), far more than the draws themselves.
pub const PROXY_SLOTS: usize = 64;

/// A proxy's per-view uniform block (group 1, binding 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ProxyUniform {
    pub tex_from_world: [[f32; 16]; PROXY_SLOTS],
    pub view_eye: [[f32; 4]; PROXY_SLOTS],
    /// x: views; y: bit i = view i premultiplied by coverage (a batch has one
    /// encoding; bit 31 stands for slots 31 and up); z, w: the atlas's width and
    /// height in texels (0: no atlas, one texture per view).
    pub counts: [u32; 4],
    /// With an atlas (issue 30 item 7): view i's rectangle in it, (x, y, w, h) as
    /// fractions of the atlas's sides.
    pub rects: [[f32; 4]; PROXY_SLOTS],
}

const _: () = assert!(size_of::<ProxyUniform>() == 96 * PROXY_SLOTS + 16);
const _: () = assert!(PROXY_SLOTS >= MAX_VIEWS && PROXY_SLOTS <= 255);

/// The frame's uniform block (group 0, binding 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Globals {
    pub clip_from_world: [f32; 16],
    pub eye: [f32; 4],
    /// x: 1 = colour by representation
    /// ([`crate::gpu::Renderer::set_representation_colours`]).
    pub debug: [u32; 4],
    /// Linear RGB per [`crate::overlay::Representation`].
    pub palette: [[f32; 4]; 8],
}

const _: () = assert!(size_of::<Globals>() == 224);

#[cfg(test)]
mod slot_tests {
    use super::PROXY_SLOTS;

    /// The shader's and the browser viewer's proxy uniform have the slots the
    /// player writes (a mismatch would shift every eye and rectangle).
    #[test]
    fn the_shader_and_the_web_viewer_agree_on_proxy_slots() {
        let wgsl = include_str!("shader.wgsl");
        assert!(wgsl.contains(&format!("const PROXY_SLOTS: u32 = {PROXY_SLOTS}u;")));
        let ts = include_str!("../web/src/scene.ts");
        assert!(ts.contains(&format!("export const PROXY_SLOTS = {PROXY_SLOTS};")));
    }
}
