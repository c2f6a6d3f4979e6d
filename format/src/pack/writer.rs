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

impl SectionData {
    /// Section `kind` with content `raw`, stored with the best of `codecs`.
    pub fn new(kind: SectionKind, raw: Vec<u8>, codecs: &'static [Codec]) -> SectionData {
        SectionData { kind, raw, codecs }
    }

    /// Section `kind` holding `records` as they lie in memory (little-endian `Pod`
    /// records, as the format's record types are laid out).
    pub fn of_records<T: bytemuck::Pod>(
        kind: SectionKind,
        records: &[T],
        codecs: &'static [Codec],
    ) -> SectionData {
        SectionData::new(kind, bytemuck::cast_slice(records).to_vec(), codecs)
    }
}

/// Codec candidates for general data.
pub const TRY_ZSTD: &[Codec] = &[Codec::Zstd];
/// Codec candidates for vertex arrays: zstd only where it saves a quarter (else they
/// stay raw, usable zero-copy from a memory map).
pub const TRY_ZSTD_PREFER_RAW: &[Codec] = &[Codec::Zstd, Codec::Raw];
/// Codec candidates for u32 index streams.
pub const TRY_INDICES: &[Codec] = &[Codec::Zstd, Codec::ZstdDeltaU32];
/// Codec candidates for triangle lists (u32 triples whose neighbours share vertices).
pub const TRY_TRIANGLES: &[Codec] = &[Codec::Zstd, Codec::ZstdDeltaU32, Codec::ZstdIndexMtf];
/// Store raw (tiny fixed-size metadata).
pub const RAW_ONLY: &[Codec] = &[];

/// Builds the bytes of a pack of `file_kind` from its sections, in the given order.
pub fn assemble(file_kind: FileKind, sections: &[SectionData]) -> Result<Vec<u8>, PackError> {
    assemble_reusing(file_kind, sections, None)
}

/// [`assemble`], copying the stored bytes of every section whose decoded content is
/// unchanged from `previous` (an earlier pack of the same file, [`PackFile::stored_if_same`])
/// instead of compressing it again: the same bytes, without the compression's cost
/// (issue 13: an incremental rebake rewrites many packs whose textures did not change).
pub fn assemble_reusing(
    file_kind: FileKind,
    sections: &[SectionData],
    previous: Option<&super::reader::PackFile>,
) -> Result<Vec<u8>, PackError> {
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
        let (codec, stored) = previous
            .and_then(|p| p.stored_if_same(s.kind, &s.raw, s.codecs))
            .unwrap_or_else(|| codec::encode_best_with(&s.raw, s.codecs, prefer_raw));
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

/// What separates a temp file's target name from its owner:
/// `.<name>.tmp-<host>-<pid>-<counter>`.
const TEMP_MARK: &str = ".tmp-";

/// This machine's host name (non-empty, no white space): `/proc/sys/kernel/hostname`,
/// else `$HOSTNAME`, else `unknown`.
pub fn hostname() -> String {
    let usable = |s: String| {
        let s = s.trim().to_string();
        (!s.is_empty() && !s.contains(char::is_whitespace)).then_some(s)
    };
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .and_then(usable)
        .or_else(|| std::env::var("HOSTNAME").ok().and_then(usable))
        .unwrap_or_else(|| "unknown".into())
}

/// The host name as it appears in temp file names (characters other than
/// `[A-Za-z0-9._]` become `_`, so the name splits unambiguously at `-`).
fn temp_host() -> String {
    hostname()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The name of [`write_atomic`]'s temp file for `target` (a file name) written by
/// process `pid` of this host: `.<target>.tmp-<host>-<pid>-<counter>`.
pub fn temp_name(target: &str, pid: u32, counter: u64) -> String {
    format!(".{target}{TEMP_MARK}{}-{pid}-{counter}", temp_host())
}

/// Whether process `pid` of this host is running (Linux `/proc`; a zombie counts as
/// gone). Where `/proc` does not exist every pid counts as alive, which only makes
/// callers more careful.
pub fn process_alive(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    match std::fs::read_to_string(format!("/proc/{pid}/status")) {
        Ok(s) => !s
            .lines()
            .any(|l| l.starts_with("State:") && l.contains('Z')),
        Err(_) => false,
    }
}

/// Removes the temp files [`write_atomic`] left in `dir` when its process was killed
/// between creating the temp file and renaming it (SIGKILL, a node lost, `scancel`).
/// A temp file is stale when its writer was on this host and is no longer running, or
/// when it has not been modified for `max_age` (a writer on another host, or a pid
/// reused since). Call it only while holding the output's lock. Returns the files
/// removed; a missing `dir` has none.
pub fn remove_stale_temps(
    dir: &Path,
    max_age: std::time::Duration,
) -> std::io::Result<Vec<PathBuf>> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let host = temp_host();
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let Some(owner) = name
            .strip_prefix('.')
            .and_then(|n| n.rfind(TEMP_MARK).map(|at| &n[at + TEMP_MARK.len()..]))
        else {
            continue;
        };
        // `<host>-<pid>-<counter>`, read from the right (older files lack the host).
        let mut parts = owner.rsplitn(3, '-');
        let (Some(_counter), Some(pid)) = (parts.next(), parts.next()) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        let writer_gone = parts.next() == Some(host.as_str()) && !process_alive(pid);
        let old = entry
            .metadata()?
            .modified()
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age > max_age);
        if writer_gone || old {
            let path = entry.path();
            match std::fs::remove_file(&path) {
                Ok(()) => removed.push(path),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(e),
            }
        }
    }
    removed.sort();
    Ok(removed)
}

/// `path`'s directory and this process's next temp file for it there
/// ([`temp_name`]); `None` when `path` names no file.
pub(crate) fn temp_file_for(path: &Path) -> Option<(PathBuf, PathBuf)> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name()?.to_string_lossy();
    let tmp = dir.join(temp_name(
        &name,
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed),
    ));
    Some((dir, tmp))
}

/// Creates the new file `tmp` holding `bytes`, synced to disk.
pub(crate) fn write_synced(tmp: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(tmp)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// Makes a rename or link in `dir` durable. Directories cannot be opened on every
/// platform; where they can, sync them.
pub(crate) fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Writes `bytes` to `path` atomically: a temp file next to it, fsync, rename over
/// `path`, fsync of the directory. Packs are never modified in place, which is what
/// makes memory-mapping them sound (see `PackFile::open`).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PackError> {
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| PackError::Io { file, source }
    };
    let (dir, tmp) = temp_file_for(path).ok_or_else(|| PackError::Invalid {
        what: format!("{}: not a file path", path.display()),
    })?;
    let result = (|| {
        write_synced(&tmp, bytes).map_err(io(&tmp))?;
        std::fs::rename(&tmp, path).map_err(io(path))?;
        sync_dir(&dir);
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Creates the new file `path` holding `bytes`, failing with `AlreadyExists` when it
/// exists (like `create_new`), and atomically: the file appears with all of `bytes`
/// or not at all, whenever the process is killed. A temp file is written as for
/// [`write_atomic`] and hard-linked to `path` (a link never replaces a file). On a
/// file system without hard links it falls back to `create_new` and one `write_all`.
pub fn create_new_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let (dir, tmp) = temp_file_for(path).ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{}: not a file path", path.display()),
        )
    })?;
    let linked = write_synced(&tmp, bytes).and_then(|()| std::fs::hard_link(&tmp, path));
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Ok(()) => {
            sync_dir(&dir);
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(e),
        // No hard links here (or no temp file could be made): one write.
        Err(_) => std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)?
            .write_all(bytes),
    }
}
