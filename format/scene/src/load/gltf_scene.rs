//! A glTF 2.0 file read as a whole scene (`scene: Gltf("file.glb")`, issue 18), not
//! as one model: every node with a mesh becomes instances with the node's composed
//! transform, and a mesh used by several nodes stays one model.
//!
//! [`load_gltf_scene`] reads as its steps:
//! 1. parse and validate the document, load its buffers (`gltf.rs`); refuse
//!    extensions the file *requires* that hexbake does not read, and note the ones it
//!    merely *uses* (they are ignored: the base colour is read from
//!    `pbrMetallicRoughness` whatever `KHR_materials_pbrSpecularGlossiness` says);
//! 2. walk the default scene's node tree depth-first (children in file order),
//!    composing transforms (a node with two parents — hence any cycle — or a
//!    hierarchy deeper than
//!    [`MAX_DEPTH`](super::gltf::MAX_DEPTH) is an error, and the walk visits each
//!    node once: a scene listing a root twice is refused); skins and morph targets are
//!    ignored with a note (the mesh is drawn in its bind pose / base shape);
//! 3. per node with a mesh, split the mesh's triangle primitives by base-colour
//!    texture: each (mesh, texture or none, mirror) is one model, created at first
//!    use, and the node places one instance of each of its mesh's models. The bake's
//!    kernels see instances as parks and `Instances` manifests have them — rotation,
//!    uniform scale and translation over models in world units — so the node's
//!    composed transform is split ([`split_transform`]): a similarity (uniform
//!    scale s × rotation, possibly mirroring) becomes the instance transform, with a
//!    mirror in x baked into the model when the node mirrors; anything else
//!    (non-uniform scale, shear) is baked whole into the model and the instance only
//!    translates. So nodes using one mesh at any uniform scales share one model
//!    (issue 29). A mirrored model has flipped winding, so triangles stay
//!    counter-clockwise in the world. What one file makes is capped
//!    ([`GltfCaps`]: instances placed, triangles and vertices read — a mesh read
//!    again for another model counts again), each refusal naming the node or the
//!    mesh and primitive that passes the cap.
//!
//!    **Objects** ([`GltfObjects`], manifest `objects`). A group of mesh nodes that
//!    forms one object is merged into one model per base-colour texture, in the
//!    frame of the group's root node (each member's transform relative to the root
//!    baked into the model, the root's world transform split as above), and placed
//!    once with the root's instance transform; groups of the same content (meshes
//!    and their placements) share their models, so twenty trucks of the same nodes
//!    are twenty instances of one truck. Which nodes form a group:
//!    - `Hierarchy` (the default, issue 29): objects follow the scene's hierarchy,
//!      as a Blender or assimp export lays them out. Below a chain of single
//!      mesh-less roots (an exporter's `RootNode`), each top-level node with
//!      everything under it is one object — a truck's body and wheels — unless the
//!      subtree is wider in x or z than [`GltfOptions::max_object_extent`] (the
//!      manifest's cell size: a merged object wider than a cell would be drawn
//!      whole by every cell it overlaps). Then its own mesh is an object and each
//!      child is tried the same way, so an empty that gathers a street of houses
//!      gives one object per house. A subtree with a single mesh node places that
//!      node alone (its model stays shared with the other nodes of its mesh).
//!    - `Parents` (issue 18's `group_by_parent: true`): the mesh nodes that are
//!      children of one node, when there are two or more, are one object; the
//!      parent's own mesh and mesh nodes at the scene's root stay apart.
//!    - `Nodes`: every mesh node is an object (the loader's behaviour before
//!      issue 18).
//! 4. a model's albedo: vertex colour (`COLOR_0`, linear) × the material's base-colour
//!    factor, to sRGB8 per vertex (white when neither is there but a texture is; the
//!    procedural pattern when nothing is); the base-colour texture (its UV set, the
//!    sampler's wrap modes) multiplies it when sampled ([`format::albedo`]).
//!
//! Models are in the file's units and frame (glTF is y-up, right-handed, as hexbake);
//! nothing is normalised. Cameras, lights and animations are not read.

use super::gltf::{
    node_label, open_document, open_triangle_primitive, primitive_error, primitive_triangles,
    vertex_srgb8, walk_nodes, Budget, GltfCaps,
};
use super::{parse_error, LoadError, Location, ModelFormat};
use crate::cleanup::{finish_mesh_with_uvs, RawMesh};
use format::albedo::{AlbedoMap, AlbedoTexture, Wrap, MAX_TEXTURE_SIDE};
use format::mesh::Mesh;
pub use format::model_source::GltfObjects;
use glam::{Mat3, Mat4};
use std::collections::BTreeMap;
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Gltf;

/// Extensions a file may *require* (none changes what hexbake reads: all are
/// declared only when used).
const REQUIRED_OK: &[&str] = &[];

/// One model of a glTF scene.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfModel {
    /// The mesh's name (else `mesh<N>`), with `-textured` / `-mirrored` where one
    /// glTF mesh gives several models; not yet unique.
    pub name: String,
    pub mesh: Mesh,
    pub albedo_map: Option<AlbedoMap>,
}

/// One placed model: a node's mesh (or the textured / untextured part of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfInstance {
    /// Index into [`GltfScene::models`].
    pub model: u32,
    /// Node → world, composed from the scene root.
    pub transform: Mat4,
    /// The glTF node it comes from.
    pub node: u32,
}

/// How a glTF file is read as a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfOptions {
    /// Which mesh nodes form one object (module docs, step 3).
    pub objects: GltfObjects,
    /// [`GltfObjects::Hierarchy`]: the widest a group of nodes may be, in x or z
    /// (world units), to be one object; the manifest passes its cell size, since an
    /// object wider than a cell is drawn whole by every cell it overlaps.
    pub max_object_extent: f32,
    /// What one file may make (issue 32 item 4): instances, triangles and vertices
    /// read.
    pub caps: GltfCaps,
}

impl Default for GltfOptions {
    fn default() -> Self {
        GltfOptions {
            objects: GltfObjects::Hierarchy,
            max_object_extent: f32::INFINITY,
            caps: GltfCaps::default(),
        }
    }
}

/// Places one instance, or refuses it when the scene would pass the cap on
/// instances, naming the node that places it.
fn place(
    path: &Path,
    budget: &Budget,
    instances: &mut Vec<GltfInstance>,
    instance: GltfInstance,
    node: &gltf::Node,
) -> Result<(), LoadError> {
    let placed = instances.len() as u64 + 1;
    if placed > budget.caps.instances {
        return Err(parse_error(
            path,
            FORMAT,
            format!(
                "{}: {placed} instances would pass the cap of {} instances for one glTF scene",
                node_label(node.index(), node.name()),
                budget.caps.instances
            ),
            Location::Element(format!("node {}", node.index())),
        ));
    }
    instances.push(instance);
    Ok(())
}

/// A glTF file as a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfScene {
    pub models: Vec<GltfModel>,
    pub instances: Vec<GltfInstance>,
    /// What was ignored, one line each (`KHR_texture_transform is not read`, ...).
    pub notes: Vec<String>,
    /// Per node of the document (by index), its name where it has a non-empty one
    /// (for messages that name an instance's node).
    pub node_names: Vec<Option<String>>,
}

/// A node met in the walk (step 2a): its world transform and its parent's visit
/// (index into the visits) and world transform.
struct Visit<'a> {
    node: gltf::Node<'a>,
    world: Mat4,
    parent: Option<(usize, Mat4)>,
}

/// Mesh nodes placed as one object (step 3): their visits in walk order, each
/// with its transform relative to the group's root node.
struct Group {
    members: Vec<usize>,
    relative: Vec<Mat4>,
}

/// What a merged model is made of: its texture and, per part, the mesh and the
/// bits of its placement in the model (linear part and offset).
type GroupKey = (Option<usize>, Vec<(usize, [u32; 12])>);

/// The groups of mesh nodes that form one object (step 3), by their root's visit:
/// under [`GltfObjects::Hierarchy`], top-level subtrees of two or more mesh nodes
/// no wider than `max_object_extent` (else their children, tried alike); under
/// [`GltfObjects::Parents`], the mesh children of one node when two or more;
/// under [`GltfObjects::Nodes`], none. Mesh nodes in no group stand alone.
fn object_groups(
    visits: &[Visit],
    buffers: &[gltf::buffer::Data],
    options: GltfOptions,
) -> BTreeMap<usize, Group> {
    let n = visits.len();
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (k, v) in visits.iter().enumerate() {
        if let Some((p, _)) = v.parent {
            children[p].push(k);
        }
    }
    let local = |k: usize| Mat4::from_cols_array_2d(&visits[k].node.transform().matrix());
    let mut groups = BTreeMap::new();
    match options.objects {
        GltfObjects::Nodes => {}
        GltfObjects::Parents => {
            for (p, kids) in children.iter().enumerate() {
                let members: Vec<usize> = kids
                    .iter()
                    .copied()
                    .filter(|&k| visits[k].node.mesh().is_some())
                    .collect();
                if members.len() >= 2 {
                    let relative = members.iter().map(|&k| local(k)).collect();
                    groups.insert(p, Group { members, relative });
                }
            }
        }
        GltfObjects::Hierarchy => {
            // Per visit: mesh nodes in its subtree and the subtree's world box
            // (children come after their parent in the walk: fold in reverse).
            let mut meshes = vec![0usize; n];
            let mut boxes: Vec<Option<(glam::Vec3, glam::Vec3)>> = vec![None; n];
            let mut position_boxes = BTreeMap::new();
            for k in (0..n).rev() {
                let v = &visits[k];
                if let Some(mesh) = v.node.mesh() {
                    meshes[k] += 1;
                    for p in mesh.primitives() {
                        let Some((lo, hi)) = position_box(&p, buffers, &mut position_boxes) else {
                            continue;
                        };
                        for c in 0..8 {
                            let corner = glam::Vec3::new(
                                if c & 1 == 0 { lo.x } else { hi.x },
                                if c & 2 == 0 { lo.y } else { hi.y },
                                if c & 4 == 0 { lo.z } else { hi.z },
                            );
                            let w = v.world.transform_point3(corner);
                            boxes[k] = Some(match boxes[k] {
                                Some((a, b)) => (a.min(w), b.max(w)),
                                None => (w, w),
                            });
                        }
                    }
                }
                if let Some((p, _)) = v.parent {
                    meshes[p] += meshes[k];
                    if let Some((a, b)) = boxes[k] {
                        boxes[p] = Some(match boxes[p] {
                            Some((c, d)) => (a.min(c), b.max(d)),
                            None => (a, b),
                        });
                    }
                }
            }
            let fits = |k: usize| {
                boxes[k].is_none_or(|(lo, hi)| {
                    let size = hi - lo;
                    size.x.max(size.z) <= options.max_object_extent
                })
            };
            // The top level: below a chain of single mesh-less roots.
            let mut top: Vec<usize> = (0..n).filter(|&k| visits[k].parent.is_none()).collect();
            while let [only] = top[..] {
                if visits[only].node.mesh().is_some() || children[only].is_empty() {
                    break;
                }
                top = children[only].clone();
            }
            let mut todo: Vec<usize> = top.into_iter().rev().collect();
            while let Some(root) = todo.pop() {
                if meshes[root] < 2 {
                    continue;
                }
                if !fits(root) {
                    todo.extend(children[root].iter().rev().copied());
                    continue;
                }
                // The subtree in walk order (a subtree is a contiguous run of
                // visits after its root), with transforms relative to the root.
                let mut relative_of: BTreeMap<usize, Mat4> = BTreeMap::new();
                relative_of.insert(root, Mat4::IDENTITY);
                let mut members = Vec::new();
                let mut relative = Vec::new();
                for (k, visit) in visits.iter().enumerate().skip(root) {
                    let rel = if k == root {
                        Mat4::IDENTITY
                    } else {
                        match visit.parent.and_then(|(p, _)| relative_of.get(&p)) {
                            Some(&parent_rel) => parent_rel * local(k),
                            None => break,
                        }
                    };
                    relative_of.insert(k, rel);
                    if visit.node.mesh().is_some() {
                        members.push(k);
                        relative.push(rel);
                    }
                }
                groups.insert(root, Group { members, relative });
            }
        }
    }
    groups
}

/// The mesh-space box of a primitive's POSITION: its accessor's `min` and `max` when
/// the file gives them (glTF requires them, many exporters omit them; the gltf
/// crate's `bounding_box` panics then), else the box of its elements, read once per
/// accessor (`cache`). `None` without a POSITION, or for an accessor without a
/// buffer view (no bytes bound what reading it would make; the primitive's read is
/// capped later, [`GltfCaps`]).
fn position_box(
    primitive: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    cache: &mut BTreeMap<usize, Option<(glam::Vec3, glam::Vec3)>>,
) -> Option<(glam::Vec3, glam::Vec3)> {
    let accessor = primitive.get(&gltf::Semantic::Positions)?;
    let bound = |v: Option<gltf::json::Value>| -> Option<glam::Vec3> {
        let a: [f32; 3] = gltf::json::deserialize::from_value(v?).ok()?;
        Some(glam::Vec3::from(a)).filter(|v| v.is_finite())
    };
    if let (Some(lo), Some(hi)) = (bound(accessor.min()), bound(accessor.max())) {
        return Some((lo, hi));
    }
    *cache.entry(accessor.index()).or_insert_with(|| {
        accessor.view()?;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        reader.read_positions()?.fold(None, |acc, p| {
            let p = glam::Vec3::from(p);
            Some(match acc {
                Some((lo, hi)) => (p.min(lo), p.max(hi)),
                None => (p, p),
            })
        })
    })
}

/// One mesh's primitives placed in a model: `offset + linear · p`, winding flipped
/// when `mirrored` (the linear part's determinant is negative).
struct Part<'a> {
    mesh: gltf::Mesh<'a>,
    prims: Vec<gltf::Primitive<'a>>,
    linear: Mat3,
    /// `None` for a node's own mesh (the model is the mesh, linearly transformed).
    offset: Option<glam::Vec3>,
    mirrored: bool,
}

/// A triangle primitive of a mesh, in mesh space.
struct ScenePrim {
    positions: Vec<[f32; 3]>,
    uvs: Option<Vec<[f32; 2]>>,
    colors: Vec<[u8; 4]>,
    triangles: Vec<[u32; 3]>,
}

/// Reads the glTF scene at `path` (steps in the module docs).
pub fn load_gltf_scene(path: &Path) -> Result<GltfScene, LoadError> {
    load_gltf_scene_with(path, GltfOptions::default())
}

/// [`load_gltf_scene`] with options (the manifest's `objects`).
pub fn load_gltf_scene_with(path: &Path, options: GltfOptions) -> Result<GltfScene, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    super::guarded(path, FORMAT, || parse_scene(path, &bytes, options))
}

/// [`load_gltf_scene`] of `bytes` already read from `path` (external buffers and
/// images resolve against `path`'s folder); what the fuzz targets call.
pub fn parse_gltf_scene(path: &Path, bytes: &[u8]) -> Result<GltfScene, LoadError> {
    parse_gltf_scene_with(path, bytes, GltfOptions::default())
}

/// [`parse_gltf_scene`] with options (the structure-aware fuzzers read both ways).
pub fn parse_gltf_scene_with(
    path: &Path,
    bytes: &[u8],
    options: GltfOptions,
) -> Result<GltfScene, LoadError> {
    super::guarded(path, FORMAT, || parse_scene(path, bytes, options))
}

/// Refuses a file that requires extensions hexbake does not read (any but
/// [`REQUIRED_OK`]), naming them.
fn refuse_required_extensions<'e>(
    path: &Path,
    required: impl Iterator<Item = &'e str>,
) -> Result<(), LoadError> {
    let refused: Vec<&str> = required.filter(|e| !REQUIRED_OK.contains(e)).collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(parse_error(
        path,
        FORMAT,
        format!(
            "the file requires glTF extensions hexbake does not read: {}",
            refused.join(", ")
        ),
        Location::Unknown,
    ))
}

fn parse_scene(path: &Path, bytes: &[u8], options: GltfOptions) -> Result<GltfScene, LoadError> {
    let err = |what: String, at: Location| parse_error(path, FORMAT, what, at);
    // Step 1: document, buffers, extensions (required ones are checked first: the
    // validator would only say "unsupported extension").
    if let Ok(g) = gltf::Gltf::from_slice_without_validation(bytes) {
        refuse_required_extensions(path, g.extensions_required())?;
    }
    let (document, buffers) = open_document(path, bytes)?;
    let mut notes = Vec::new();
    refuse_required_extensions(path, document.extensions_required())?;
    let used: Vec<&str> = document.extensions_used().collect();
    if !used.is_empty() {
        notes.push(format!(
            "glTF extensions ignored (not read): {}",
            used.join(", ")
        ));
    }
    if document.animations().next().is_some() {
        notes.push("animations ignored: the scene is drawn at rest".into());
    }
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| err("no scene".into(), Location::Unknown))?;

    // Step 2: walk the nodes.
    let mut budget = Budget::new(options.caps);
    let mut models: Vec<GltfModel> = Vec::new();
    let mut instances: Vec<GltfInstance> = Vec::new();
    // (mesh, texture, baked linear part's bits, mirrored) → model index.
    let mut model_of: BTreeMap<(usize, Option<usize>, [u32; 9], bool), u32> = BTreeMap::new();
    // Decoded textures by (texture index).
    let mut textures: BTreeMap<usize, AlbedoTexture> = BTreeMap::new();
    let mut skinned = Vec::new();
    let mut morphed = Vec::new();
    // Step 2a: every node in depth-first order with its world transform and its
    // parent's visit; then the groups of mesh nodes that form one object.
    let mut visits: Vec<Visit> = Vec::new();
    let mut last_visit: BTreeMap<usize, usize> = BTreeMap::new();
    walk_nodes(path, &scene, |node, world, parent| {
        if node.skin().is_some() {
            skinned.push(node.index());
        }
        let parent = parent.and_then(|(p, w)| last_visit.get(&p).map(|&v| (v, w)));
        last_visit.insert(node.index(), visits.len());
        visits.push(Visit {
            node: node.clone(),
            world,
            parent,
        });
        Ok(())
    })?;
    let groups = object_groups(&visits, &buffers, options);
    // Member visit → its group's root visit (a group is placed at its first member).
    let grouped: BTreeMap<usize, usize> = groups
        .iter()
        .flat_map(|(&root, g)| g.members.iter().map(move |&k| (k, root)))
        .collect();
    // Merged models by content: (texture, parts) → model, so that identical groups
    // (two trucks of the same nodes) share their models.
    let mut group_models: BTreeMap<GroupKey, u32> = BTreeMap::new();
    // Step 2b: place the mesh nodes (a group where its first member is visited).
    for (
        k,
        Visit {
            node,
            world,
            parent,
        },
    ) in visits.iter().enumerate()
    {
        let world = *world;
        let at = || Location::Element(format!("node {}", node.index()));
        if let Some(mesh) = node.mesh() {
            if mesh
                .primitives()
                .any(|p| p.morph_targets().next().is_some())
            {
                morphed.push(mesh.index());
            }
        }
        let _ = parent;
        if let Some(&root) = grouped.get(&k) {
            let group = &groups[&root];
            if group.members[0] == k {
                place_group(
                    path,
                    &document,
                    &buffers,
                    &mut budget,
                    &visits,
                    root,
                    group,
                    &mut textures,
                    &mut group_models,
                    &mut models,
                    &mut instances,
                )?;
            }
            continue;
        }
        if let Some(mesh) = node.mesh() {
            let (baked, instance_transform) = split_transform(world);
            let mirrored = baked.determinant() < 0.0;
            // Step 3: the mesh's models, by texture.
            // Groups in order of first appearance among the primitives.
            let mut groups: Vec<(Option<usize>, Vec<gltf::Primitive>)> = Vec::new();
            for p in mesh.primitives() {
                let texture = base_color_texture(&p);
                match groups.iter_mut().find(|(t, _)| *t == texture) {
                    Some((_, prims)) => prims.push(p),
                    None => groups.push((texture, vec![p])),
                }
            }
            let split = groups.len() > 1;
            for (texture, prims) in groups {
                let key = (
                    mesh.index(),
                    texture,
                    baked.to_cols_array().map(f32::to_bits),
                    mirrored,
                );
                let id = match model_of.get(&key) {
                    Some(&id) => Some(id),
                    None => {
                        let part = Part {
                            mesh: mesh.clone(),
                            prims,
                            linear: baked,
                            offset: None,
                            mirrored,
                        };
                        let name = model_name(
                            mesh.name(),
                            || format!("mesh{}", mesh.index()),
                            texture,
                            split,
                            mirrored,
                        );
                        let model = build_model(
                            path,
                            &document,
                            &buffers,
                            &mut budget,
                            &[part],
                            texture,
                            name,
                            &mut textures,
                        )?;
                        match model {
                            Some(m) => {
                                let id = u32::try_from(models.len())
                                    .map_err(|_| err("too many models".into(), at()))?;
                                models.push(m);
                                model_of.insert(key, id);
                                Some(id)
                            }
                            None => None,
                        }
                    }
                };
                if let Some(model) = id {
                    let instance = GltfInstance {
                        model,
                        transform: instance_transform,
                        node: node.index() as u32,
                    };
                    place(path, &budget, &mut instances, instance, node)?;
                }
            }
        }
    }
    if !skinned.is_empty() {
        notes.push(format!(
            "skins ignored (meshes drawn in their bind pose) on nodes {skinned:?}"
        ));
    }
    if !morphed.is_empty() {
        morphed.dedup();
        notes.push(format!(
            "morph targets ignored (base shapes drawn) on meshes {morphed:?}"
        ));
    }
    if instances.is_empty() {
        return Err(err(
            "the scene has no node with a triangle mesh".into(),
            Location::Unknown,
        ));
    }
    let node_names = document
        .nodes()
        .map(|n| n.name().filter(|n| !n.is_empty()).map(str::to_string))
        .collect();
    Ok(GltfScene {
        models,
        instances,
        notes,
        node_names,
    })
}

/// Places a group of mesh nodes (step 3): one model per base-colour texture of all
/// their primitives, in the frame of the group's root node (its world transform
/// split by [`split_transform`]), each placed once with the root's instance
/// transform. A model is shared with every earlier group of the same content
/// (`models_of`: texture, meshes and placements in the model).
#[allow(clippy::too_many_arguments)]
fn place_group(
    path: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    budget: &mut Budget,
    visits: &[Visit],
    root: usize,
    group: &Group,
    textures: &mut BTreeMap<usize, AlbedoTexture>,
    models_of: &mut BTreeMap<GroupKey, u32>,
    models: &mut Vec<GltfModel>,
    instances: &mut Vec<GltfInstance>,
) -> Result<(), LoadError> {
    let root_node = &visits[root].node;
    let at = || Location::Element(format!("node {}", root_node.index()));
    let (baked, instance_transform) = split_transform(visits[root].world);
    // Textures in order of first appearance over the members' primitives.
    let mut by_texture: Vec<(Option<usize>, Vec<Part>)> = Vec::new();
    for (&k, &relative) in group.members.iter().zip(&group.relative) {
        let Some(mesh) = visits[k].node.mesh() else {
            continue;
        };
        let affine = Mat4::from_mat3(baked) * relative;
        let linear = Mat3::from_mat4(affine);
        for p in mesh.primitives() {
            let texture = base_color_texture(&p);
            let slot = match by_texture.iter().position(|(t, _)| *t == texture) {
                Some(i) => i,
                None => {
                    by_texture.push((texture, Vec::new()));
                    by_texture.len() - 1
                }
            };
            // Consecutive primitives of one node share a part.
            let offset = Some(affine.w_axis.truncate());
            let parts = &mut by_texture[slot].1;
            match parts.last_mut() {
                Some(part)
                    if part.mesh.index() == mesh.index()
                        && part.linear == linear
                        && part.offset == offset =>
                {
                    part.prims.push(p)
                }
                _ => parts.push(Part {
                    mesh: mesh.clone(),
                    prims: vec![p],
                    linear,
                    offset,
                    mirrored: linear.determinant() < 0.0,
                }),
            }
        }
    }
    let split = by_texture.len() > 1;
    for (texture, parts) in by_texture {
        let key: GroupKey = (
            texture,
            parts
                .iter()
                .map(|part| {
                    let mut bits = [0u32; 12];
                    for (b, x) in bits.iter_mut().zip(
                        part.linear
                            .to_cols_array()
                            .into_iter()
                            .chain(part.offset.unwrap_or_default().to_array()),
                    ) {
                        *b = x.to_bits();
                    }
                    (part.mesh.index(), bits)
                })
                .collect(),
        );
        let id = match models_of.get(&key) {
            Some(&id) => Some(id),
            None => {
                let name = model_name(
                    root_node.name(),
                    || format!("node{}", root_node.index()),
                    texture,
                    split,
                    false,
                );
                match build_model(
                    path, document, buffers, budget, &parts, texture, name, textures,
                )? {
                    Some(m) => {
                        let id = u32::try_from(models.len()).map_err(|_| {
                            parse_error(path, FORMAT, "too many models".to_string(), at())
                        })?;
                        models.push(m);
                        models_of.insert(key, id);
                        Some(id)
                    }
                    None => None,
                }
            }
        };
        if let Some(model) = id {
            let instance = GltfInstance {
                model,
                transform: instance_transform,
                node: root_node.index() as u32,
            };
            place(path, budget, instances, instance, root_node)?;
        }
    }
    Ok(())
}

/// The texture index of a primitive's base colour, if it has one (a mesh's models
/// are split by it).
fn base_color_texture(primitive: &gltf::Primitive) -> Option<usize> {
    primitive
        .material()
        .pbr_metallic_roughness()
        .base_color_texture()
        .map(|t| t.texture().index())
}

/// The name of a model: `name` (the mesh's, or a group's parent node's), else
/// `unnamed()` (`mesh<N>`, `node<N>`), with `-textured` / `-plain` when the mesh or
/// group is `split` by texture and `-mirrored`.
fn model_name(
    name: Option<&str>,
    unnamed: impl FnOnce() -> String,
    texture: Option<usize>,
    split: bool,
    mirrored: bool,
) -> String {
    let mut name = name
        .filter(|n| !n.is_empty())
        .map(str::to_string)
        .unwrap_or_else(unnamed);
    if split {
        name.push_str(if texture.is_some() {
            "-textured"
        } else {
            "-plain"
        });
    }
    if mirrored {
        name.push_str("-mirrored");
    }
    name
}

/// One model named `name`: the primitives of `parts` (all using `texture`), each
/// part's positions transformed and its winding flipped when it mirrors; `None`
/// when none of them has triangles. Each primitive read is counted in `budget`.
#[allow(clippy::too_many_arguments)]
fn build_model(
    path: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    budget: &mut Budget,
    parts: &[Part],
    texture: Option<usize>,
    name: String,
    textures: &mut BTreeMap<usize, AlbedoTexture>,
) -> Result<Option<GltfModel>, LoadError> {
    let at = || {
        Location::Element(format!(
            "mesh {}",
            parts.first().map_or(0, |p| p.mesh.index())
        ))
    };
    let err = |what: String| parse_error(path, FORMAT, what, at());
    let mut read = Vec::new();
    for part in parts {
        for p in &part.prims {
            if let Some(prim) =
                read_scene_primitive(path, buffers, budget, &part.mesh, p, texture.is_some())?
            {
                read.push((prim, part));
            }
        }
    }
    if read.is_empty() {
        return Ok(None);
    }
    // Concatenate the primitives.
    let any_colors = texture.is_some()
        || parts.iter().flat_map(|part| &part.prims).any(|p| {
            p.get(&gltf::Semantic::Colors(0)).is_some()
                || p.material().pbr_metallic_roughness().base_color_factor() != [1.0; 4]
        });
    let mut raw = RawMesh {
        colors: any_colors.then(Vec::new),
        ..RawMesh::default()
    };
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    for (part, placed) in &read {
        let (linear, offset, mirrored) = (placed.linear, placed.offset, placed.mirrored);
        let base =
            u32::try_from(raw.positions.len()).map_err(|_| err("too many vertices".into()))?;
        raw.positions.extend(part.positions.iter().map(|p| {
            let q = linear * glam::Vec3::from_array(*p);
            match offset {
                Some(o) => (q + o).to_array(),
                None => q.to_array(),
            }
        }));
        if let Some(c) = &mut raw.colors {
            c.extend_from_slice(&part.colors);
        }
        if let Some(u) = &part.uvs {
            uvs.extend_from_slice(u);
        }
        raw.triangles.extend(part.triangles.iter().map(|t| {
            let t = t.map(|i| base.saturating_add(i));
            if mirrored {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        }));
    }
    let (mesh_out, uvs_out, _) =
        finish_mesh_with_uvs(raw, texture.map(|_| uvs)).map_err(|source| LoadError::Invalid {
            path: path.to_path_buf(),
            source,
        })?;
    let albedo_map = match (texture, uvs_out) {
        (Some(t), Some(uvs)) => {
            let texture = match textures.entry(t) {
                std::collections::btree_map::Entry::Occupied(e) => e.get().clone(),
                std::collections::btree_map::Entry::Vacant(e) => e
                    .insert(decode_texture(path, document, buffers, t)?)
                    .clone(),
            };
            Some(AlbedoMap { uvs, texture })
        }
        _ => None,
    };
    Ok(Some(GltfModel {
        name,
        mesh: mesh_out,
        albedo_map,
    }))
}

/// Splits a node's world transform into the linear part baked into its model and
/// the instance transform (step 3 of the module docs): for a similarity `T·(s·Q)`
/// (Q orthogonal; checked to 10⁻⁴), `(F, T·s·Q·F)` with F = I, or the mirror
/// diag(−1, 1, 1) when Q mirrors (so instance transforms are uniformly scaled
/// proper rotations, as an `Instances` manifest's `scale` makes them); otherwise
/// `(L, T)` with L the whole linear part. `instance · baked` is the world
/// transform's linear part.
pub(crate) fn split_transform(world: Mat4) -> (Mat3, Mat4) {
    let linear = Mat3::from_mat4(world);
    let translation = Mat4::from_translation(world.w_axis.truncate());
    let s = linear.determinant().abs().cbrt();
    if s > 0.0 && s.is_finite() {
        let q = linear * (1.0 / s);
        let qtq = q.transpose() * q;
        let orthogonal = (qtq - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|d| d.abs() < 1e-4);
        if orthogonal {
            // A mirror goes into the model (x negated), so the instance rotates
            // and scales uniformly (issue 29: a mesh reused at several scales is
            // one model).
            let mirror = if q.determinant() < 0.0 { -1.0 } else { 1.0 };
            let flip = Mat3::from_diagonal(glam::Vec3::new(mirror, 1.0, 1.0));
            return (flip, translation * Mat4::from_mat3(linear * flip));
        }
    }
    (linear, translation)
}

/// A triangle primitive in mesh space with its sRGB8 colours (vertex colour × base
/// colour factor) and, when `textured`, the UVs of its base-colour texture's set;
/// `None` for points and lines.
fn read_scene_primitive(
    path: &Path,
    buffers: &[gltf::buffer::Data],
    budget: &mut Budget,
    mesh: &gltf::Mesh,
    primitive: &gltf::Primitive,
    textured: bool,
) -> Result<Option<ScenePrim>, LoadError> {
    let err = primitive_error(path, mesh, primitive);
    let Some((mode, reader, positions)) =
        open_triangle_primitive(buffers, budget, primitive, &err)?
    else {
        return Ok(None);
    };
    let n = positions.len();
    let pbr = primitive.material().pbr_metallic_roughness();
    let factor = pbr.base_color_factor();
    let colors_f: Option<Vec<[f32; 4]>> =
        reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
    let colors: Vec<[u8; 4]> = vertex_srgb8(colors_f.as_deref(), factor, n).collect();
    let uvs = if textured {
        let set = pbr.base_color_texture().map_or(0, |t| t.tex_coord());
        let uvs: Vec<[f32; 2]> = reader
            .read_tex_coords(set)
            .ok_or_else(|| {
                err(format!(
                    "the base-colour texture uses TEXCOORD_{set}, which the primitive lacks"
                ))
            })?
            .into_f32()
            .collect();
        if uvs.len() != n {
            return Err(err(format!(
                "TEXCOORD_{set} has {} entries for {n} vertices",
                uvs.len()
            )));
        }
        if let Some(bad) = uvs.iter().position(|uv| !uv.iter().all(|x| x.is_finite())) {
            return Err(err(format!("TEXCOORD_{set} of vertex {bad} is not finite")));
        }
        Some(uvs)
    } else {
        None
    };
    let indices = reader.read_indices().map(|i| i.into_u32().collect());
    let triangles = primitive_triangles(indices, mode, n, &err)?;
    Ok(Some(ScenePrim {
        positions,
        uvs,
        colors,
        triangles,
    }))
}

/// Decodes texture `index` (its image to RGBA8 sRGB, its sampler's wrap modes).
fn decode_texture(
    path: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    index: usize,
) -> Result<AlbedoTexture, LoadError> {
    let at = || Location::Element(format!("texture {index}"));
    let err = |what: String| parse_error(path, FORMAT, what, at());
    let texture = document
        .textures()
        .nth(index)
        .ok_or_else(|| err("no such texture".into()))?;
    let image = texture.source();
    // `from_source` resolves relative URIs against the file's folder.
    let base = Some(path.parent().unwrap_or(Path::new(".")));
    let data = gltf::image::Data::from_source(image.source(), base, buffers)
        .map_err(|e| err(format!("image {}: {e}", image.index())))?;
    let (w, h) = (data.width, data.height);
    if !(1..=MAX_TEXTURE_SIDE).contains(&w) || !(1..=MAX_TEXTURE_SIDE).contains(&h) {
        return Err(err(format!(
            "image {} is {w} × {h} texels; sides must be in 1..={MAX_TEXTURE_SIDE}",
            image.index()
        )));
    }
    use gltf::image::Format as F;
    let channels = match data.format {
        F::R8 => 1,
        F::R8G8 => 2,
        F::R8G8B8 => 3,
        F::R8G8B8A8 => 4,
        other => {
            return Err(err(format!(
                "image {} has pixel format {other:?}; only 8-bit images are read",
                image.index()
            )))
        }
    };
    let texels = w as usize * h as usize;
    if data.pixels.len() != texels * channels {
        return Err(err(format!(
            "image {} decoded to {} bytes, expected {}",
            image.index(),
            data.pixels.len(),
            texels * channels
        )));
    }
    let mut rgba = Vec::with_capacity(texels * 4);
    for px in data.pixels.chunks_exact(channels) {
        match channels {
            1 | 2 => rgba.extend_from_slice(&[px[0], px[0], px[0], 255]),
            3 => rgba.extend_from_slice(&[px[0], px[1], px[2], 255]),
            _ => rgba.extend_from_slice(&[px[0], px[1], px[2], 255]),
        }
    }
    let wrap = |m: gltf::texture::WrappingMode| match m {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    };
    let sampler = texture.sampler();
    Ok(AlbedoTexture {
        width: w,
        height: h,
        rgba,
        wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
    })
}
