//! Reports of a bake (issue 6 item 5): `report.json`, `report.md` and `report.png`
//! in the output directory, with the per-cell averages in the form of the paper's
//! Tables 3–8 (000 §4.3) and heat maps of the hex grid (tiny-skia).
//!
//! Everything is read back from the output directory (plan, job records, packs), so
//! `pipeline report <out>` works on any finished bake, local or Slurm. On a bake that
//! is not finished it says so first — how many jobs are done, which failed, which are
//! pending — and gives averages only over the cells that are baked: with none baked,
//! there are none (`per_cell` is `null` in JSON, and the Markdown says why).
//!
//! The report's schema is `format::schema::report` (re-exported here); this module
//! builds and renders it.

use format::pack::index::LEGACY_BASE_FILE;
use format::pack::texture_store::{self, TextureRef};
use format::pack::{BasePack, Index, PackFile, SectionKind};
use format::schema::job::error_path;
use format::schema::plan::{plan_path, read_partial, PlanFile};
pub use format::schema::report::{
    CellLine, FarFieldStats, FarLevelStats, PaperTable, Report, Storage, WORST_CELLS,
};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use worker::job::{done_record, CellReport};

/// The textures a cell or group pack holds or names: its inline `textures` section's
/// stored bytes, and (format version 6) each texture of the bake's store it names
/// with that file's bytes. Nothing for a pack that does not open.
fn pack_textures(path: &Path) -> (u64, Vec<(TextureRef, u64)>) {
    let Ok(pack) = PackFile::read(path) else {
        return (0, Vec::new());
    };
    let inline = pack
        .sections()
        .iter()
        .filter(|s| s.kind == SectionKind::TEXTURES)
        .map(|s| s.stored_len)
        .sum();
    let bake = texture_store::bake_dir_of(path);
    let refs = texture_store::pack_refs(&pack)
        .unwrap_or_default()
        .into_iter()
        .map(|r| {
            let bytes = bake.map_or(0, |b| {
                std::fs::metadata(texture_store::texture_path(b, &r)).map_or(0, |m| m.len())
            });
            (r, bytes)
        })
        .collect();
    (inline, refs)
}

/// Adds a pack's textures to `storage` (a store file only the first time `seen`
/// meets it) and returns the pack's inline texture bytes.
fn count_textures(
    storage: &mut Storage,
    seen: &mut BTreeSet<TextureRef>,
    path: &Path,
    group: bool,
) -> u64 {
    let (inline, refs) = pack_textures(path);
    let mut distinct = inline;
    for (r, bytes) in refs {
        storage.texture_uses += 1;
        storage.texture_bytes_per_use += bytes;
        if seen.insert(r) {
            storage.store_textures += 1;
            storage.store_bytes += bytes;
            distinct += bytes;
        }
    }
    if group {
        storage.group_texture_bytes += distinct;
    } else {
        storage.texture_bytes += distinct;
    }
    inline
}

/// Builds the report of a finished (or partly finished) bake from its files.
pub fn build_report(out: &Path) -> anyhow::Result<Report> {
    use anyhow::Context;
    let plan: PlanFile = serde_json::from_slice(
        &std::fs::read(plan_path(out))
            .with_context(|| format!("{}: no plan.json: is this a bake output?", out.display()))?,
    )
    .with_context(|| format!("{}/plan.json", out.display()))?;
    // Issue 32: the index first, then the base pack it names; records of another
    // generation than the index are refused, not mixed in.
    let index = Index::read(&out.join("index.pack")).ok();
    if let Some(index) = &index {
        same_generation(out, &plan, index)?;
    }
    let base_path = out.join(index.as_ref().map_or(LEGACY_BASE_FILE, |i| i.base_file()));
    let base = match &index {
        Some(i) => i.read_base(out),
        None => BasePack::read(&base_path),
    }
    .with_context(|| base_path.display().to_string())?;
    let scene_triangles = base
        .instances
        .iter()
        .map(|i| base.models[i.model as usize].mesh.triangle_count() as u64)
        .sum();
    let mut report = Report {
        scene: plan.name.clone(),
        jobs: plan.jobs.len(),
        grid_cells: plan.jobs.iter().map(|j| j.cells.len()).sum(),
        partial: read_partial(out),
        overrides: plan.overrides.clone(),
        bake: plan.bake.clone(),
        cell_params: plan.cell_params.clone(),
        instances: base.instances.len(),
        scene_triangles,
        ..Report::default()
    };
    report.storage.base_bytes = std::fs::metadata(&base_path)?.len();
    report.storage.index_bytes = std::fs::metadata(out.join("index.pack"))
        .map(|m| m.len())
        .unwrap_or(0);
    let (mut cpu_s, mut shared_process) = (0.0, false);
    // Far-field groups first: every cell line adds its group's proxies (what the
    // cell draws).
    let mut groups: BTreeMap<u32, CellReport> = BTreeMap::new();
    let mut far = FarFieldStats::default();
    let (mut seen, mut inline_cell_textures) = (BTreeSet::new(), 0u64);
    // Only valid done records count (a stale or torn record is not a baked cell);
    // each is checked once (it reads and hashes every pack it lists).
    let records: Vec<Option<worker::job::JobRecord>> =
        plan.jobs.iter().map(|j| done_record(out, j)).collect();
    for record in records.iter().flatten() {
        for g in &record.groups {
            let r = &g.report;
            far.groups += 1;
            far.group_bytes += g.bytes;
            far.bytes_shared += g.bytes * u64::from(r.far_objects).saturating_sub(1);
            far.group_proxies += r.proxy_keys.len() as u64;
            report.proxies_reused += u64::from(r.reused_proxies);
            for (k, ms) in r.stage_ms.entries() {
                *report.stage_s.entry(k.to_string()).or_default() += ms / 1000.0;
            }
            count_textures(&mut report.storage, &mut seen, &out.join(&g.file), true);
            report.storage.group_bytes += g.bytes;
            groups.insert(g.cell, r.clone());
        }
    }
    // Levels (issue 27): a group's parent (its `far_group`) has a larger id, so in
    // ascending order every child is seen before its parent.
    let mut level: BTreeMap<u32, u32> = groups.keys().map(|&g| (g, 1)).collect();
    for (&g, r) in &groups {
        if let Some(p) = r.far_group {
            let l = level[&g] + 1;
            let e = level.entry(p).or_insert(1);
            *e = (*e).max(l);
        }
    }
    for record in records.iter().flatten() {
        for g in &record.groups {
            let l = level.get(&g.cell).copied().unwrap_or(1) as usize;
            if far.levels.len() < l {
                far.levels.resize_with(l, FarLevelStats::default);
            }
            let s = &mut far.levels[l - 1];
            s.level = l as u32;
            s.groups += 1;
            s.proxies += g.report.proxy_keys.len() as u64;
            s.impostors += u64::from(g.report.impostors);
            s.objects += u64::from(
                g.report.sv_objects + g.report.cluster_objects + g.report.impostor_objects,
            );
            s.bytes += g.bytes;
            s.bake_s += g
                .report
                .stage_ms
                .entries()
                .iter()
                .map(|(_, ms)| ms)
                .sum::<f64>()
                / 1000.0;
        }
    }
    far.levels.retain(|s| s.groups > 0);
    for (job, record) in plan.jobs.iter().zip(&records) {
        let Some(record) = record else {
            if error_path(out, job.id).exists() {
                report.jobs_failed.push(job.id);
            } else {
                report.jobs_pending.push(job.id);
            }
            continue;
        };
        report.jobs_done += 1;
        report.job_wall_s += record.wall_s;
        cpu_s += record.cpu_s;
        shared_process |= record.shared_process;
        for c in &record.cells {
            let r = &c.report;
            // What the cell draws: its own proxies plus its groups' far field, every
            // level of its chain (each group names its parent).
            let group = r.far_group.and_then(|g| groups.get(&g));
            let chain: Vec<&CellReport> =
                std::iter::successors(group, |g| g.far_group.and_then(|p| groups.get(&p)))
                    .take(16)
                    .collect();
            let both = |f: fn(&CellReport) -> f64| f(r) + chain.iter().map(|g| f(g)).sum::<f64>();
            let mut line = CellLine {
                cell: c.cell,
                polygons_inside: r.polygons_inside as f64,
                sv_polygons: both(|r| r.sv_polygons as f64),
                mv_polygons: r.mv_polygons as f64,
                cluster_polygons: both(|r| r.cluster_polygons as f64),
                sv_objects: both(|r| r.sv_objects.into()),
                mv_objects: r.mv_objects.into(),
                cluster_objects: both(|r| r.cluster_objects.into()),
                culled_objects: r.culled_objects.into(),
                outside_original_polygons: both(|r| r.outside_original_polygons as f64),
                texture_bytes: both(|r| r.texture_bytes as f64),
                pack_bytes: c.bytes,
                impostor_objects: both(|r| r.impostor_objects.into()),
                impostor_polygons: both(|r| r.impostor_polygons as f64),
                selection_culled: r.selection_culled.into(),
                ..CellLine::default()
            };
            quality_of(&mut line, r, group);
            far.far_objects_per_cell += f64::from(r.far_objects);
            far.cell_proxies += r.proxy_keys.len() as u64;
            for (k, ms) in r.stage_ms.entries() {
                line.stage_ms.insert(k.to_string(), ms);
                line.bake_ms += ms;
                *report.stage_s.entry(k.to_string()).or_default() += ms / 1000.0;
            }
            inline_cell_textures +=
                count_textures(&mut report.storage, &mut seen, &out.join(&c.file), false);
            report.proxies += r.proxy_keys.len() as u64;
            report.proxies_reused += u64::from(r.reused_proxies);
            report.storage.cell_bytes += c.bytes;
            report.cell_lines.push(line);
        }
    }
    report.job_cpu_s = (!shared_process).then_some(cpu_s);
    report.cell_lines.sort_by_key(|l| l.cell);
    report.cells = report.cell_lines.len();
    if far.groups > 0 {
        far.far_objects_per_cell /= report.cells.max(1) as f64;
        report.proxies += far.group_proxies;
        report.far_field = Some(far);
    }
    let s = &mut report.storage;
    s.mesh_bytes = s.cell_bytes - inline_cell_textures.min(s.cell_bytes);
    s.total_bytes = s.base_bytes + s.index_bytes + s.cell_bytes + s.group_bytes + s.store_bytes;
    // Averages over the baked cells; over none there are none.
    s.per_cell_bytes = if report.cells > 0 {
        (s.cell_bytes + s.group_bytes + s.store_bytes) as f64 / report.cells as f64
    } else {
        0.0
    };
    report.per_cell = paper_table(&report.cell_lines);
    let mut worst: Vec<(u32, f64)> = report
        .cell_lines
        .iter()
        .filter(|l| l.measured_proxies > 0.0)
        .map(|l| (l.cell, l.worst_view_psnr_db))
        .collect();
    worst.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    worst.truncate(WORST_CELLS);
    report.worst_cells = worst;
    let mut share = BTreeMap::new();
    let lines = &report.cell_lines;
    let total: f64 = lines
        .iter()
        .map(|l| {
            l.sv_objects + l.mv_objects + l.cluster_objects + l.impostor_objects + l.culled_objects
        })
        .sum();
    if total > 0.0 {
        for (k, f) in [
            ("sv", (|l: &CellLine| l.sv_objects) as fn(&CellLine) -> f64),
            ("mv", |l| l.mv_objects),
            ("cluster", |l| l.cluster_objects),
            ("layered_impostor", |l| l.impostor_objects),
            ("culled", |l| l.culled_objects),
        ] {
            share.insert(k.to_string(), lines.iter().map(f).sum::<f64>() / total);
        }
    }
    report.representation_share = share;
    Ok(report)
}

/// The quality figures of a cell's record `r` and its far-field group's `group`
/// (issue 16): measured proxies add up, the worst view is the worse of the two.
fn quality_of(line: &mut CellLine, r: &CellReport, group: Option<&CellReport>) {
    line.worst_view_psnr_db = format::metrics::PSNR_CAP;
    line.worst_view_ssim = 1.0;
    for q in std::iter::once(r).chain(group).map(|v| &v.quality) {
        line.measured_proxies += f64::from(q.measured_proxies);
        if q.measured_proxies > 0 {
            line.worst_view_psnr_db = line.worst_view_psnr_db.min(q.worst_psnr_db);
            line.worst_view_ssim = line.worst_view_ssim.min(q.worst_ssim);
        }
        for (a, b) in line.error_histogram.iter_mut().zip(q.error_histogram) {
            *a += b;
        }
    }
}

/// The per-cell averages of `lines`; `None` for no lines.
fn paper_table(lines: &[CellLine]) -> Option<PaperTable> {
    if lines.is_empty() {
        return None;
    }
    let n = lines.len() as f64;
    let avg = |f: &dyn Fn(&CellLine) -> f64| lines.iter().map(f).sum::<f64>() / n;
    let outside = |l: &CellLine| l.sv_objects + l.mv_objects + l.cluster_objects + l.culled_objects;
    let pct = |f: &dyn Fn(&CellLine) -> f64| {
        avg(&|l| {
            let o = outside(l);
            if o > 0.0 {
                100.0 * f(l) / o
            } else {
                0.0
            }
        })
    };
    let simplified = avg(&|l| l.sv_polygons + l.mv_polygons + l.cluster_polygons);
    let original = avg(&|l| l.outside_original_polygons);
    Some(PaperTable {
        polygons_inside_a_cell: avg(&|l| l.polygons_inside),
        sv_single_percent: pct(&|l| l.sv_objects),
        sv_clustered_percent: pct(&|l| l.cluster_objects),
        mv_percent: pct(&|l| l.mv_objects),
        culled_percent: pct(&|l| l.culled_objects),
        polygons_sv_and_mv: simplified,
        polygons_for_a_cell: simplified + avg(&|l| l.polygons_inside),
        simplified_to_original: if simplified > 0.0 {
            original / simplified
        } else {
            0.0
        },
        texture_kb: avg(&|l| l.texture_bytes) / 1024.0,
    })
}

/// The report as Markdown.
pub fn to_markdown(r: &Report) -> String {
    use std::fmt::Write;
    let mut m = String::new();
    let s = &r.storage;
    let _ = writeln!(m, "# Bake report: {}\n", r.scene);
    let _ = writeln!(
        m,
        "{} cells in {} jobs; {} instances, {} triangles.\n",
        r.cells, r.jobs, r.instances, r.scene_triangles
    );
    if let Some(p) = &r.partial {
        let _ = writeln!(
            m,
            "**{}**: the averages below are over the baked cells only.\n",
            p.line()
        );
        if !r.jobs_failed.is_empty() {
            let _ = writeln!(
                m,
                "**{} job(s) failed**; `pipeline status` lists them.\n",
                r.jobs_failed.len()
            );
        }
    } else if let Some(jobs) = r.jobs_line() {
        let _ = writeln!(
            m,
            "**The bake is not finished: {jobs}.** The numbers below cover only the baked \
             cells ({} of {}); `pipeline status` lists the jobs.\n",
            r.cells, r.grid_cells
        );
    }
    if !r.overrides.is_empty() {
        let _ = writeln!(
            m,
            "Parameters overridden on the command line: `{}`.\n",
            r.overrides.join("`, `")
        );
    }
    let _ = writeln!(m, "## Per-cell averages (paper 000, Tables 3–8)\n");
    match &r.per_cell {
        Some(t) => averages_table(&mut m, t),
        None => {
            let _ = writeln!(m, "No cell is baked yet: there is nothing to average.");
        }
    }
    let _ = writeln!(m, "\n## Storage\n\n| kind | bytes |\n|---|---|");
    for (k, v) in [
        ("base (models, instances)", s.base_bytes),
        ("cell meshes (indices, masks, tables)", s.mesh_bytes),
        ("cell textures (each stored once)", s.texture_bytes),
        ("far-field group packs", s.group_bytes),
        (
            "far-field textures (each stored once)",
            s.group_texture_bytes,
        ),
        ("index", s.index_bytes),
        ("total", s.total_bytes),
    ] {
        let _ = writeln!(m, "| {k} | {v} |");
    }
    if r.cells > 0 {
        let _ = writeln!(m, "| per cell (average) | {:.0} |", s.per_cell_bytes);
    }
    if s.store_textures > 0 {
        let _ = writeln!(
            m,
            "\nCaptures are stored once (`textures/`, format version 6): {} distinct textures, \
             {} bytes, for {} uses by cells and groups; a copy per use would take {} bytes \
             ({:.2}×).",
            s.store_textures,
            s.store_bytes,
            s.texture_uses,
            s.texture_bytes_per_use,
            s.texture_bytes_per_use as f64 / s.store_bytes.max(1) as f64
        );
    }
    if let Some(f) = &r.far_field {
        let _ = writeln!(
            m,
            "\n## Far field (levels of 7, 49, 343 … cells)\n\n| | value |\n|---|---|\n\
             | groups | {} |\n\
             | proxies in cell packs (level 0) | {} |\n\
             | proxies in group packs (levels ≥ 1) | {} |\n\
             | objects a cell draws from its groups (mean) | {:.1} |\n\
             | group-pack bytes | {} |\n\
             | bytes shared (a copy per cell would add) | {} |",
            f.groups,
            f.cell_proxies,
            f.group_proxies,
            f.far_objects_per_cell,
            f.group_bytes,
            f.bytes_shared
        );
        if !f.levels.is_empty() {
            let _ = writeln!(
                m,
                "\n| level | cells per group | groups | proxies | of which merged impostors | objects drawn | bytes | bake s |\n|---:|---:|---:|---:|---:|---:|---:|---:|"
            );
            for l in &f.levels {
                let _ = writeln!(
                    m,
                    "| {} | ≤ {} | {} | {} | {} | {} | {} | {:.1} |",
                    l.level,
                    7u64.saturating_pow(l.level),
                    l.groups,
                    l.proxies,
                    l.impostors,
                    l.objects,
                    l.bytes,
                    l.bake_s
                );
            }
        }
    }
    quality_section(&mut m, r);
    time_section(&mut m, r);
    m
}

/// What a cell's worst figure is, next to it in the report (issue 28): the bake
/// does not record the worst proxy's size on screen, and the figure is often a
/// tiny object's.
pub const WORST_FIGURES_CAVEAT: &str = "A cell's figure is its single worst proxy in \
    that proxy's worst sample view, whatever its size on screen (the bake does not \
    record it): worst values can come from objects a few pixels across — on the demo, \
    its 0.3-unit pebbles — where a few wrong pixels are much of the object, so they say \
    little about a walk's frames (`player compare` measures those).";

/// Issue 16: representation shares, the quality check's worst cells and the pooled
/// error histogram.
fn quality_section(m: &mut String, r: &Report) {
    use std::fmt::Write;
    if !r.representation_share.is_empty() {
        let _ = writeln!(
            m,
            "\n## Representations of the outside objects (share over the baked cells)\n\n| kind | share |\n|---|---|"
        );
        for (k, v) in &r.representation_share {
            let _ = writeln!(m, "| {k} | {:.1} % |", 100.0 * v);
        }
    }
    let measured: f64 = r.cell_lines.iter().map(|l| l.measured_proxies).sum();
    if measured == 0.0 {
        return;
    }
    let _ = writeln!(
        m,
        "\n## Quality check (objective selection, issue 16)\n\n{measured:.0} proxies \
         measured from their region's sample viewpoints against the original, on the \
         objects' own pixels (worker `select.rs`). Worst cells by their worst sample \
         view's PSNR(Y). {WORST_FIGURES_CAVEAT}\n\n| cell | worst view PSNR(Y) dB | \
         worst view SSIM |\n|---|---|---|"
    );
    for (cell, psnr) in &r.worst_cells {
        let ssim = r
            .cell_lines
            .iter()
            .find(|l| l.cell == *cell)
            .map_or(f64::NAN, |l| l.worst_view_ssim);
        let _ = writeln!(m, "| {cell} | {psnr:.2} | {ssim:.3} |");
    }
    let mut hist = [0u64; 8];
    for l in &r.cell_lines {
        for (a, b) in hist.iter_mut().zip(l.error_histogram) {
            *a += b;
        }
    }
    let total = hist.iter().sum::<u64>().max(1) as f64;
    let _ = writeln!(
        m,
        "\nError histogram over the measured object pixels (|ΔY|, 8-bit levels):\n\n| |ΔY| | share |\n|---|---|"
    );
    for (i, h) in hist.iter().enumerate() {
        let range = if i == 7 {
            ">= 56".to_string()
        } else {
            format!("{}–{}", 8 * i, 8 * i + 7)
        };
        let _ = writeln!(m, "| {range} | {:.2} % |", 100.0 * *h as f64 / total);
    }
}

/// The rows of the paper's Tables 3–8 for averages `t`.
fn averages_table(m: &mut String, t: &PaperTable) {
    use std::fmt::Write;
    let _ = writeln!(m, "| statistic | value |\n|---|---|");
    // (statistic, value, decimals); the simplification ratio reads "1:x".
    let rows = [
        (
            "Avg. polygon no. inside a viewcell",
            t.polygons_inside_a_cell,
            0,
        ),
        (
            "Avg. percentage of SVMeshes from clustered objects (%)",
            t.sv_clustered_percent,
            1,
        ),
        (
            "Avg. percentage of SVMeshes from single objects (%)",
            t.sv_single_percent,
            1,
        ),
        ("Avg. percentage of MVMeshes (%)", t.mv_percent, 1),
        ("Avg. percentage of culled objects (%)", t.culled_percent, 1),
        (
            "Avg. polygon no. for SVMesh & MVMesh",
            t.polygons_sv_and_mv,
            0,
        ),
        ("Avg. polygon no. for a viewcell", t.polygons_for_a_cell, 0),
        ("Simplified:original", t.simplified_to_original, 1),
        ("Avg. texture size per cell (KB)", t.texture_kb, 1),
    ];
    for (k, v, decimals) in rows {
        let ratio = if k == "Simplified:original" { "1:" } else { "" };
        let _ = writeln!(m, "| {k} | {ratio}{v:.decimals$} |");
    }
}

/// The Time section of [`to_markdown`].
fn time_section(m: &mut String, r: &Report) {
    use std::fmt::Write;
    let _ = writeln!(m, "\n## Time\n");
    let jobs_line = match r.job_cpu_s {
        Some(cpu) => format!(
            "Jobs: {:.1} s wall, {cpu:.1} s CPU (summed over jobs).",
            r.job_wall_s
        ),
        None => format!(
            "Jobs: {:.1} s wall (summed over jobs); CPU not measured per job (jobs baked side \
             by side in one process; the stage times below are per cell and thread).",
            r.job_wall_s
        ),
    };
    let _ = writeln!(
        m,
        "{jobs_line} Proxies: {} derived, {} reused from the output's earlier bake \
         (their content key was unchanged).\n\n| stage | seconds (summed over cells) |\n|---|---|",
        r.proxies - r.proxies_reused.min(r.proxies),
        r.proxies_reused
    );
    for (k, v) in &r.stage_s {
        let _ = writeln!(m, "| {k} | {v:.2} |");
    }
    let _ = writeln!(
        m,
        "\n![heat maps: polygons, bytes, bake time, worst-view PSNR(Y) dB per cell](report.png)"
    );
}

/// Whether `index` lists the jobs `plan` holds (issue 32): every cell and group it
/// lists was baked by the job of the same fingerprint that `plan.json` has now. After
/// a rebake was interrupted, or while one runs, `plan.json` is the new generation's
/// and `index.pack` the old one's: the report refuses rather than mixing them.
fn same_generation(out: &Path, plan: &PlanFile, index: &Index) -> anyhow::Result<()> {
    let mut planned = BTreeMap::new();
    for job in &plan.jobs {
        planned.extend(job.cells.iter().map(|&c| ((false, c), job.fingerprint)));
        planned.extend(job.groups.iter().map(|&g| ((true, g), job.fingerprint)));
    }
    let listed =
        (index.cells.iter().map(|e| (false, e))).chain(index.groups.iter().map(|e| (true, e)));
    for (is_group, e) in listed {
        if planned.get(&(is_group, e.cell_id)) != Some(&e.fingerprint) {
            anyhow::bail!(
                "{}: index.pack is of another generation than plan.json ({} {} was baked by \
                 a job the plan no longer has): a rebake is running or was interrupted; \
                 `pipeline run` finishes it, then the report describes the new bake",
                out.display(),
                if is_group { "far-field group" } else { "cell" },
                e.cell_id
            );
        }
    }
    Ok(())
}

/// Writes `report.json`, `report.md` and `report.png` into `out`.
pub fn write_report(out: &Path) -> anyhow::Result<Report> {
    let r = build_report(out)?;
    format::pack::write_atomic(&out.join("report.json"), &serde_json::to_vec_pretty(&r)?)?;
    format::pack::write_atomic(&out.join("report.md"), to_markdown(&r).as_bytes())?;
    let base = match Index::read(&out.join("index.pack")) {
        Ok(i) => i.read_base(out)?,
        Err(_) => BasePack::read(&out.join(LEGACY_BASE_FILE))?,
    };
    let png = crate::heatmap::render(&base.grid, &r.cell_lines)?;
    format::pack::write_atomic(&out.join("report.png"), &png)?;
    Ok(r)
}
