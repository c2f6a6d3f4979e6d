//! Issue 19: a cell pack is used only if it is the one `index.pack` lists — same size,
//! checksum and job fingerprint. A pack from another bake or setting copied into a
//! bake is refused with a message that names the pack and what differs (the player
//! then draws the cell as original geometry, as for a corrupt pack). No GPU needed.

use format::pack::{BasePack, CellPack, Index, IndexEntry};
use player::bake::{load_cell, BakeError};
use player::testdata::write_synthetic_bake_with;
use std::path::Path;

/// The error loading `cell` gives, if any.
fn load(dir: &Path, cell: u32) -> Option<BakeError> {
    let base = BasePack::read(&dir.join("base.pack")).unwrap();
    let index = Index::read(&dir.join("index.pack")).unwrap();
    load_cell(dir, Some(&index), &base, cell).err()
}

fn refused_for(error: Option<BakeError>, what: &str) {
    match error {
        Some(e @ BakeError::NotThisBake { .. }) => {
            let text = e.to_string();
            assert!(text.contains(what), "{text}");
            assert!(text.contains("cells/0.pack"), "names the pack: {text}");
        }
        other => panic!("expected NotThisBake ({what}), got {other:?}"),
    }
}

#[test]
fn a_pack_from_another_bake_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let (ours, other) = (tmp.path().join("ours"), tmp.path().join("other"));
    write_synthetic_bake_with(&ours, false).unwrap();
    write_synthetic_bake_with(&other, true).unwrap();
    assert!(load(&ours, 0).is_none(), "the bake's own pack loads");

    // Another bake's pack of the same cell, copied in: size/checksum differ.
    std::fs::copy(other.join("cells/0.pack"), ours.join("cells/0.pack")).unwrap();
    let refused = load(&ours, 0);
    assert!(
        matches!(refused, Some(BakeError::NotThisBake { .. })),
        "{refused:?}"
    );

    // The same content baked with another setting (another job fingerprint), and an
    // index edited to list its size and checksum: the fingerprint still differs.
    write_synthetic_bake_with(&ours, false).unwrap();
    let path = ours.join("cells/0.pack");
    let mut pack = CellPack::read(&path).unwrap();
    pack.fingerprint = [9u8; 32];
    pack.write(&path).unwrap();
    refused_for(load(&ours, 0), "checksum");
    let mut index = Index::read(&ours.join("index.pack")).unwrap();
    let entry = index.cells.iter_mut().find(|e| e.cell_id == 0).unwrap();
    let listed = IndexEntry::for_file(
        &ours,
        "cells/0.pack",
        0,
        entry.neighbours.clone(),
        entry.fingerprint,
    )
    .unwrap();
    *entry = listed;
    index.write(&ours.join("index.pack")).unwrap();
    refused_for(load(&ours, 0), "fingerprint");
}
