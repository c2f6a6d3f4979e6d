//! glTF 2.0 (`.gltf` + buffers, or `.glb`) through the `gltf` crate: every triangle
//! primitive (modes TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN) of every node of the
//! default scene (else the first scene), with node transforms composed from the root
//! (a node with two parents, a root with one — hence any cycle —, a node the walk
//! meets twice or a hierarchy deeper than [`MAX_DEPTH`] is an error). Mirroring
//! transforms flip the winding so triangles stay CCW. What one file may make is
//! capped ([`GltfCaps`]). Colours:
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

/// Caps on what one glTF file may make (issue 32 item 4), each refusal naming where
/// it was passed; the defaults are `format::limits`' `MAX_GLTF_*`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GltfCaps {
    /// Instances a scene places (the scene reader; refused at the node that passes it).
    pub instances: u64,
    /// Triangles read, over every primitive read: a primitive read again for another
    /// model (a mesh at another non-uniform scale) counts again. Checked on the
    /// counts the accessors announce, before the primitive is read.
    pub triangles: u64,
    /// Vertices (POSITION elements) read, counted alike.
    pub vertices: u64,
}

impl Default for GltfCaps {
    fn default() -> Self {
        GltfCaps {
            instances: format::limits::MAX_GLTF_INSTANCES,
            triangles: format::limits::MAX_GLTF_TRIANGLES,
            vertices: format::limits::MAX_GLTF_VERTICES,
        }
    }
}

/// What has been read from one file so far, against its [`GltfCaps`].
pub(crate) struct Budget {
    pub(crate) caps: GltfCaps,
    vertices: u64,
    triangles: u64,
}

impl Budget {
    pub(crate) fn new(caps: GltfCaps) -> Budget {
        Budget {
            caps,
            vertices: 0,
            triangles: 0,
        }
    }

    /// Counts a primitive of `vertices` and `triangles` about to be read, or refuses
    /// it when the file's total would pass a cap.
    fn take(
        &mut self,
        vertices: u64,
        triangles: u64,
        err: &dyn Fn(String) -> LoadError,
    ) -> Result<(), LoadError> {
        let v = self.vertices.saturating_add(vertices);
        if v > self.caps.vertices {
            return Err(err(format!(
                "{v} vertices read from this file ({vertices} in this primitive) would pass \
                 the cap of {} vertices for one glTF file",
                self.caps.vertices
            )));
        }
        let t = self.triangles.saturating_add(triangles);
        if t > self.caps.triangles {
            return Err(err(format!(
                "{t} triangles read from this file ({triangles} in this primitive) would \
                 pass the cap of {} triangles for one glTF file",
                self.caps.triangles
            )));
        }
        (self.vertices, self.triangles) = (v, t);
        Ok(())
    }
}

/// `node 3`, or `node 3 ("name")` when the node has a name: how every message names a
/// node.
pub(super) fn node_label(index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("node {index} ({name:?})"),
        None => format!("node {index}"),
    }
}

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
    let mut budget = Budget::new(GltfCaps::default());
    walk_nodes(path, &scene, |node, world, _| {
        if let Some(mesh) = node.mesh() {
            let before = prims.len();
            for primitive in mesh.primitives() {
                if let Some(p) =
                    read_primitive(path, &buffers, &mut budget, &mesh, &primitive, world)?
                {
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
/// `byteStride` or the element's size. Also:
///
/// - a count of at least 1 (§5.1.2; the crate computes `count − 1`);
/// - a stride no shorter than the element (elements would overlap; the crate only
///   debug-asserts it);
/// - a sparse accessor (§3.6.2.3): `1 ≤ sparse.count ≤ count`, its indices and
///   values in their views, and the indices strictly increasing and below `count`
///   (the crate drops a substitution whose index it never meets, silently).
///
/// An accessor without a view is all zeros but for its sparse substitutions: no bytes
/// bound its count, the caps on what a primitive reads do ([`GltfCaps`]).
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
    // The bytes `count` elements of `element` bytes from `offset` need in view
    // `index` (its stride or the element's size), or why they do not fit.
    let fits = |what: &str,
                index: usize,
                count: u64,
                element: u64,
                offset: u64|
     -> Result<&gltf::json::buffer::View, String> {
        let Some(view) = root.buffer_views.get(index) else {
            return Err(format!("{what}: no bufferView {index}"));
        };
        let stride = view.byte_stride.map_or(element, |s| s.0 as u64);
        if stride < element {
            return Err(format!(
                "{what}: stride {stride} of bufferView {index} is shorter than the \
                 elements of {element} bytes: they would overlap"
            ));
        }
        let need = if count == 0 {
            offset
        } else {
            offset
                .saturating_add((count - 1).saturating_mul(stride))
                .saturating_add(element)
        };
        if need > view.byte_length.0 {
            return Err(format!(
                "{what}: {count} elements of {element} bytes (stride {stride}, offset \
                 {offset}) need {need} bytes of bufferView {index}, which has {}",
                view.byte_length.0
            ));
        }
        Ok(view)
    };
    for (a, accessor) in root.accessors.iter().enumerate() {
        let at = || format!("accessor {a}");
        let count = accessor.count.0;
        if count == 0 {
            return Err(err(
                "count 0: an accessor has at least one element (glTF 2.0 §5.1.2)".into(),
                at(),
            ));
        }
        let (Checked::Valid(component), Checked::Valid(kind)) =
            (&accessor.component_type, &accessor.type_)
        else {
            continue; // the crate's validation named it
        };
        let element = (component.0.size() * kind.multiplicity()) as u64;
        if let Some(view) = accessor.buffer_view {
            let offset = accessor.byte_offset.map_or(0, |o| o.0);
            fits("elements", view.value(), count, element, offset)
                .map_err(|what| err(what, at()))?;
        }
        let Some(sparse) = &accessor.sparse else {
            continue;
        };
        let n = sparse.count.0;
        if n == 0 || n > count {
            return Err(err(
                format!(
                    "sparse count {n}, the accessor has {count} elements (glTF 2.0 \
                     §3.6.2.3: 1 ..= count substitutions)"
                ),
                at(),
            ));
        }
        let Checked::Valid(index_type) = &sparse.indices.component_type else {
            continue;
        };
        let index_size = index_type.0.size() as u64;
        let index_offset = sparse.indices.byte_offset.0;
        let index_view = fits(
            "sparse indices",
            sparse.indices.buffer_view.value(),
            n,
            index_size,
            index_offset,
        )
        .map_err(|what| err(what, at()))?;
        fits(
            "sparse values",
            sparse.values.buffer_view.value(),
            n,
            element,
            sparse.values.byte_offset.0,
        )
        .map_err(|what| err(what, at()))?;
        // The indices themselves: in range of the buffer (the view fits it, checked
        // above), strictly increasing, below the count.
        let Some(bytes) = buffers.get(index_view.buffer.value()) else {
            continue;
        };
        let stride = index_view.byte_stride.map_or(index_size, |s| s.0 as u64);
        let start = index_view
            .byte_offset
            .map_or(0, |o| o.0)
            .saturating_add(index_offset);
        let mut previous: Option<u64> = None;
        for k in 0..n {
            let at_byte = (start + k * stride) as usize;
            let b = bytes
                .get(at_byte..at_byte + index_size as usize)
                .ok_or_else(|| err(format!("sparse index {k} is past its buffer"), at()))?;
            let value = b
                .iter()
                .rev()
                .fold(0u64, |acc, &byte| (acc << 8) | u64::from(byte));
            if value >= count {
                return Err(err(
                    format!("sparse index {k} is {value}: not below {count}, the accessor's count"),
                    at(),
                ));
            }
            if previous.is_some_and(|p| value <= p) {
                return Err(err(
                    format!(
                        "sparse index {k} is {value}, not above the one before ({}): sparse \
                         indices strictly increase (glTF 2.0 §3.6.2.3)",
                        previous.unwrap_or(0)
                    ),
                    at(),
                ));
            }
            previous = Some(value);
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
    let node_name = |i: usize| node_label(i, root.nodes.get(i).and_then(|n| n.name.as_deref()));
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
/// root has one, so no cycle is reachable), and the walk meets each node once: a node
/// met again (a scene listing a root twice) is refused, as are a hierarchy deeper
/// than [`MAX_DEPTH`] and a transform that is not finite, where the walk meets them.
/// Memory is one frame per level (each holding its node's child iterator), whatever
/// the width. Shared by the model loader and the scene loader (`gltf_scene.rs`).
pub(super) fn walk_nodes<'a>(
    path: &Path,
    scene: &gltf::Scene<'a>,
    mut visit: impl FnMut(&gltf::Node<'a>, Mat4, Option<(usize, Mat4)>) -> Result<(), LoadError>,
) -> Result<(), LoadError> {
    let err = |what: String, node: &gltf::Node| {
        parse_error(
            path,
            FORMAT,
            what,
            Location::Element(format!("node {}", node.index())),
        )
    };
    // One level of the walk: a node, its world transform, its children to visit.
    struct Frame<'a> {
        index: usize,
        world: Mat4,
        children: gltf::scene::iter::Children<'a>,
    }
    let mut visited: Vec<bool> = Vec::new();
    let mut stack: Vec<Frame<'a>> = Vec::new();
    let mut enter = |node: gltf::Node<'a>,
                     parent: Option<(usize, Mat4)>,
                     depth: usize,
                     stack: &mut Vec<Frame<'a>>|
     -> Result<(), LoadError> {
        let i = node.index();
        if i >= visited.len() {
            visited.resize(i + 1, false);
        }
        if std::mem::replace(&mut visited[i], true) {
            return Err(err(
                format!(
                    "{} is visited twice in the walk of scene {}: each node is one place \
                     in the hierarchy (a scene lists it twice among its roots)",
                    node_label(i, node.name()),
                    scene.index()
                ),
                &node,
            ));
        }
        if depth >= MAX_DEPTH {
            return Err(err(
                format!("node hierarchy deeper than {MAX_DEPTH}"),
                &node,
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent.map_or(Mat4::IDENTITY, |(_, w)| w) * local;
        if !world.is_finite() {
            return Err(err("node transform is not finite".into(), &node));
        }
        visit(&node, world, parent)?;
        stack.push(Frame {
            index: i,
            world,
            children: node.children(),
        });
        Ok(())
    };
    for root in scene.nodes() {
        enter(root, None, 0, &mut stack)?;
        while let Some(frame) = stack.last_mut() {
            match frame.children.next() {
                Some(child) => {
                    let parent = Some((frame.index, frame.world));
                    let depth = stack.len();
                    enter(child, parent, depth, &mut stack)?;
                }
                None => {
                    stack.pop();
                }
            }
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
/// Before anything is read, every attribute must have POSITION's count (glTF 2.0
/// §3.7.2.1: a shorter COLOR_0 was read as white past its end) and the primitive's
/// vertices and triangles, as its accessors announce them, must fit `budget`.
/// Shared by the model loader and the scene loader (`gltf_scene.rs`).
#[allow(clippy::type_complexity)]
pub(super) fn open_triangle_primitive<'a, 's>(
    buffers: &'s [gltf::buffer::Data],
    budget: &mut Budget,
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
    let position = primitive
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| err("no POSITION attribute".into()))?;
    let n = position.count();
    for (semantic, accessor) in primitive.attributes() {
        if accessor.count() != n {
            return Err(err(format!(
                "{} (accessor {}) has {} elements, POSITION (accessor {}) has {n}: a \
                 primitive's attributes have one count (glTF 2.0 §3.7.2.1)",
                semantic.to_string(),
                accessor.index(),
                accessor.count(),
                position.index()
            )));
        }
    }
    let corners = primitive.indices().map_or(n, |a| a.count()) as u64;
    let triangles = match mode {
        Mode::Triangles => corners / 3,
        _ => corners.saturating_sub(2),
    };
    budget.take(n as u64, triangles, err)?;
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
    budget: &mut Budget,
    mesh: &gltf::Mesh,
    primitive: &gltf::Primitive,
    world: Mat4,
) -> Result<Option<Prim>, LoadError> {
    let err = primitive_error(path, mesh, primitive);
    let Some((mode, reader, mut positions)) =
        open_triangle_primitive(buffers, budget, primitive, &err)?
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
