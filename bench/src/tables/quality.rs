//! The tables of image quality and what it costs in triangles: per-cell figures,
//! the parameter sweeps (000 Tables 3–5), hybrid against the LOD baseline (Fig. 14)
//! and the crossing pops.

use super::*;

/// Tables 3–8's per-cell statistics per scene (Table 7's rows; the percentages are
/// Table 3's T_s = 5 column, the paper's only published split).
pub(super) fn per_cell(ctx: &Ctx) -> String {
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
pub(super) fn sweep(ctx: &Ctx, param: SweepParam) -> String {
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

/// Hybrid (the bake) against the distance-LOD baseline (`player compare --mode
/// lod`, one row per `--lod-pixel-error`), and the comparison at equal triangles
/// (lod PSNR interpolated at the hybrid's triangle count, on log triangles) and at
/// equal PSNR (lod triangles interpolated at the hybrid's PSNR).
pub(super) fn hybrid_vs_lod(ctx: &Ctx) -> String {
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
pub(super) fn crossings(ctx: &Ctx) -> String {
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
