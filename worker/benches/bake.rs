//! `bake_cell` and `check_cell` on five cells of park-2m (issue 4 item 7): the centre
//! cell, two edge cells and two corner cells. A plain timing printout (harness off):
//! per cell the representation counts, polygons, texture bytes, time per stage and
//! the mean PSNR-Y over 16 views at 1024²; the worst view of each cell is written as
//! PNG (reference | hybrid | difference) to the temp dir.
//!
//! `cargo bench -p worker --bench bake` (models from `HEXBAKE_MODELS` or
//! `<repo>/models`; skipped through `testkit::skip` when absent). `HEXBAKE_BENCH_CELLS=a,b,...`
//! picks other cells, `HEXBAKE_BENCH_VIEWS` / `HEXBAKE_BENCH_RES` the check size,
//! `HEXBAKE_BENCH_TL` another edge-length tolerance T_l than the manifest's 4.5;
//! `HEXBAKE_BENCH_CHAINS=1` bakes as `pipeline run` does, every collapse starting
//! from the models' LOD chains (built here once, their time printed), instead of the
//! paper's full meshes.

use format::manifest::parse_manifest;
use std::path::PathBuf;
use std::time::Instant;
use worker::check::check_cell;
use worker::grid::HexGrid;
use worker::groups::bake_cell_hybrid;
use worker::lod_chain::LodChains;

fn main() {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    if testkit::model("bunny.obj").is_none() {
        return;
    }
    let mut plan = parse_manifest(&repo.join("manifests/park-2m.ron")).expect("manifest");
    if let Some(t) = std::env::var("HEXBAKE_BENCH_TL")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        plan.bake.edge_length_tolerance_px = t;
    }
    eprintln!("T_l = {}", plan.bake.edge_length_tolerance_px);
    let t = Instant::now();
    let scene = scene::build_scene(&plan).expect("scene");
    eprintln!(
        "park-2m: {} instances, {} triangles, loaded in {:.1} s, {} threads",
        scene.instances.len(),
        scene.triangle_count(),
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    let grid = HexGrid::new(plan.ground, plan.cells.cell_size);
    let groups = worker::far_field::CellGroups::new(&grid);
    let chains = if std::env::var("HEXBAKE_BENCH_CHAINS").is_ok_and(|v| v == "1") {
        let t = Instant::now();
        let (chains, _) = LodChains::prepare(&scene, None).expect("chains");
        eprintln!(
            "LOD chains of {} models built in {:.1} s",
            scene.models.len(),
            t.elapsed().as_secs_f64()
        );
        chains
    } else {
        LodChains::none()
    };
    let (n, m) = (grid.n_cols() as i64, grid.n_rows() as i64);
    let cells: Vec<(String, u32)> = match std::env::var("HEXBAKE_BENCH_CELLS") {
        Ok(list) => list
            .split(',')
            .filter_map(|s| s.trim().parse().ok())
            .map(|c| (format!("cell {c}"), c))
            .collect(),
        Err(_) => vec![
            ("centre".to_string(), grid.id(n / 2, m / 2).unwrap()),
            ("edge x-min".to_string(), grid.id(0, m / 2).unwrap()),
            ("edge z-max".to_string(), grid.id(n / 2, m - 1).unwrap()),
            ("corner min".to_string(), grid.id(0, 0).unwrap()),
            ("corner max".to_string(), grid.id(n - 1, m - 1).unwrap()),
        ],
    };
    let views: usize = std::env::var("HEXBAKE_BENCH_VIEWS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(16);
    let res: u32 = std::env::var("HEXBAKE_BENCH_RES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1024);
    println!(
        "| cell | id | orig (tris) | SV (tris) | clusters/members (tris) | MV (tris) | culled | ratio | texture MB | split | cluster | capture | weights | simplify | total ms | check s | mean PSNR-Y | pooled PSNR-Y | empty views | worst |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut means = Vec::new();
    for (name, cell) in cells {
        // The cell's proxies and its group's far field, as the player draws them.
        let bake = bake_cell_hybrid(
            &scene,
            &chains,
            &grid,
            &groups,
            cell,
            &plan.cells,
            &plan.bake,
        )
        .expect("bake");
        let s = &bake.stats;
        let t = Instant::now();
        let report = check_cell(
            &scene,
            &grid,
            cell,
            &plan.cells,
            &plan.bake,
            &bake,
            views,
            res,
        )
        .expect("check");
        let check_s = t.elapsed().as_secs_f64();
        let tm = &s.times;
        println!(
            "| {name} | {cell} | {} ({}) | {} ({}) | {}/{} ({}) | {} ({}) | {} | {:.4} | {:.1} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.1} | {:.2} | {:.2} | {} | {:.2} |",
            s.originals,
            s.polygons_inside,
            s.sv_count,
            s.sv_polygons,
            s.cluster_count,
            s.cluster_members,
            s.cluster_polygons,
            s.mv_count,
            s.mv_polygons,
            s.culled,
            s.simplified_ratio,
            s.texture_bytes as f64 / 1e6,
            tm.split_ms,
            tm.cluster_ms,
            tm.capture_ms,
            tm.weights_ms,
            tm.simplify_ms,
            tm.total_ms,
            check_s,
            report.mean,
            report.pooled_psnr_y,
            report.empty_views,
            report.per_view_psnr_y[report.worst_view],
        );
        eprintln!("  {name}: PSNR-Y per view {:.1?}", report.per_view_psnr_y);
        let w = &report.worst;
        let width = w.width as usize;
        let mut out = vec![[0u8; 4]; 3 * width * w.height as usize];
        for y in 0..w.height as usize {
            for (k, img) in [&w.reference, &w.proxy, &w.diff].into_iter().enumerate() {
                out[y * 3 * width + k * width..y * 3 * width + (k + 1) * width]
                    .copy_from_slice(&img[y * width..(y + 1) * width]);
            }
        }
        let path = std::env::temp_dir().join(format!("hexbake-check-park-2m-cell{cell}.png"));
        worker::picture::write_rgba(&path, 3 * w.width, w.height, &out).expect("png");
        eprintln!("  wrote {}", path.display());
        means.push(report.mean);
    }
    println!(
        "mean over cells: {:.2} dB",
        means.iter().sum::<f64>() / means.len().max(1) as f64
    );
}
