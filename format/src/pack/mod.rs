//! Versioned, checksummed, memory-mappable zstd packs: `base.pack`, `cells/<id>.pack`
//! and `index.pack` (DESIGN.md "Data flow"; issue 5). format/README.md is the
//! byte-level specification and the compatibility policy.
//!
//! - [`layout`]: header, section table, section kinds, codecs (the spec in code).
//! - [`writer`]: deterministic assembly, atomic writes.
//! - [`reader`]: [`PackFile`] — mmap or read, validated before use, lazy sections.
//! - [`base`], [`cell`], [`index`]: the three files' contents.
//! - [`texture`]: capture texture encodings.

pub mod albedo_maps;
pub mod base;
pub mod cell;
pub mod codec;
pub mod error;
pub mod index;
pub mod layout;
pub mod patches;
pub mod reader;
pub mod sample;
pub mod texture;
pub mod writer;

pub use base::{BasePack, GridParams, PackedInstance, PackedModel};
pub use cell::{
    code_of_depth, depth_of_code, CellPack, ImpostorLayer, ImpostorLayers, Proxy, ProxyKind,
    ProxyMember, ProxyView, MAX_IMPOSTOR_LAYERS,
};
pub use error::PackError;
pub use index::{Index, IndexEntry};
pub use layout::{Codec, FileKind, SectionKind, FORMAT_VERSION};
pub use patches::{ModelPatch, ModelPatches, PatchSet};
pub use reader::{scan, PackFile, PackScan, SectionInfo};
pub use texture::{Texture, TextureEncoding};
pub use writer::{
    create_new_atomic, hostname, process_alive, remove_stale_temps, temp_name, write_atomic,
};

use std::path::Path;

pub(crate) fn invalid(what: impl Into<String>) -> PackError {
    PackError::Invalid { what: what.into() }
}

pub(crate) fn malformed(
    file: &Path,
    section: SectionKind,
    offset: u64,
    what: impl Into<String>,
) -> PackError {
    PackError::Malformed {
        file: file.to_path_buf(),
        section,
        offset,
        what: what.into(),
    }
}
