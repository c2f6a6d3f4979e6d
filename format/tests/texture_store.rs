//! The bake's texture store (format version 6, issue 27 item 3): captures are stored
//! once and named by their content; every way a store or a pack naming it can be
//! wrong is an error naming the file, never a wrong texture.

use format::pack::texture_store::{self, TEXTURES_DIR};
use format::pack::writer::{assemble, SectionData, RAW_ONLY};
use format::pack::{sample, CellPack, FileKind, PackFile, SectionKind};
use std::path::{Path, PathBuf};

/// A fresh bake directory under the temp dir.
fn bake_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hexbake-store-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("cells")).unwrap();
    dir
}

/// Writes `cell` as `<bake>/cells/<id>.pack` with its textures in the store.
fn write_cell(bake: &Path, cell: &CellPack) -> PathBuf {
    let bytes = cell.encode_reusing(false, None, Some(bake)).unwrap();
    let path = bake.join(format!("cells/{}.pack", cell.cell_id));
    std::fs::write(&path, bytes).unwrap();
    path
}

fn store_files(bake: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for sub in std::fs::read_dir(bake.join(TEXTURES_DIR)).unwrap() {
        for f in std::fs::read_dir(sub.unwrap().path()).unwrap() {
            files.push(f.unwrap().path());
        }
    }
    files.sort();
    files
}

fn decode(path: &Path) -> Result<CellPack, String> {
    PackFile::open(path)
        .and_then(|p| CellPack::decode(&p))
        .map_err(|e| e.to_string())
}

#[test]
fn a_capture_used_by_several_cells_is_stored_once() {
    let bake = bake_dir("shared");
    let a = sample::small_cell_v4();
    let path_a = write_cell(&bake, &a);
    let once = store_files(&bake);
    let bytes_once: Vec<Vec<u8>> = once.iter().map(|p| std::fs::read(p).unwrap()).collect();
    // A second cell with the same captures adds no texture file.
    let mut b = a.clone();
    b.cell_id = 6;
    let path_b = write_cell(&bake, &b);
    assert_eq!(store_files(&bake), once);
    // Writing again changes no byte (the name is the content).
    write_cell(&bake, &a);
    let again: Vec<Vec<u8>> = once.iter().map(|p| std::fs::read(p).unwrap()).collect();
    assert_eq!(again, bytes_once);
    assert_eq!(decode(&path_a).unwrap(), a);
    assert_eq!(decode(&path_b).unwrap(), b);
    // The pack holds 32 bytes per view instead of the texture bytes.
    let pack = PackFile::open(&path_a).unwrap();
    let views: usize = a.proxies.iter().map(|p| p.views.len()).sum();
    assert_eq!(texture_store::pack_refs(&pack).unwrap().len(), views);
    assert!(texture_store::missing_texture(&pack).is_none());
    std::fs::remove_dir_all(&bake).ok();
}

#[test]
fn a_missing_damaged_or_substituted_texture_is_an_error_naming_it() {
    let bake = bake_dir("damaged");
    let cell = sample::small_cell_v4();
    let path = write_cell(&bake, &cell);
    let files = store_files(&bake);
    assert!(files.len() >= 2);
    let name = |p: &Path| p.file_name().unwrap().to_string_lossy().into_owned();

    // Missing.
    let saved = std::fs::read(&files[0]).unwrap();
    std::fs::remove_file(&files[0]).unwrap();
    let err = decode(&path).unwrap_err();
    assert!(err.contains(&name(&files[0])), "{err}");
    let pack = PackFile::open(&path).unwrap();
    assert!(texture_store::missing_texture(&pack).is_some());

    // Another texture's (valid) file under this name.
    std::fs::copy(&files[1], &files[0]).unwrap();
    let err = decode(&path).unwrap_err();
    assert!(
        err.contains(&name(&files[0]))
            && (err.contains("differs from its name") || err.contains("not a texture")),
        "{err}"
    );
    assert!(texture_store::missing_texture(&pack).is_some());

    // A flipped byte.
    let mut flipped = saved.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x40;
    std::fs::write(&files[0], &flipped).unwrap();
    let err = decode(&path).unwrap_err();
    assert!(err.contains(&name(&files[0])), "{err}");

    // Writing the cell again repairs the store (a resumed job does this).
    write_cell(&bake, &cell);
    assert_eq!(std::fs::read(&files[0]).unwrap(), saved);
    assert_eq!(decode(&path).unwrap(), cell);
    std::fs::remove_dir_all(&bake).ok();
}

/// The sections of `path` with `texture-refs` replaced by `refs` (or dropped when
/// `None`) and `extra` added, re-assembled into a valid pack of the same kind.
fn rebuilt(path: &Path, refs: Option<Vec<u8>>, extra: Option<SectionData>) -> Vec<u8> {
    let pack = PackFile::open(path).unwrap();
    let mut sections: Vec<SectionData> = pack
        .sections()
        .iter()
        .filter(|s| s.kind != SectionKind::TEXTURE_REFS)
        .map(|s| SectionData::new(s.kind, pack.section(s.kind).unwrap().into_owned(), RAW_ONLY))
        .collect();
    if let Some(r) = refs {
        sections.push(SectionData::new(SectionKind::TEXTURE_REFS, r, RAW_ONLY));
    }
    sections.extend(extra);
    assemble(FileKind::Cell, &sections).unwrap()
}

#[test]
fn texture_references_that_do_not_fit_the_views_are_refused() {
    let bake = bake_dir("refs");
    let path = write_cell(&bake, &sample::small_cell_v4());
    let refs = PackFile::open(&path)
        .unwrap()
        .section(SectionKind::TEXTURE_REFS)
        .unwrap()
        .into_owned();
    let bad = bake.join("cells/7.pack");
    for (what, bytes, expect) in [
        (
            "one reference short",
            rebuilt(&path, Some(refs[..refs.len() - 32].to_vec()), None),
            "references for",
        ),
        (
            "a reference cut in half",
            rebuilt(&path, Some(refs[..refs.len() - 16].to_vec()), None),
            "not a whole number",
        ),
        (
            "references and inline textures",
            rebuilt(
                &path,
                Some(refs.clone()),
                Some(SectionData::new(
                    SectionKind::TEXTURES,
                    vec![0; 8],
                    RAW_ONLY,
                )),
            ),
            "without a textures section",
        ),
    ] {
        std::fs::write(&bad, bytes).unwrap();
        let err = decode(&bad).unwrap_err();
        assert!(
            err.contains(expect) && err.contains("7.pack"),
            "{what}: {err}"
        );
    }
    // Before version 6 a pack may not name store textures (the header checksum
    // re-computed, so that it is the version the reader refuses).
    let mut v5 = rebuilt(&path, Some(refs), None);
    v5[12..16].copy_from_slice(&5u32.to_le_bytes());
    let table_len = u32::from_le_bytes(v5[20..24].try_into().unwrap()) as usize * 64;
    let sum = format::pack::layout::header_checksum(&v5[..48], &v5[64..64 + table_len]);
    v5[48..64].copy_from_slice(&sum);
    std::fs::write(&bad, &v5).unwrap();
    let err = decode(&bad).unwrap_err();
    assert!(err.contains("needs format version 6"), "{err}");
    std::fs::remove_dir_all(&bake).ok();
}

#[test]
fn sweeping_removes_only_textures_no_pack_names() {
    let bake = bake_dir("sweep");
    let cell = sample::small_cell_v4();
    let path = write_cell(&bake, &cell);
    let kept = store_files(&bake);
    // An orphan: a texture only an older pack named.
    let orphan = texture_store::write_texture(&bake, b"an old capture").unwrap();
    assert_eq!(store_files(&bake).len(), kept.len() + 1);
    let (files, bytes) = texture_store::sweep_unreferenced(&bake).unwrap();
    assert_eq!(files, 1);
    assert!(bytes > 0);
    assert_eq!(store_files(&bake), kept);
    assert!(!texture_store::texture_path(&bake, &orphan).exists());
    assert_eq!(decode(&path).unwrap(), cell);
    std::fs::remove_dir_all(&bake).ok();
}
