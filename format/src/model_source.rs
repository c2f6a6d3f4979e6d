//! What a manifest may name as a model (format/README.md "Manifest"): the model file
//! formats by extension, the procedural models' names and how a glTF scene's nodes
//! become objects. The manifest validates against these lists; the scene crate's
//! loaders and generators (`scene::load`, `scene::procedural`) implement them and test
//! that they cover every entry.

use std::path::Path;

/// File extensions `scene::load::load_model` reads (lower case; matching ignores case).
pub const SUPPORTED_EXTENSIONS: &[&str] = &["gltf", "glb", "obj", "ply", "off", "stl"];

/// A model file format, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelFormat {
    Gltf,
    Obj,
    Ply,
    Off,
    Stl,
}

impl ModelFormat {
    /// The format of `path` by its extension (case-insensitive); `None` if unsupported.
    pub fn from_path(path: &Path) -> Option<ModelFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "gltf" | "glb" => Some(ModelFormat::Gltf),
            "obj" => Some(ModelFormat::Obj),
            "ply" => Some(ModelFormat::Ply),
            "off" => Some(ModelFormat::Off),
            "stl" => Some(ModelFormat::Stl),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            ModelFormat::Gltf => "glTF",
            ModelFormat::Obj => "OBJ",
            ModelFormat::Ply => "PLY",
            ModelFormat::Off => "OFF",
            ModelFormat::Stl => "STL",
        }
    }
}

/// The procedural models' names (`scene::procedural::build` makes each).
pub const PROCEDURAL_NAMES: &[&str] = &["torus_knot", "sphere", "box", "column", "vase", "torus"];

/// Which mesh nodes of a glTF scene form one object of the bake (the scene crate's `load::gltf_scene`, step 3; manifest `objects`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum GltfObjects {
    /// The default: objects follow the node hierarchy — each top-level node (below
    /// a chain of single mesh-less roots) with everything under it is one object,
    /// unless it spans more than the scene loader's `GltfOptions::max_object_extent` (the cell size): then its own
    /// mesh is one object and each child is tried the same way.
    #[default]
    Hierarchy,
    /// The mesh nodes that are children of one node, two or more, are one object
    /// (the parent's own mesh stays apart): issue 18's `group_by_parent`.
    Parents,
    /// Every mesh node is an object of its own.
    Nodes,
}
