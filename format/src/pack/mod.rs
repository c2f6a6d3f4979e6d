//! Versioned, checksummed, memory-mappable zstd packs: `base.pack`, `cells/<id>.pack`
//! and `index.pack` (DESIGN.md "Data flow"; issue 5). format/README.md is the
//! byte-level specification and the compatibility policy.
//!
//! - [`layout`]: header, section table, section kinds, codecs (the spec in code).
//! - [`writer`]: deterministic assembly, atomic writes.
//! - [`reader`]: [`PackFile`] — mmap or read, validated before use, lazy sections.
//! - [`base`], [`cell`], [`index`]: the three files' contents.
//! - [`texture`]: capture texture encodings.
//! - [`texture_store`]: the bake's shared store of capture textures (version 6).
//! - [`generation`]: publishing a bake's packs under names of their content and the
//!   index as the commit point (version 7, issue 32).

pub mod albedo_maps;
pub mod base;
pub mod cell;
pub mod codec;
pub mod error;
pub mod generation;
pub mod index;
pub mod layout;
pub mod patches;
pub mod reader;
pub mod sample;
pub mod texture;
pub mod texture_store;
pub mod web;
pub mod writer;

pub use base::{BasePack, GridParams, PackedInstance, PackedModel};
pub use cell::{
    code_of_depth, depth_of_code, CellPack, ImpostorLayer, ImpostorLayers, Proxy, ProxyKind,
    ProxyMember, ProxyView, MAX_IMPOSTOR_LAYERS,
};
pub use error::PackError;
pub use index::{BaseEntry, Index, IndexEntry};
pub use layout::{Codec, FileKind, SectionKind, FORMAT_VERSION};
pub use patches::{ModelPatch, ModelPatches, PatchSet};
pub use reader::{scan, PackFile, PackScan, SectionInfo};
pub use texture::{Texture, TextureEncoding};
pub use writer::{
    create_new_atomic, hostname, process_alive, remove_stale_temps, temp_name, write_atomic,
};

use std::path::Path;

/// The file methods every pack type has, from its `encode` and `decode`:
/// `from_bytes` (validate and decode bytes in memory), `write` (atomically) and
/// `read` (memory-map, validate, decode).
macro_rules! pack_file_methods {
    ($pack:ident) => {
        impl $pack {
            /// Validates and decodes pack bytes held in memory.
            pub fn from_bytes(bytes: &[u8]) -> Result<$pack, $crate::pack::PackError> {
                $pack::decode(&$crate::pack::PackFile::from_bytes(bytes)?)
            }

            /// Writes the pack atomically to `path`.
            pub fn write(&self, path: &std::path::Path) -> Result<(), $crate::pack::PackError> {
                $crate::pack::write_atomic(path, &self.encode()?)
            }

            /// Memory-maps, validates and decodes the pack at `path`.
            pub fn read(path: &std::path::Path) -> Result<$pack, $crate::pack::PackError> {
                $pack::decode(&$crate::pack::PackFile::open(path)?)
            }
        }
    };
}
pub(crate) use pack_file_methods;

/// An enum stored as a `u32` code, with its name in messages and tools: one row per
/// variant, `Variant = code => "name"`, gives the enum, `from_u32` (the variant of a
/// code; `None` for one this version does not know) and `name`.
macro_rules! code_enum {
    (
        $(#[$attr:meta])*
        pub enum $enum:ident {
            $($(#[$variant_attr:meta])* $variant:ident = $code:literal => $name:literal,)*
        }
    ) => {
        $(#[$attr])*
        pub enum $enum {
            $($(#[$variant_attr])* $variant = $code,)*
        }

        impl $enum {
            /// The variant stored as `v`; `None` for a code this version does not know.
            pub fn from_u32(v: u32) -> Option<$enum> {
                match v {
                    $($code => Some($enum::$variant),)*
                    _ => None,
                }
            }

            /// The name messages and tools use.
            pub fn name(self) -> &'static str {
                match self {
                    $($enum::$variant => $name,)*
                }
            }
        }
    };
}
pub(crate) use code_enum;

/// On-disk records, read and written as their bytes: each `pub struct Name[SIZE] {
/// fields }` gives the struct, `#[repr(C)]` with `Clone`, `Copy`, `Debug` and
/// `bytemuck`'s `Pod` and `Zeroable` (further derives as attributes), and a
/// compile-time assertion that it is `SIZE` bytes (obvhs style; format/README.md gives
/// each record byte by byte).
macro_rules! pod_records {
    ($(
        $(#[$attr:meta])*
        pub struct $name:ident[$size:expr] {
            $($(#[$field_attr:meta])* pub $field:ident: $ty:ty,)*
        }
    )*) => {$(
        $(#[$attr])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Pod, Zeroable)]
        pub struct $name {
            $($(#[$field_attr])* pub $field: $ty,)*
        }
        const _: () = assert!(std::mem::size_of::<$name>() == $size);
    )*};
}
pub(crate) use pod_records;

/// The `len` items of `items` from `start`; `None` where they reach past the end.
pub(crate) fn range_of<T>(items: &[T], start: usize, len: usize) -> Option<&[T]> {
    items.get(start..start.checked_add(len)?)
}

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
