//! Model loaders: glTF/GLB, OBJ, PLY, OFF, STL → [`Mesh`](crate::Mesh).
//!
//! TODO(issue 2): loaders.

use std::path::Path;

/// File extensions `load_model` reads (lower case; matching ignores case).
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
}
