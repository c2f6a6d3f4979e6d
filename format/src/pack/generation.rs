//! A bake's generations (issue 32 item 1): `index.pack` is the commit point.
//!
//! Jobs write their packs under working names (`cells/<id>.pack`,
//! `groups/<id>.pack`, `base.pack`) and overwrite them when a rebake changes them.
//! Readers never open those. When every job is done, `pipeline` **publishes** each
//! pack under a name of its content, `cells/<id>-<h>.pack` (and
//! `groups/<id>-<h>.pack`, `base-<h>.pack`), where `<h>` is the first 16 hex digits
//! of the file's blake3: a hard link to the working file (a copy where the file
//! system has none), so publishing costs no space. A published file is never
//! written again. Then the new `index.pack`, which names the published files with
//! their sizes and blake3 (the base pack included, format version 7), replaces the
//! old one by one atomic rename: the commit. A reader that opens `index.pack` first
//! and then only the files it names sees one generation whole, whenever a rebake is
//! killed and whatever it was writing.
//!
//! After the commit, [`sweep`] removes the published files that neither the new
//! index nor the one it replaced names: a reader still on the previous generation
//! keeps its files; one that holds a generation across two commits finds its files
//! gone and says which (it never mixes two generations).

use super::index::{check_relative_path, Index};
use std::collections::BTreeSet;
use std::path::Path;

/// Hex digits of the blake3 in a published name.
const HASH_DIGITS: usize = 16;

/// The published name of the working file `staged` (relative to the bake) whose
/// blake3 is `checksum`: `cells/17.pack` → `cells/17-0123456789abcdef.pack`.
pub fn published_name(staged: &str, checksum: &[u8; 32]) -> String {
    let hex = crate::fingerprint::to_hex(checksum);
    let stem = staged.strip_suffix(".pack").unwrap_or(staged);
    format!("{stem}-{}.pack", &hex[..HASH_DIGITS])
}

/// Whether the file name (no folder) has the form of a published file:
/// `<stem>-<16 lowercase hex digits>.pack`.
pub fn is_published_file_name(name: &str) -> bool {
    let Some(stem) = name.strip_suffix(".pack") else {
        return false;
    };
    let Some((head, hash)) = stem.rsplit_once('-') else {
        return false;
    };
    !head.is_empty()
        && hash.len() == HASH_DIGITS
        && hash
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// Publishes the working file `dir/staged`, whose content has blake3 `checksum`,
/// under [`published_name`]; returns that name. An existing published file of the
/// same name and content is kept (publishing is idempotent); one of other content
/// (damaged) is replaced atomically. The caller checked `staged`'s content.
pub fn publish(dir: &Path, staged: &str, checksum: &[u8; 32]) -> std::io::Result<String> {
    check_relative_path(staged).map_err(std::io::Error::other)?;
    let name = published_name(staged, checksum);
    let from = dir.join(staged);
    let to = dir.join(&name);
    if let Ok(data) = std::fs::read(&to) {
        if blake3::hash(&data).as_bytes() == checksum {
            return Ok(name);
        }
    }
    let (parent, tmp) = super::writer::temp_file_for(&to)
        .ok_or_else(|| std::io::Error::other(format!("{}: not a file path", to.display())))?;
    let linked = std::fs::hard_link(&from, &tmp).or_else(|_| {
        // No hard links here: a copy, synced.
        let data = std::fs::read(&from)?;
        super::writer::write_synced(&tmp, &data)
    });
    let result = linked.and_then(|()| std::fs::rename(&tmp, &to));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result?;
    super::writer::sync_dir(&parent);
    Ok(name)
}

/// Every file an index names: its cells', its groups' and (version 7) its base pack.
pub fn named_files(index: &Index) -> BTreeSet<String> {
    index
        .cells
        .iter()
        .chain(&index.groups)
        .map(|e| e.file.clone())
        .chain(index.base.as_ref().map(|b| b.file.clone()))
        .collect()
}

/// Removes the published files of the bake at `dir` (in `dir`, `cells/` and
/// `groups/`) that `keep` does not name; returns how many and their bytes. Working
/// files and every other file are left alone. Only under the output lock.
pub fn sweep(dir: &Path, keep: &BTreeSet<String>) -> std::io::Result<(u64, u64)> {
    let (mut files, mut bytes) = (0u64, 0u64);
    for sub in ["", "cells", "groups"] {
        let entries = match std::fs::read_dir(dir.join(sub)) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        for e in entries {
            let e = e?;
            let name = e.file_name();
            let Some(name) = name.to_str() else { continue };
            let rel = if sub.is_empty() {
                name.to_string()
            } else {
                format!("{sub}/{name}")
            };
            if is_published_file_name(name) && !keep.contains(&rel) && e.file_type()?.is_file() {
                bytes += e.metadata().map_or(0, |m| m.len());
                std::fs::remove_file(e.path())?;
                files += 1;
            }
        }
    }
    Ok((files, bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_names() {
        let sum = [0xab; 32];
        assert_eq!(
            published_name("cells/17.pack", &sum),
            "cells/17-abababababababab.pack"
        );
        assert_eq!(
            published_name("base.pack", &sum),
            "base-abababababababab.pack"
        );
        assert!(is_published_file_name("17-abababababababab.pack"));
        assert!(is_published_file_name("base-0123456789abcdef.pack"));
        for not in [
            "17.pack",
            "base.pack",
            "-0123456789abcdef.pack",
            "17-0123456789ABCDEF.pack",
            "17-0123456789abcde.pack",
            "17-0123456789abcdef.tex",
            "index.pack",
        ] {
            assert!(!is_published_file_name(not), "{not}");
        }
    }

    #[test]
    fn publish_links_once_and_sweep_keeps_what_is_named() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("cells")).unwrap();
        std::fs::write(dir.path().join("cells/3.pack"), b"generation one").unwrap();
        let one = *blake3::hash(b"generation one").as_bytes();
        let a = publish(dir.path(), "cells/3.pack", &one).unwrap();
        assert_eq!(a, published_name("cells/3.pack", &one));
        assert_eq!(publish(dir.path(), "cells/3.pack", &one).unwrap(), a);
        // The working file is rewritten (by rename, as every writer does): the
        // published file keeps the old content.
        super::super::write_atomic(&dir.path().join("cells/3.pack"), b"generation two").unwrap();
        let two = *blake3::hash(b"generation two").as_bytes();
        let b = publish(dir.path(), "cells/3.pack", &two).unwrap();
        assert_ne!(a, b);
        assert_eq!(
            std::fs::read(dir.path().join(&a)).unwrap(),
            b"generation one"
        );
        assert_eq!(
            std::fs::read(dir.path().join(&b)).unwrap(),
            b"generation two"
        );
        // A damaged published file is replaced. (Damage written in place would hit
        // the working file too, its hard link: the job's record then no longer
        // matches it and the job is baked again, its working file replaced.)
        super::super::write_atomic(&dir.path().join(&b), b"generation tw0").unwrap();
        publish(dir.path(), "cells/3.pack", &two).unwrap();
        assert_eq!(
            std::fs::read(dir.path().join(&b)).unwrap(),
            b"generation two"
        );
        let keep: BTreeSet<String> = [b.clone()].into();
        assert_eq!(sweep(dir.path(), &keep).unwrap().0, 1);
        assert!(!dir.path().join(&a).exists());
        assert!(dir.path().join(&b).exists());
        assert!(dir.path().join("cells/3.pack").exists());
    }
}
