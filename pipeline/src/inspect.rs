//! `pipeline inspect <pack> [--json]`: what is inside a base, cell or index pack —
//! header, file kind, version, every section (kind, codec, offset, stored and raw
//! sizes, checksum status) and a summary of the decoded content. A corrupt pack is an
//! error that names the bad section (the caller exits non-zero), with the table
//! still shown so a person can see what else is intact. Format: format/README.md.

use anyhow::{anyhow, Context};
use format::pack::error::hex;
use format::pack::{
    self, BasePack, CellPack, FileKind, Index, PackFile, ProxyKind, FORMAT_VERSION,
};
use serde::Serialize;
use std::fmt::Write;
use std::path::Path;

/// One section as `inspect` reports it.
#[derive(Clone, Debug, Serialize)]
pub struct SectionReport {
    pub entry: u32,
    pub kind: u32,
    /// The spec's name, or `unknown` for kinds this build does not know (skipped).
    pub name: String,
    pub codec: String,
    pub offset: u64,
    pub stored_bytes: u64,
    pub raw_bytes: u64,
    pub checksum: String,
    pub checksum_ok: bool,
}

/// Everything `inspect` reports about one pack.
#[derive(Clone, Debug, Serialize)]
pub struct InspectReport {
    pub path: String,
    pub file_kind: String,
    pub version: u32,
    pub supported_version: u32,
    pub file_bytes: u64,
    pub header_checksum: String,
    pub sections: Vec<SectionReport>,
    /// `Ok: <summary>` of the decoded content, or the decoding error.
    pub content: Result<String, String>,
}

impl InspectReport {
    /// The first problem, if any: a bad section checksum, else a content error.
    pub fn problem(&self) -> Option<String> {
        if let Some(s) = self.sections.iter().find(|s| !s.checksum_ok) {
            return Some(format!(
                "{}: section {} ({:#06x}) at offset {}: checksum mismatch (BAD)",
                self.path, s.name, s.kind, s.offset
            ));
        }
        self.content
            .as_ref()
            .err()
            .map(|e| format!("content does not decode: {e}"))
    }

    /// The human-readable table.
    pub fn to_text(&self) -> String {
        let mut t = String::new();
        let _ = writeln!(t, "file      {}", self.path);
        let _ = writeln!(t, "kind      {}", self.file_kind);
        let _ = writeln!(
            t,
            "version   {} (this build reads 1..={})",
            self.version, self.supported_version
        );
        let _ = writeln!(t, "size      {} bytes", self.file_bytes);
        let _ = writeln!(
            t,
            "header    checksum {} OK (header + table)",
            self.header_checksum
        );
        let _ = writeln!(t, "sections  {}", self.sections.len());
        let _ = writeln!(
            t,
            "  {:>2}  {:<26} {:<15} {:>10} {:>12} {:>12} {:>6}  checksum",
            "#", "kind", "codec", "offset", "stored", "raw", "ratio"
        );
        for s in &self.sections {
            let ratio = if s.stored_bytes == 0 {
                1.0
            } else {
                s.raw_bytes as f64 / s.stored_bytes as f64
            };
            let _ = writeln!(
                t,
                "  {:>2}  {:<26} {:<15} {:>10} {:>12} {:>12} {:>6.2}  {}",
                s.entry,
                format!("{} ({:#06x})", s.name, s.kind),
                s.codec,
                s.offset,
                s.stored_bytes,
                s.raw_bytes,
                ratio,
                if s.checksum_ok { "OK" } else { "BAD" }
            );
        }
        let stored: u64 = self.sections.iter().map(|s| s.stored_bytes).sum();
        let raw: u64 = self.sections.iter().map(|s| s.raw_bytes).sum();
        let _ = writeln!(t, "  total stored {stored} bytes, raw {raw} bytes");
        match &self.content {
            Ok(summary) => {
                let _ = writeln!(t, "content   OK: {summary}");
            }
            Err(e) => {
                let _ = writeln!(t, "content   ERROR: {e}");
            }
        }
        t
    }
}

/// Reads and checks the pack at `path` (never memory-mapped: inspect must survive a
/// file being rewritten under it). Errors only when the header or table is unreadable.
pub fn inspect_report(path: &Path) -> anyhow::Result<InspectReport> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let scan = pack::scan(&bytes, path)?;
    let sections = scan
        .sections
        .iter()
        .zip(&scan.checksum_ok)
        .map(|(s, ok)| SectionReport {
            entry: s.entry,
            kind: s.kind.0,
            name: s.kind.name().unwrap_or("unknown").to_string(),
            codec: s.codec.name().to_string(),
            offset: s.offset,
            stored_bytes: s.stored_len,
            raw_bytes: s.raw_len,
            checksum: hex(&s.checksum),
            checksum_ok: *ok,
        })
        .collect();
    let content = if scan.checksum_ok.iter().all(|ok| *ok) {
        let file = PackFile::from_bytes_named(&bytes, path)?;
        summarize(&file).map_err(|e| e.to_string())
    } else {
        Err("not decoded: a section checksum is bad".to_string())
    };
    Ok(InspectReport {
        path: path.display().to_string(),
        file_kind: scan.file_kind.name().to_string(),
        version: scan.header.version,
        supported_version: FORMAT_VERSION,
        file_bytes: bytes.len() as u64,
        header_checksum: hex(&scan.header.header_checksum),
        sections,
        content,
    })
}

fn summarize(file: &PackFile) -> Result<String, format::pack::PackError> {
    Ok(match file.file_kind() {
        FileKind::Base => {
            let b = BasePack::decode(file)?;
            let verts: usize = b.models.iter().map(|m| m.mesh.positions.len()).sum();
            let tris: usize = b.models.iter().map(|m| m.mesh.triangles.len()).sum();
            format!(
                "{} models ({verts} vertices, {tris} triangles), {} instances, grid {}x{} cells of size {}, scene fingerprint {}",
                b.models.len(),
                b.instances.len(),
                b.grid.n_cols,
                b.grid.n_rows,
                b.grid.cell_size,
                &hex(&b.scene_fingerprint)[..16]
            )
        }
        FileKind::Cell | FileKind::Group => {
            let group = file.file_kind() == FileKind::Group;
            let c = if group {
                CellPack::decode_group(file)?
            } else {
                CellPack::decode(file)?
            };
            let count = |k: ProxyKind| c.proxies.iter().filter(|p| p.kind == k).count();
            let views: usize = c.proxies.iter().map(|p| p.views.len()).sum();
            let texels: u64 = c
                .proxies
                .iter()
                .flat_map(|p| &p.views)
                .map(|v| v.texture.width as u64 * v.texture.height as u64)
                .sum();
            let far = match (c.far_group, group) {
                (Some(g), false) => format!(" (far field: group {g})"),
                (Some(g), true) => format!(" (parent: group {g})"),
                (None, _) => String::new(),
            };
            // Textures by encoding: count and encoded bytes (issue 15).
            let mut by_encoding: std::collections::BTreeMap<&str, (usize, usize)> =
                std::collections::BTreeMap::new();
            for v in c.proxies.iter().flat_map(|p| &p.views) {
                let e = by_encoding.entry(v.texture.encoding.name()).or_default();
                e.0 += 1;
                e.1 += v.texture.data.len();
            }
            let encodings: Vec<String> = by_encoding
                .iter()
                .map(|(name, (n, bytes))| format!("{n} {name} ({bytes} bytes)"))
                .collect();
            let encodings = crate::list_or_nothing("; textures: ", &encodings, "");
            format!(
                "{} {}{far}, {} originals, {} proxies (SvMesh {}, Cluster {}, MvMesh {}, LayeredImpostor {}), {} proxy triangles, {views} views ({texels} texels{encodings}), fingerprint {}",
                if group { "far-field group" } else { "cell" },
                c.cell_id,
                c.originals.len(),
                c.proxies.len(),
                count(ProxyKind::SvMesh),
                count(ProxyKind::Cluster),
                count(ProxyKind::MvMesh),
                count(ProxyKind::LayeredImpostor),
                c.triangle_count(),
                &hex(&c.fingerprint)[..16]
            )
        }
        FileKind::Index => {
            let i = Index::decode(file)?;
            let bytes: u64 = i.cells.iter().map(|c| c.bytes).sum();
            let group_bytes: u64 = i.groups.iter().map(|c| c.bytes).sum();
            format!(
                "{} cells ({bytes} bytes of cell packs), {} far-field groups ({group_bytes} bytes of group packs), build fingerprint {}",
                i.cells.len(),
                i.groups.len(),
                &hex(&i.build_fingerprint)[..16]
            )
        }
    })
}

/// `pipeline inspect`: the report as text (or pretty JSON with `json`). A pack with a
/// bad header/table, a bad section checksum or undecodable content is an `Err` whose
/// message names the problem (the bad section, with its offset) followed by the report.
pub fn inspect(path: &Path, json: bool) -> anyhow::Result<String> {
    let report = inspect_report(path)?;
    let rendered = if json {
        serde_json::to_string_pretty(&report)? + "\n"
    } else {
        report.to_text()
    };
    match report.problem() {
        Some(problem) => Err(anyhow!("{problem}\n{rendered}")),
        None => Ok(rendered),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use format::pack::{sample, SectionKind};

    #[test]
    fn inspect_shows_every_section_of_a_good_pack() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("12.pack");
        sample::small_cell().write(&path).unwrap();
        let text = inspect(&path, false).unwrap();
        for name in [
            "cell-meta",
            "proxies",
            "member-triangles",
            "view-masks",
            "textures",
            "OK: cell 12",
        ] {
            assert!(text.contains(name), "{name} missing from\n{text}");
        }
        assert!(!text.contains("BAD"));
        let json: serde_json::Value = serde_json::from_str(&inspect(&path, true).unwrap()).unwrap();
        assert_eq!(json["file_kind"], "cell");
        assert_eq!(json["sections"].as_array().unwrap().len(), 8);
        assert_eq!(json["sections"][0]["checksum_ok"], true);
    }

    #[test]
    fn inspect_names_the_corrupt_section() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("base.pack");
        let bytes = sample::small_base().encode().unwrap();
        let pack = PackFile::from_bytes(&bytes).unwrap();
        let s = *pack.section_info(SectionKind::TRIANGLES).unwrap();
        let mut bad = bytes.clone();
        bad[s.offset as usize + 3] ^= 0x40;
        std::fs::write(&path, &bad).unwrap();
        let err = inspect(&path, false).unwrap_err().to_string();
        assert!(
            err.contains("section triangles") && err.contains(&s.offset.to_string()),
            "{err}"
        );
        assert!(
            err.contains("BAD") && err.contains("instances"),
            "table still shown:\n{err}"
        );
        // A broken header is an error too.
        std::fs::write(&path, &bytes[..40]).unwrap();
        assert!(inspect(&path, true).is_err());
    }
}

/// What `pipeline inspect <out>` (a bake directory) found.
#[derive(Clone, Debug, Serialize)]
pub struct BakeCheck {
    pub dir: String,
    /// Cell packs the index lists, and how many verified.
    pub cells_indexed: usize,
    pub cells_ok: usize,
    /// Far-field group packs the index lists, and how many verified.
    pub groups_indexed: usize,
    pub groups_ok: usize,
    /// One line per problem: the pack and what differs.
    pub problems: Vec<String>,
}

/// Verifies a whole bake (issue 19): `index.pack` and the base pack it names decode
/// (the base's size and blake3 as the index records them, format version 7), the index's
/// cells and neighbours lie in the base pack's grid, every cell the index lists exists with the listed size, checksum and job fingerprint, decodes,
/// holds that cell and references only instances and vertices of the base pack.
/// Returns the report; the caller exits non-zero when `problems` is not empty.
pub fn check_bake(dir: &Path) -> anyhow::Result<BakeCheck> {
    // The index first, then only what it names (issue 32: one generation whole).
    let index = Index::read(&dir.join("index.pack"))
        .with_context(|| format!("{}: cannot read the index", dir.display()))?;
    let base = index.read_base(dir).with_context(|| {
        format!(
            "{}: cannot read the base pack the index names",
            dir.join(index.base_file()).display()
        )
    })?;
    let mut problems = Vec::new();
    let (mut ok, mut groups_ok) = (0, 0);
    // The index against the base pack: every listed cell is a cell of the base pack's
    // grid, and every neighbour it lists is adjacent to it there.
    if let Err(e) = index.check_against(&base) {
        problems.push(format!("{}: {e}", dir.join("index.pack").display()));
    }
    // Cells, then far-field groups (format version 2).
    let units = index
        .cells
        .iter()
        .map(|e| (e, false))
        .chain(index.groups.iter().map(|e| (e, true)));
    for (entry, is_group) in units {
        let path = dir.join(&entry.file);
        let what = if is_group { "far-field group" } else { "cell" };
        let problem = (|| -> Result<(), String> {
            entry.verify(dir).map_err(|e| e.to_string())?;
            let pack = PackFile::open(&path)
                .and_then(|f| {
                    if is_group {
                        CellPack::decode_group(&f)
                    } else {
                        CellPack::decode(&f)
                    }
                })
                .map_err(|e| e.to_string())?;
            if pack.cell_id != entry.cell_id {
                return Err(format!(
                    "{}: holds {what} {}, the index lists it for {what} {}",
                    path.display(),
                    pack.cell_id,
                    entry.cell_id
                ));
            }
            // A cell's far-field group, a group's parent (format version 5).
            if pack.far_group != entry.group {
                return Err(format!(
                    "{}: far-field group or parent {:?}, the index says {:?}",
                    path.display(),
                    pack.far_group,
                    entry.group
                ));
            }
            if pack.fingerprint != entry.fingerprint {
                return Err(format!(
                    "{}: job fingerprint {} differs from the index's {} (a pack of another bake or setting)",
                    path.display(),
                    hex(&pack.fingerprint),
                    hex(&entry.fingerprint)
                ));
            }
            pack.check_against(&base)
                .map_err(|e| format!("{}: {e}", path.display()))
        })();
        match problem {
            Ok(()) if is_group => groups_ok += 1,
            Ok(()) => ok += 1,
            Err(p) => problems.push(p),
        }
    }
    Ok(BakeCheck {
        dir: dir.display().to_string(),
        cells_indexed: index.cells.len(),
        cells_ok: ok,
        groups_indexed: index.groups.len(),
        groups_ok,
        problems,
    })
}

/// Text form of [`BakeCheck`].
pub fn render_bake_check(c: &BakeCheck) -> String {
    let mut out = format!(
        "{}: {} of {} indexed cell packs and {} of {} far-field group packs verified against index.pack and base.pack\n",
        c.dir, c.cells_ok, c.cells_indexed, c.groups_ok, c.groups_indexed
    );
    for p in &c.problems {
        let _ = writeln!(out, "  {p}");
    }
    out
}
