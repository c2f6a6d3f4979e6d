//! BENCHMARKS.md's measured tables, regenerated from `docs/bench/*.json`
//! ([`crate::results`]) side by side with the paper's published numbers
//! (000 §4: Tables 2–8 and Fig. 14, from `bench/data/paper-tables.ron` with their
//! table and row, [`crate::paper`]).
//!
//! Each table lives between `<!-- bench:NAME begin -->` and `<!-- bench:NAME end -->`
//! in the document; [`replace_sections`] rewrites only what is between the markers,
//! so the hand-written text around them (explanations, "why we are worse") stays.

mod cost;
mod quality;

use cost::*;
use quality::*;

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
