//! Pack writer: lays sections out as format/README.md says (header, table, 64-byte
//! aligned sections, zero padding), chooses each section's codec deterministically,
//! and writes files atomically (temp file in the same directory, fsync, rename, fsync
//! of the directory), so a reader never sees a half-written pack and a crashed bake
//! leaves either the old file or the new one.

use super::codec;
use super::error::PackError;
use super::layout::{
    align_up, header_checksum, Codec, FileKind, Header, SectionEntry, SectionKind, ENTRY_SIZE,
    FORMAT_VERSION, HEADER_CHECKED_LEN, HEADER_SIZE, MAGIC, MAX_RAW_LEN, MAX_SECTIONS,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// One section to write: its kind, its decoded content, and the codecs worth trying
/// (the writer keeps the smallest that pays, else stores it raw; listing
/// [`Codec::Raw`] among them means "prefer raw": compress only for a 1/4 saving).
#[derive(Clone, Debug)]
pub struct SectionData {
    pub kind: SectionKind,
    pub raw: Vec<u8>,
    pub codecs: &'static [Codec],
}

/// Codec candidates for general data.
pub const TRY_ZSTD: &[Codec] = &[Codec::Zstd];
/// Codec candidates for vertex arrays: zstd only where it saves a quarter (else they
/// stay raw, usable zero-copy from a memory map).
pub const TRY_ZSTD_PREFER_RAW: &[Codec] = &[Codec::Zstd, Codec::Raw];
/// Codec candidates for u32 index streams.
pub const TRY_INDICES: &[Codec] = &[Codec::Zstd, Codec::ZstdDeltaU32];
/// Store raw (tiny fixed-size metadata).
pub const RAW_ONLY: &[Codec] = &[];

/// Builds the bytes of a pack of `file_kind` from its sections, in the given order.
pub fn assemble(file_kind: FileKind, sections: &[SectionData]) -> Result<Vec<u8>, PackError> {
    // 1. Check the sections can be described by a v1 table.
    if sections.len() as u64 > MAX_SECTIONS as u64 {
        return Err(PackError::Invalid {
            what: format!("{} sections, at most {MAX_SECTIONS}", sections.len()),
        });
    }
    for (i, s) in sections.iter().enumerate() {
        if s.kind.0 == 0 {
            return Err(PackError::Invalid {
                what: "section kind 0 is reserved".into(),
            });
        }
        if sections[..i].iter().any(|o| o.kind == s.kind) {
            return Err(PackError::Invalid {
                what: format!("duplicate section {}", s.kind),
            });
        }
        if s.raw.len() as u64 > MAX_RAW_LEN {
            return Err(PackError::Invalid {
                what: format!(
                    "section {} is {} bytes, at most {MAX_RAW_LEN}",
                    s.kind,
                    s.raw.len()
                ),
            });
        }
    }

    // 2. Encode every section and place it at the next aligned offset.
    let table_offset = HEADER_SIZE as u64;
    let table_len = (sections.len() * ENTRY_SIZE) as u64;
    let mut cursor = table_offset + table_len;
    let mut entries = Vec::with_capacity(sections.len());
    let mut stored_all = Vec::with_capacity(sections.len());
    for s in sections {
        let prefer_raw = s.codecs.contains(&Codec::Raw);
        let (codec, stored) = codec::encode_best_with(&s.raw, s.codecs, prefer_raw);
        let offset = align_up(cursor).ok_or_else(|| PackError::Invalid {
            what: "pack too large".into(),
        })?;
        cursor = offset + stored.len() as u64;
        entries.push(SectionEntry {
            kind: s.kind.0,
            codec: codec as u32,
            offset,
            stored_len: stored.len() as u64,
            raw_len: s.raw.len() as u64,
            checksum: *blake3::hash(&stored).as_bytes(),
        });
        stored_all.push(stored);
    }
    let file_len = cursor;

    // 3. Header, table, padding and sections.
    let table: &[u8] = bytemuck::cast_slice(&entries);
    let mut header = Header {
        magic: MAGIC,
        file_kind: file_kind as u32,
        version: FORMAT_VERSION,
        flags: 0,
        section_count: sections.len() as u32,
        table_offset,
        file_len,
        reserved: 0,
        header_checksum: [0; 16],
    };
    header.header_checksum =
        header_checksum(&bytemuck::bytes_of(&header)[..HEADER_CHECKED_LEN], table);
    let mut out = Vec::with_capacity(file_len as usize);
    out.extend_from_slice(bytemuck::bytes_of(&header));
    out.extend_from_slice(table);
    for (e, stored) in entries.iter().zip(&stored_all) {
        out.resize(e.offset as usize, 0);
        out.extend_from_slice(stored);
    }
    debug_assert_eq!(out.len() as u64, file_len);
    Ok(out)
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically: a temp file next to it, fsync, rename over
/// `path`, fsync of the directory. Packs are never modified in place, which is what
/// makes memory-mapping them sound (see `PackFile::open`).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PackError> {
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| PackError::Io { file, source }
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| PackError::Invalid {
        what: format!("{}: not a file path", path.display()),
    })?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(io(&tmp))?;
        f.write_all(bytes).map_err(io(&tmp))?;
        f.sync_all().map_err(io(&tmp))?;
        drop(f);
        std::fs::rename(&tmp, path).map_err(io(path))?;
        // Make the rename itself durable. Directories cannot be opened on every
        // platform; where they can, sync them.
        if let Ok(d) = std::fs::File::open(&dir) {
            let _ = d.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
