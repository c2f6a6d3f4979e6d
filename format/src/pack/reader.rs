//! Pack reader: one memory-mapping constructor with a documented safety contract
//! ([`PackFile::open`]), plain-read fallbacks ([`PackFile::read`],
//! [`PackFile::from_bytes`]), and validation of the header, the table and every
//! section checksum before anything is exposed. Sections decode lazily, on request;
//! raw sections are available zero-copy. Every offset and length read from the file is
//! checked (checked arithmetic, bounds, alignment, canonical placement); any malformed
//! input is a [`PackError`], never a panic (meshoptimizer's "decoders are hostile
//! territory", STYLE.md habit 5).

use super::codec;
use super::error::{hex, PackError};
use super::layout::{
    align_up, header_checksum, Codec, FileKind, Header, SectionEntry, SectionKind, ENTRY_SIZE,
    FORMAT_VERSION, HEADER_CHECKED_LEN, HEADER_SIZE, MAGIC, MAX_EXPANSION, MAX_RAW_LEN,
    MAX_SECTIONS, SECTION_ALIGN,
};
use bytemuck::{Pod, Zeroable};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// One validated section table entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SectionInfo {
    /// Position in the table.
    pub entry: u32,
    pub kind: SectionKind,
    pub codec: Codec,
    /// Offset of the stored bytes from the file start.
    pub offset: u64,
    pub stored_len: u64,
    pub raw_len: u64,
    pub checksum: [u8; 32],
}

/// The structure of a pack whose header and table are valid; section checksums are
/// reported one by one (`checksum_ok`), for tools like `pipeline inspect` that show
/// every section even when one is corrupt. [`PackFile`] refuses any bad checksum.
#[derive(Clone, Debug)]
pub struct PackScan {
    pub header: Header,
    pub file_kind: FileKind,
    pub sections: Vec<SectionInfo>,
    /// `checksum_ok[i]` is whether `sections[i]`'s stored bytes match its checksum.
    pub checksum_ok: Vec<bool>,
}

/// Validates the header and the section table of `bytes` and checks every section's
/// checksum. `file` only names the input in errors.
pub fn scan(bytes: &[u8], file: &Path) -> Result<PackScan, PackError> {
    let f = || file.to_path_buf();
    let found = bytes.len() as u64;
    // Bytes `start..end` of the file, or `Truncated` naming `what`.
    let take = |start: usize, end: usize, what: &'static str| {
        bytes.get(start..end).ok_or_else(|| PackError::Truncated {
            file: f(),
            what,
            needed: end as u64,
            found,
        })
    };
    // 1. Magic, file kind and version come first, so that a future version with a
    //    different header layout still gets a clear FutureVersion error.
    let magic = take(0, 8, "magic")?;
    if magic != MAGIC {
        let mut m = [0u8; 8];
        m.copy_from_slice(magic);
        return Err(PackError::BadMagic {
            file: f(),
            found: m,
        });
    }
    let kv = take(8, 16, "file kind and version")?;
    let raw_kind = u32::from_le_bytes([kv[0], kv[1], kv[2], kv[3]]);
    let version = u32::from_le_bytes([kv[4], kv[5], kv[6], kv[7]]);
    let file_kind = FileKind::from_u32(raw_kind).ok_or(PackError::UnknownFileKind {
        file: f(),
        found: raw_kind,
    })?;
    if version > FORMAT_VERSION {
        return Err(PackError::FutureVersion {
            file: f(),
            found: version,
            supported: FORMAT_VERSION,
        });
    }
    if version == 0 {
        return Err(PackError::UnknownVersion {
            file: f(),
            found: version,
        });
    }
    if file_kind == FileKind::Group && version < 2 {
        // Group packs exist from version 2 on.
        return Err(PackError::UnknownFileKind {
            file: f(),
            found: raw_kind,
        });
    }

    // 2. The v1 header.
    let hb = take(0, HEADER_SIZE, "header")?;
    let header: Header = bytemuck::pod_read_unaligned(hb);
    let bad =
        |field: &'static str, offset: u64, expected: String, found: String| PackError::BadHeader {
            file: f(),
            field,
            offset,
            expected,
            found,
        };
    if header.table_offset != HEADER_SIZE as u64 {
        return Err(bad(
            "table_offset",
            24,
            HEADER_SIZE.to_string(),
            header.table_offset.to_string(),
        ));
    }
    if header.section_count > MAX_SECTIONS {
        return Err(bad(
            "section_count",
            20,
            format!("<= {MAX_SECTIONS}"),
            header.section_count.to_string(),
        ));
    }
    let table_len = header.section_count as usize * ENTRY_SIZE;
    let table_end = HEADER_SIZE + table_len;
    let table = take(HEADER_SIZE, table_end, "section table")?;
    let expected_sum = header_checksum(&hb[..HEADER_CHECKED_LEN], table);
    if expected_sum != header.header_checksum {
        return Err(PackError::HeaderChecksum {
            file: f(),
            expected: hex(&header.header_checksum),
            found: hex(&expected_sum),
        });
    }
    if header.flags != 0 {
        return Err(bad("flags", 16, "0".into(), format!("{:#x}", header.flags)));
    }
    if header.reserved != 0 {
        return Err(bad("reserved", 40, "0".into(), header.reserved.to_string()));
    }
    if header.file_len != found {
        return Err(PackError::LengthMismatch {
            file: f(),
            expected: header.file_len,
            found,
        });
    }

    // 3. The table: each section starts at the first aligned offset after the previous
    //    one (so sections are in order, aligned, in bounds and never overlap), with a
    //    known codec and a bounded raw length.
    let mut sections: Vec<SectionInfo> = Vec::with_capacity(header.section_count as usize);
    let mut cursor = table_end as u64;
    for (i, chunk) in table.chunks_exact(ENTRY_SIZE).enumerate() {
        let e: SectionEntry = bytemuck::pod_read_unaligned(chunk);
        let entry_offset = (HEADER_SIZE + i * ENTRY_SIZE) as u64;
        let kind = SectionKind(e.kind);
        let table_err = |what: String| PackError::BadTable {
            file: f(),
            entry: i as u32,
            offset: entry_offset,
            section: kind,
            what,
        };
        if e.kind == 0 {
            return Err(table_err("section kind 0 is reserved".into()));
        }
        if sections.iter().any(|s| s.kind == kind) {
            return Err(table_err("section kind appears twice".into()));
        }
        let codec = Codec::from_u32(e.codec)
            .ok_or_else(|| table_err(format!("unknown codec {}", e.codec)))?;
        if codec == Codec::ZstdIndexMtf && header.version < 3 {
            return Err(table_err(format!(
                "codec 3 (zstd+index-mtf) needs format version 3, the file has {}",
                header.version
            )));
        }
        let expected_offset =
            align_up(cursor).ok_or_else(|| table_err("offset overflow".into()))?;
        if e.offset != expected_offset {
            return Err(table_err(format!(
                "section offset {} (expected {expected_offset}: sections follow each other at {SECTION_ALIGN}-byte alignment)",
                e.offset
            )));
        }
        let end = e
            .offset
            .checked_add(e.stored_len)
            .ok_or_else(|| table_err("offset + stored length overflows".into()))?;
        if end > found {
            return Err(table_err(format!(
                "section ends at {end}, past the end of the file ({found} bytes)"
            )));
        }
        if e.raw_len > MAX_RAW_LEN {
            return Err(table_err(format!(
                "raw length {} exceeds {MAX_RAW_LEN}",
                e.raw_len
            )));
        }
        match codec {
            Codec::Raw if e.raw_len != e.stored_len => {
                return Err(table_err(format!(
                    "raw section: raw length {} differs from stored length {}",
                    e.raw_len, e.stored_len
                )));
            }
            Codec::Zstd | Codec::ZstdDeltaU32 | Codec::ZstdIndexMtf
                if e.raw_len > e.stored_len.saturating_mul(MAX_EXPANSION) =>
            {
                return Err(table_err(format!(
                    "raw length {} is more than {MAX_EXPANSION}x the stored length {}",
                    e.raw_len, e.stored_len
                )));
            }
            _ => {}
        }
        cursor = end;
        sections.push(SectionInfo {
            entry: i as u32,
            kind,
            codec,
            offset: e.offset,
            stored_len: e.stored_len,
            raw_len: e.raw_len,
            checksum: e.checksum,
        });
    }
    if cursor != found {
        // Unreachable for a consistent header (file_len == found), but cheap to state.
        return Err(PackError::LengthMismatch {
            file: f(),
            expected: cursor,
            found,
        });
    }

    // 4. Padding between sections must be zero (no byte of the file goes unchecked).
    let mut prev_end = table_end as u64;
    for s in &sections {
        for off in prev_end..s.offset {
            let b = bytes.get(off as usize).copied().unwrap_or(0);
            if b != 0 {
                return Err(PackError::NonZeroPadding {
                    file: f(),
                    offset: off,
                    found: b,
                });
            }
        }
        prev_end = s.offset + s.stored_len;
    }

    // 5. Section checksums.
    let checksum_ok = sections
        .iter()
        .map(|s| {
            let stored = bytes
                .get(s.offset as usize..(s.offset + s.stored_len) as usize)
                .unwrap_or(&[]);
            *blake3::hash(stored).as_bytes() == s.checksum
        })
        .collect();
    Ok(PackScan {
        header,
        file_kind,
        sections,
        checksum_ok,
    })
}

/// 64-byte-aligned owned storage, so raw sections of a plainly read pack are as
/// aligned as those of a memory-mapped one.
#[repr(C, align(64))]
#[derive(Clone, Copy, Zeroable, Pod)]
struct Block([u8; 64]);

enum Backing {
    Mapped(memmap2::Mmap),
    Owned { blocks: Vec<Block>, len: usize },
}

impl Backing {
    fn bytes(&self) -> &[u8] {
        match self {
            Backing::Mapped(m) => m,
            Backing::Owned { blocks, len } => {
                let all: &[u8] = bytemuck::cast_slice(blocks);
                &all[..*len]
            }
        }
    }
}

/// A validated pack: header, table and every section checksum have been checked.
pub struct PackFile {
    file: PathBuf,
    backing: Backing,
    scan: PackScan,
}

impl std::fmt::Debug for PackFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PackFile")
            .field("file", &self.file)
            .field("kind", &self.scan.file_kind)
            .field("sections", &self.scan.sections)
            .finish()
    }
}

impl PackFile {
    /// Memory-maps and validates the pack at `path`.
    ///
    /// # Safety contract
    ///
    /// A memory map reflects later changes to the file: if another process truncates
    /// or rewrites the file while it is mapped, reads may see changed bytes (after
    /// validation) or the process may be killed by SIGBUS. hexbake never modifies a
    /// pack in place — writers create a temp file and atomically rename it over the
    /// old one ([`super::writer::write_atomic`]), which leaves existing maps on the old
    /// inode untouched — so this is sound for packs written by hexbake as long as no
    /// other program edits them in place. Where that cannot be promised (packs on a
    /// network file system edited by others), use [`PackFile::read`].
    pub fn open(path: &Path) -> Result<PackFile, PackError> {
        let io = |source| PackError::Io {
            file: path.to_path_buf(),
            source,
        };
        let f = std::fs::File::open(path).map_err(io)?;
        let len = f.metadata().map_err(io)?.len();
        if len < HEADER_SIZE as u64 {
            // Too small to be a pack; read it so the error says exactly why.
            return PackFile::read(path);
        }
        // SAFETY: see the contract above — packs are only ever replaced by rename, never
        // modified in place, and every byte is validated before use.
        let map = unsafe { memmap2::Mmap::map(&f) }.map_err(io)?;
        PackFile::from_backing(path.to_path_buf(), Backing::Mapped(map))
    }

    /// Reads the whole file into memory and validates it (no memory map).
    pub fn read(path: &Path) -> Result<PackFile, PackError> {
        let bytes = std::fs::read(path).map_err(|source| PackError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        PackFile::from_bytes_named(&bytes, path)
    }

    /// Validates a pack held in memory (copied into aligned storage).
    pub fn from_bytes(bytes: &[u8]) -> Result<PackFile, PackError> {
        PackFile::from_bytes_named(bytes, Path::new("<memory>"))
    }

    /// As [`PackFile::from_bytes`], naming the input `name` in errors.
    pub fn from_bytes_named(bytes: &[u8], name: &Path) -> Result<PackFile, PackError> {
        let mut blocks = vec![Block([0; 64]); bytes.len().div_ceil(64)];
        bytemuck::cast_slice_mut::<Block, u8>(&mut blocks)[..bytes.len()].copy_from_slice(bytes);
        PackFile::from_backing(
            name.to_path_buf(),
            Backing::Owned {
                blocks,
                len: bytes.len(),
            },
        )
    }

    fn from_backing(file: PathBuf, backing: Backing) -> Result<PackFile, PackError> {
        let scan = scan(backing.bytes(), &file)?;
        if let Some(i) = scan.checksum_ok.iter().position(|ok| !ok) {
            let s = &scan.sections[i];
            let bytes = backing.bytes();
            let stored = bytes
                .get(s.offset as usize..(s.offset + s.stored_len) as usize)
                .unwrap_or(&[]);
            return Err(PackError::SectionChecksum {
                file,
                section: s.kind,
                offset: s.offset,
                expected: hex(&s.checksum),
                found: hex(blake3::hash(stored).as_bytes()),
            });
        }
        Ok(PackFile {
            file,
            backing,
            scan,
        })
    }

    /// The path (or `<memory>`) this pack was read from.
    pub fn path(&self) -> &Path {
        &self.file
    }

    pub fn file_kind(&self) -> FileKind {
        self.scan.file_kind
    }

    pub fn version(&self) -> u32 {
        self.scan.header.version
    }

    pub fn header(&self) -> &Header {
        &self.scan.header
    }

    /// Every section, in file order (including kinds this reader does not know).
    pub fn sections(&self) -> &[SectionInfo] {
        &self.scan.sections
    }

    /// The whole file.
    pub fn bytes(&self) -> &[u8] {
        self.backing.bytes()
    }

    /// Whether the bytes are memory-mapped (as opposed to read into memory).
    pub fn is_mapped(&self) -> bool {
        matches!(self.backing, Backing::Mapped(_))
    }

    /// Errors unless this is a pack of `kind`.
    pub fn expect_kind(&self, kind: FileKind) -> Result<(), PackError> {
        if self.scan.file_kind != kind {
            return Err(PackError::WrongFileKind {
                file: self.file.clone(),
                expected: kind.name(),
                found: self.scan.file_kind.name(),
            });
        }
        Ok(())
    }

    pub fn section_info(&self, kind: SectionKind) -> Option<&SectionInfo> {
        self.scan.sections.iter().find(|s| s.kind == kind)
    }

    /// The section table entry of `kind`, or `MissingSection`.
    fn required_section_info(&self, kind: SectionKind) -> Result<SectionInfo, PackError> {
        self.section_info(kind)
            .copied()
            .ok_or_else(|| PackError::MissingSection {
                file: self.file.clone(),
                section: kind,
            })
    }

    fn stored(&self, s: &SectionInfo) -> &[u8] {
        // In bounds: checked by `scan` against the same bytes.
        self.bytes()
            .get(s.offset as usize..(s.offset + s.stored_len) as usize)
            .unwrap_or(&[])
    }

    /// The codec and stored bytes of section `kind` if its decoded content is `raw`,
    /// its codec is one of `codecs` and this pack has the writer's format version:
    /// what [`super::writer::assemble_reusing`] copies instead of compressing `raw`
    /// again (the writer's codec choice is deterministic, so a fresh encoding would
    /// give these very bytes).
    pub fn stored_if_same(
        &self,
        kind: SectionKind,
        raw: &[u8],
        codecs: &[Codec],
    ) -> Option<(Codec, Vec<u8>)> {
        let s = *self.section_info(kind)?;
        if self.version() != FORMAT_VERSION
            || s.raw_len != raw.len() as u64
            || !(s.codec == Codec::Raw || codecs.contains(&s.codec))
        {
            return None;
        }
        (self.section(kind).ok()?.as_ref() == raw).then(|| (s.codec, self.stored(&s).to_vec()))
    }

    /// A section's decoded content: borrowed for raw sections, decompressed now for
    /// compressed ones (nothing is decompressed until asked for).
    pub fn section(&self, kind: SectionKind) -> Result<Cow<'_, [u8]>, PackError> {
        let s = self.required_section_info(kind)?;
        let stored = self.stored(&s);
        match s.codec {
            Codec::Raw => Ok(Cow::Borrowed(stored)),
            c => codec::decode(c, stored, s.raw_len)
                .map(Cow::Owned)
                .map_err(|detail| PackError::Decompress {
                    file: self.file.clone(),
                    section: kind,
                    offset: s.offset,
                    detail,
                }),
        }
    }

    /// Zero-copy typed view of a raw section: `Ok(Some(slice))` when the section is
    /// stored raw, `Ok(None)` when it is compressed (use [`PackFile::section_vec`]).
    pub fn raw_slice<T: Pod>(&self, kind: SectionKind) -> Result<Option<&[T]>, PackError> {
        let s = self.required_section_info(kind)?;
        if s.codec != Codec::Raw {
            return Ok(None);
        }
        let stored = self.stored(&s);
        bytemuck::try_cast_slice(stored)
            .map(Some)
            .map_err(|e| PackError::Malformed {
                file: self.file.clone(),
                section: kind,
                offset: 0,
                what: format!(
                    "cannot view {} bytes as [{}]: {e}",
                    stored.len(),
                    std::any::type_name::<T>()
                ),
            })
    }

    /// A fixed-size section (a file's metadata record) as one `T`: exactly
    /// `size_of::<T>()` bytes, else a Malformed error at offset 0.
    pub fn section_record<T: Pod>(&self, kind: SectionKind) -> Result<T, PackError> {
        let bytes = self.section(kind)?;
        let size = std::mem::size_of::<T>();
        if bytes.len() != size {
            return Err(PackError::Malformed {
                file: self.file.clone(),
                section: kind,
                offset: 0,
                what: format!("{} bytes, expected {size}", bytes.len()),
            });
        }
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }

    /// A table section as a vector of `T` holding `count` records, as the metadata
    /// section `meta` says, else a Malformed error "N `what`, `meta` says `count`".
    pub fn section_table<T: Pod>(
        &self,
        kind: SectionKind,
        count: u32,
        what: &str,
        meta: &str,
    ) -> Result<Vec<T>, PackError> {
        let records: Vec<T> = self.section_vec(kind)?;
        if records.len() != count as usize {
            return Err(PackError::Malformed {
                file: self.file.clone(),
                section: kind,
                offset: 0,
                what: format!("{} {what}, {meta} says {count}", records.len()),
            });
        }
        Ok(records)
    }

    /// A section's content as a vector of `T` (copying; works for every codec).
    pub fn section_vec<T: Pod>(&self, kind: SectionKind) -> Result<Vec<T>, PackError> {
        let bytes = self.section(kind)?;
        pod_vec(&bytes, &self.file, kind)
    }
}

/// `bytes` as a vector of `T`, or a Malformed error if the length is not a multiple of
/// `size_of::<T>()`.
pub(crate) fn pod_vec<T: Pod>(
    bytes: &[u8],
    file: &Path,
    section: SectionKind,
) -> Result<Vec<T>, PackError> {
    let size = std::mem::size_of::<T>();
    if size == 0 || !bytes.len().is_multiple_of(size) {
        return Err(PackError::Malformed {
            file: file.to_path_buf(),
            section,
            offset: bytes.len() as u64,
            what: format!(
                "length {} is not a multiple of the record size {size}",
                bytes.len()
            ),
        });
    }
    Ok(bytemuck::pod_collect_to_vec(bytes))
}
