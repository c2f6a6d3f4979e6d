//! Hostile input (meshoptimizer style, STYLE.md habit 5): every truncation of a small
//! pack, a zeroed header, a future version, a trailing byte, a flipped bit anywhere
//! (header, table, each section, padding) are all rejected with an error; structurally
//! valid packs with inconsistent content (checksums recomputed) decode to an error,
//! never a panic; unknown section kinds are skipped; round trips are exact (proptest).

use format::pack::layout::{Codec, SectionKind, HEADER_SIZE};
use format::pack::writer::{assemble, SectionData, TRY_INDICES, TRY_ZSTD};
use format::pack::{
    sample, BasePack, CellPack, FileKind, GridParams, Index, IndexEntry, PackError, PackFile,
    PackedInstance, PackedModel, Proxy, ProxyKind, ProxyMember, ProxyView, Texture,
    TextureEncoding, FORMAT_VERSION,
};
use format::Mesh;
use proptest::prelude::*;

/// Decodes `bytes` with the reader of `kind`.
fn decode(kind: FileKind, bytes: &[u8]) -> Result<(), PackError> {
    match kind {
        FileKind::Base => BasePack::from_bytes(bytes).map(drop),
        FileKind::Cell => CellPack::from_bytes(bytes).map(drop),
        FileKind::Index => Index::from_bytes(bytes).map(drop),
        FileKind::Group => CellPack::group_from_bytes(bytes).map(drop),
    }
}

fn samples() -> Vec<(FileKind, Vec<u8>)> {
    vec![
        (FileKind::Base, sample::small_base().encode().unwrap()),
        (FileKind::Cell, sample::small_cell().encode().unwrap()),
        (FileKind::Index, sample::small_index().encode().unwrap()),
        (FileKind::Cell, sample::small_cell_v2().encode().unwrap()),
        (
            FileKind::Group,
            sample::small_group().encode_group().unwrap(),
        ),
        (FileKind::Index, sample::small_index_v2().encode().unwrap()),
        (
            FileKind::Cell,
            sample::small_cell_impostor().encode().unwrap(),
        ),
    ]
}

#[test]
fn samples_decode() {
    for (kind, bytes) in samples() {
        decode(kind, &bytes).unwrap();
    }
}

#[test]
fn every_truncation_is_rejected() {
    for (kind, bytes) in samples() {
        for len in 0..bytes.len() {
            let r = decode(kind, &bytes[..len]);
            assert!(
                r.is_err(),
                "{kind:?} truncated to {len} of {} bytes was accepted",
                bytes.len()
            );
        }
    }
}

#[test]
fn zeroed_header_is_rejected_as_bad_magic() {
    for (kind, mut bytes) in samples() {
        bytes[..HEADER_SIZE].fill(0);
        assert!(matches!(
            decode(kind, &bytes),
            Err(PackError::BadMagic { .. })
        ));
    }
}

#[test]
fn future_version_is_rejected_with_a_clear_error() {
    for (kind, mut bytes) in samples() {
        let next = FORMAT_VERSION + 1;
        bytes[12..16].copy_from_slice(&next.to_le_bytes());
        match decode(kind, &bytes) {
            Err(
                e @ PackError::FutureVersion {
                    found,
                    supported: FORMAT_VERSION,
                    ..
                },
            ) if found == next => {
                assert!(e.to_string().contains("newer than this reader"), "{e}");
            }
            other => panic!("{kind:?}: expected FutureVersion, got {other:?}"),
        }
        bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            decode(kind, &bytes),
            Err(PackError::FutureVersion { .. })
        ));
        bytes[12..16].copy_from_slice(&0u32.to_le_bytes());
        assert!(matches!(
            decode(kind, &bytes),
            Err(PackError::UnknownVersion { .. })
        ));
    }
}

#[test]
fn one_trailing_byte_is_rejected() {
    for (kind, mut bytes) in samples() {
        bytes.push(0);
        assert!(
            matches!(decode(kind, &bytes), Err(PackError::LengthMismatch { .. })),
            "{kind:?}"
        );
    }
}

#[test]
fn wrong_file_kind_is_rejected() {
    let cell = sample::small_cell().encode().unwrap();
    assert!(matches!(
        BasePack::from_bytes(&cell),
        Err(PackError::WrongFileKind { .. })
    ));
    assert!(matches!(
        Index::from_bytes(&cell),
        Err(PackError::WrongFileKind { .. })
    ));
}

#[test]
fn every_flipped_bit_is_rejected() {
    // Every bit of every byte: header, table, padding and each section.
    for (kind, bytes) in samples() {
        let sections = PackFile::from_bytes(&bytes).unwrap().sections().to_vec();
        let mut copy = bytes.clone();
        for i in 0..bytes.len() {
            for bit in 0..8 {
                copy[i] ^= 1 << bit;
                let r = decode(kind, &copy);
                copy[i] ^= 1 << bit;
                let Err(e) = r else {
                    panic!("{kind:?}: flipping bit {bit} of byte {i} was accepted");
                };
                // A flip inside a section is reported as that section's checksum error.
                if let Some(s) = sections
                    .iter()
                    .find(|s| (s.offset..s.offset + s.stored_len).contains(&(i as u64)))
                {
                    match e {
                        PackError::SectionChecksum { section, .. } => assert_eq!(section, s.kind),
                        other => panic!("{kind:?} byte {i} in {}: {other}", s.kind),
                    }
                }
            }
        }
    }
}

#[test]
fn section_checksum_error_names_the_section_and_offset() {
    let bytes = sample::small_cell().encode().unwrap();
    let pack = PackFile::from_bytes(&bytes).unwrap();
    let s = *pack.section_info(SectionKind::PROXIES).unwrap();
    let mut bad = bytes.clone();
    bad[s.offset as usize] ^= 0x10;
    let e = CellPack::from_bytes(&bad).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("proxies") && msg.contains(&s.offset.to_string()),
        "{msg}"
    );
}

/// The sections of a sample pack as writer input (decoded content, same kinds).
fn sections_of(bytes: &[u8]) -> Vec<SectionData> {
    let pack = PackFile::from_bytes(bytes).unwrap();
    pack.sections()
        .iter()
        .map(|s| {
            SectionData::new(
                s.kind,
                pack.section(s.kind).unwrap().into_owned(),
                TRY_INDICES,
            )
        })
        .collect()
}

#[test]
fn unknown_section_kinds_are_skipped() {
    let cell = sample::small_cell();
    let bytes = cell.encode().unwrap();
    let mut sections = sections_of(&bytes);
    sections.insert(
        2,
        SectionData::new(SectionKind(0x02ff), vec![7; 300], TRY_ZSTD),
    );
    sections.push(SectionData::new(SectionKind(0x02fe), vec![1, 2, 3], &[]));
    let extended = assemble(FileKind::Cell, &sections).unwrap();
    assert_eq!(CellPack::from_bytes(&extended).unwrap(), cell);
}

#[test]
fn missing_section_is_an_error() {
    let bytes = sample::small_index().encode().unwrap();
    let mut sections = sections_of(&bytes);
    sections.retain(|s| s.kind != SectionKind::INDEX_NEIGHBOURS);
    let e = Index::from_bytes(&assemble(FileKind::Index, &sections).unwrap()).unwrap_err();
    assert!(
        matches!(
            e,
            PackError::MissingSection {
                section: SectionKind::INDEX_NEIGHBOURS,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn lying_raw_length_is_rejected() {
    // A zstd section whose table entry claims a different decoded length.
    let bytes = sample::small_base().encode().unwrap();
    let pack = PackFile::from_bytes(&bytes).unwrap();
    let s = *pack
        .sections()
        .iter()
        .find(|s| s.codec != Codec::Raw)
        .expect("a compressed section");
    let mut bad = bytes.clone();
    let entry = HEADER_SIZE + s.entry as usize * 64;
    bad[entry + 24..entry + 32].copy_from_slice(&(s.raw_len + 4).to_le_bytes());
    // Re-seal the header so only the lie remains.
    let table_end = HEADER_SIZE + pack.sections().len() * 64;
    let sum = format::pack::layout::header_checksum(&bad[..48], &bad[HEADER_SIZE..table_end]);
    bad[48..64].copy_from_slice(&sum);
    let pack = PackFile::from_bytes(&bad).unwrap();
    let e = pack.section(s.kind).unwrap_err();
    assert!(matches!(e, PackError::Decompress { .. }), "{e}");
    assert!(BasePack::decode(&pack).is_err());
}

/// Structure-aware corruption: mutate decoded section content, re-assemble (valid
/// checksums), decode. Must never panic; must reject what it cannot represent.
fn mutate_and_decode(kind: FileKind, bytes: &[u8], seed: u64) {
    let mut rng = sample::SplitMix(seed);
    let mut sections = sections_of(bytes);
    let s = rng.below(sections.len() as u64) as usize;
    let raw = &mut sections[s].raw;
    match rng.below(4) {
        0 if !raw.is_empty() => {
            let i = rng.below(raw.len() as u64) as usize;
            raw[i] ^= 1 << rng.below(8);
        }
        1 if !raw.is_empty() => {
            let i = rng.below(raw.len() as u64) as usize;
            raw[i] = [0x00, 0xff, 0x7f, 0x80][rng.below(4) as usize];
        }
        2 => {
            let n = rng.below(raw.len() as u64 + 1) as usize;
            raw.truncate(n);
        }
        _ => {
            let n = rng.below(9) as usize;
            raw.extend((0..n).map(|_| rng.below(256) as u8));
        }
    }
    let rebuilt = assemble(kind, &sections).unwrap();
    let _ = decode(kind, &rebuilt);
}

#[test]
fn corrupt_content_with_valid_checksums_never_panics() {
    for (kind, bytes) in samples() {
        for seed in 0..400 {
            mutate_and_decode(kind, &bytes, seed);
        }
    }
}

#[test]
fn inconsistent_cell_content_is_rejected_by_the_writer_and_check_against() {
    let mut cell = sample::small_cell();
    cell.proxies[0].members[0].view_masks = vec![1; cell.proxies[0].members[0].triangles.len()];
    assert!(
        matches!(cell.encode(), Err(PackError::Invalid { .. })),
        "SV proxy with view masks"
    );
    let mut cell = sample::small_cell();
    cell.proxies[2].members[0].view_masks[0] = 0b1000; // only 3 views
    assert!(cell.encode().is_err());
    let mut cell = sample::small_cell();
    cell.proxies[0].members[0].triangles[0] = [0, 1, 10_000];
    let bytes = cell.encode().unwrap();
    let decoded = CellPack::from_bytes(&bytes).unwrap();
    assert!(decoded.check_against(&sample::small_base()).is_err());
    let mut cell = sample::small_cell();
    cell.originals.push(99);
    assert!(cell.check_against(&sample::small_base()).is_err());
}

/// `bytes` (a sample pack of `kind`) with `value` written at `offset` of section
/// `section`'s decoded content, re-assembled: every checksum is valid, so only the
/// content rules can refuse it.
fn with_value(
    kind: FileKind,
    bytes: &[u8],
    section: SectionKind,
    offset: usize,
    value: &[u8],
) -> Vec<u8> {
    let mut sections = sections_of(bytes);
    let s = sections
        .iter_mut()
        .find(|s| s.kind == section)
        .expect("section present");
    s.raw[offset..offset + value.len()].copy_from_slice(value);
    assemble(kind, &sections).unwrap()
}

fn f32s(v: f32) -> Vec<u8> {
    v.to_le_bytes().to_vec()
}

fn u32s(v: u32) -> Vec<u8> {
    v.to_le_bytes().to_vec()
}

/// A content case: section, byte offset of the edit, new bytes, the offset the error
/// must name, and words its message must contain.
type Case = (SectionKind, usize, Vec<u8>, u64, &'static str);

fn assert_refused(kind: FileKind, bytes: &[u8], cases: Vec<Case>) {
    for (section, at, value, offset, says) in cases {
        let bad = with_value(kind, bytes, section, at, &value);
        let e = decode(kind, &bad).expect_err(says);
        match &e {
            PackError::Malformed {
                section: s,
                offset: o,
                what,
                ..
            } => {
                assert_eq!((*s, *o), (section, offset), "{says}: {e}");
                assert!(what.contains(says), "expected {says:?} in {e}");
            }
            other => panic!("{says}: expected a content error, got {other}"),
        }
    }
}

/// Issue 19: `BasePack::decode` checks every value, not only the structure: the grid
/// by the manifest's own rules and against its ground and cell size, finite and
/// bounded positions, finite normals and transforms, tints in range, reserved 0.
#[test]
fn base_pack_values_are_validated() {
    let bytes = sample::small_base().encode().unwrap();
    let meta = SectionKind::BASE_META;
    let cases: Vec<Case> = vec![
        (
            meta,
            48,
            f32s(0.0),
            48,
            "`cells.cell_size` must be > 0, found 0",
        ),
        (
            meta,
            48,
            f32s(f32::NAN),
            48,
            "`cells.cell_size` must be > 0",
        ),
        (meta, 48, f32s(0.001), 48, "more than 1000000"),
        (
            meta,
            64,
            u32s(5),
            60,
            "grid of 7 × 5 cells, but cell size 10",
        ),
        (meta, 60, u32s(70), 60, "makes 7 × 6"),
        (
            meta,
            40,
            f32s(f32::INFINITY),
            40,
            "`ground.max` must be a finite",
        ),
        (meta, 32, f32s(-1e30), 32, "`ground.min` must be within"),
        (meta, 52, f32s(5.0), 56, "must be >= `min_eye_height` (5)"),
        (
            meta,
            56,
            f32s(1e30),
            56,
            "`cells.max_eye_height` must be at most",
        ),
        (meta, 76, u32s(1), 76, "reserved field is 1"),
        (
            SectionKind::POSITIONS,
            16,
            f32s(f32::NAN),
            12,
            "vertex 1: position",
        ),
        (
            SectionKind::POSITIONS,
            0,
            f32s(1e30),
            0,
            "vertex 0: position",
        ),
        (
            SectionKind::NORMALS,
            24,
            f32s(f32::NEG_INFINITY),
            24,
            "vertex 2: normal",
        ),
        // Issue 32: a zero normal and one that is not unit length.
        (SectionKind::NORMALS, 12, f32s(0.0), 12, "vertex 1: normal"),
        (SectionKind::NORMALS, 36, f32s(2.0), 36, "vertex 3: normal"),
        (
            SectionKind::INSTANCES,
            80,
            f32s(f32::NAN),
            80,
            "instance 1: transform",
        ),
        (
            SectionKind::INSTANCES,
            48,
            f32s(1e30),
            0,
            "translates beyond",
        ),
        (
            SectionKind::INSTANCES,
            160 + 64,
            f32s(-1.0),
            224,
            "instance 2: tint",
        ),
    ];
    assert_refused(FileKind::Base, &bytes, cases);
    // The writer refuses what the reader would.
    let mut base = sample::small_base();
    base.grid.cell_size = 0.0;
    assert!(matches!(base.encode(), Err(PackError::Invalid { .. })));
    let mut base = sample::small_base();
    base.grid.n_rows += 1;
    assert!(matches!(base.encode(), Err(PackError::Invalid { .. })));
    let mut base = sample::small_base();
    base.models[1].mesh.positions[3][1] = f32::NAN;
    assert!(matches!(base.encode(), Err(PackError::Invalid { .. })));
}

/// Issue 19: the cell pack's reserved fields are 0 and its views finite; its id lies
/// in the base pack's grid.
#[test]
fn cell_pack_values_are_validated() {
    let bytes = sample::small_cell().encode().unwrap();
    let cases: Vec<Case> = vec![
        (
            SectionKind::CELL_META,
            56,
            u32s(1),
            52,
            "reserved fields are [4294967295, 1, 0]",
        ),
        (
            SectionKind::CELL_META,
            52,
            u32s(1 << 30),
            52,
            "far group 1073741824 is past the largest grid",
        ),
        (
            SectionKind::PROXIES,
            16 + 12,
            u32s(7),
            28,
            "record 1: reserved",
        ),
        (SectionKind::MEMBERS, 12, u32s(7), 12, "record 0: reserved"),
        (
            SectionKind::VIEWS,
            64,
            f32s(f32::NAN),
            0,
            "proxy 0 view 0: eye",
        ),
        (
            SectionKind::VIEWS,
            2 * 96 + 8,
            f32s(f32::INFINITY),
            192,
            "view 2: texture matrix",
        ),
    ];
    assert_refused(FileKind::Cell, &bytes, cases);
    let mut cell = sample::small_cell();
    cell.proxies[0].views[0].eye[1] = f32::NAN;
    assert!(matches!(cell.encode(), Err(PackError::Invalid { .. })));
    // 7 × 6 cells: 41 is the last, 42 is outside.
    let base = sample::small_base();
    let mut cell = sample::without_overlap(sample::small_cell());
    cell.cell_id = 41;
    cell.check_against(&base).unwrap();
    cell.cell_id = 42;
    let e = cell.check_against(&base).unwrap_err();
    assert!(
        e.to_string().contains("outside the base pack's grid"),
        "{e}"
    );
}

/// Issue 16: the `layered-impostors` section's values are checked — layer count,
/// reserved fields, codes, depth range — naming the section and the offset; a
/// LayeredImpostor without the section, or with a block-compressed texture, is
/// refused; the writer refuses what the reader would.
#[test]
fn layered_impostor_values_are_validated() {
    let bytes = sample::small_cell_impostor().encode().unwrap();
    let end = 64 + 3 * 16;
    let cases: Vec<Case> = vec![
        (SectionKind::LAYERED_IMPOSTORS, 56, u32s(0), 56, "0 layers"),
        (
            SectionKind::LAYERED_IMPOSTORS,
            56,
            u32s(65),
            56,
            "65 layers",
        ),
        (SectionKind::LAYERED_IMPOSTORS, 60, u32s(1), 60, "reserved"),
        (
            SectionKind::LAYERED_IMPOSTORS,
            64 + 12,
            u32s(1),
            68,
            "reserved 1",
        ),
        (
            SectionKind::LAYERED_IMPOSTORS,
            64 + 4,
            u32s(300),
            68,
            "codes 300",
        ),
        (
            SectionKind::LAYERED_IMPOSTORS,
            64 + 4,
            u32s(0),
            end as u64,
            "codes 0..=86",
        ),
        (
            SectionKind::LAYERED_IMPOSTORS,
            48,
            f32s(f32::NAN),
            end as u64,
            "depth range",
        ),
        (
            SectionKind::LAYERED_IMPOSTORS,
            0,
            f32s(f32::INFINITY),
            end as u64,
            "corner rays",
        ),
        (
            SectionKind::LAYERED_IMPOSTORS,
            64,
            f32s(-1.0),
            end as u64,
            "layer 0: depth",
        ),
    ];
    assert_refused(FileKind::Cell, &bytes, cases);
    // Without its section the impostor's record is past the (empty) section's end.
    let mut sections = sections_of(&bytes);
    sections.retain(|s| s.kind != SectionKind::LAYERED_IMPOSTORS);
    let e = CellPack::from_bytes(&assemble(FileKind::Cell, &sections).unwrap()).unwrap_err();
    assert!(
        e.to_string().contains("record past the section's end"),
        "{e}"
    );
    // Writer side.
    let mut cell = sample::small_cell_impostor();
    cell.proxies.last_mut().unwrap().layers = None;
    assert!(matches!(cell.encode(), Err(PackError::Invalid { .. })));
    let mut cell = sample::small_cell_impostor();
    cell.proxies[0].layers = cell.proxies.last().unwrap().layers.clone();
    assert!(matches!(cell.encode(), Err(PackError::Invalid { .. })));
    let mut cell = sample::small_cell_impostor();
    let v = &mut cell.proxies.last_mut().unwrap().views[0];
    v.texture = Texture::from_rgba8_block(12, 10, &v.texture.to_rgba8().unwrap()).unwrap();
    assert!(matches!(cell.encode(), Err(PackError::Invalid { .. })));
}

/// Issue 15: block-compressed textures with a bad size or data length are refused,
/// naming the `textures` section and the texture's offset; a version-1 pack may not
/// use the version-2 block encodings.
#[test]
fn block_texture_sizes_are_validated() {
    let cell = sample::small_cell_v2();
    let bytes = cell.encode().unwrap();
    // Proxy 0 view 0 is BC3 16 × 12 (192 bytes) at textures offset 0; record at views 0.
    let tex = &cell.proxies[0].views[0].texture;
    assert_eq!((tex.width, tex.height, tex.data.len()), (16, 12, 192));
    let bad = |at: usize, value: Vec<u8>| {
        let b = with_value(FileKind::Cell, &bytes, SectionKind::VIEWS, at, &value);
        decode(FileKind::Cell, &b).unwrap_err()
    };
    // Width 15 with data_len still 192: not a multiple of 4.
    let e = bad(76, u32s(15));
    assert!(
        matches!(&e, PackError::Malformed { section, offset: 0, what, .. }
            if *section == SectionKind::TEXTURES && what.contains("multiples of 4")),
        "{e}"
    );
    // Height 16 (needs 256 bytes) with data_len 192.
    let e = bad(80, u32s(16));
    assert!(
        matches!(&e, PackError::Malformed { section, what, .. }
            if *section == SectionKind::TEXTURES && what.contains("expected 256")),
        "{e}"
    );
    // Unknown encoding 9.
    let e = bad(84, u32s(9));
    assert!(
        matches!(&e, PackError::Malformed { section, offset: 84, what, .. }
            if *section == SectionKind::VIEWS && what.contains("unknown texture encoding 9")),
        "{e}"
    );
    // A version-1 cell pack claiming BC1 (encoding 2) is refused.
    let v1 = sample::small_cell().encode().unwrap();
    let mut sections = sections_of(&v1);
    let views = sections
        .iter_mut()
        .find(|s| s.kind == SectionKind::VIEWS)
        .unwrap();
    views.raw[84..88].copy_from_slice(&u32s(2));
    let meta = sections
        .iter_mut()
        .find(|s| s.kind == SectionKind::CELL_META)
        .unwrap();
    meta.raw[52..56].copy_from_slice(&u32s(0)); // version 1: far_group reserved, 0
    let mut b = assemble(FileKind::Cell, &sections).unwrap();
    b[12..16].copy_from_slice(&1u32.to_le_bytes());
    assert!(sample::reseal(&mut b));
    let e = decode(FileKind::Cell, &b).unwrap_err();
    assert!(
        e.to_string()
            .contains("unknown texture encoding 2 in format version 1"),
        "{e}"
    );
    // The writer refuses what the reader refuses.
    let mut cell = sample::small_cell_v2();
    cell.proxies[1].views[0].texture.data.pop();
    assert!(cell.encode().is_err());
}

/// Issue 19: index entries name real cells: ids within the largest grid, packs at
/// least a header long, at most six distinct neighbours that are not the cell itself.
#[test]
fn index_values_are_validated() {
    let bytes = sample::small_index().encode().unwrap();
    let cells = SectionKind::INDEX_CELLS;
    let cases: Vec<Case> = vec![
        (
            SectionKind::INDEX_META,
            40,
            u32s(9),
            36,
            "reserved fields are [0, 9, 0]",
        ),
        (
            cells,
            88 + 8,
            10u64.to_le_bytes().to_vec(),
            88,
            "shorter than its header",
        ),
        (
            SectionKind::INDEX_NEIGHBOURS,
            0,
            u32s(5),
            0,
            "neighbour 5 is the cell itself",
        ),
        (
            SectionKind::INDEX_NEIGHBOURS,
            4,
            u32s(6),
            4,
            "neighbour 6 is the cell itself, repeated",
        ),
        (cells, 3 * 88, u32s(2_000_000), 264, "past the largest grid"),
    ];
    assert_refused(FileKind::Index, &bytes, cases);
    let mut index = sample::small_index();
    index.cells[2].neighbours.push(12);
    assert!(matches!(index.encode(), Err(PackError::Invalid { .. })));
}

#[test]
fn atomic_write_replaces_and_leaves_no_temp_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cell.pack");
    sample::small_cell().write(&path).unwrap();
    let mapped = PackFile::open(&path).unwrap();
    let mut other = sample::small_cell();
    other.cell_id = 99;
    other.write(&path).unwrap();
    // The old map still sees the old, valid file (rename, not in-place write).
    assert_eq!(CellPack::decode(&mapped).unwrap().cell_id, 12);
    assert_eq!(CellPack::read(&path).unwrap().cell_id, 99);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("cell.pack")]);
    assert!(matches!(
        CellPack::read(&dir.path().join("missing.pack")),
        Err(PackError::Io { .. })
    ));
}

/// A run killed between creating a temp file and renaming it leaves the temp file;
/// the next run (holding the lock) removes it when its writer on this host is gone or
/// when it is old, and keeps everything else.
#[test]
fn stale_temp_files_are_removed_and_nothing_else() {
    use format::pack::{remove_stale_temps, temp_name};
    use std::time::{Duration, SystemTime};
    let dir = tempfile::tempdir().unwrap();
    let touch = |name: &str| {
        std::fs::write(dir.path().join(name), b"x").unwrap();
        name.to_string()
    };
    // No process has a pid this large (Linux caps pids at 2^22).
    let dead_here = touch(&temp_name("1.pack", 999_999_999, 3));
    let alive_here = touch(&temp_name("2.pack", std::process::id(), 0));
    let other_host = touch(".3.pack.tmp-elsewhere-12-0");
    let old_other_host = touch(".4.pack.tmp-elsewhere-12-1");
    let legacy_old = touch(".5.pack.tmp-77-2");
    let keep = [
        touch("0.pack"),
        touch(".lock"),
        touch(".notes.tmp-x"),
        alive_here.clone(),
        other_host.clone(),
    ];
    let two_hours_ago = SystemTime::now() - Duration::from_secs(7200);
    for name in [&old_other_host, &legacy_old] {
        std::fs::File::options()
            .write(true)
            .open(dir.path().join(name))
            .unwrap()
            .set_modified(two_hours_ago)
            .unwrap();
    }
    let removed = remove_stale_temps(dir.path(), Duration::from_secs(3600)).unwrap();
    let mut expected: Vec<_> = [dead_here, old_other_host, legacy_old]
        .iter()
        .map(|n| dir.path().join(n))
        .collect();
    expected.sort();
    assert_eq!(removed, expected);
    let mut left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    let mut keep = keep.to_vec();
    keep.sort();
    assert_eq!(left, keep);
    // A missing directory has nothing to remove.
    assert!(remove_stale_temps(&dir.path().join("none"), Duration::ZERO)
        .unwrap()
        .is_empty());
}

#[test]
fn index_entry_for_file_and_verify() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("cells")).unwrap();
    sample::small_cell()
        .write(&dir.path().join("cells/12.pack"))
        .unwrap();
    let e = IndexEntry::for_file(dir.path(), "cells/12.pack", 12, vec![5], [3; 32]).unwrap();
    e.verify(dir.path()).unwrap();
    assert!(IndexEntry::for_file(dir.path(), "../x", 1, vec![], [0; 32]).is_err());
    let mut wrong = e.clone();
    wrong.checksum[0] ^= 1;
    assert!(wrong.verify(dir.path()).is_err());
}

// ---- round-trip property tests ----

fn arb_mesh() -> impl Strategy<Value = Mesh> {
    (1usize..20, 0usize..30).prop_flat_map(|(nv, nt)| {
        (
            prop::collection::vec(prop::array::uniform3(-1e3f32..1e3), nv),
            prop::collection::vec(prop::array::uniform3(-1f32..1.0), nv),
            prop::collection::vec(prop::array::uniform4(any::<u8>()), nv),
            prop::collection::vec(prop::array::uniform3(0..nv as u32), nt),
        )
            .prop_map(|(positions, normals, albedo, triangles)| Mesh {
                positions,
                // Packs hold unit normals (issue 32); a zero draw stands for +y.
                normals: normals
                    .into_iter()
                    .map(|n| {
                        let v = glam::Vec3::from(n);
                        if v.length() > 1e-3 {
                            v.normalize().to_array()
                        } else {
                            [0.0, 1.0, 0.0]
                        }
                    })
                    .collect(),
                albedo,
                triangles,
            })
    })
}

fn arb_base() -> impl Strategy<Value = BasePack> {
    (
        prop::collection::vec(("[a-z0-9é]{0,12}", arb_mesh()), 0..4),
        any::<[u8; 32]>(),
        0usize..6,
    )
        .prop_flat_map(|(models, fp, ni)| {
            let nm = models.len() as u32;
            let inst = if nm == 0 {
                Just(vec![]).boxed()
            } else {
                prop::collection::vec(
                    (
                        0..nm,
                        prop::array::uniform16(-1e3f32..1e3),
                        prop::array::uniform3(0f32..2.0),
                    )
                        .prop_map(|(model, transform, tint)| PackedInstance {
                            model,
                            transform,
                            tint,
                        }),
                    ni,
                )
                .boxed()
            };
            (Just(models), Just(fp), inst).prop_map(|(models, scene_fingerprint, instances)| {
                BasePack {
                    scene_fingerprint,
                    grid: GridParams {
                        ground_min: [-5.0, -6.0],
                        ground_max: [50.0, 60.0],
                        cell_size: 5.0,
                        min_eye_height: 1.0,
                        max_eye_height: 2.0,
                        n_cols: 8,
                        n_rows: 9,
                    },
                    models: models
                        .into_iter()
                        .map(|(name, mesh)| PackedModel {
                            content_hash: *blake3::hash(name.as_bytes()).as_bytes(),
                            name,
                            mesh,
                            albedo_map: None,
                        })
                        .collect(),
                    instances,
                    patches: None,
                }
            })
        })
}

fn arb_texture() -> impl Strategy<Value = Texture> {
    (1u32..6, 1u32..6, any::<bool>(), any::<u64>()).prop_map(|(w, h, left, seed)| {
        let mut rng = sample::SplitMix(seed);
        let rgba: Vec<u8> = (0..w * h * 4).map(|_| rng.below(256) as u8).collect();
        let enc = if left {
            TextureEncoding::Rgba8Left
        } else {
            TextureEncoding::Rgba8
        };
        Texture::from_rgba8(w, h, &rgba, enc).unwrap()
    })
}

fn arb_proxy() -> impl Strategy<Value = Proxy> {
    (0u32..3, 1usize..4, 1usize..4).prop_flat_map(|(k, nmembers, nviews)| {
        let kind = [ProxyKind::SvMesh, ProxyKind::Cluster, ProxyKind::MvMesh][k as usize];
        let nviews = if kind == ProxyKind::MvMesh {
            nviews.max(1)
        } else {
            1
        };
        let member = (
            any::<u32>(),
            prop::collection::vec(prop::array::uniform3(any::<u32>()), 0..40),
            any::<u64>(),
        )
            .prop_map(move |(instance, triangles, seed)| {
                let mut rng = sample::SplitMix(seed);
                let view_masks = if kind == ProxyKind::MvMesh {
                    triangles
                        .iter()
                        .map(|_| rng.below(1 << nviews) as u8)
                        .collect()
                } else {
                    vec![]
                };
                ProxyMember {
                    instance,
                    triangles,
                    view_masks,
                }
            });
        let view = (
            prop::array::uniform3(-1e3f32..1e3),
            prop::array::uniform16(-10f32..10.0),
            arb_texture(),
        )
            .prop_map(|(eye, matrix, texture)| ProxyView {
                eye,
                matrix,
                texture,
            });
        (
            prop::collection::vec(member, nmembers),
            prop::collection::vec(view, nviews),
        )
            .prop_map(move |(members, views)| Proxy {
                kind,
                members,
                views,
                layers: None,
            })
    })
}

fn arb_cell() -> impl Strategy<Value = CellPack> {
    (
        any::<u32>(),
        any::<[u8; 32]>(),
        prop::collection::vec(any::<u32>(), 0..20),
        prop::collection::vec(arb_proxy(), 0..5),
        prop::option::of(0..format::manifest::MAX_CELLS as u32),
    )
        .prop_map(
            |(cell_id, fingerprint, originals, proxies, far_group)| CellPack {
                cell_id,
                fingerprint,
                far_group,
                originals,
                proxies,
            },
        )
}

fn arb_index() -> impl Strategy<Value = Index> {
    (
        any::<[u8; 32]>(),
        prop::collection::btree_map(
            0..format::manifest::MAX_CELLS as u32,
            (
                prop::collection::btree_set(0..format::manifest::MAX_CELLS as u32, 0..7),
                64..u64::MAX,
                "[a-z]{1,8}(/[a-z0-9.]{1,8})?",
            ),
            0..10,
        ),
        prop::collection::btree_set(0..format::manifest::MAX_CELLS as u32, 0..4),
    )
        .prop_map(|(build_fingerprint, cells, groups)| {
            let groups: Vec<u32> = groups.into_iter().collect();
            Index {
                build_fingerprint,
                groups: groups
                    .iter()
                    .map(|&g| IndexEntry {
                        cell_id: g,
                        file: format!("groups/{g}.pack"),
                        bytes: 64 + u64::from(g),
                        checksum: [g as u8; 32],
                        neighbours: Vec::new(),
                        fingerprint: [!g as u8; 32],
                        group: None,
                    })
                    .collect(),
                cells: cells
                    .into_iter()
                    .filter(|(_, (_, _, f))| format::pack::index::check_relative_path(f).is_ok())
                    .map(|(cell_id, (neighbours, bytes, file))| IndexEntry {
                        cell_id,
                        file,
                        bytes,
                        checksum: *blake3::hash(&bytes.to_le_bytes()).as_bytes(),
                        // Distinct (a set), never the cell itself, at most six.
                        neighbours: neighbours
                            .into_iter()
                            .filter(|&n| n != cell_id)
                            .take(format::pack::index::MAX_NEIGHBOURS)
                            .collect(),
                        fingerprint: [cell_id as u8; 32],
                        group: (!groups.is_empty())
                            .then(|| groups[cell_id as usize % groups.len()])
                            .filter(|_| cell_id % 3 != 0),
                    })
                    .collect(),
                // Version 7: a generation's base pack, named by half the indexes.
                base: (build_fingerprint[0] % 2 == 0).then(|| format::pack::index::BaseEntry {
                    file: format!("base-{:02x}.pack", build_fingerprint[1]),
                    bytes: 64 + u64::from(build_fingerprint[2]),
                    checksum: build_fingerprint,
                }),
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn base_round_trips(base in arb_base()) {
        let bytes = base.encode().unwrap();
        prop_assert_eq!(BasePack::from_bytes(&bytes).unwrap(), base.clone());
        prop_assert_eq!(base.encode().unwrap(), bytes);
    }

    #[test]
    fn cell_round_trips(cell in arb_cell()) {
        let bytes = cell.encode().unwrap();
        prop_assert_eq!(CellPack::from_bytes(&bytes).unwrap(), cell.clone());
        prop_assert_eq!(cell.encode().unwrap(), bytes);
        for p in &cell.proxies {
            for v in &p.views {
                let rgba = v.texture.to_rgba8().unwrap();
                let again = Texture::from_rgba8(v.texture.width, v.texture.height, &rgba, v.texture.encoding).unwrap();
                prop_assert_eq!(&again, &v.texture);
            }
        }
    }

    #[test]
    fn index_round_trips(index in arb_index()) {
        let bytes = index.encode().unwrap();
        prop_assert_eq!(Index::from_bytes(&bytes).unwrap(), index);
    }

    #[test]
    fn random_bytes_after_a_valid_header_are_rejected(tail in prop::collection::vec(any::<u8>(), 0..600)) {
        let mut bytes = sample::small_index().encode().unwrap()[..HEADER_SIZE].to_vec();
        bytes.extend_from_slice(&tail);
        prop_assert!(Index::from_bytes(&bytes).is_err());
    }
}

#[test]
fn raw_sections_are_zero_copy_and_aligned() {
    // Incompressible positions stay raw and are viewed in place, mapped or read.
    let mut base = sample::small_base();
    let mut rng = sample::SplitMix(5);
    for p in base.models[1].mesh.positions.iter_mut() {
        *p = [rng.unit() * 100.0, rng.unit() * 7.0, rng.unit() - 0.5];
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("base.pack");
    base.write(&path).unwrap();
    for pack in [
        PackFile::open(&path).unwrap(),
        PackFile::read(&path).unwrap(),
    ] {
        let info = *pack.section_info(SectionKind::POSITIONS).unwrap();
        assert_eq!(info.codec, Codec::Raw);
        assert_eq!(info.offset % 64, 0);
        let view = pack
            .raw_slice::<[f32; 3]>(SectionKind::POSITIONS)
            .unwrap()
            .expect("raw");
        assert_eq!(
            view.as_ptr() as usize % 64,
            0,
            "section start is 64-byte aligned in memory"
        );
        assert_eq!(&view[4..], base.models[1].mesh.positions.as_slice());
        let inside = pack.bytes().as_ptr_range();
        assert!(
            inside.contains(&(view.as_ptr() as *const u8)),
            "a view into the pack, not a copy"
        );
        // Compressed sections are not offered zero-copy.
        assert!(pack
            .raw_slice::<[u32; 3]>(SectionKind::TRIANGLES)
            .unwrap()
            .is_none());
        assert_eq!(BasePack::decode(&pack).unwrap(), base);
    }
}

/// `create_new_atomic` creates a file whole, never replaces one, and leaves no temp
/// file either way.
#[test]
fn create_new_atomic_creates_whole_and_never_replaces() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(".lock");
    format::pack::create_new_atomic(&path, b"12 host\n").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"12 host\n");
    let e = format::pack::create_new_atomic(&path, b"34 other\n").unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
    assert_eq!(std::fs::read(&path).unwrap(), b"12 host\n", "not replaced");
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from(".lock")]);
}

/// The fuzz driver's structure-aware edit (`sample::mutate_decoded`) keeps every
/// checksum valid — the pack still parses — so what refuses it is the content
/// validation; over many edits of each sample pack some are refused that way, and
/// none panics.
#[test]
fn structure_aware_edits_reach_the_content_validation() {
    for (kind, bytes) in samples() {
        let mut refused = 0;
        for pick in 0..400u64 {
            let Some(edited) = sample::mutate_decoded(&bytes, pick) else {
                continue;
            };
            assert!(
                PackFile::from_bytes(&edited).is_ok(),
                "{kind:?}: checksums stay valid"
            );
            if decode(kind, &edited).is_err() {
                refused += 1;
            }
        }
        assert!(refused > 0, "{kind:?}: no edit was refused");
    }
}

/// Issue 32 item 3: values the structural checks let through are refused by name —
/// an instance transform of scale 0 (base pack), a view matrix of zeros (cell pack),
/// and a cell that lists an original twice (checked against the base pack, as every
/// reader does).
#[test]
fn degenerate_values_are_refused_by_name() {
    let mut base = sample::small_base();
    base.instances[0].transform = [0.0; 16];
    let e = base.encode().unwrap_err().to_string();
    assert!(e.contains("instance 0") && e.contains("singular"), "{e}");
    let mut flat = sample::small_base();
    flat.instances[0].transform[5] = 0.0; // y scaled to 0
    flat.instances[0].transform[4] = 0.0;
    flat.instances[0].transform[6] = 0.0;
    assert!(flat.encode().is_err());

    let base = sample::small_base();
    // Issue 32: an original that is also a member of one of the cell's proxies.
    let overlap = sample::small_cell();
    let e = overlap.check_against(&base).unwrap_err().to_string();
    assert!(
        e.contains("cell 12 proxy 1: instance 0 is an original of the cell and a member"),
        "{e}"
    );
    let cell = sample::without_overlap(overlap);
    cell.check_against(&base).unwrap();
    let mut zero_view = cell.clone();
    let view = zero_view
        .proxies
        .iter_mut()
        .find_map(|p| p.views.first_mut())
        .expect("the sample cell has a proxy with a view");
    view.matrix = [0.0; 16];
    let e = zero_view.encode().unwrap_err().to_string();
    assert!(e.contains("all zeros"), "{e}");

    let first = *cell
        .originals
        .first()
        .expect("the sample cell has an original");
    let mut twice = cell.clone();
    twice.originals.push(first);
    let e = twice.check_against(&base).unwrap_err().to_string();
    assert!(
        e.contains(&format!("instance {first} is listed twice")),
        "{e}"
    );
}

/// Issue 32 item 3: the same degenerate values are refused when a pack that holds
/// them is read (written by another writer, checksums valid), naming the section and
/// the record's offset: an all-zero instance transform, one whose y column is zero
/// (scale 0 along y), and a proxy view's matrix of zeros.
#[test]
fn issue32_degenerate_values_are_refused_at_decode() {
    let base = sample::small_base().encode().unwrap();
    let zeros = |n: usize| vec![0u8; n];
    assert_refused(
        FileKind::Base,
        &base,
        vec![
            (
                SectionKind::INSTANCES,
                0,
                zeros(64),
                0,
                "instance 0: transform",
            ),
            (
                SectionKind::INSTANCES,
                80 + 16,
                zeros(12),
                80,
                "is singular",
            ),
        ],
    );
    let cell = sample::small_cell().encode().unwrap();
    assert_refused(
        FileKind::Cell,
        &cell,
        vec![(
            SectionKind::VIEWS,
            96,
            zeros(64),
            96,
            "texture matrix is all zeros",
        )],
    );
}

/// Issue 32: the index is checked against the base pack it is read with: a cell
/// past the grid and a neighbour that is not adjacent are refused, naming both.
#[test]
fn index_is_bound_to_the_base_grid() {
    let base = sample::small_base();
    let grid = format::grid::HexGrid::from_params(&base.grid).unwrap();
    let mut index = sample::small_index();
    // Make the sample's neighbour lists the grid's own: then it is accepted.
    for e in &mut index.cells {
        e.neighbours = grid.neighbours(e.cell_id);
    }
    index.check_against(&base).unwrap();

    let mut far = index.clone();
    let not_adjacent = (0..grid.cell_count())
        .find(|&c| c != far.cells[0].cell_id && !grid.neighbours(far.cells[0].cell_id).contains(&c))
        .unwrap();
    far.cells[0].neighbours.push(not_adjacent);
    let e = far.check_against(&base).unwrap_err().to_string();
    assert!(
        e.contains(&format!("neighbour {not_adjacent}")) && e.contains("not adjacent"),
        "{e}"
    );

    let mut past = index.clone();
    past.cells.last_mut().unwrap().cell_id = grid.cell_count();
    let e = past.check_against(&base).unwrap_err().to_string();
    assert!(e.contains(&format!("cell {}", grid.cell_count())), "{e}");
}
