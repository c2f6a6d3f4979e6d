//! Typed errors of the pack reader and writer (STYLE.md habit 7): every variant says
//! what went wrong and where — the file, the byte offset, the section, and the
//! expected and found values.

use super::layout::SectionKind;
use std::path::PathBuf;

/// Everything that can go wrong reading or writing a pack. Readers return one of these
/// for *any* malformed input; they never panic.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    #[error("{}: {source}", file.display())]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: truncated: {what} needs {needed} bytes, the file has {found}", file.display())]
    Truncated {
        file: PathBuf,
        what: &'static str,
        needed: u64,
        found: u64,
    },
    #[error("{}: not a hexbake pack: magic at offset 0 is {found:02x?}, expected \"HEXBAKE\\0\"", file.display())]
    BadMagic { file: PathBuf, found: [u8; 8] },
    #[error("{}: unknown file kind {found} at offset 8 (1 = base, 2 = cell, 3 = index)", file.display())]
    UnknownFileKind { file: PathBuf, found: u32 },
    #[error("{}: wrong file kind: expected a {expected} pack, found a {found} pack", file.display())]
    WrongFileKind {
        file: PathBuf,
        expected: &'static str,
        found: &'static str,
    },
    #[error("{}: pack format version {found} is newer than this reader (supports up to {supported}); rebuild the packs or update hexbake", file.display())]
    FutureVersion {
        file: PathBuf,
        found: u32,
        supported: u32,
    },
    #[error("{}: pack format version {found} was never shipped", file.display())]
    UnknownVersion { file: PathBuf, found: u32 },
    #[error("{}: header field {field} at offset {offset}: expected {expected}, found {found}", file.display())]
    BadHeader {
        file: PathBuf,
        field: &'static str,
        offset: u64,
        expected: String,
        found: String,
    },
    #[error("{}: header/table checksum mismatch: expected {expected}, found {found}", file.display())]
    HeaderChecksum {
        file: PathBuf,
        expected: String,
        found: String,
    },
    #[error("{}: file checksum mismatch (the index records {expected}, the file has {found})", file.display())]
    FileChecksum {
        file: PathBuf,
        expected: String,
        found: String,
    },
    #[error("{}: file length is {found} bytes but the header says {expected}", file.display())]
    LengthMismatch {
        file: PathBuf,
        expected: u64,
        found: u64,
    },
    #[error("{}: section table entry {entry} (offset {offset}, section {section}): {what}", file.display())]
    BadTable {
        file: PathBuf,
        entry: u32,
        offset: u64,
        section: SectionKind,
        what: String,
    },
    #[error("{}: padding byte at offset {offset} is {found:#04x}, expected 0", file.display())]
    NonZeroPadding {
        file: PathBuf,
        offset: u64,
        found: u8,
    },
    #[error("{}: section {section} at offset {offset}: checksum mismatch: expected {expected}, found {found}", file.display())]
    SectionChecksum {
        file: PathBuf,
        section: SectionKind,
        offset: u64,
        expected: String,
        found: String,
    },
    #[error("{}: section {section} at offset {offset}: cannot decompress: {detail}", file.display())]
    Decompress {
        file: PathBuf,
        section: SectionKind,
        offset: u64,
        detail: String,
    },
    #[error("{}: section {section} is missing", file.display())]
    MissingSection { file: PathBuf, section: SectionKind },
    #[error("{}: section {section}, byte {offset} of its content: {what}", file.display())]
    Malformed {
        file: PathBuf,
        section: SectionKind,
        offset: u64,
        what: String,
    },
    #[error("cannot write pack: {what}")]
    Invalid { what: String },
}

/// Lower-case hex of a byte string, for error messages and `inspect`.
pub fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(bytes.len() * 2);
    for b in bytes {
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// A value of a base pack that breaks a content rule: the section, the byte offset
/// in it, and what is wrong. The writer refuses it ([`PackError::Invalid`]), the
/// reader reports it as [`PackError::Malformed`].
pub(super) struct BadValue(pub(super) SectionKind, pub(super) u64, pub(super) String);
