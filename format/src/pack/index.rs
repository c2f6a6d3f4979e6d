//! `index.pack`: the table of contents of a bake — for each cell, its pack file
//! (relative to the bake's output directory), byte size, blake3 checksum, neighbour
//! cells (what the player prefetches) and job fingerprint, plus the build fingerprint
//! (DESIGN.md "Data flow": the player mmaps packs, finds the current cell, prefetches
//! neighbours).

use super::error::{hex, PackError};
use super::layout::{FileKind, SectionKind};
use super::reader::PackFile;
use super::writer::{assemble, SectionData, RAW_ONLY, TRY_INDICES, TRY_ZSTD};
use super::{invalid, malformed};
use bytemuck::{Pod, Zeroable};
use std::path::Path;

/// One cell's entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IndexEntry {
    pub cell_id: u32,
    /// Path of the cell pack relative to the bake directory, `/`-separated
    /// (e.g. `cells/17.pack`); never absolute, never `..`.
    pub file: String,
    /// Size of that file in bytes.
    pub bytes: u64,
    /// blake3 of the whole file.
    pub checksum: [u8; 32],
    /// Ids of the neighbouring cells, in the order the player should prefetch them.
    pub neighbours: Vec<u32>,
    /// The job fingerprint the cell was baked with.
    pub fingerprint: [u8; 32],
    /// A cell's far-field group (an entry of [`Index::groups`]), `None` without one
    /// (format version 2; `None` in version 1); for a group's own entry, its parent
    /// group of the next level, of a larger id (version 5, issue 27; `None` before).
    pub group: Option<u32>,
}

/// The content of `index.pack`. Cells are sorted by id, ids unique; so are the
/// far-field groups (version 2: `groups/<id>.pack`, each shared by the cells whose
/// `group` names it; their entries have no neighbours).
///
/// Version 7 (issue 32): the index is the commit point of a bake's generation. It
/// names the base pack too ([`Index::base`]), with its size and blake3, so that a
/// reader that opens `index.pack` first and then only the files it names sees one
/// generation whole (`pipeline` publishes each file under a name of its content and
/// never rewrites a published file).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Index {
    pub build_fingerprint: [u8; 32],
    pub cells: Vec<IndexEntry>,
    pub groups: Vec<IndexEntry>,
    /// The base pack of this generation (section `index-base`, version 7); `None`:
    /// the base pack is [`LEGACY_BASE_FILE`], not bound to this index.
    pub base: Option<BaseEntry>,
}

/// The base pack an index names (version 7).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BaseEntry {
    /// Path relative to the bake directory, e.g. `base-0123456789abcdef.pack`.
    pub file: String,
    /// Size of that file in bytes.
    pub bytes: u64,
    /// blake3 of the whole file.
    pub checksum: [u8; 32],
}

/// The base pack of an index without an `index-base` section (versions 1–6), and the
/// name `pipeline run` writes the base pack under before publishing it.
pub const LEGACY_BASE_FILE: &str = "base.pack";

impl BaseEntry {
    /// The entry of a base pack named `file` whose content is `data`.
    pub fn for_bytes(file: &str, data: &[u8]) -> BaseEntry {
        BaseEntry {
            file: file.to_string(),
            bytes: data.len() as u64,
            checksum: *blake3::hash(data).as_bytes(),
        }
    }

    /// Checks that `data`, the content of the base pack at `path`, has the recorded
    /// size and blake3.
    pub fn verify_bytes(&self, path: &Path, data: &[u8]) -> Result<(), PackError> {
        self.as_entry().verify_bytes(path, data)
    }

    fn as_entry(&self) -> IndexEntry {
        IndexEntry {
            cell_id: 0,
            file: self.file.clone(),
            bytes: self.bytes,
            checksum: self.checksum,
            neighbours: Vec::new(),
            fingerprint: [0; 32],
            group: None,
        }
    }
}

super::pod_records! {
    /// Section `index-meta` (48 bytes).
    pub struct IndexMetaRecord[48] {
        pub build_fingerprint: [u8; 32],
        pub cell_count: u32,
        /// Version 2: entries of `index-groups`; reserved (0) in version 1.
        pub group_count: u32,
        pub reserved: [u32; 2],
    }

    /// One entry of section `index-cells` (88 bytes). A cell's neighbours (in
    /// `index-neighbours`) follow those of the cells before it.
    pub struct CellRecord[88] {
        pub cell_id: u32,
        pub neighbour_count: u32,
        pub bytes: u64,
        pub checksum: [u8; 32],
        pub fingerprint: [u8; 32],
        /// Byte range of the file name in `index-file-names` (UTF-8).
        pub name_offset: u32,
        pub name_len: u32,
    }
}

/// An entry's file is a safe relative path and its size is within bounds (the
/// writer's check; `what` is `cell` or `group`).
fn check_file_and_size(what: &str, e: &IndexEntry) -> Result<(), PackError> {
    check_relative_path(&e.file).map_err(|err| invalid(format!("{what} {}: {err}", e.cell_id)))?;
    check_entry(e.cell_id, e.bytes).map_err(invalid)
}

/// The `index-cells` / `index-groups` record of an entry, its file name appended to
/// `names` (a group entry has no neighbours: its count is 0).
fn entry_record(e: &IndexEntry, names: &mut Vec<u8>) -> Result<CellRecord, PackError> {
    let record = CellRecord {
        cell_id: e.cell_id,
        neighbour_count: u32::try_from(e.neighbours.len())
            .map_err(|_| invalid("too many neighbours"))?,
        bytes: e.bytes,
        checksum: e.checksum,
        fingerprint: e.fingerprint,
        name_offset: u32::try_from(names.len()).map_err(|_| invalid("file names too long"))?,
        name_len: u32::try_from(e.file.len()).map_err(|_| invalid("file name too long"))?,
    };
    names.extend_from_slice(e.file.as_bytes());
    Ok(record)
}

/// Whether `file` is a safe relative path (`/`-separated, no empty, `.` or `..`
/// component, no backslash or NUL).
pub fn check_relative_path(file: &str) -> Result<(), String> {
    if file.is_empty() || file.contains('\\') || file.contains('\0') {
        return Err(format!(
            "file name {file:?} is empty or contains '\\' or NUL"
        ));
    }
    if file
        .split('/')
        .any(|c| c.is_empty() || c == "." || c == "..")
    {
        return Err(format!("file name {file:?} is not a plain relative path"));
    }
    Ok(())
}

/// `index-cell-groups` value of a cell without a far-field group.
pub const NO_GROUP: u32 = u32::MAX;

impl Index {
    /// Checks the index against the base pack it is read with (what every reader
    /// runs; issue 32): every listed cell is a cell of the base pack's grid and every
    /// neighbour it lists is adjacent to it on that grid. A group's id is a cell of the
    /// grid too (a grid has at most as many groups as cells).
    pub fn check_against(&self, base: &super::BasePack) -> Result<(), PackError> {
        let grid = crate::grid::HexGrid::from_params(&base.grid)
            .map_err(|e| invalid(format!("the base pack's grid: {e}")))?;
        let cells = grid.cell_count();
        let listed = self.cells.iter().map(|e| ("cell", e.cell_id));
        let groups = self.groups.iter().map(|e| ("group", e.cell_id));
        if let Some((what, id)) = listed.chain(groups).find(|&(_, id)| id >= cells) {
            return Err(invalid(format!(
                "index.pack lists {what} {id}, but base.pack's grid has {cells} cells"
            )));
        }
        for entry in &self.cells {
            let adjacent = grid.neighbours(entry.cell_id);
            if let Some(&n) = entry.neighbours.iter().find(|n| !adjacent.contains(n)) {
                return Err(invalid(format!(
                    "index.pack: cell {} lists neighbour {n}, which is not adjacent to it on \
                     base.pack's grid (its neighbours are {adjacent:?})",
                    entry.cell_id
                )));
            }
        }
        Ok(())
    }
}

/// Most neighbours a hexagonal cell has.
pub const MAX_NEIGHBOURS: usize = 6;

/// Checks an entry's values: a cell id below `format::manifest::MAX_CELLS` and a
/// pack at least a header long.
pub fn check_entry(cell_id: u32, bytes: u64) -> Result<(), String> {
    let max_cells = crate::manifest::MAX_CELLS;
    if u64::from(cell_id) >= max_cells {
        return Err(format!(
            "cell id {cell_id} is past the largest grid ({max_cells} cells)"
        ));
    }
    if bytes < super::layout::HEADER_SIZE as u64 {
        return Err(format!(
            "cell {cell_id}: a pack of {bytes} bytes is shorter than its header"
        ));
    }
    Ok(())
}

/// Checks a cell's neighbours: at most [`MAX_NEIGHBOURS`], each below `MAX_CELLS`,
/// none repeated and none the cell itself. On failure: the position in the list.
pub fn check_neighbours(cell_id: u32, neighbours: &[u32]) -> Result<(), (usize, String)> {
    if neighbours.len() > MAX_NEIGHBOURS {
        return Err((
            MAX_NEIGHBOURS,
            format!(
                "cell {cell_id}: {} neighbours, a hexagon has at most {MAX_NEIGHBOURS}",
                neighbours.len()
            ),
        ));
    }
    for (k, &n) in neighbours.iter().enumerate() {
        if n == cell_id
            || u64::from(n) >= crate::manifest::MAX_CELLS
            || neighbours[..k].contains(&n)
        {
            return Err((
                k,
                format!(
                    "cell {cell_id}: neighbour {n} is the cell itself, repeated or past the \
                     largest grid"
                ),
            ));
        }
    }
    Ok(())
}

impl IndexEntry {
    /// The entry of the cell pack at `dir/file`: its size and blake3 are read from disk.
    pub fn for_file(
        dir: &Path,
        file: &str,
        cell_id: u32,
        neighbours: Vec<u32>,
        fingerprint: [u8; 32],
    ) -> Result<IndexEntry, PackError> {
        check_relative_path(file).map_err(invalid)?;
        let path = dir.join(file);
        let data = std::fs::read(&path).map_err(|source| PackError::Io {
            file: path.clone(),
            source,
        })?;
        Ok(IndexEntry {
            cell_id,
            file: file.to_string(),
            bytes: data.len() as u64,
            checksum: *blake3::hash(&data).as_bytes(),
            neighbours,
            fingerprint,
            group: None,
        })
    }

    /// Checks that `dir/file` has the recorded size and checksum.
    pub fn verify(&self, dir: &Path) -> Result<(), PackError> {
        let path = dir.join(&self.file);
        let data = std::fs::read(&path).map_err(|source| PackError::Io {
            file: path.clone(),
            source,
        })?;
        self.verify_bytes(&path, &data)
    }

    /// Checks that `data`, the content of the pack at `path` (already read or
    /// mapped), has the recorded size and checksum.
    pub fn verify_bytes(&self, path: &Path, data: &[u8]) -> Result<(), PackError> {
        let path = path.to_path_buf();
        if data.len() as u64 != self.bytes {
            return Err(PackError::LengthMismatch {
                file: path,
                expected: self.bytes,
                found: data.len() as u64,
            });
        }
        let found = blake3::hash(data);
        if *found.as_bytes() != self.checksum {
            return Err(PackError::FileChecksum {
                file: path,
                expected: hex(&self.checksum),
                found: hex(found.as_bytes()),
            });
        }
        Ok(())
    }
}

impl Index {
    /// The base pack's path relative to the bake directory: the one this index names
    /// (version 7), else `base.pack`.
    pub fn base_file(&self) -> &str {
        self.base
            .as_ref()
            .map_or(LEGACY_BASE_FILE, |b| b.file.as_str())
    }

    /// Reads the base pack this index names from the bake directory `dir`, checking
    /// its size and blake3 against the index when it names one (version 7): a base
    /// pack of another generation is refused, naming both files.
    pub fn read_base(&self, dir: &Path) -> Result<super::BasePack, PackError> {
        let path = dir.join(self.base_file());
        if let Some(b) = &self.base {
            let data = std::fs::read(&path).map_err(|source| PackError::Io {
                file: path.clone(),
                source,
            })?;
            b.verify_bytes(&path, &data)?;
            return super::BasePack::decode(&PackFile::from_bytes_named(&data, &path)?);
        }
        super::BasePack::read(&path)
    }

    /// The entry of `cell_id`, if the index has one.
    pub fn cell(&self, cell_id: u32) -> Option<&IndexEntry> {
        self.cells
            .binary_search_by_key(&cell_id, |e| e.cell_id)
            .ok()
            .map(|i| &self.cells[i])
    }

    /// The entry of far-field group `group`, if the index has one.
    pub fn group(&self, group: u32) -> Option<&IndexEntry> {
        self.groups
            .binary_search_by_key(&group, |e| e.cell_id)
            .ok()
            .map(|i| &self.groups[i])
    }

    /// The pack's bytes (deterministic). Cells must be sorted by id, ids unique;
    /// likewise groups, and every cell's group must be listed.
    pub fn encode(&self) -> Result<Vec<u8>, PackError> {
        let mut records = Vec::with_capacity(self.cells.len());
        let mut names = Vec::new();
        let mut neighbours: Vec<u32> = Vec::new();
        let mut cell_groups: Vec<u32> = Vec::with_capacity(self.cells.len());
        for (i, g) in self.groups.iter().enumerate() {
            if i > 0 && self.groups[i - 1].cell_id >= g.cell_id {
                return Err(invalid(format!(
                    "index groups not sorted by unique id at entry {i} (group {})",
                    g.cell_id
                )));
            }
            if !g.neighbours.is_empty() {
                return Err(invalid(format!(
                    "group {}: a group entry has no neighbours",
                    g.cell_id
                )));
            }
            // Version 5: a group names its parent, a listed group of a larger id.
            if let Some(p) = g.group {
                if p <= g.cell_id || self.group(p).is_none() {
                    return Err(invalid(format!(
                        "group {}: its parent {p} is not a listed group of a larger id",
                        g.cell_id
                    )));
                }
            }
        }
        for (i, c) in self.cells.iter().enumerate() {
            if i > 0 && self.cells[i - 1].cell_id >= c.cell_id {
                return Err(invalid(format!(
                    "index cells not sorted by unique id at entry {i} (cell {})",
                    c.cell_id
                )));
            }
            if let Some(g) = c.group {
                if self.group(g).is_none() {
                    return Err(invalid(format!(
                        "cell {}: its group {g} has no entry",
                        c.cell_id
                    )));
                }
            }
            cell_groups.push(c.group.unwrap_or(NO_GROUP));
            check_file_and_size("cell", c)?;
            check_neighbours(c.cell_id, &c.neighbours).map_err(|(_, e)| invalid(e))?;
            records.push(entry_record(c, &mut names)?);
            neighbours.extend_from_slice(&c.neighbours);
        }
        let mut group_records = Vec::with_capacity(self.groups.len());
        for g in &self.groups {
            check_file_and_size("group", g)?;
            group_records.push(entry_record(g, &mut names)?);
            cell_groups.push(g.group.unwrap_or(NO_GROUP));
        }
        let mut base_records = Vec::new();
        if let Some(b) = &self.base {
            let e = b.as_entry();
            check_relative_path(&e.file).map_err(|err| invalid(format!("base pack: {err}")))?;
            base_records.push(entry_record(&e, &mut names)?);
        }
        let meta = IndexMetaRecord {
            build_fingerprint: self.build_fingerprint,
            cell_count: u32::try_from(self.cells.len()).map_err(|_| invalid("too many cells"))?,
            group_count: u32::try_from(self.groups.len())
                .map_err(|_| invalid("too many groups"))?,
            reserved: [0; 2],
        };
        assemble(
            FileKind::Index,
            &[
                SectionData::of_records(SectionKind::INDEX_META, &[meta], RAW_ONLY),
                SectionData::of_records(SectionKind::INDEX_CELLS, &records, TRY_ZSTD),
                SectionData::new(SectionKind::INDEX_FILE_NAMES, names, TRY_ZSTD),
                SectionData::of_records(SectionKind::INDEX_NEIGHBOURS, &neighbours, TRY_INDICES),
                SectionData::of_records(SectionKind::INDEX_GROUPS, &group_records, TRY_ZSTD),
                SectionData::of_records(SectionKind::INDEX_CELL_GROUPS, &cell_groups, TRY_INDICES),
            ]
            .into_iter()
            .chain(
                (!base_records.is_empty()).then(|| {
                    SectionData::of_records(SectionKind::INDEX_BASE, &base_records, RAW_ONLY)
                }),
            )
            .collect::<Vec<_>>(),
        )
    }

    /// Decodes a validated index pack.
    pub fn decode(pack: &PackFile) -> Result<Index, PackError> {
        pack.expect_kind(FileKind::Index)?;
        let file = pack.path();
        let meta: IndexMetaRecord = pack.section_record(SectionKind::INDEX_META)?;
        let v2 = pack.version() >= 2;
        if meta.reserved != [0; 2] || (!v2 && meta.group_count != 0) {
            return Err(malformed(
                file,
                SectionKind::INDEX_META,
                36,
                format!(
                    "reserved fields are {:?}, expected 0",
                    [meta.group_count, meta.reserved[0], meta.reserved[1]]
                ),
            ));
        }
        let records: Vec<CellRecord> = pack.section_table(
            SectionKind::INDEX_CELLS,
            meta.cell_count,
            "cells",
            "index-meta",
        )?;
        let names = pack.section(SectionKind::INDEX_FILE_NAMES)?;
        let neighbours: Vec<u32> = pack.section_vec(SectionKind::INDEX_NEIGHBOURS)?;
        let mut next = 0usize;
        let mut cells = Vec::with_capacity(records.len());
        for (i, r) in records.iter().enumerate() {
            let off = (i * std::mem::size_of::<CellRecord>()) as u64;
            if i > 0 && records[i - 1].cell_id >= r.cell_id {
                return Err(malformed(
                    file,
                    SectionKind::INDEX_CELLS,
                    off,
                    format!("cell ids not increasing at entry {i}"),
                ));
            }
            let name = super::range_of(&names, r.name_offset as usize, r.name_len as usize)
                .ok_or_else(|| {
                    malformed(
                        file,
                        SectionKind::INDEX_CELLS,
                        off,
                        format!("cell {}: name outside index-file-names", r.cell_id),
                    )
                })?;
            let name = std::str::from_utf8(name).map_err(|e| {
                malformed(
                    file,
                    SectionKind::INDEX_FILE_NAMES,
                    r.name_offset as u64,
                    e.to_string(),
                )
            })?;
            check_relative_path(name).map_err(|e| {
                malformed(file, SectionKind::INDEX_FILE_NAMES, r.name_offset as u64, e)
            })?;
            let nb = super::range_of(&neighbours, next, r.neighbour_count as usize).ok_or_else(
                || {
                    malformed(
                        file,
                        SectionKind::INDEX_CELLS,
                        off + 4,
                        format!("cell {}: neighbour count past index-neighbours", r.cell_id),
                    )
                },
            )?;
            check_entry(r.cell_id, r.bytes)
                .map_err(|e| malformed(file, SectionKind::INDEX_CELLS, off, e))?;
            check_neighbours(r.cell_id, nb).map_err(|(k, e)| {
                malformed(
                    file,
                    SectionKind::INDEX_NEIGHBOURS,
                    ((next + k) * 4) as u64,
                    e,
                )
            })?;
            next += nb.len();
            cells.push(IndexEntry {
                cell_id: r.cell_id,
                file: name.to_string(),
                bytes: r.bytes,
                checksum: r.checksum,
                neighbours: nb.to_vec(),
                fingerprint: r.fingerprint,
                group: None,
            });
        }
        let groups = if v2 {
            Index::decode_groups(pack, &meta, &names, &mut cells)?
        } else {
            Vec::new()
        };
        if next != neighbours.len() {
            return Err(malformed(
                file,
                SectionKind::INDEX_NEIGHBOURS,
                (next * 4) as u64,
                format!(
                    "{} neighbours not referenced by any cell",
                    neighbours.len() - next
                ),
            ));
        }
        let base = Index::decode_base(pack, &names)?;
        Ok(Index {
            build_fingerprint: meta.build_fingerprint,
            cells,
            groups,
            base,
        })
    }

    /// Version 7: the base pack's entry, when the index has an `index-base` section.
    fn decode_base(pack: &PackFile, names: &[u8]) -> Result<Option<BaseEntry>, PackError> {
        let file = pack.path();
        if pack.section_info(SectionKind::INDEX_BASE).is_none() {
            return Ok(None);
        }
        let bad = |off: u64, what: String| malformed(file, SectionKind::INDEX_BASE, off, what);
        if pack.version() < 7 {
            return Err(bad(0, "index-base needs format version 7".into()));
        }
        let records: Vec<CellRecord> = pack.section_vec(SectionKind::INDEX_BASE)?;
        let [r] = records[..] else {
            return Err(bad(0, format!("{} records, expected 1", records.len())));
        };
        if r.cell_id != 0 || r.neighbour_count != 0 || r.fingerprint != [0; 32] {
            return Err(bad(
                0,
                "cell id, neighbour count and fingerprint of the base entry must be 0".into(),
            ));
        }
        let name = super::range_of(names, r.name_offset as usize, r.name_len as usize)
            .and_then(|n| std::str::from_utf8(n).ok())
            .ok_or_else(|| bad(32, "name outside index-file-names or not UTF-8".into()))?;
        check_relative_path(name).map_err(|e| bad(32, e))?;
        if r.bytes < super::layout::HEADER_SIZE as u64 {
            return Err(bad(
                8,
                format!(
                    "a base pack of {} bytes is shorter than its header",
                    r.bytes
                ),
            ));
        }
        Ok(Some(BaseEntry {
            file: name.to_string(),
            bytes: r.bytes,
            checksum: r.checksum,
        }))
    }

    /// Version 2: the group entries and each cell's group.
    fn decode_groups(
        pack: &PackFile,
        meta: &IndexMetaRecord,
        names: &[u8],
        cells: &mut [IndexEntry],
    ) -> Result<Vec<IndexEntry>, PackError> {
        let file = pack.path();
        let records: Vec<CellRecord> = pack.section_table(
            SectionKind::INDEX_GROUPS,
            meta.group_count,
            "groups",
            "index-meta",
        )?;
        let mut groups = Vec::with_capacity(records.len());
        for (i, r) in records.iter().enumerate() {
            let off = (i * std::mem::size_of::<CellRecord>()) as u64;
            let bad = |what: String| malformed(file, SectionKind::INDEX_GROUPS, off, what);
            if i > 0 && records[i - 1].cell_id >= r.cell_id {
                return Err(bad(format!("group ids not increasing at entry {i}")));
            }
            if r.neighbour_count != 0 {
                return Err(bad(format!(
                    "group {}: a group has no neighbours",
                    r.cell_id
                )));
            }
            let name = super::range_of(names, r.name_offset as usize, r.name_len as usize)
                .and_then(|n| std::str::from_utf8(n).ok())
                .ok_or_else(|| {
                    bad(format!(
                        "group {}: name outside index-file-names or not UTF-8",
                        r.cell_id
                    ))
                })?;
            check_relative_path(name).map_err(bad)?;
            check_entry(r.cell_id, r.bytes).map_err(bad)?;
            groups.push(IndexEntry {
                cell_id: r.cell_id,
                file: name.to_string(),
                bytes: r.bytes,
                checksum: r.checksum,
                neighbours: Vec::new(),
                fingerprint: r.fingerprint,
                group: None,
            });
        }
        let cell_groups: Vec<u32> = pack.section_vec(SectionKind::INDEX_CELL_GROUPS)?;
        // Version 5: the cells' groups, then each group's parent.
        let parents = if pack.version() >= 5 { groups.len() } else { 0 };
        if cell_groups.len() != cells.len() + parents {
            return Err(malformed(
                file,
                SectionKind::INDEX_CELL_GROUPS,
                0,
                format!(
                    "{} entries for {} cells and {parents} group parents",
                    cell_groups.len(),
                    cells.len()
                ),
            ));
        }
        let (cell_groups, group_parents) = cell_groups.split_at(cells.len());
        for k in 0..group_parents.len() {
            let (id, p) = (groups[k].cell_id, group_parents[k]);
            if p == NO_GROUP {
                continue;
            }
            if p <= id || groups.binary_search_by_key(&p, |e| e.cell_id).is_err() {
                return Err(malformed(
                    file,
                    SectionKind::INDEX_CELL_GROUPS,
                    ((cells.len() + k) * 4) as u64,
                    format!("group {id}: its parent {p} is not a listed group of a larger id"),
                ));
            }
            groups[k].group = Some(p);
        }
        for (k, (cell, &g)) in cells.iter_mut().zip(cell_groups).enumerate() {
            if g == NO_GROUP {
                continue;
            }
            if groups.binary_search_by_key(&g, |e| e.cell_id).is_err() {
                return Err(malformed(
                    file,
                    SectionKind::INDEX_CELL_GROUPS,
                    (k * 4) as u64,
                    format!("cell {}: group {g} is not in index-groups", cell.cell_id),
                ));
            }
            cell.group = Some(g);
        }
        Ok(groups)
    }
}

super::pack_file_methods!(Index);
