//! glTF 2.0 (`.gltf` + buffers, or `.glb`) through the `gltf` crate: every triangle
//! primitive (modes TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN) of every node of the
//! default scene (else the first scene), with node transforms composed from the root
//! (a node with two parents, a root with one — hence any cycle — or a hierarchy
//! deeper than [`MAX_DEPTH`] is an error). Mirroring transforms flip the winding so triangles stay CCW. Colours:
//! `COLOR_0` × the material's base colour factor (both linear, converted to sRGB8)
//! when any primitive has `COLOR_0` or a non-white factor; else the procedural
//! albedo. Textures are not read (images are never decoded).

use super::{parse_error, Location, ModelFormat, Parsed};
use crate::cleanup::RawMesh;
use crate::load::LoadError;
use format::srgb::linear_to_srgb_powf;
use glam::{Mat3, Mat4, Vec3};
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Gltf;

/// Deepest node hierarchy accepted.
pub const MAX_DEPTH: usize = 256;

struct Prim {
    positions: Vec<[f32; 3]>,
    colors: Option<Vec<[f32; 4]>>,
    factor: [f32; 4],
    triangles: Vec<[u32; 3]>,
}

/// Parses and validates a glTF document and loads its buffers (shared with the
/// scene reader, `gltf_scene.rs`).
pub(crate) fn open_document(
    path: &Path,
    bytes: &[u8],
) -> Result<(gltf::Document, Vec<gltf::buffer::Data>), LoadError> {
    let err = |what: String, at: Location| parse_error(path, FORMAT, what, at);
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| err(e.to_string(), Location::Unknown))?;
    // Validate, tolerating only missing POSITION bounds (`min`/`max`), which many
    // exporters omit and which are not used here.
    {
        use gltf::json::validation::{Error as V, Validate};
        let root = document.as_json();
        let mut errors: Vec<String> = Vec::new();
        root.validate(root, gltf::json::Path::new, &mut |path, error| {
            let path = path();
            let bounds = path.as_str().ends_with(".min") || path.as_str().ends_with(".max");
            if !(bounds && matches!(error, V::Missing)) {
                errors.push(format!("{}: {error}", path.as_str()));
            }
        });
        if !errors.is_empty() {
            return Err(err(
                format!("invalid glTF: {}", errors.join("; ")),
                Location::Unknown,
            ));
        }
    }
    check_structure(path, document.as_json())?;
    let base = path.parent();
    let buffers = gltf::import_buffers(&document, base, blob)
        .map_err(|e| err(format!("buffers: {e}"), Location::Unknown))?;
    check_accessors(path, document.as_json(), &buffers)?;
    Ok((document, buffers))
}

pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Parsed, LoadError> {
    let err = |what: String, at: Location| parse_error(path, FORMAT, what, at);
    let (document, buffers) = open_document(path, bytes)?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| err("no scene".into(), Location::Unknown))?;

    // Walk the node tree depth-first, composing transforms.
    let mut prims: Vec<Prim> = Vec::new();
    let mut nodes_with_geometry = 0usize;
    walk_nodes(path, &scene, |node, world, _| {
        if let Some(mesh) = node.mesh() {
            let before = prims.len();
            for primitive in mesh.primitives() {
                if let Some(p) = read_primitive(path, &buffers, &mesh, &primitive, world)? {
                    prims.push(p);
                }
            }
            if prims.len() > before {
                nodes_with_geometry += 1;
            }
        }
        Ok(())
    })?;

    // Concatenate the primitives.
    let any_colors = prims
        .iter()
        .any(|p| p.colors.is_some() || p.factor != [1.0; 4]);
    let mut raw = RawMesh {
        colors: any_colors.then(Vec::new),
        ..RawMesh::default()
    };
    for p in &prims {
        let base = u32::try_from(raw.positions.len())
            .map_err(|_| err("too many vertices".into(), Location::Unknown))?;
        raw.positions.extend_from_slice(&p.positions);
        if let Some(colors) = &mut raw.colors {
            colors.extend(vertex_srgb8(
                p.colors.as_deref(),
                p.factor,
                p.positions.len(),
            ));
        }
        raw.triangles.extend(
            p.triangles
                .iter()
                .map(|t| t.map(|i| base.saturating_add(i))),
        );
    }
    Ok(Parsed {
        raw,
        nodes: nodes_with_geometry,
        parts: prims.len(),
    })
}

/// Every accessor fits its buffer view and every buffer view its buffer, checked on
/// the JSON and the loaded buffers before the gltf crate reads a value (issue 32
/// item 4: its reader stops silently at the end of a short view, so an index accessor
/// whose count exceeds its view gave 2 of 12 triangles). glTF 2.0 §3.6.2.4: an
/// element `i` starts at `byteOffset + i · stride`, `stride` the view's
/// `byteStride` or the element's size. Accessors without a view (all zeros, or
/// sparse) hold no bytes to check.
fn check_accessors(
    path: &Path,
    root: &gltf::json::Root,
    buffers: &[gltf::buffer::Data],
) -> Result<(), LoadError> {
    use gltf::json::validation::Checked;
    let err = |what: String, at: String| parse_error(path, FORMAT, what, Location::Element(at));
    for (v, view) in root.buffer_views.iter().enumerate() {
        let have = buffers
            .get(view.buffer.value())
            .map_or(0, |b| b.len() as u64);
        let end = view
            .byte_offset
            .map_or(0, |o| o.0)
            .saturating_add(view.byte_length.0);
        if end > have {
            return Err(err(
                format!(
                    "bytes up to {end} of buffer {}, which has {have}",
                    view.buffer.value()
                ),
                format!("bufferView {v}"),
            ));
        }
    }
    for (a, accessor) in root.accessors.iter().enumerate() {
        let (Some(view_index), Checked::Valid(component), Checked::Valid(kind)) = (
            accessor.buffer_view,
            &accessor.component_type,
            &accessor.type_,
        ) else {
            continue;
        };
        let Some(view) = root.buffer_views.get(view_index.value()) else {
            continue; // the crate's validation names a missing view
        };
        let element = (component.0.size() * kind.multiplicity()) as u64;
        let stride = view.byte_stride.map_or(element, |s| s.0 as u64);
        let count = accessor.count.0;
        let offset = accessor.byte_offset.map_or(0, |o| o.0);
        let need = if count == 0 {
            offset
        } else {
            offset
                .saturating_add((count - 1).saturating_mul(stride))
                .saturating_add(element)
        };
        if need > view.byte_length.0 {
            return Err(err(
                format!(
                    "{count} elements of {element} bytes (stride {stride}, offset {offset}) \
                     need {need} bytes of bufferView {}, which has {}",
                    view_index.value(),
                    view.byte_length.0
                ),
                format!("accessor {a}"),
            ));
        }
    }
    Ok(())
}

/// What the gltf crate's validation leaves to the reader (issue 32 item 4), checked
/// on the JSON before any node is walked, each refusal naming the node:
///
/// - `asset.version` must be 2.x (the only glTF this reader knows);
/// - every node has at most one parent, and a scene's root nodes none (glTF 2.0
///   §3.5.3: the hierarchy is a set of disjoint trees). A node listed twice, by one
///   parent or two, would otherwise be visited once per path: 40 nodes that each
///   list the next twice make 2⁴⁰ visits;
/// - a rotation is a unit quaternion (§5.25; a zero quaternion is not a rotation);
///   1 % of slack for exporters' rounding.
fn check_structure(path: &Path, root: &gltf::json::Root) -> Result<(), LoadError> {
    let err = |what: String, at: Location| parse_error(path, FORMAT, what, at);
    let version = root.asset.version.as_str();
    if version.split('.').next() != Some("2") {
        return Err(err(
            format!("asset.version {version:?}: hexbake reads glTF 2.x"),
            Location::Element("asset".into()),
        ));
    }
    let node_name = |i: usize| {
        root.nodes
            .get(i)
            .and_then(|n| n.name.as_deref())
            .map_or(format!("node {i}"), |name| format!("node {i} ({name:?})"))
    };
    let mut parent: Vec<Option<usize>> = vec![None; root.nodes.len()];
    for (p, node) in root.nodes.iter().enumerate() {
        for child in node.children.iter().flatten() {
            let c = child.value();
            let Some(slot) = parent.get_mut(c) else {
                continue; // an index out of range: the validation reported it
            };
            if let Some(first) = *slot {
                let what = if first == p {
                    format!("{} lists {} twice as a child", node_name(p), node_name(c))
                } else {
                    format!(
                        "{} is a child of {} and of {}",
                        node_name(c),
                        node_name(first),
                        node_name(p)
                    )
                };
                return Err(err(
                    format!("{what}: a glTF node has at most one parent (glTF 2.0 §3.5.3)"),
                    Location::Element(format!("node {c}")),
                ));
            }
            *slot = Some(p);
        }
        if let Some(q) = node.rotation.as_ref().map(|r| r.0) {
            let len = q.iter().map(|v| v * v).sum::<f32>().sqrt();
            if (len - 1.0).abs().is_nan() || (len - 1.0).abs() > 0.01 {
                return Err(err(
                    format!(
                        "{}: rotation {q:?} is not a unit quaternion (length {len})",
                        node_name(p)
                    ),
                    Location::Element(format!("node {p}")),
                ));
            }
        }
    }
    for (k, scene) in root.scenes.iter().enumerate() {
        for n in &scene.nodes {
            if let Some(Some(p)) = parent.get(n.value()) {
                return Err(err(
                    format!(
                        "{} is a root of scene {k} and a child of {}: a scene's root nodes have no parent",
                        node_name(n.value()),
                        node_name(*p)
                    ),
                    Location::Element(format!("node {}", n.value())),
                ));
            }
        }
    }
    Ok(())
}

/// Walks the node tree of `scene` depth-first in document order, composing
/// transforms, and calls `visit` with each node, its world transform and its parent
/// (index and world transform; `None` for a root node). The hierarchy is a set of
/// trees ([`check_structure`] ran in [`open_document`]: no node has two parents, no
/// root has one, so no cycle is reachable); refuses one deeper than [`MAX_DEPTH`]
/// and a transform that is not finite, where it meets them. Shared by the model
/// loader and the scene loader (`gltf_scene.rs`).
pub(super) fn walk_nodes<'a>(
    path: &Path,
    scene: &gltf::Scene<'a>,
    mut visit: impl FnMut(&gltf::Node<'a>, Mat4, Option<(usize, Mat4)>) -> Result<(), LoadError>,
) -> Result<(), LoadError> {
    let err = |what: String, at: Location| parse_error(path, FORMAT, what, at);
    // (node, its parent's index and world transform, depth).
    type Parent = Option<(usize, Mat4)>;
    let mut stack: Vec<(gltf::Node, Parent, usize)> = scene.nodes().map(|n| (n, None, 0)).collect();
    stack.reverse();
    while let Some((node, parent, depth)) = stack.pop() {
        let at = || Location::Element(format!("node {}", node.index()));
        if depth >= MAX_DEPTH {
            return Err(err(format!("node hierarchy deeper than {MAX_DEPTH}"), at()));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent.map_or(Mat4::IDENTITY, |(_, w)| w) * local;
        if !world.is_finite() {
            return Err(err("node transform is not finite".into(), at()));
        }
        visit(&node, world, parent)?;
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, Some((node.index(), world)), depth + 1));
        }
    }
    Ok(())
}

/// The triangles of a primitive of `mode` (triangles, strip or fan) from its indices
/// (`None`: the vertices in order), checked against its `n` vertices. Shared by the
/// model loader and the scene loader (`gltf_scene.rs`).
pub(super) fn primitive_triangles(
    indices: Option<Vec<u32>>,
    mode: gltf::mesh::Mode,
    n: usize,
    err: &dyn Fn(String) -> LoadError,
) -> Result<Vec<[u32; 3]>, LoadError> {
    use gltf::mesh::Mode;
    let indices: Vec<u32> = match indices {
        Some(i) => i,
        None => {
            let n = u32::try_from(n).map_err(|_| err("too many vertices".into()))?;
            (0..n).collect()
        }
    };
    let triangles: Vec<[u32; 3]> = match mode {
        // glTF 2.0 §3.7.2.1: TRIANGLES takes whole triples; a count that is not a
        // multiple of 3 is a broken file, not a hint to drop the rest.
        Mode::Triangles if !indices.len().is_multiple_of(3) => {
            return Err(err(format!(
                "{} indices for TRIANGLES, not a multiple of 3",
                indices.len()
            )));
        }
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        Mode::TriangleStrip => indices
            .windows(3)
            .enumerate()
            .map(|(k, t)| {
                if k % 2 == 0 {
                    [t[0], t[1], t[2]]
                } else {
                    [t[1], t[0], t[2]]
                }
            })
            .collect(),
        _ => (1..indices.len().saturating_sub(1))
            .map(|k| [indices[0], indices[k], indices[k + 1]])
            .collect(),
    };
    if let Some((face, t)) = triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
    {
        return Err(err(format!(
            "triangle {face} uses vertex {}, but the primitive has only {n} vertices",
            t.iter().copied().max().unwrap_or(0)
        )));
    }
    Ok(triangles)
}

/// The error of primitive `primitive` of `mesh` in `path`: its location names both.
/// Shared by the model loader and the scene loader (`gltf_scene.rs`).
pub(super) fn primitive_error<'p>(
    path: &'p Path,
    mesh: &gltf::Mesh,
    primitive: &gltf::Primitive,
) -> impl Fn(String) -> LoadError + 'p {
    let (mesh, primitive) = (mesh.index(), primitive.index());
    move |what| {
        let at = Location::Element(format!("mesh {mesh} primitive {primitive}"));
        parse_error(path, FORMAT, what, at)
    }
}

/// How every primitive reader starts: `None` for points and lines; for a triangle
/// primitive its mode, its attribute reader and its POSITION attribute (mesh space).
/// Shared by the model loader and the scene loader (`gltf_scene.rs`).
#[allow(clippy::type_complexity)]
pub(super) fn open_triangle_primitive<'a, 's>(
    buffers: &'s [gltf::buffer::Data],
    primitive: &'a gltf::Primitive<'a>,
    err: &dyn Fn(String) -> LoadError,
) -> Result<
    Option<(
        gltf::mesh::Mode,
        gltf::mesh::Reader<'a, 's, impl Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>>,
        Vec<[f32; 3]>,
    )>,
    LoadError,
> {
    use gltf::mesh::Mode;
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(None);
    }
    let reader = primitive.reader(move |b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<[f32; 3]> = reader
        .read_positions()
        .ok_or_else(|| err("no POSITION attribute".into()))?
        .collect();
    Ok(Some((mode, reader, positions)))
}

/// The sRGB8 colours of a primitive's `n` vertices: `COLOR_0` (`colors`; white
/// where absent) × the base colour `factor`, both linear; alpha 255. Shared by the
/// model loader and the scene loader (`gltf_scene.rs`).
pub(super) fn vertex_srgb8(
    colors: Option<&[[f32; 4]]>,
    factor: [f32; 4],
    n: usize,
) -> impl Iterator<Item = [u8; 4]> + '_ {
    (0..n).map(move |i| {
        let c = colors.and_then(|c| c.get(i)).copied().unwrap_or([1.0; 4]);
        [
            linear_to_srgb_powf(c[0] * factor[0]),
            linear_to_srgb_powf(c[1] * factor[1]),
            linear_to_srgb_powf(c[2] * factor[2]),
            255,
        ]
    })
}

/// One primitive in world space; `None` for points and lines.
fn read_primitive(
    path: &Path,
    buffers: &[gltf::buffer::Data],
    mesh: &gltf::Mesh,
    primitive: &gltf::Primitive,
    world: Mat4,
) -> Result<Option<Prim>, LoadError> {
    let err = primitive_error(path, mesh, primitive);
    let Some((mode, reader, mut positions)) = open_triangle_primitive(buffers, primitive, &err)?
    else {
        return Ok(None);
    };
    for p in &mut positions {
        *p = world.transform_point3(Vec3::from(*p)).to_array();
    }
    let colors = reader
        .read_colors(0)
        .map(|c| c.into_rgba_f32().collect::<Vec<_>>());
    let indices = reader.read_indices().map(|i| i.into_u32().collect());
    let mut triangles = primitive_triangles(indices, mode, positions.len(), &err)?;
    if Mat3::from_mat4(world).determinant() < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    let factor = primitive
        .material()
        .pbr_metallic_roughness()
        .base_color_factor();
    Ok(Some(Prim {
        positions,
        colors,
        factor,
        triangles,
    }))
}
