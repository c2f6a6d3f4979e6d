//! Vertex weights from an object's depth image (paper 000 §3.1.3.2; 003 §4.1.4).
//!
//! The weight says how much a vertex matters to the simplification (000 §3.1.3.3
//! collapses the vertex of smaller weight). Following 000 §3.1.3.2:
//!
//! 1. A vertex is **back-facing** w.r.t. the cell's centre (the capture's eye) when all
//!    triangles incident to it are back-facing — the paper's definition, not the
//!    vertex normal's. Back-facing vertices get 0.5, like the exterior silhouette
//!    ([`BACK_FACING_WEIGHT`]). A vertex no triangle references is back-facing by
//!    that definition (it never takes part in a collapse anyway).
//! 2. Every other (front-facing) vertex is projected into the capture and tested
//!    against the depth buffer ([`crate::visibility`], module docs: visible when it
//!    lies at most one pixel footprint behind the plane of the triangle seen at its own
//!    pixel — the triangle-ID buffer names it — measured along that plane's normal, or
//!    when its own pixel is empty). A visible vertex gets the weight of the class of
//!    the pixel it projects to ([`crate::classify::PixelClass::weight`]: 0.5 / 0.4 /
//!    0.25 / 0.125): its own pixel, or, when that does not show the object (a vertex
//!    on the outline whose pixel centre the object misses), the object pixel nearest
//!    to its projection in the 3×3 around it.
//! 3. An invisible front-facing vertex gets 0.05 ([`INVISIBLE_WEIGHT`]), "smaller than
//!    vertices corresponding to the pixel category interior". A front-facing vertex
//!    projecting outside the capture (outside the window, behind the eye, beyond
//!    near/far) is not seen from the centre either and also gets 0.05.
//!
//! A visible vertex with no pixel of its object around it (its own pixel empty or
//! showing another object farther away, and none of the 3×3 showing its object) is a
//! sub-pixel part of the object on the outline of its coverage, and gets the
//! exterior-silhouette weight.

use crate::backface::{front_facing_vertices_of, world_positions};
use crate::classify::PixelClass;
use crate::raster::Capture;
use crate::visibility::{depth_visibility_of, DepthTolerance, DepthVisibility};
use format::Mesh;
use glam::{Mat4, Vec3};

/// Weight of a vertex whose incident triangles all face away from the eye (000 §3.1.3.2).
pub const BACK_FACING_WEIGHT: f32 = 0.5;
/// Weight of a front-facing vertex hidden from the eye (000 §3.1.3.2).
pub const INVISIBLE_WEIGHT: f32 = 0.05;

/// How a vertex was weighted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexState {
    /// All incident triangles face away from the eye.
    BackFacing,
    /// Front-facing and visible; the class of the pixel it projects to.
    Visible(PixelClass),
    /// Front-facing but hidden, or outside the capture.
    Invisible,
}

impl VertexState {
    pub fn weight(self) -> f32 {
        match self {
            VertexState::BackFacing => BACK_FACING_WEIGHT,
            VertexState::Visible(class) => class.weight(),
            VertexState::Invisible => INVISIBLE_WEIGHT,
        }
    }
}

/// The state of every vertex of `mesh` (placed by `transform`, drawn as `object_id`)
/// in `capture`, whose pixel classes are `classes` (from
/// [`crate::classify::classify`]). The eye is `capture.view.eye`. For MvMesh view sets
/// (000 §3.1.4), `Visible` is the "vertex visible to this view" flag.
pub fn vertex_states(
    mesh: &Mesh,
    transform: Mat4,
    capture: &Capture,
    classes: &[PixelClass],
    object_id: u32,
    depth_tolerance: DepthTolerance,
) -> Vec<VertexState> {
    vertex_states_captured(
        mesh,
        &mesh.triangles,
        &mesh.triangles,
        transform,
        capture,
        classes,
        object_id,
        depth_tolerance,
    )
}

/// [`vertex_states`] of a level of the model's LOD chain (`mesh`: the model's
/// vertices; `triangles`: the level's) in the capture of the full model, whose
/// triangles are `captured_triangles`: "front-facing" is judged on the level's
/// triangles, the depth test's surface plane on the captured triangle under the
/// vertex's pixel (the triangle-ID buffer indexes the captured mesh, not the level).
#[allow(clippy::too_many_arguments)]
pub fn vertex_states_captured(
    mesh: &Mesh,
    triangles: &[[u32; 3]],
    captured_triangles: &[[u32; 3]],
    transform: Mat4,
    capture: &Capture,
    classes: &[PixelClass],
    object_id: u32,
    depth_tolerance: DepthTolerance,
) -> Vec<VertexState> {
    // Step 1: per vertex, "some incident triangle is front-facing" from the eye.
    let world = world_positions(mesh, transform);
    let front_facing_vertex = front_facing_vertices_of(&world, triangles, capture.view.eye);
    // Steps 2–3: depth-buffer visibility of the front-facing vertices, combined.
    states_gated(
        &world,
        &front_facing_vertex,
        captured_triangles,
        capture,
        classes,
        object_id,
        depth_tolerance,
    )
}

/// The state every vertex of the model (`mesh`: the captured mesh) would have if it
/// were front-facing: [`vertex_states_captured`] before its front-facing test,
/// which depends on the triangles of the start mesh (a level of the model's chain)
/// while this does not. [`with_front_facing`] finishes it for a start mesh; so one
/// capture serves every level ([`crate::capture_memo`]).
pub fn vertex_states_if_front(
    mesh: &Mesh,
    transform: Mat4,
    capture: &Capture,
    classes: &[PixelClass],
    object_id: u32,
    depth_tolerance: DepthTolerance,
) -> Vec<VertexState> {
    let world = world_positions(mesh, transform);
    let every = vec![true; world.len()];
    states_gated(
        &world,
        &every,
        &mesh.triangles,
        capture,
        classes,
        object_id,
        depth_tolerance,
    )
}

/// [`vertex_states_captured`] from [`vertex_states_if_front`]'s states: a vertex of
/// `start` (the model's vertices) none of whose `start_triangles` (a level's)
/// faces `eye` is back-facing, any other keeps its state. Equal to
/// [`vertex_states_captured`] of `start` in the same capture.
pub fn with_front_facing(
    if_front: &[VertexState],
    start: &Mesh,
    start_triangles: &[[u32; 3]],
    transform: Mat4,
    eye: Vec3,
) -> Vec<VertexState> {
    let world = world_positions(start, transform);
    let front = front_facing_vertices_of(&world, start_triangles, eye);
    front
        .iter()
        .zip(if_front)
        .map(|(&f, &s)| if f { s } else { VertexState::BackFacing })
        .collect()
}

/// Steps 2–3 of [`vertex_states_captured`] for the vertices at `world` whose
/// `front_facing` flag is given.
fn states_gated(
    world: &[Vec3],
    front_facing_vertex: &[bool],
    captured_triangles: &[[u32; 3]],
    capture: &Capture,
    classes: &[PixelClass],
    object_id: u32,
    depth_tolerance: DepthTolerance,
) -> Vec<VertexState> {
    // Step 2: depth-buffer visibility and the pixel each visible vertex projects to.
    let visibility = depth_visibility_of(
        world,
        front_facing_vertex,
        captured_triangles,
        capture,
        object_id,
        depth_tolerance,
    );
    // Step 3: combine.
    front_facing_vertex
        .iter()
        .zip(&visibility)
        .map(|(&front, vis)| {
            if !front {
                return VertexState::BackFacing;
            }
            match *vis {
                DepthVisibility::Visible { pixel, own_object } => {
                    let class = if own_object {
                        classes
                            .get(pixel)
                            .copied()
                            .unwrap_or(PixelClass::Background)
                    } else {
                        PixelClass::ExteriorSilhouette
                    };
                    // A pixel of the object is never Background in its own class map;
                    // if the caller passed another object's map, fall back to the
                    // outline class rather than weight 0.
                    if class == PixelClass::Background {
                        VertexState::Visible(PixelClass::ExteriorSilhouette)
                    } else {
                        VertexState::Visible(class)
                    }
                }
                DepthVisibility::Hidden | DepthVisibility::Outside => VertexState::Invisible,
            }
        })
        .collect()
}

/// The weight of every vertex (000 §3.1.3.2; see [`vertex_states`]).
pub fn vertex_weights(
    mesh: &Mesh,
    transform: Mat4,
    capture: &Capture,
    classes: &[PixelClass],
    object_id: u32,
    depth_tolerance: DepthTolerance,
) -> Vec<f32> {
    vertex_states(
        mesh,
        transform,
        capture,
        classes,
        object_id,
        depth_tolerance,
    )
    .into_iter()
    .map(VertexState::weight)
    .collect()
}
