//! The tables of run time, storage and bake time (000 Tables 6–8), and the
//! machine they were measured on.

use super::*;

/// Tables 6–7: the player along the path.
pub(super) fn runtime(ctx: &Ctx) -> String {
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

/// Table 8: storage and cell load time.
pub(super) fn storage(ctx: &Ctx) -> String {
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
pub(super) fn bake_time(ctx: &Ctx) -> String {
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

/// The runs used and their exact commands.
pub(super) fn machine(ctx: &Ctx) -> String {
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
