//! The bake's texture store (format version 6; issue 27 item 3, "captures stored
//! once"; format/README.md "textures/").
//!
//! Paper 000 §3.1.4 builds an MVMesh from captures taken at the centres of the
//! neighbouring cells, so the capture of one object from one centre is used by up to
//! seven cells (the centre's own cell and its six neighbours), and a far-field group's
//! captures by every cell below it. Stored inside each cell pack, the same bytes were
//! written up to seven times: on park-2m, 746 MB of encoded captures held 167 MB of
//! distinct ones. A version-6 cell or group pack therefore names each view's texture
//! by the blake3 hash of its encoded bytes (section `texture-refs`), and the bytes live
//! once in the bake directory:
//!
//! ```text
//! <bake>/textures/<h[0..2]>/<h>.tex   one zstd frame of the encoded texture bytes
//! ```
//!
//! where `h` is the 64-digit lower-case hex of the hash. The name is the content: two
//! jobs writing the same capture write the same file, so parallel jobs, Slurm tasks
//! and resumed bakes need no coordination, and the set of files does not depend on
//! the thread count or executor. A reader decompresses (never more than the view's
//! `data_len` bytes) and checks the hash, so a damaged or substituted file is an
//! error naming it, never a wrong picture.
//!
//! Files are written with a temp file and a rename (a reader never sees half a file)
//! but without fsync: the job record, written and synced after its packs, is only
//! trusted when every texture its packs name is present and whole
//! ([`missing_texture`]), so a texture lost in a crash makes the job run again.

use super::codec;
use super::layout::Codec;
use super::{PackError, PackFile, SectionKind};
use crate::fingerprint::{from_hex, to_hex};
use std::path::{Path, PathBuf};

/// The store's directory inside a bake directory.
pub const TEXTURES_DIR: &str = "textures";

/// Bytes of one texture reference in section `texture-refs`.
pub const REF_LEN: usize = 32;

/// A texture's name in the store: the blake3 hash of its encoded bytes.
pub type TextureRef = [u8; REF_LEN];

/// The hash that names `data`.
pub fn texture_ref(data: &[u8]) -> TextureRef {
    *blake3::hash(data).as_bytes()
}

/// `<bake>/textures/<h[0..2]>/<h>.tex`.
pub fn texture_path(bake: &Path, r: &TextureRef) -> PathBuf {
    let hex = to_hex(r);
    bake.join(TEXTURES_DIR)
        .join(&hex[..2])
        .join(format!("{hex}.tex"))
}

/// The bake directory of a cell or group pack at `<bake>/cells/<id>.pack` or
/// `<bake>/groups/<id>.pack` (`None` for a pack held in memory).
pub fn bake_dir_of(pack: &Path) -> Option<&Path> {
    pack.parent()?.parent()
}

/// Stores `data` under its hash unless a whole copy is already there; returns the
/// reference. The file's bytes depend only on `data` (fixed zstd level).
pub fn write_texture(bake: &Path, data: &[u8]) -> Result<TextureRef, PackError> {
    let r = texture_ref(data);
    let path = texture_path(bake, &r);
    if read_texture_at(&path, &r, data.len() as u64).is_ok() {
        return Ok(r);
    }
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| PackError::Io { file, source }
    };
    let dir = path.parent().expect("texture paths have a directory");
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let (_, tmp) = super::writer::temp_file_for(&path).expect("texture paths name a file");
    let frame = codec::zstd_compress(data);
    let result = std::fs::write(&tmp, &frame)
        .map_err(io(&tmp))
        .and_then(|()| std::fs::rename(&tmp, &path).map_err(io(&path)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map(|()| r)
}

/// Reads texture `r` of `len` encoded bytes from the store of `bake`, checking its
/// hash.
pub fn read_texture(bake: &Path, r: &TextureRef, len: u64) -> Result<Vec<u8>, PackError> {
    read_texture_at(&texture_path(bake, r), r, len)
}

fn read_texture_at(path: &Path, r: &TextureRef, len: u64) -> Result<Vec<u8>, PackError> {
    let stored = std::fs::read(path).map_err(|source| PackError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    let bad = |what: String| PackError::Invalid {
        what: format!("{}: {what}", path.display()),
    };
    let data = codec::decode(Codec::Zstd, &stored, len)
        .map_err(|e| bad(format!("not a texture of {len} bytes: {e}")))?;
    if texture_ref(&data) != *r {
        return Err(bad(format!(
            "content hash {} differs from its name (a damaged or substituted texture)",
            to_hex(&texture_ref(&data))
        )));
    }
    Ok(data)
}

/// The references of a version-6 pack's `texture-refs` section, in view order
/// (empty when the pack keeps its textures inline).
pub fn pack_refs(pack: &PackFile) -> Result<Vec<TextureRef>, PackError> {
    if pack.section_info(SectionKind::TEXTURE_REFS).is_none() {
        return Ok(Vec::new());
    }
    let bytes = pack.section(SectionKind::TEXTURE_REFS)?;
    if bytes.len() % REF_LEN != 0 {
        return Err(super::malformed(
            pack.path(),
            SectionKind::TEXTURE_REFS,
            (bytes.len() - bytes.len() % REF_LEN) as u64,
            format!(
                "{} bytes, not a whole number of 32-byte references",
                bytes.len()
            ),
        ));
    }
    Ok(bytes
        .chunks_exact(REF_LEN)
        .map(|c| c.try_into().expect("32-byte chunk"))
        .collect())
}

/// The first texture a pack names that its bake's store lacks or holds damaged
/// (the job-record check of [`crate`]'s users: a job is only done when its packs'
/// textures are all there). `None` when every one is whole.
pub fn missing_texture(pack: &PackFile) -> Option<String> {
    let refs = match pack_refs(pack) {
        Ok(r) => r,
        Err(e) => return Some(e.to_string()),
    };
    if refs.is_empty() {
        return None;
    }
    let Some(bake) = bake_dir_of(pack.path()) else {
        return Some(format!(
            "{}: not in a bake directory",
            pack.path().display()
        ));
    };
    let views = match super::cell::view_data_lens(pack) {
        Ok(v) => v,
        Err(e) => return Some(e.to_string()),
    };
    if views.len() != refs.len() {
        return Some(format!(
            "{}: {} texture references for {} views",
            pack.path().display(),
            refs.len(),
            views.len()
        ));
    }
    refs.iter()
        .zip(views)
        .find_map(|(r, len)| read_texture(bake, r, len).err().map(|e| e.to_string()))
}

/// The store's subdirectories that exist (`textures/00` … `textures/ff`).
fn store_dirs(bake: &Path) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(bake.join(TEXTURES_DIR))
        .map(|entries| {
            entries
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.is_dir())
                .collect()
        })
        .unwrap_or_default();
    dirs.sort();
    dirs
}

/// [`super::remove_stale_temps`] over every directory of the store.
pub fn remove_stale_temps(bake: &Path, age: std::time::Duration) -> std::io::Result<()> {
    for dir in store_dirs(bake) {
        super::remove_stale_temps(&dir, age)?;
    }
    Ok(())
}

/// Every texture named by a cell or group pack in `<bake>/cells/` and
/// `<bake>/groups/` (packs that do not open name none).
pub fn referenced(bake: &Path) -> std::collections::BTreeSet<TextureRef> {
    let mut refs = std::collections::BTreeSet::new();
    for sub in ["cells", "groups"] {
        let Ok(entries) = std::fs::read_dir(bake.join(sub)) else {
            continue;
        };
        for e in entries.filter_map(|e| e.ok()) {
            let path = e.path();
            if path.extension().is_some_and(|x| x == "pack") {
                if let Ok(pack) = PackFile::read(&path) {
                    refs.extend(pack_refs(&pack).unwrap_or_default());
                }
            }
        }
    }
    refs
}

/// Deletes the store's texture files that no pack of the bake names any more (after
/// an incremental rebake changed captures); returns how many and their bytes. Only
/// while the output lock is held: a job writing a texture it is about to name would
/// otherwise lose it.
pub fn sweep_unreferenced(bake: &Path) -> std::io::Result<(u64, u64)> {
    let keep = referenced(bake);
    let (mut files, mut bytes) = (0u64, 0u64);
    for dir in store_dirs(bake) {
        for e in std::fs::read_dir(&dir)?.filter_map(|e| e.ok()) {
            let path = e.path();
            let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
            if path.extension().is_none_or(|x| x != "tex") {
                continue;
            }
            if !from_hex(name).is_some_and(|r| keep.contains(&r)) {
                bytes += e.metadata().map_or(0, |m| m.len());
                std::fs::remove_file(&path)?;
                files += 1;
            }
        }
    }
    Ok((files, bytes))
}
