//! The byte layout shared by every pack file (base, cell, index): a fixed 64-byte
//! header, a table of 64-byte section entries, then 64-byte-aligned sections.
//! format/README.md is the normative, byte-by-byte description; this file is its
//! code form. All integers are little-endian; the structs are `#[repr(C)]` +
//! `bytemuck::Pod` with their sizes asserted at compile time (obvhs style), and no
//! cargo feature changes any of them.

use bytemuck::{Pod, Zeroable};
use std::fmt;

/// First 8 bytes of every pack.
pub const MAGIC: [u8; 8] = *b"HEXBAKE\0";
/// The format version this crate writes (and the newest it reads).
pub const FORMAT_VERSION: u32 = 7;
/// Every section starts at a multiple of this many bytes from the file start, so a
/// memory-mapped (page-aligned) raw section can be viewed as `&[f32]`, `&[[u32; 3]]`...
pub const SECTION_ALIGN: u64 = 64;
/// Size of [`Header`].
pub const HEADER_SIZE: usize = 64;
/// Size of [`SectionEntry`].
pub const ENTRY_SIZE: usize = 64;
/// The most sections a v1 reader accepts in one file.
pub const MAX_SECTIONS: u32 = 4096;
/// A zstd section may not claim to expand by more than this factor (bounds the memory
/// a hostile file can make the reader allocate); the writer stores such a section raw.
pub const MAX_EXPANSION: u64 = 1024;
/// Largest decoded section (4 GiB - 1): no section of a sane pack comes close.
pub const MAX_RAW_LEN: u64 = u32::MAX as u64;
/// Bytes of the header covered by `header_checksum` (together with the table).
pub const HEADER_CHECKED_LEN: usize = 48;

super::pod_records! {
    /// The fixed file header at offset 0.
    #[derive(PartialEq, Eq)]
    pub struct Header[HEADER_SIZE] {
        /// [`MAGIC`].
        pub magic: [u8; 8],
        /// [`FileKind`] as u32.
        pub file_kind: u32,
        /// Format version, [`FORMAT_VERSION`] for files this crate writes.
        pub version: u32,
        /// Reserved flag bits; zero in v1 (a v1 reader rejects any set bit).
        pub flags: u32,
        /// Number of [`SectionEntry`] records in the table.
        pub section_count: u32,
        /// Offset of the section table; [`HEADER_SIZE`] in v1.
        pub table_offset: u64,
        /// Total length of the file in bytes.
        pub file_len: u64,
        /// Zero in v1.
        pub reserved: u64,
        /// blake3 of header bytes 0..48 followed by the whole section table, first 16 bytes.
        pub header_checksum: [u8; 16],
    }

    /// One entry of the section table.
    #[derive(PartialEq, Eq)]
    pub struct SectionEntry[ENTRY_SIZE] {
        /// [`SectionKind`] as u32 (never 0).
        pub kind: u32,
        /// [`Codec`] as u32.
        pub codec: u32,
        /// Offset of the stored bytes from the file start; a multiple of [`SECTION_ALIGN`].
        pub offset: u64,
        /// Length of the stored (possibly compressed) bytes.
        pub stored_len: u64,
        /// Length of the section's content after decoding.
        pub raw_len: u64,
        /// Full blake3 of the stored bytes.
        pub checksum: [u8; 32],
    }
}

super::code_enum! {
    /// Which of the three files a pack is.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
    pub enum FileKind {
        /// `base.pack`: models, instances, grid parameters.
        Base = 1 => "base",
        /// `cells/<id>.pack`: one cell's originals and proxies.
        Cell = 2 => "cell",
        /// `index.pack`: cell → file, size, checksum, neighbours (and, from version 2,
        /// the far-field groups).
        Index = 3 => "index",
        /// `groups/<id>.pack` (version 2): the far field shared by a group of cells —
        /// the same sections as a cell pack, no originals.
        Group = 4 => "group",
    }
}

super::code_enum! {
    /// How a section's stored bytes decode into its content.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Codec {
        /// Stored bytes are the content (`stored_len == raw_len`); usable zero-copy.
        Raw = 0 => "raw",
        /// One zstd frame.
        Zstd = 1 => "zstd",
        /// Content is a stream of little-endian u32 (index buffers). Stored as one zstd
        /// frame of the *pre-coded* stream: successive differences, zig-zag mapped, with
        /// the four bytes of each value split into four planes (see README "Codecs").
        ZstdDeltaU32 = 2 => "zstd+delta-u32",
        /// Content is a stream of little-endian u32 indices (triangle lists). Stored as one
        /// zstd frame of a move-to-front pre-coding: per index one code byte (its position
        /// in a 16-entry list of recent indices, or 16 for a new one) and, for new ones,
        /// a zig-zag LEB128 delta from the previous new index (README "Codecs"; format
        /// version 3, issue 15 item 4).
        ZstdIndexMtf = 3 => "zstd+index-mtf",
    }
}

/// A section kind. The high byte groups kinds by file (1 base, 2 cell, 3 index);
/// readers skip kinds they do not know, so later kinds (layered impostors, patch
/// visibility bitfields) need no format break.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SectionKind(pub u32);

impl SectionKind {
    // base.pack
    pub const BASE_META: SectionKind = SectionKind(0x0101);
    pub const MODEL_TABLE: SectionKind = SectionKind(0x0102);
    pub const MODEL_NAMES: SectionKind = SectionKind(0x0103);
    pub const POSITIONS: SectionKind = SectionKind(0x0104);
    pub const NORMALS: SectionKind = SectionKind(0x0105);
    pub const VERTEX_COLOURS: SectionKind = SectionKind(0x0106);
    pub const TRIANGLES: SectionKind = SectionKind(0x0107);
    pub const INSTANCES: SectionKind = SectionKind(0x0108);
    /// Issue 18: albedo textures of textured models (optional; README).
    pub const ALBEDO_TEXTURES: SectionKind = SectionKind(0x0109);
    /// Issue 18: per textured model, its texture and one UV per vertex (optional).
    pub const TEXCOORDS: SectionKind = SectionKind(0x010a);
    /// Issue 17: per-model patch tiling, normal cones and sampling parameters.
    pub const PATCH_TABLE: SectionKind = SectionKind(0x010b);
    /// Issue 17: each model's triangle ids grouped by patch.
    pub const PATCH_TRIANGLES: SectionKind = SectionKind(0x010c);
    /// Issue 17: per patch, its bits over the spherical samples (002).
    pub const PATCH_SAMPLES: SectionKind = SectionKind(0x010d);
    // cells/<id>.pack
    pub const CELL_META: SectionKind = SectionKind(0x0201);
    pub const ORIGINALS: SectionKind = SectionKind(0x0202);
    pub const PROXIES: SectionKind = SectionKind(0x0203);
    pub const MEMBERS: SectionKind = SectionKind(0x0204);
    pub const MEMBER_TRIANGLES: SectionKind = SectionKind(0x0205);
    pub const VIEW_MASKS: SectionKind = SectionKind(0x0206);
    pub const VIEWS: SectionKind = SectionKind(0x0207);
    pub const TEXTURES: SectionKind = SectionKind(0x0208);
    /// Layered impostors (paper 001, issue 16): the layers of every LayeredImpostor
    /// proxy; present only in packs that have one (format/README.md).
    pub const LAYERED_IMPOSTORS: SectionKind = SectionKind(0x0209);
    /// Reserved for patch visibility bitfields (paper 002); no v1 writer emits it.
    pub const PATCH_BITFIELDS: SectionKind = SectionKind(0x020a);
    /// Version 6 (issue 27 item 3): per view, the 32-byte blake3 name of its texture
    /// in the bake's store (`texture_store`); a pack has this or `textures`, not both.
    pub const TEXTURE_REFS: SectionKind = SectionKind(0x020b);
    // index.pack
    pub const INDEX_META: SectionKind = SectionKind(0x0301);
    pub const INDEX_CELLS: SectionKind = SectionKind(0x0302);
    pub const INDEX_FILE_NAMES: SectionKind = SectionKind(0x0303);
    pub const INDEX_NEIGHBOURS: SectionKind = SectionKind(0x0304);
    /// Version 2: one record per far-field group pack (the layout of `index-cells`).
    pub const INDEX_GROUPS: SectionKind = SectionKind(0x0305);
    /// Version 2: per cell (in `index-cells` order), its far-field group or u32::MAX.
    pub const INDEX_CELL_GROUPS: SectionKind = SectionKind(0x0306);
    /// Version 7 (issue 32): the base pack of this generation, one record in the
    /// layout of `index-cells` (its file name in `index-file-names`, its size and
    /// blake3); without it the base pack is `base.pack`.
    pub const INDEX_BASE: SectionKind = SectionKind(0x0307);

    /// The spec's name of a known kind, `None` for kinds this reader does not know.
    pub fn name(self) -> Option<&'static str> {
        Some(match self {
            SectionKind::BASE_META => "base-meta",
            SectionKind::MODEL_TABLE => "model-table",
            SectionKind::MODEL_NAMES => "model-names",
            SectionKind::POSITIONS => "positions",
            SectionKind::NORMALS => "normals",
            SectionKind::VERTEX_COLOURS => "vertex-colours",
            SectionKind::TRIANGLES => "triangles",
            SectionKind::INSTANCES => "instances",
            SectionKind::ALBEDO_TEXTURES => "albedo-textures",
            SectionKind::TEXCOORDS => "texcoords",
            SectionKind::PATCH_TABLE => "patch-table",
            SectionKind::PATCH_TRIANGLES => "patch-triangles",
            SectionKind::PATCH_SAMPLES => "patch-samples",
            SectionKind::CELL_META => "cell-meta",
            SectionKind::ORIGINALS => "originals",
            SectionKind::PROXIES => "proxies",
            SectionKind::MEMBERS => "members",
            SectionKind::MEMBER_TRIANGLES => "member-triangles",
            SectionKind::VIEW_MASKS => "view-masks",
            SectionKind::VIEWS => "views",
            SectionKind::TEXTURES => "textures",
            SectionKind::LAYERED_IMPOSTORS => "layered-impostors",
            SectionKind::PATCH_BITFIELDS => "patch-bitfields",
            SectionKind::TEXTURE_REFS => "texture-refs",
            SectionKind::INDEX_META => "index-meta",
            SectionKind::INDEX_CELLS => "index-cells",
            SectionKind::INDEX_FILE_NAMES => "index-file-names",
            SectionKind::INDEX_NEIGHBOURS => "index-neighbours",
            SectionKind::INDEX_GROUPS => "index-groups",
            SectionKind::INDEX_CELL_GROUPS => "index-cell-groups",
            SectionKind::INDEX_BASE => "index-base",
            _ => return None,
        })
    }
}

impl fmt::Display for SectionKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(n) => write!(f, "{n} ({:#06x})", self.0),
            None => write!(f, "unknown ({:#06x})", self.0),
        }
    }
}

impl fmt::Debug for SectionKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// `v` rounded up to a multiple of [`SECTION_ALIGN`]; `None` on overflow.
pub fn align_up(v: u64) -> Option<u64> {
    v.checked_add(SECTION_ALIGN - 1)
        .map(|x| x & !(SECTION_ALIGN - 1))
}

/// The header checksum: blake3 of header bytes 0..48 and the table, first 16 bytes.
pub fn header_checksum(header_prefix: &[u8], table: &[u8]) -> [u8; 16] {
    let mut h = blake3::Hasher::new();
    h.update(header_prefix);
    h.update(table);
    let full = h.finalize();
    let mut out = [0u8; 16];
    out.copy_from_slice(&full.as_bytes()[..16]);
    out
}
