//! Model loaders: glTF/GLB, OBJ, PLY, OFF, STL → [`Mesh`] (issue 2,
//! "Model loading").
//!
//! One file per format, each turning the file's bytes into a
//! [`RawMesh`] (positions, optional sRGB8 colours,
//! triangles); [`load_model`] then runs the common clean-up
//! ([`cleanup::finish_mesh`](crate::cleanup::finish_mesh): reject NaN/inf, absurd
//! coordinates (beyond ±10¹², [`MAX_MODEL_COORDINATE`](crate::cleanup::MAX_MODEL_COORDINATE))
//! and bad indices, weld, drop degenerate and duplicate triangles, smooth normals, albedo).
//!
//! Readers never trust input (STYLE.md habit 5): the whole file is read into memory,
//! every count is checked against the bytes there are, and crate parsers run under
//! `catch_unwind`, so a parser bug on a hostile file is an error, not a crash.
//! Loaded meshes are in the file's own units and frame; scenes normalise them
//! (`scene_build::normalise`).

mod gltf;
pub mod gltf_sample;
mod gltf_scene;
mod obj;
mod off;
mod ply;
mod stl;

use crate::cleanup::{finish_mesh, CleanupError, CleanupStats, RawMesh};
use format::mesh::Mesh;
pub use gltf::GltfCaps;
pub use gltf_scene::{
    load_gltf_scene, load_gltf_scene_with, parse_gltf_scene, parse_gltf_scene_with, GltfInstance,
    GltfModel, GltfObjects, GltfOptions, GltfScene,
};
use std::fmt;
use std::path::{Path, PathBuf};

pub use format::model_source::{ModelFormat, SUPPORTED_EXTENSIONS};

/// Where in a file a problem is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    Unknown,
    /// 1-based line of a text file.
    Line(usize),
    /// Byte offset in a binary file.
    Byte(u64),
    /// An element: `vertex 12`, `face 7`, `node 3`, `mesh 0 primitive 1`.
    Element(String),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Unknown => Ok(()),
            Location::Line(l) => write!(f, " (line {l})"),
            Location::Byte(b) => write!(f, " (byte {b})"),
            Location::Element(e) => write!(f, " ({e})"),
        }
    }
}

/// A model that cannot be loaded: the path, what is wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: unsupported model format (expected one of {})", path.display(), SUPPORTED_EXTENSIONS.join(", "))]
    Unsupported { path: PathBuf },
    #[error("{}: {format}: {what}{at}", path.display())]
    Parse {
        path: PathBuf,
        format: &'static str,
        what: String,
        at: Location,
    },
    #[error("{}: {source}", path.display())]
    Invalid { path: PathBuf, source: CleanupError },
    #[error("{}: the {format} parser failed on this file (it panicked: {message})", path.display())]
    ParserPanic {
        path: PathBuf,
        format: &'static str,
        message: String,
    },
}

impl LoadError {
    /// Where the problem is, when known.
    pub fn location(&self) -> Location {
        match self {
            LoadError::Parse { at, .. } => at.clone(),
            LoadError::Invalid { source, .. } => match source {
                CleanupError::NonFinite { vertex, .. } | CleanupError::TooFar { vertex, .. } => {
                    Location::Element(format!("vertex {vertex}"))
                }
                CleanupError::IndexOutOfRange { face, .. } => {
                    Location::Element(format!("face {face}"))
                }
                _ => Location::Unknown,
            },
            _ => Location::Unknown,
        }
    }
}

/// What loading did, for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadStats {
    /// glTF nodes that contributed triangles (0 for other formats).
    pub nodes: usize,
    /// glTF primitives / OBJ models read.
    pub parts: usize,
    /// Whether the file supplied colours (else the albedo is procedural).
    pub file_colors: bool,
    pub cleanup: CleanupStats,
}

/// A parser's partial result: the raw mesh and its node/part counts.
pub(crate) struct Parsed {
    raw: RawMesh,
    nodes: usize,
    parts: usize,
}

/// Loads the model at `path`, dispatching on its extension.
pub fn load_model(path: &Path) -> Result<Mesh, LoadError> {
    load_model_with_stats(path).map(|(mesh, _)| mesh)
}

/// [`load_model`], also returning what loading did.
pub fn load_model_with_stats(path: &Path) -> Result<(Mesh, LoadStats), LoadError> {
    let format = ModelFormat::from_path(path).ok_or_else(|| LoadError::Unsupported {
        path: path.to_path_buf(),
    })?;
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let parsed = guarded(path, format, || match format {
        ModelFormat::Gltf => gltf::parse(path, &bytes),
        ModelFormat::Obj => obj::parse(path, &bytes),
        ModelFormat::Ply => ply::parse(path, &bytes),
        ModelFormat::Off => off::parse(path, &bytes),
        ModelFormat::Stl => stl::parse(path, &bytes),
    })?;
    let file_colors = parsed.raw.colors.is_some();
    let (mesh, cleanup) = finish_mesh(parsed.raw).map_err(|source| LoadError::Invalid {
        path: path.to_path_buf(),
        source,
    })?;
    Ok((
        mesh,
        LoadStats {
            nodes: parsed.nodes,
            parts: parsed.parts,
            file_colors,
            cleanup,
        },
    ))
}

thread_local! {
    /// Set while this thread runs a crate parser under [`guarded`]: its panics are
    /// returned as errors, so the panic hook does not print them (issue 32 item 4: a
    /// backtrace before a clean exit 2 reads as a crash).
    static QUIET: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Installs, once per process, a panic hook that stays silent on a thread inside
/// [`guarded`] and otherwise calls the hook that was there before.
fn install_quiet_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(|q| q.get()) {
                previous(info);
            }
        }));
    });
}

/// Runs a parser, turning a panic inside a crate parser into [`LoadError::ParserPanic`]
/// without printing it.
fn guarded<T>(
    path: &Path,
    format: ModelFormat,
    parse: impl FnOnce() -> Result<T, LoadError>,
) -> Result<T, LoadError> {
    let result = QUIET.with(|quiet| {
        install_quiet_hook();
        quiet.set(true);
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(parse));
        quiet.set(false);
        result
    });
    match result {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(LoadError::ParserPanic {
                path: path.to_path_buf(),
                format: format.name(),
                message,
            })
        }
    }
}

/// A [`LoadError::Parse`] for `path`.
pub(crate) fn parse_error(
    path: &Path,
    format: ModelFormat,
    what: impl Into<String>,
    at: Location,
) -> LoadError {
    LoadError::Parse {
        path: path.to_path_buf(),
        format: format.name(),
        what: what.into(),
        at,
    }
}

/// An already-sRGB [0, 1] value → sRGB8.
pub(crate) fn unit_to_u8(x: f32) -> u8 {
    if x.is_finite() {
        (x.clamp(0.0, 1.0) * 255.0).round() as u8
    } else {
        0
    }
}

/// Fan-triangulates a polygon (`n ≥ 3` indices) into `out`.
pub(crate) fn fan(polygon: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..polygon.len().saturating_sub(1) {
        out.push([polygon[0], polygon[k], polygon[k + 1]]);
    }
}
