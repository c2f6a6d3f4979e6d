//! BENCHMARKS.md's measured tables, regenerated from `docs/bench/*.json`
//! ([`crate::results`]) side by side with the paper's published numbers
//! (000 §4: Tables 2–8 and Fig. 14, from `bench/data/paper-tables.ron` with their
//! table and row, [`crate::paper`]).
//!
//! Each table lives between `<!-- bench:NAME begin -->` and `<!-- bench:NAME end -->`
//! in the document; [`replace_sections`] rewrites only what is between the markers,
//! so the hand-written text around them (explanations, "why we are worse") stays.

use crate::labels::{RunLabel, SweepParam};
use crate::paper::{paper, PaperRow, PaperTables, SweepTable};
use crate::results::{
    BakeResult, CompareReport, CompareResult, CompareStats, LoadTime, Merged, RenderResult,
};
use pipeline::report::Report;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::path::Path;

/// Our park scenes and the paper's names for them (2M, 4M, 8M), from the data file.
pub fn scenes() -> [(&'static str, &'static str); 3] {
    let s = &paper().scenes;
    [0, 1, 2].map(|k| (s[k].ours.as_str(), s[k].paper.as_str()))
}

/// A scene-indexed paper row as its three columns.
fn per_scene(row: &PaperRow) -> [f64; 3] {
    PaperTables::per_scene(row)
}

/// Table 3's T_s = 5 column of a percentage row (the paper's only published split).
fn table3_t5(row: &Option<PaperRow>) -> f64 {
    let col = paper().table3.column_of(5.0);
    match (row, col) {
        (Some(r), Some(c)) => r.values[c],
        _ => f64::NAN,
    }
}

/// The paper's table of a sweep (none for our deviation bound).
fn sweep_table(param: SweepParam) -> Option<&'static SweepTable> {
    let p = paper();
    match param {
        SweepParam::Ts => Some(&p.table3),
        SweepParam::Tl => Some(&p.table4),
        SweepParam::CellSize => Some(&p.table5),
        SweepParam::Deviation => None,
    }
}

// ---------------------------------------------------------------------------------
// Markers.

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MarkerError {
    #[error("no `<!-- bench:{name} {which} -->` marker in the document (the generator writes section `{name}`)")]
    Missing { name: String, which: &'static str },
    #[error("marker `<!-- bench:{name} {which} -->` appears {count} times")]
    Duplicate {
        name: String,
        which: &'static str,
        count: usize,
    },
    #[error("`<!-- bench:{name} end -->` comes before its begin marker")]
    OutOfOrder { name: String },
    #[error(
        "the document has a section `bench:{name}` the generator does not know (known: {known})"
    )]
    Unknown { name: String, known: String },
}

fn marker(name: &str, which: &str) -> String {
    format!("<!-- bench:{name} {which} -->")
}

/// Replaces the text between each section's begin and end markers with the section
/// (followed by a newline); everything outside markers is kept byte for byte. Every
/// section must have exactly one begin and one end marker, in order, and every
/// `bench:` marker in the document must name a known section.
pub fn replace_sections(
    doc: &str,
    sections: &BTreeMap<String, String>,
) -> Result<String, MarkerError> {
    // Unknown sections in the document (a typo would otherwise go stale silently).
    let mut found = BTreeSet::new();
    for (i, _) in doc.match_indices("<!-- bench:") {
        let rest = &doc[i + "<!-- bench:".len()..];
        if let Some(name) = rest.split_whitespace().next() {
            found.insert(name.to_string());
        }
    }
    for name in &found {
        if !sections.contains_key(name) {
            return Err(MarkerError::Unknown {
                name: name.clone(),
                known: sections.keys().cloned().collect::<Vec<_>>().join(", "),
            });
        }
    }
    // Locate every section's markers first, then splice from the back.
    let mut spans = Vec::new();
    for name in sections.keys() {
        let at = |which: &'static str| -> Result<(usize, usize), MarkerError> {
            let m = marker(name, which);
            let hits: Vec<usize> = doc.match_indices(&m).map(|(i, _)| i).collect();
            match hits.len() {
                0 => Err(MarkerError::Missing {
                    name: name.clone(),
                    which,
                }),
                1 => Ok((hits[0], hits[0] + m.len())),
                count => Err(MarkerError::Duplicate {
                    name: name.clone(),
                    which,
                    count,
                }),
            }
        };
        let (_, begin_end) = at("begin")?;
        let (end_start, _) = at("end")?;
        if end_start < begin_end {
            return Err(MarkerError::OutOfOrder { name: name.clone() });
        }
        spans.push((begin_end, end_start, name));
    }
    spans.sort();
    let mut out = String::with_capacity(doc.len());
    let mut pos = 0;
    for (start, end, name) in spans {
        out.push_str(&doc[pos..start]);
        out.push('\n');
        let body = &sections[name];
        out.push_str(body.trim_end_matches('\n'));
        out.push('\n');
        pos = end;
    }
    out.push_str(&doc[pos..]);
    Ok(out)
}

// ---------------------------------------------------------------------------------
// Number formatting.

/// `1234567.8` → `1,234,568`; NaN → `–`.
pub fn int(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let n = v.round() as i64;
    let digits = n.unsigned_abs().to_string();
    let mut s = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            s.push(',');
        }
        s.push(ch);
    }
    if n < 0 {
        format!("−{s}")
    } else {
        s
    }
}

/// Fixed decimals; NaN → `–`.
pub fn fixed(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        "–".into()
    }
}

fn ratio(v: f64) -> String {
    if v.is_finite() && v > 0.0 {
        format!("1:{v:.1}")
    } else {
        "–".into()
    }
}

fn mb(bytes: f64) -> f64 {
    bytes / 1e6
}

fn kb(bytes: f64) -> f64 {
    bytes / 1e3
}

/// `better` / `worse` / `≈` (within 5%) of ours against the paper's value, for a
/// metric where lower is better (triangles, bytes, time).
fn verdict(ours: f64, paper: f64) -> String {
    if !ours.is_finite() || !paper.is_finite() || paper == 0.0 {
        return String::new();
    }
    let rel = ours / paper;
    if (rel - 1.0).abs() <= 0.05 {
        return "≈".into();
    }
    let ours_better = rel < 1.0;
    let factor = if rel >= 1.0 { rel } else { 1.0 / rel };
    format!(
        "{} ({factor:.1}× {})",
        if ours_better { "better" } else { "worse" },
        if rel >= 1.0 { "higher" } else { "lower" }
    )
}

/// Like [`verdict`] for dB values: a difference, not a ratio.
fn verdict_db(ours: f64, paper: f64) -> String {
    if !ours.is_finite() || !paper.is_finite() {
        return String::new();
    }
    let d = ours - paper;
    if d.abs() <= 0.5 {
        "≈".into()
    } else if d > 0.0 {
        format!("better (+{d:.1} dB)")
    } else {
        format!("worse ({d:.1} dB)")
    }
}

const NOT_MEASURED: &str = "_Not measured yet: run `scripts/bench.sh`._";

// ---------------------------------------------------------------------------------
// Lookups in the merged results.

struct Ctx<'a> {
    m: &'a Merged,
    /// Folder of the plots as the document links them (e.g. `docs/bench`).
    plot_prefix: &'a str,
    /// Run files that contributed to the output (for the machine section).
    used: std::cell::RefCell<BTreeSet<String>>,
}

impl<'a> Ctx<'a> {
    fn bake(&self, label: &str) -> Option<&'a BakeResult> {
        let (file, b) = self.m.bakes.get(label)?;
        self.used.borrow_mut().insert(file.clone());
        Some(b)
    }
    fn compare(&self, label: &str) -> Option<&'a CompareResult> {
        let (file, c) = self.m.compares.get(label)?;
        self.used.borrow_mut().insert(file.clone());
        Some(c)
    }
    fn render(&self, label: &str) -> Option<&'a RenderResult> {
        let (file, r) = self.m.renders.get(label)?;
        self.used.borrow_mut().insert(file.clone());
        Some(r)
    }
    fn load(&self, label: &str) -> Option<&'a LoadTime> {
        let (file, l) = self.m.load_times.get(label)?;
        self.used.borrow_mut().insert(file.clone());
        Some(l)
    }
    /// The bake standing for a scene at the paper's settings: the full bake if there
    /// is one, else the path-only (partial) bake.
    fn scene_bake(&self, scene: &str) -> Option<(&'static str, &'a BakeResult)> {
        if let Some(b) = self.bake(scene).filter(|b| b.report.is_some()) {
            return Some(("", b));
        }
        self.bake(&RunLabel::PathBake(scene).to_string())
            .filter(|b| b.report.is_some())
            .map(|b| ("path", b))
    }
    /// The bake the player ran on for a scene (the label the compare names).
    fn hybrid_compare(&self, scene: &str) -> Option<&'a CompareResult> {
        self.compare(&RunLabel::Hybrid(scene).to_string())
    }
}

/// A statistic row: name, the paper's values, our value from a report, formatting.
type StatRow<P> = (&'static str, P, fn(&Report) -> f64, fn(f64) -> String);

/// "(84 of 528 cells)" for a partial report.
fn coverage(r: &Report) -> String {
    if r.grid_cells > 0 && r.cells < r.grid_cells {
        format!(" ({} of {} cells)", r.cells, r.grid_cells)
    } else {
        String::new()
    }
}

/// A table header: the first column left-aligned, the others right-aligned
/// (numbers).
fn table_header(m: &mut String, cols: &[String]) {
    let _ = writeln!(m, "| {} |", cols.join(" | "));
    let _ = writeln!(
        m,
        "|{}",
        cols.iter()
            .enumerate()
            .map(|(i, _)| if i == 0 { "---|" } else { "---:|" })
            .collect::<String>()
    );
}

/// A table header with every column left-aligned (text).
fn text_table_header(m: &mut String, cols: &[String]) {
    let _ = writeln!(m, "| {} |", cols.join(" | "));
    let _ = writeln!(m, "|{}", "---|".repeat(cols.len()));
}

fn row(m: &mut String, cells: &[String]) {
    let _ = writeln!(m, "| {} |", cells.join(" | "));
}

// ---------------------------------------------------------------------------------
// Sections.

/// Every section the generator writes, by marker name; plots are linked as
/// `<plot_prefix>/<scene>-walk.png`.
pub fn sections(m: &Merged, plot_prefix: &str) -> BTreeMap<String, String> {
    let ctx = Ctx {
        m,
        plot_prefix,
        used: Default::default(),
    };
    let mut s = BTreeMap::new();
    s.insert("per-cell".to_string(), per_cell(&ctx));
    for param in SweepParam::ALL {
        s.insert(param.section().to_string(), sweep(&ctx, param));
    }
    s.insert("runtime".to_string(), runtime(&ctx));
    s.insert("hybrid-vs-lod".to_string(), hybrid_vs_lod(&ctx));
    s.insert("crossings".to_string(), crossings(&ctx));
    s.insert("storage".to_string(), storage(&ctx));
    s.insert("bake-time".to_string(), bake_time(&ctx));
    s.insert("plots".to_string(), plots(&ctx));
    // Last: it lists the runs the other sections used.
    s.insert("machine".to_string(), machine(&ctx));
    s
}

/// Tables 3–8's per-cell statistics per scene (Table 7's rows; the percentages are
/// Table 3's T_s = 5 column, the paper's only published split).
fn per_cell(ctx: &Ctx) -> String {
    let mut m = String::new();
    let bakes: Vec<_> = scenes().iter().map(|(s, _)| ctx.scene_bake(s)).collect();
    if bakes.iter().all(Option::is_none) {
        return NOT_MEASURED.into();
    }
    let (t3, t7, t8) = (&paper().table3, &paper().table7, &paper().table8);
    let mut cols = vec!["per cell (c 50, T_s 5, T_l 4.5)".to_string()];
    for ((_, paper), b) in scenes().iter().zip(&bakes) {
        cols.push(format!("{paper} paper"));
        cols.push(match b.and_then(|(_, b)| b.report.as_ref()) {
            Some(r) => format!("{paper} ours{}", coverage(r)),
            None => format!("{paper} ours"),
        });
    }
    table_header(&mut m, &cols);
    let rows: [StatRow<[f64; 3]>; 9] = [
        (
            "polygons inside a cell (Table 7)",
            per_scene(&t7.polygons_inside_a_viewcell),
            |r| r.averages().polygons_inside_a_cell,
            int,
        ),
        (
            "SVMesh from clustered objects % (Table 3)",
            [f64::NAN, table3_t5(&t3.sv_clustered_percent), f64::NAN],
            |r| r.averages().sv_clustered_percent,
            |v| fixed(v, 1),
        ),
        (
            "SVMesh from single objects % (Table 3)",
            [f64::NAN, table3_t5(&t3.sv_single_percent), f64::NAN],
            |r| r.averages().sv_single_percent,
            |v| fixed(v, 1),
        ),
        (
            "MVMesh % (Table 3)",
            [f64::NAN, table3_t5(&t3.mv_percent), f64::NAN],
            |r| r.averages().mv_percent,
            |v| fixed(v, 1),
        ),
        (
            "culled objects %",
            [f64::NAN; 3],
            |r| r.averages().culled_percent,
            |v| fixed(v, 1),
        ),
        (
            "polygons of SVMesh & MVMesh (Table 7)",
            per_scene(&t7.polygons_sv_and_mv),
            |r| r.averages().polygons_sv_and_mv,
            int,
        ),
        (
            "polygons for a cell (Table 7)",
            per_scene(&t7.polygons_for_a_viewcell),
            |r| r.averages().polygons_for_a_cell,
            int,
        ),
        (
            "simplified : original (Table 7)",
            per_scene(&t7.simplified_to_original),
            |r| r.averages().simplified_to_original,
            ratio,
        ),
        (
            "texture texels per cell, KB raw RGBA8 (paper: DXT3 KB × 4, Table 8)",
            per_scene(&t8.cell_textures_kb).map(|kb| kb * 4.0),
            |r| r.averages().texture_kb * 1.024,
            int,
        ),
    ];
    for (name, paper, pick, fmt) in rows {
        let mut cells = vec![name.to_string()];
        for (k, b) in bakes.iter().enumerate() {
            cells.push(fmt(paper[k]));
            cells.push(
                b.and_then(|(_, b)| b.report.as_ref())
                    .map_or("–".into(), |r| fmt(pick(r))),
            );
        }
        row(&mut m, &cells);
    }
    let _ = writeln!(
        &mut m,
        "\nOurs: `report.json` of each bake (`pipeline report`), averaged over the baked cells; \
         a scene marked \"N of M cells\" was baked only along `park-walk.ron` (`--cells path:`), \
         whose cells are not a uniform sample of the park."
    );
    m
}

/// Tables 3 / 4 / 5 (and our deviation bound): one sweep over the fixed cell sample.
fn sweep(ctx: &Ctx, param: SweepParam) -> String {
    let mut points: Vec<(f64, &BakeResult)> = ctx
        .m
        .bakes
        .values()
        .map(|(_, b)| b)
        .filter(|b| b.report.is_some())
        .filter_map(|b| {
            let point = b.sweeps.iter().find(|s| s.param == param)?;
            Some((point.value, b))
        })
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (_, b) in &points {
        ctx.bake(&b.label);
    }
    if points.is_empty() {
        return NOT_MEASURED.into();
    }
    // The deviation bound is ours (worker simplify.rs): no paper columns.
    let table = sweep_table(param);
    let table_name = table.map_or("not in the paper", |t| t.table.as_str());
    let symbol = param.symbol();
    let has_paper = table.is_some();
    let paper_col = |v: f64| table.and_then(|t| t.column_of(v));
    // The paper's value of `row` in the column of swept value `v`, formatted.
    let paper_cell = |row: Option<&PaperRow>, v: f64, fmt: fn(f64) -> String| -> String {
        row.zip(paper_col(v))
            .map_or("–".into(), |(r, i)| fmt(r.values[i]))
    };
    // One point's two cells (paper, ours), or only ours.
    let pair = |cells: &mut Vec<String>, paper: String, ours: String| {
        if has_paper {
            cells.push(paper);
        }
        cells.push(ours);
    };
    let mut cols = vec![format!("4M, {symbol} ({table_name})")];
    for (v, b) in &points {
        let cells = b.report.as_ref().map_or(0, |r| r.cells);
        pair(
            &mut cols,
            format!("{symbol} {v} paper"),
            format!("{symbol} {v} ours ({cells} cells)"),
        );
    }
    let mut m = String::new();
    table_header(&mut m, &cols);
    // Statistic rows: name, the paper's row (Table 3 alone has the percentages),
    // our value from a report, formatting.
    type SweepRow = (
        &'static str,
        Option<&'static PaperRow>,
        fn(&Report) -> f64,
        fn(f64) -> String,
    );
    let mut paper_rows: Vec<SweepRow> = Vec::new();
    if let Some(t) = table.filter(|t| t.sv_clustered_percent.is_some()) {
        paper_rows.extend::<[SweepRow; 3]>([
            (
                "SVMesh from clustered objects %",
                t.sv_clustered_percent.as_ref(),
                |r| r.averages().sv_clustered_percent,
                |v| fixed(v, 1),
            ),
            (
                "SVMesh from single objects %",
                t.sv_single_percent.as_ref(),
                |r| r.averages().sv_single_percent,
                |v| fixed(v, 1),
            ),
            (
                "MVMesh %",
                t.mv_percent.as_ref(),
                |r| r.averages().mv_percent,
                |v| fixed(v, 1),
            ),
        ]);
    }
    paper_rows.extend::<[SweepRow; 4]>([
        (
            "polygons inside a cell",
            table.map(|t| &t.polygons_inside_a_viewcell),
            |r| r.averages().polygons_inside_a_cell,
            int,
        ),
        (
            "polygons of SVMesh & MVMesh",
            table.map(|t| &t.polygons_sv_and_mv),
            |r| r.averages().polygons_sv_and_mv,
            int,
        ),
        (
            "polygons for a cell",
            table.map(|t| &t.polygons_for_a_viewcell),
            |r| r.averages().polygons_for_a_cell,
            int,
        ),
        (
            "simplified : original",
            table.map(|t| &t.simplified_to_original),
            |r| r.averages().simplified_to_original,
            ratio,
        ),
    ]);
    if let Some(viewcells) = table.and_then(|t| t.viewcells.as_ref()) {
        let mut cells = vec!["cells (grid)".to_string()];
        for (v, b) in &points {
            cells.push(
                paper_col(*v)
                    .map(|i| viewcells.values[i].clone())
                    .unwrap_or("–".into()),
            );
            cells.push(
                b.report
                    .as_ref()
                    .map_or("–".into(), |r| int(r.grid_cells as f64)),
            );
        }
        row(&mut m, &cells);
    }
    for (name, paper, pick, fmt) in paper_rows {
        let mut cells = vec![name.to_string()];
        for (v, b) in &points {
            pair(
                &mut cells,
                paper_cell(paper, *v, fmt),
                b.report.as_ref().map_or("–".into(), |r| fmt(pick(r))),
            );
        }
        row(&mut m, &cells);
    }
    // The other Tables 3–5 rows where we have a counterpart.
    let mut cells = vec!["culled objects %".to_string()];
    for (_, b) in &points {
        pair(
            &mut cells,
            "–".into(),
            b.report
                .as_ref()
                .map_or("–".into(), |r| fixed(r.averages().culled_percent, 1)),
        );
    }
    row(&mut m, &cells);
    // Performance rows: `player compare` over `worker check`'s viewpoints in the
    // sampled cells (bench.sh labels the compare like the bake).
    let summaries: Vec<Option<&CompareReport>> = points
        .iter()
        .map(|(_, b)| {
            ctx.compare(&b.label)
                .filter(|c| c.available)
                .and_then(|c| c.summary.as_ref())
        })
        .collect();
    let mut views = 0;
    if summaries.iter().any(Option::is_some) {
        type PerfRow<'r> = (
            &'r str,
            Option<&'r PaperRow>,
            fn(&CompareReport) -> f64,
            fn(f64) -> String,
        );
        let perf_rows: [PerfRow; 5] = [
            (
                "PSNR(Y) pooled over the views, dB",
                table.map(|t| &t.psnr_db),
                pooled_psnr_y,
                |v| fixed(v, 2),
            ),
            ("PSNR(Y) min, dB", None, |c| c.min_psnr_y, |v| fixed(v, 2)),
            ("SSIM mean", None, |c| c.mean_ssim, |v| fixed(v, 4)),
            (
                "FPS (ours: lavapipe, hybrid draw)",
                table.map(|t| &t.fps),
                |c| 1e3 / c.mean_ms(|f| f.frame_ms),
                |v| fixed(v, 1),
            ),
            (
                "triangles per frame (in frustum)",
                table.map(|t| &t.polygons_in_frustum),
                |c| c.mean_triangles,
                int,
            ),
        ];
        for (name, paper, pick, fmt) in perf_rows {
            let mut cells = vec![name.to_string()];
            for ((v, _), summary) in points.iter().zip(&summaries) {
                pair(
                    &mut cells,
                    paper_cell(paper, *v, fmt),
                    summary.map_or("–".into(), |c| fmt(pick(c))),
                );
            }
            row(&mut m, &cells);
        }
        views = summaries
            .iter()
            .flatten()
            .map(|c| c.frames)
            .max()
            .unwrap_or(0);
    }
    let sample: BTreeSet<String> = points.iter().filter_map(|(_, b)| b.cells.clone()).collect();
    let scenes: BTreeSet<&str> = points.iter().map(|(_, b)| b.scene.as_str()).collect();
    let _ = writeln!(
        &mut m,
        "\n{}Ours: averages over the cells \
         baked with `--cells {}` on `{}` (one job per cell), i.e. a fixed sample of \
         centre, edge and corner cells, not the whole grid.",
        if has_paper {
            "Paper: averages over all cells of the 4M scene. "
        } else {
            ""
        },
        sample.into_iter().collect::<Vec<_>>().join("` / `"),
        scenes.into_iter().collect::<Vec<_>>().join("`, `")
    );
    if views > 0 {
        let _ = writeln!(
            &mut m,
            "\nThe paper's FPS and PSNR are means along its walk; ours are over {views} \
             views, `worker check`'s viewpoints in the sampled cells (16 per cell in \
             bench.sh, `hexbake-bench views`), from `player compare --no-crossings` with every texture \
             uploaded before its frame (no pending proxies). PSNR is pooled (the mean \
             squared error over all views, then PSNR): views of edge and corner cells \
             that look off the park show only sky, score the 100 dB cap and would \
             inflate a per-view mean. FPS is the hybrid draw on lavapipe, comparable \
             between columns only."
        );
    } else {
        let _ = writeln!(
            &mut m,
            "\nThe paper's FPS and PSNR rows: not measured in these runs (bench.sh measures \
             them with `player compare` over the sampled cells' check viewpoints)."
        );
    }
    m
}

/// PSNR(Y) of the mean squared error over every frame of a compare (frames at the
/// player's 100 dB cap count as error-free).
pub fn pooled_psnr_y(c: &CompareReport) -> f64 {
    let mse = crate::results::mean(
        c.per_frame
            .iter()
            .map(|f| 255.0 * 255.0 / 10f64.powf(f.psnr_y / 10.0)),
    );
    worker::check::psnr_of_mse(mse)
}

/// Tables 6–7: the player along the path.
fn runtime(ctx: &Ctx) -> String {
    let mut m = String::new();
    // 1. The hybrid compare run of each scene (none measured: say so).
    let compares: Vec<_> = scenes()
        .iter()
        .map(|(s, _)| ctx.hybrid_compare(s).filter(|c| c.available))
        .collect();
    if compares.iter().all(Option::is_none) {
        return NOT_MEASURED.into();
    }
    // 2. The header: the walks measured and the paper's columns.
    let paths: BTreeSet<String> = compares
        .iter()
        .flatten()
        .map(|c| {
            Path::new(&c.path)
                .file_name()
                .map_or(c.path.clone(), |n| n.to_string_lossy().into_owned())
        })
        .collect();
    let mut cols = vec![format!(
        "along `{}`",
        paths.into_iter().collect::<Vec<_>>().join("`, `")
    )];
    for ((_, paper), c) in scenes().iter().zip(&compares) {
        cols.push(format!("{paper} paper"));
        cols.push(match c {
            Some(c) => format!(
                "{paper} ours ({} frames, {})",
                c.summary.as_ref().map_or(0, |s| s.frames),
                c.size
            ),
            None => format!("{paper} ours"),
        });
        cols.push("vs paper".to_string());
    }
    table_header(&mut m, &cols);
    // 3. The renders beside each compare, and the paper's tables 6 and 7.
    let frustum: Vec<Option<&RenderResult>> = scenes()
        .iter()
        .map(|(s, _)| {
            ctx.render(&RunLabel::Frustum(s).to_string())
                .filter(|r| r.available)
        })
        .collect();
    let hybrid_render: Vec<Option<&RenderResult>> = scenes()
        .iter()
        .map(|(s, _)| {
            ctx.render(&RunLabel::Hybrid(s).to_string())
                .filter(|r| r.available)
        })
        .collect();
    let (t6, t7) = (&paper().table6, &paper().table7);
    let paper_a = |k: usize| {
        if k == 2 {
            t6.polygons.values[0]
        } else {
            paper().scene_polygons.total.values[k]
        }
    };
    // 4. One row per measure: ours per scene beside the paper's.
    let mut add = |name: &str,
                   paper: [f64; 3],
                   ours: [f64; 3],
                   fmt: fn(f64) -> String,
                   v: &dyn Fn(f64, f64) -> String| {
        let mut cells = vec![name.to_string()];
        for k in 0..3 {
            cells.push(fmt(paper[k]));
            cells.push(fmt(ours[k]));
            cells.push(v(ours[k], paper[k]));
        }
        row(&mut m, &cells);
    };
    let s = |k: usize| compares[k].and_then(|c| c.summary.as_ref());
    let per = |f: &dyn Fn(usize) -> f64| [f(0), f(1), f(2)];
    let nan = f64::NAN;
    add(
        "triangles per frame, C hybrid (Tables 6–7)",
        per_scene(&t7.polygons_in_frustum),
        per(&|k| s(k).map_or(nan, |s| s.mean_triangles)),
        int,
        &|o, p| verdict(o, p),
    );
    add(
        "triangles per frame, B frustum (Table 6)",
        [nan, nan, t6.polygons.values[1]],
        per(&|k| frustum[k].map_or(nan, |r| r.mean_triangles())),
        int,
        &|_, _| String::new(),
    );
    add(
        "triangles per frame, A full (Table 6; 2M/4M: scene)",
        per(&paper_a),
        per(&|k| s(k).map_or(nan, |s| s.reference_triangles)),
        int,
        &|_, _| String::new(),
    );
    add(
        "PSNR(Y) mean, dB (Table 7)",
        per_scene(&t7.psnr_db),
        per(&|k| s(k).map_or(nan, |s| s.mean_psnr_y)),
        |v| fixed(v, 2),
        &verdict_db,
    );
    add(
        "PSNR(Y) min, dB",
        [nan; 3],
        per(&|k| s(k).map_or(nan, |s| s.min_psnr_y)),
        |v| fixed(v, 2),
        &|_, _| String::new(),
    );
    add(
        "SSIM(Y) mean",
        [nan; 3],
        per(&|k| s(k).map_or(nan, |s| s.mean_ssim)),
        |v| fixed(v, 4),
        &|_, _| String::new(),
    );
    add(
        "SSIM(Y) min",
        [nan; 3],
        per(&|k| s(k).map_or(nan, |s| s.min_ssim())),
        |v| fixed(v, 4),
        &|_, _| String::new(),
    );
    add(
        "frame time C / B frustum (Table 6)",
        [
            nan,
            nan,
            t6.frame_time_ms.values[2] / t6.frame_time_ms.values[1],
        ],
        per(&|k| s(k).map_or(nan, |s| s.frame_time_ratio_frustum)),
        |v| fixed(v, 4),
        &|o, p| verdict(o, p),
    );
    add(
        "frame time C / A full (Table 6)",
        [
            nan,
            nan,
            t6.frame_time_ms.values[2] / t6.frame_time_ms.values[0],
        ],
        per(&|k| s(k).map_or(nan, |s| s.frame_time_ratio)),
        |v| fixed(v, 4),
        &|o, p| verdict(o, p),
    );
    add(
        "C frame time, ms (mean)",
        [nan, nan, t6.frame_time_ms.values[2]],
        per(&|k| s(k).map_or(nan, |s| s.mean_ms(|f| f.frame_ms))),
        |v| fixed(v, 2),
        &|_, _| String::new(),
    );
    add(
        "C frames per second (Table 7)",
        per_scene(&t7.fps),
        per(&|k| s(k).map_or(nan, |s| 1e3 / s.mean_ms(|f| f.frame_ms))),
        |v| fixed(v, 1),
        &|_, _| String::new(),
    );
    add(
        "C with streaming (`player render`), ms (mean)",
        [nan; 3],
        per(&|k| hybrid_render[k].map_or(nan, |r| r.mean_frame_ms())),
        |v| fixed(v, 2),
        &|_, _| String::new(),
    );
    // 5. The adapters the times were taken on.
    let adapters: BTreeSet<String> = compares
        .iter()
        .flatten()
        .filter_map(|c| c.summary.as_ref().map(|s| s.adapter.clone()))
        .filter(|a| !a.is_empty())
        .collect();
    let _ = writeln!(
        &mut m,
        "\nPaper: GeForce4 Ti 4400, 1024². Ours: `player compare` (C vs A, PSNR/SSIM on Y) and \
         `player render --mode frustum|hybrid` on {}. Frame times on a software rasterizer are \
         not the paper's GPU frame times; the ratios are the comparable part. Our polygon \
         counts are whole-frame triangles after per-instance/per-proxy frustum culling; the \
         paper's are polygons inside the view frustum.",
        if adapters.is_empty() {
            "the adapter the player reported".to_string()
        } else {
            adapters.into_iter().collect::<Vec<_>>().join(", ")
        }
    );
    m
}

/// Linear interpolation of y at `x0` on the first segment of `points` (sorted by x)
/// that brackets it; None outside the measured range.
pub fn interpolate(points: &[(f64, f64)], x0: f64) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((xa, ya), (xb, yb)) = (w[0], w[1]);
        if xa <= x0 && x0 <= xb {
            Some(if xb > xa {
                ya + (yb - ya) * (x0 - xa) / (xb - xa)
            } else {
                ya
            })
        } else {
            None
        }
    })
}

/// Hybrid (the bake) against the distance-LOD baseline (`player compare --mode
/// lod`, one row per `--lod-pixel-error`), and the comparison at equal triangles
/// (lod PSNR interpolated at the hybrid's triangle count, on log triangles) and at
/// equal PSNR (lod triangles interpolated at the hybrid's PSNR).
fn hybrid_vs_lod(ctx: &Ctx) -> String {
    let mut m = String::new();
    let mut any = false;
    table_header(
        &mut m,
        &[
            "scene".into(),
            "mode".into(),
            "triangles per frame".into(),
            "PSNR(Y) mean / min".into(),
            "SSIM mean / min".into(),
            "frame time / full".into(),
        ],
    );
    let mut notes = Vec::new();
    for (scene, paper) in scenes() {
        let h = ctx.hybrid_compare(scene);
        let lods: Vec<&CompareResult> = ctx
            .m
            .compares
            .keys()
            .filter(|k| RunLabel::lod_of(k).is_some_and(|(s, _)| s == scene))
            .filter_map(|k| ctx.compare(k))
            .collect();
        if h.is_none() && lods.is_empty() {
            continue;
        }
        any = true;
        let mut entries: Vec<(String, Option<&CompareResult>)> = vec![("hybrid".into(), h)];
        if lods.is_empty() {
            entries.push(("lod".into(), None));
        }
        for l in &lods {
            // The player's threshold (an f32) as it wrote it, else bench.sh's.
            let err = l
                .summary
                .as_ref()
                .and_then(|s| s.lod_pixel_error)
                .map(|e| e.to_string())
                .or(l.lod_pixel_error.map(|e| e.to_string()));
            let name = match err {
                Some(e) => format!("lod, {e} px"),
                None => "lod".into(),
            };
            entries.push((name, Some(l)));
        }
        let mut hybrid_point = None;
        let mut lod_points = Vec::new();
        for (mode, c) in entries {
            match c.and_then(|c| c.summary.as_ref().filter(|_| c.available)) {
                Some(s) => {
                    if mode == "hybrid" {
                        hybrid_point = Some((s.mean_triangles, s.mean_psnr_y));
                    } else {
                        lod_points.push((s.mean_triangles, s.mean_psnr_y));
                    }
                    row(
                        &mut m,
                        &[
                            format!("{scene} ({paper})"),
                            mode,
                            int(s.mean_triangles),
                            format!("{} / {}", fixed(s.mean_psnr_y, 2), fixed(s.min_psnr_y, 2)),
                            format!("{} / {}", fixed(s.mean_ssim, 4), fixed(s.min_ssim(), 4)),
                            fixed(s.frame_time_ratio, 3),
                        ],
                    )
                }
                None => {
                    let why = c
                        .and_then(|c| c.message.clone())
                        .unwrap_or("not run".into())
                        .replace('|', "\\|");
                    let text = if why.starts_with(&format!("{mode}: not available")) {
                        why
                    } else {
                        format!("{mode}: not available ({why})")
                    };
                    row(
                        &mut m,
                        &[
                            format!("{scene} ({paper})"),
                            mode.clone(),
                            text,
                            String::new(),
                            String::new(),
                            String::new(),
                        ],
                    )
                }
            }
        }
        let Some((ht, hp)) = hybrid_point else {
            continue;
        };
        if lod_points.is_empty() || ht.is_nan() || ht <= 0.0 {
            continue;
        }
        let mut by_tris: Vec<(f64, f64)> = lod_points
            .iter()
            .filter(|(t, p)| *t > 0.0 && p.is_finite())
            .map(|&(t, p)| (t.ln(), p))
            .collect();
        by_tris.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut by_psnr: Vec<(f64, f64)> = by_tris.iter().map(|&(lt, p)| (p, lt)).collect();
        by_psnr.sort_by(|a, b| a.0.total_cmp(&b.0));
        let at_tris = match interpolate(&by_tris, ht.ln()) {
            Some(p) => format!(
                "at the hybrid's {} triangles lod would score {} dB (hybrid {} dB)",
                int(ht),
                fixed(p, 2),
                fixed(hp, 2)
            ),
            None => format!(
                "the hybrid's {} triangles are outside the lod points measured ({} to {})",
                int(ht),
                int(by_tris.first().map_or(f64::NAN, |p| p.0.exp())),
                int(by_tris.last().map_or(f64::NAN, |p| p.0.exp()))
            ),
        };
        let at_psnr = match interpolate(&by_psnr, hp) {
            Some(lt) => format!(
                "to reach the hybrid's {} dB lod needs {} triangles ({:.2}× the hybrid's)",
                fixed(hp, 2),
                int(lt.exp()),
                lt.exp() / ht
            ),
            None => format!(
                "the hybrid's {} dB is outside the lod points' PSNR range ({} to {} dB)",
                fixed(hp, 2),
                fixed(by_psnr.first().map_or(f64::NAN, |p| p.0), 2),
                fixed(by_psnr.last().map_or(f64::NAN, |p| p.0), 2)
            ),
        };
        notes.push(format!("{scene}: {at_tris}; {at_psnr}."));
    }
    if !any {
        return NOT_MEASURED.into();
    }
    let _ = writeln!(
        &mut m,
        "\nEqual triangles / equal PSNR: interpolated linearly between the two lod points \
         that bracket the hybrid (PSNR against log triangles); with one lod point only the \
         two operating points are shown."
    );
    for n in notes {
        let _ = writeln!(&mut m, "\n{n}");
    }
    m
}

/// Fig. 14: frame time at cell crossings, prefetch on and off.
fn crossings(ctx: &Ctx) -> String {
    let mut m = String::new();
    let mut any = false;
    table_header(
        &mut m,
        &[
            "scene".into(),
            "prefetch".into(),
            "crossings".into(),
            "in-cell median ms".into(),
            "max in the 10 frames after a crossing, ms".into(),
            "ratio".into(),
        ],
    );
    for (scene, paper) in scenes() {
        let Some(s) = ctx
            .hybrid_compare(scene)
            .filter(|c| c.available)
            .and_then(|c| c.summary.as_ref())
        else {
            continue;
        };
        for (name, c) in [
            ("on", &s.crossing_prefetch),
            ("off", &s.crossing_no_prefetch),
        ] {
            if let Some(c) = c {
                any = true;
                row(
                    &mut m,
                    &[
                        format!("{scene} ({paper})"),
                        name.into(),
                        c.crossings.to_string(),
                        fixed(c.in_cell_median_ms, 2),
                        fixed(c.max_after_crossing_ms, 2),
                        fixed(c.ratio, 2),
                    ],
                );
            }
        }
    }
    if !any {
        return NOT_MEASURED.into();
    }
    let _ = writeln!(
        &mut m,
        "\nPaper (Fig. 14, 8M): the frame rate with prefetching is \"quite stable except some \
         sudden decreases\" (at cells containing objects); no number is published."
    );
    m
}

/// Table 8: storage and cell load time.
fn storage(ctx: &Ctx) -> String {
    let mut m = String::new();
    let bakes: Vec<_> = scenes().iter().map(|(s, _)| ctx.scene_bake(s)).collect();
    if bakes.iter().all(Option::is_none) {
        return NOT_MEASURED.into();
    }
    let t8 = &paper().table8;
    let mut cols = vec!["storage (Table 8)".to_string()];
    for ((_, paper), b) in scenes().iter().zip(&bakes) {
        cols.push(format!("{paper} paper"));
        cols.push(match b.and_then(|(_, b)| b.report.as_ref()) {
            Some(r) => format!("{paper} ours{}", coverage(r)),
            None => format!("{paper} ours"),
        });
        cols.push("vs paper".into());
    }
    table_header(&mut m, &cols);
    let reports: Vec<Option<&Report>> = bakes
        .iter()
        .map(|b| b.and_then(|(_, b)| b.report.as_ref()))
        .collect();
    // Totals of a partial bake are extrapolated from its per-cell average.
    let scale = |r: &Report| {
        if r.cells > 0 && r.grid_cells > r.cells {
            r.grid_cells as f64 / r.cells as f64
        } else {
            1.0
        }
    };
    let loads: Vec<Option<&LoadTime>> = scenes()
        .iter()
        .zip(&bakes)
        .map(|((s, _), b)| {
            ctx.load(s)
                .or_else(|| b.and_then(|(_, b)| ctx.load(&b.label)))
        })
        .collect();
    type Pick<'x> = &'x dyn Fn(&Report) -> f64;
    let mut add = |name: &str, paper: [f64; 3], pick: Pick, fmt: fn(f64) -> String| {
        let mut cells = vec![name.to_string()];
        for k in 0..3 {
            let ours = reports[k].map_or(f64::NAN, pick);
            cells.push(fmt(paper[k]));
            cells.push(fmt(ours));
            cells.push(verdict(ours, paper[k]));
        }
        row(&mut m, &cells);
    };
    let f1 = |v: f64| fixed(v, 1);
    add(
        "SVMesh & MVMesh (cell meshes, tables), MB",
        per_scene(&t8.sv_mv_mb),
        &|r| mb(r.storage.mesh_bytes as f64 * scale(r)),
        f1,
    );
    add(
        "textures, MB",
        per_scene(&t8.textures_mb),
        &|r| mb(r.storage.texture_bytes as f64 * scale(r)),
        f1,
    );
    add(
        "total (cells + index), MB",
        per_scene(&t8.total_mb),
        &|r| mb((r.storage.cell_bytes as f64 * scale(r)) + r.storage.index_bytes as f64),
        f1,
    );
    add(
        "original meshes (base.pack), MB",
        per_scene(&t8.original_meshes_mb),
        &|r| mb(r.storage.base_bytes as f64),
        f1,
    );
    add(
        "per cell: meshes, KB",
        per_scene(&t8.cell_polygons_kb),
        &|r| kb(r.storage.mesh_bytes as f64 / r.cells.max(1) as f64),
        f1,
    );
    add(
        "per cell: textures, KB",
        per_scene(&t8.cell_textures_kb),
        &|r| kb(r.storage.texture_bytes as f64 / r.cells.max(1) as f64),
        f1,
    );
    add(
        "per cell: total, KB",
        per_scene(&t8.cell_total_kb),
        &|r| kb(r.storage.per_cell_bytes),
        f1,
    );
    add(
        "cell load at 55 MB/s (size ÷ speed), ms",
        per_scene(&t8.load_ms_55),
        &|r| r.storage.per_cell_bytes / 55e6 * 1e3,
        f1,
    );
    add(
        "cell load at 35 MB/s (size ÷ speed), ms",
        per_scene(&t8.load_ms_35),
        &|r| r.storage.per_cell_bytes / 35e6 * 1e3,
        f1,
    );
    let mut cells =
        vec!["measured: open + validate + decode, warm cache, ms (mean / max)".to_string()];
    for l in &loads {
        cells.push("–".into());
        cells.push(l.map_or("–".into(), |l| {
            format!("{} / {}", fixed(l.mean_ms, 1), fixed(l.max_ms, 1))
        }));
        cells.push(String::new());
    }
    row(&mut m, &cells);
    let _ = writeln!(
        &mut m,
        "\nPaper: DXT3 textures (1:4). Ours: lossless RGBA8 in zstd (format/README.md); \
         \"meshes\" is every non-texture byte of the cell packs. Totals of a partial bake \
         (\"N of M cells\") are its per-cell average × M. The measured load time is CPU \
         (mmap, blake3 of every section, zstd, decode) on this machine, from `hexbake-bench \
         load`; the paper's is disk time at the given speed."
    );
    m
}

/// Bake time by stage (the paper publishes none).
fn bake_time(ctx: &Ctx) -> String {
    let mut m = String::new();
    let bakes: Vec<&BakeResult> = ctx
        .m
        .bakes
        .values()
        .map(|(_, b)| b)
        .filter(|b| b.report.is_some())
        .collect();
    if bakes.is_empty() {
        return NOT_MEASURED.into();
    }
    let stages: BTreeSet<String> = bakes
        .iter()
        .filter_map(|b| b.report.as_ref())
        .flat_map(|r| r.stage_s.keys().cloned())
        .collect();
    let mut cols: Vec<String> = [
        "bake",
        "settings",
        "cells",
        "job wall s",
        "job CPU s",
        "CPU s per cell",
    ]
    .map(String::from)
    .to_vec();
    cols.extend(stages.iter().map(|s| format!("{s} s")));
    table_header(&mut m, &cols);
    for b in bakes {
        ctx.bake(&b.label);
        let r = b.report.as_ref().expect("filtered");
        // No per-job CPU (jobs shared a process) prints as –.
        let cpu = r.job_cpu_s.unwrap_or(f64::NAN);
        let mut settings = b.set.clone();
        if let Some(c) = &b.cells {
            settings.push(format!("--cells {c}"));
        }
        let mut cells = vec![
            b.label.clone(),
            if settings.is_empty() {
                "manifest".into()
            } else {
                format!("`{}`", settings.join(" "))
            },
            format!("{}{}", r.cells, coverage(r)),
            fixed(r.job_wall_s, 1),
            fixed(cpu, 1),
            fixed(cpu / r.cells.max(1) as f64, 2),
        ];
        let total: f64 = r.stage_s.values().sum();
        for s in &stages {
            let v = r.stage_s.get(s).copied().unwrap_or(f64::NAN);
            cells.push(if total > 0.0 && v.is_finite() {
                format!("{} ({:.0}%)", fixed(v, 1), 100.0 * v / total)
            } else {
                fixed(v, 1)
            });
        }
        row(&mut m, &cells);
    }
    let _ = writeln!(
        &mut m,
        "\nJob wall and CPU are summed over the jobs' records (a resumed bake keeps the times \
         of the run that baked each job). Job CPU is the process's CPU while the job ran: \
         where jobs baked side by side in one process (local executor, several threads) it \
         is not theirs, and reports now show – there; run files made before hexbake recorded \
         that (all up to 2026-11-21) count each concurrent job's CPU too (about 2× on 2 \
         threads). Stage seconds are summed over cells, one thread per cell. The paper gives no preprocessing times."
    );
    m
}

/// Links to the per-frame plots (written next to the run files).
fn plots(ctx: &Ctx) -> String {
    let mut m = String::new();
    for (scene, paper) in scenes() {
        if ctx
            .hybrid_compare(scene)
            .is_some_and(|c| c.available && c.summary.is_some())
        {
            let _ = writeln!(
                &mut m,
                "![{scene} ({paper}): per-frame PSNR(Y) and triangles along park-walk.ron, cell crossings marked]({}/{})\n",
                ctx.plot_prefix,
                plot_file_name(scene)
            );
        }
    }
    if m.is_empty() {
        return NOT_MEASURED.into();
    }
    m.push_str(
        "Top: PSNR(Y) of each frame against full geometry (hybrid blue, lod orange when \
         measured); bottom: triangles drawn (hybrid blue, full grey, lod orange); yellow \
         lines: cell crossings (the paper's Fig. 14 marks them the same way).",
    );
    m
}

/// File name of a scene's plot in the results folder.
pub fn plot_file_name(scene: &str) -> String {
    format!("{scene}-walk.png")
}

/// The runs used and their exact commands.
fn machine(ctx: &Ctx) -> String {
    let used = ctx.used.borrow().clone();
    if used.is_empty() {
        return NOT_MEASURED.into();
    }
    let mut m = String::new();
    text_table_header(
        &mut m,
        &[
            "run file".into(),
            "mode".into(),
            "date".into(),
            "commit".into(),
            "nproc".into(),
            "CPU".into(),
            "memory".into(),
        ],
    );
    let get = |r: &crate::results::BenchRun, k: &str| {
        r.machine.get(k).cloned().unwrap_or_else(|| "–".into())
    };
    for (file, run) in ctx.m.runs.iter().filter(|(f, _)| used.contains(f)) {
        row(
            &mut m,
            &[
                format!("`docs/bench/{file}`"),
                run.mode.clone(),
                get(run, "date"),
                get(run, "git_commit"),
                get(run, "nproc"),
                get(run, "cpu_model"),
                get(run, "memory"),
            ],
        );
    }
    for (file, run) in ctx.m.runs.iter().filter(|(f, _)| used.contains(f)) {
        let _ = writeln!(
            &mut m,
            "\n<details><summary>Commands of {file} ({} commands, {:.0} s)</summary>\n\n```sh",
            run.commands.len(),
            run.commands
                .iter()
                .map(|c| c.wall_s)
                .filter(|w| w.is_finite())
                .sum::<f64>()
        );
        for c in &run.commands {
            let _ = writeln!(
                &mut m,
                "{}  # {} s, exit {}",
                c.command,
                fixed(c.wall_s, 1),
                c.exit
            );
        }
        let _ = writeln!(&mut m, "```\n\n</details>");
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn secs(names: &[&str]) -> BTreeMap<String, String> {
        names
            .iter()
            .map(|n| (n.to_string(), format!("new {n}")))
            .collect()
    }

    #[test]
    fn text_outside_markers_is_untouched() {
        let doc = "# Title\n\nhand text\n<!-- bench:a begin -->\nold a\n<!-- bench:a end -->\nmiddle ✓\n<!-- bench:b begin --><!-- bench:b end -->\ntail";
        let out = replace_sections(doc, &secs(&["a", "b"])).unwrap();
        assert_eq!(
            out,
            "# Title\n\nhand text\n<!-- bench:a begin -->\nnew a\n<!-- bench:a end -->\nmiddle ✓\n<!-- bench:b begin -->\nnew b\n<!-- bench:b end -->\ntail"
        );
        // Idempotent.
        assert_eq!(replace_sections(&out, &secs(&["a", "b"])).unwrap(), out);
    }

    #[test]
    fn marker_errors_are_clear() {
        let doc = "<!-- bench:a begin -->x<!-- bench:a end -->";
        let e = replace_sections(doc, &secs(&["a", "b"])).unwrap_err();
        assert_eq!(
            e,
            MarkerError::Missing {
                name: "b".into(),
                which: "begin"
            }
        );
        assert!(e.to_string().contains("<!-- bench:b begin -->"), "{e}");
        let e = replace_sections("<!-- bench:a begin -->", &secs(&["a"])).unwrap_err();
        assert!(matches!(e, MarkerError::Missing { which: "end", .. }));
        let e = replace_sections("<!-- bench:a end --><!-- bench:a begin -->", &secs(&["a"]))
            .unwrap_err();
        assert!(matches!(e, MarkerError::OutOfOrder { .. }));
        let e = replace_sections(
            "<!-- bench:a begin --><!-- bench:a begin --><!-- bench:a end -->",
            &secs(&["a"]),
        )
        .unwrap_err();
        assert!(matches!(e, MarkerError::Duplicate { count: 2, .. }));
        let e = replace_sections(
            "<!-- bench:a begin --><!-- bench:a end --><!-- bench:typo begin -->",
            &secs(&["a"]),
        )
        .unwrap_err();
        assert!(matches!(e, MarkerError::Unknown { .. }), "{e}");
    }

    #[test]
    fn numbers_format() {
        assert_eq!(int(2_007_920.4), "2,007,920");
        assert_eq!(int(999.0), "999");
        assert_eq!(int(f64::NAN), "–");
        assert_eq!(ratio(85.04), "1:85.0");
        assert_eq!(verdict(44.0, 30.0), "worse (1.5× higher)");
        assert_eq!(verdict(20.0, 40.0), "better (2.0× lower)");
        assert_eq!(verdict(20.0, f64::NAN), "");
        assert_eq!(verdict(41.0, 40.0), "≈");
        assert_eq!(verdict_db(34.1, 44.92), "worse (-10.8 dB)");
    }

    #[test]
    fn pooled_psnr_averages_squared_errors() {
        use crate::results::CompareFrame;
        let frames = |ps: &[f64]| CompareReport {
            per_frame: ps
                .iter()
                .map(|&psnr_y| CompareFrame {
                    psnr_y,
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        };
        // 30 dB and a sky-only frame at the cap: half the error of 30 dB, +3.01 dB.
        let p = pooled_psnr_y(&frames(&[30.0, 100.0]));
        assert!((p - (30.0 + 10.0 * 2f64.log10())).abs() < 1e-6, "{p}");
        assert!((pooled_psnr_y(&frames(&[40.0, 40.0])) - 40.0).abs() < 1e-9);
    }

    #[test]
    fn interpolation_brackets() {
        let pts = [(0.0, 10.0), (1.0, 20.0), (3.0, 40.0)];
        assert_eq!(interpolate(&pts, 0.5), Some(15.0));
        assert_eq!(interpolate(&pts, 2.0), Some(30.0));
        assert_eq!(interpolate(&pts, 3.5), None);
        assert_eq!(interpolate(&pts[..1], 0.0), None);
    }

    #[test]
    fn empty_results_say_not_measured() {
        let s = sections(&Merged::default(), "docs/bench");
        assert!(s.values().all(|v| v == NOT_MEASURED), "{s:?}");
    }
}

/// The lod run drawn next to the hybrid: the one at the player's default threshold
/// (`<scene>-lod`), else the `<scene>-lod-e*` whose triangle count is closest (in
/// ratio) to the hybrid's.
fn plot_lod<'a>(
    merged: &'a Merged,
    scene: &str,
    hybrid_triangles: f64,
) -> Option<&'a CompareReport> {
    let available = |label: &str| {
        merged
            .compares
            .get(label)
            .filter(|(_, c)| c.available)
            .and_then(|(_, c)| c.summary.as_ref())
    };
    let default = RunLabel::Lod {
        scene,
        pixel_error: None,
    };
    if let Some(s) = available(&default.to_string()) {
        return Some(s);
    }
    merged
        .compares
        .keys()
        .filter(|k| RunLabel::lod_of(k).is_some_and(|(s, e)| s == scene && e.is_some()))
        .filter_map(|k| available(k))
        .filter(|s| s.mean_triangles > 0.0)
        .min_by(|a, b| {
            let d = |s: &CompareReport| (s.mean_triangles / hybrid_triangles.max(1.0)).ln().abs();
            d(a).total_cmp(&d(b))
        })
}

/// What [`regenerate`] wrote.
#[derive(Debug, Default)]
pub struct Regenerated {
    pub runs: usize,
    pub sections: usize,
    pub plots: Vec<std::path::PathBuf>,
}

/// Reads every run file in `results`, draws the per-scene plots into `results`, and
/// rewrites the marked sections of `doc` (plots linked as `plot_prefix/...`).
pub fn regenerate(
    results: &std::path::Path,
    doc: &std::path::Path,
    plot_prefix: &str,
) -> anyhow::Result<Regenerated> {
    use anyhow::Context;
    let runs = crate::results::read_runs(results)?;
    let n_runs = runs.len();
    let merged = crate::results::merge(runs);
    let text =
        std::fs::read_to_string(doc).with_context(|| format!("{}: cannot read", doc.display()))?;
    let secs = sections(&merged, plot_prefix);
    let new = replace_sections(&text, &secs).with_context(|| doc.display().to_string())?;
    let mut plots = Vec::new();
    for (scene, _) in scenes() {
        let Some((_, compare)) = merged
            .compares
            .get(&RunLabel::Hybrid(scene).to_string())
            .filter(|(_, c)| c.available)
        else {
            continue;
        };
        let Some(hybrid) = compare.summary.as_ref() else {
            continue;
        };
        let path_name = Path::new(&compare.path)
            .file_name()
            .map_or(compare.path.clone(), |n| n.to_string_lossy().into_owned());
        let lod = plot_lod(&merged, scene, hybrid.mean_triangles);
        let png =
            crate::plot::render_walk_plot(&format!("{scene} along {path_name}"), hybrid, lod)?;
        let path = results.join(plot_file_name(scene));
        format::pack::write_atomic(&path, &png).with_context(|| path.display().to_string())?;
        plots.push(path);
    }
    if new != text {
        format::pack::write_atomic(doc, new.as_bytes())
            .with_context(|| doc.display().to_string())?;
    }
    Ok(Regenerated {
        runs: n_runs,
        sections: secs.len(),
        plots,
    })
}
