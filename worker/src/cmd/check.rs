//! `worker check`: bake one cell and measure its proxies against the original geometry (PSNR(Y) per view, the worst view's pictures).

use std::path::PathBuf;
use worker::cli::{bad_input, failed, Failure};

#[derive(clap::Args)]
pub struct Args {
    pub manifest: PathBuf,
    #[arg(long)]
    pub cell: u32,
    #[arg(long, default_value_t = 16)]
    pub views: usize,
    /// Square image side of each view (60° FOV).
    #[arg(long, default_value_t = 1024)]
    pub res: u32,
    /// Where the worst view's PNGs go (default: no pictures).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Override T_l (edge-length tolerance, pixels) of the manifest
    /// (`--set bake.edge_length_tolerance_px=V`: validated as in the manifest).
    #[arg(long)]
    pub edge_length_tolerance_px: Option<f32>,
    /// Override the deviation bound (pixels; 0 = the paper's algorithm as written).
    #[arg(long)]
    pub max_deviation_px: Option<f32>,
    /// Start every collapse from the full meshes instead of the models' LOD chains
    /// (the paper as written; for comparing the two).
    #[arg(long)]
    pub no_lod_chain: bool,
    /// Give the cell its own proxy of every outside object instead of sharing
    /// the far field of its 7-cell group (`bake.far_field: false`).
    #[arg(long)]
    pub no_far_field: bool,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<(), Failure> {
    let Args {
        manifest,
        cell,
        views,
        res,
        out,
        edge_length_tolerance_px,
        max_deviation_px,
        no_lod_chain,
        no_far_field,
        json,
    } = args;
    // The overrides go through the manifest's one validator, like `--set`.
    let overrides = [
        edge_length_tolerance_px.map(|t| ("bake.edge_length_tolerance_px", t.to_string())),
        max_deviation_px.map(|d| ("bake.max_deviation_px", d.to_string())),
        no_far_field.then(|| ("bake.far_field", "false".to_string())),
    ]
    .into_iter()
    .flatten()
    .map(|(key, value)| format::manifest::parse_override(&format!("{key}={value}")))
    .collect::<Result<Vec<_>, _>>()
    .map_err(bad_input)?;
    let plan = format::manifest::parse_manifest_with(&manifest, &overrides).map_err(bad_input)?;
    let scene = scene::build_scene(&plan).map_err(bad_input)?;
    let grid = worker::grid::HexGrid::new(scene.ground, plan.cells.cell_size);
    let groups = worker::far_field::CellGroups::for_params(&grid, &plan.bake);
    // The chains of the manifest's output, as the bake uses them.
    let chains = if no_lod_chain {
        worker::lod_chain::LodChains::none()
    } else {
        let t = std::time::Instant::now();
        let (chains, stats) = worker::lod_chain::LodChains::prepare(
            &scene,
            Some(&worker::job::lod_dir(&plan.output)),
        )
        .map_err(failed)?;
        eprintln!(
            "lod chains: {} built ({} of them refused from the cache), {} loaded in {:.1} s",
            stats.built,
            stats.refused,
            stats.loaded,
            t.elapsed().as_secs_f64()
        );
        chains
    };
    let t = std::time::Instant::now();
    // The cell's proxies and its group's far field, as the player draws them.
    let bake = worker::groups::bake_cell_hybrid(
        &scene,
        &chains,
        &grid,
        &groups,
        cell,
        &plan.cells,
        &plan.bake,
    )
    .map_err(bad_input)?;
    let s = &bake.stats;
    eprintln!(
        "bake of cell {cell}: {:.2} s wall ({:.0} ms capture, {:.0} ms weights, {:.0} ms simplify, summed over proxies)",
        t.elapsed().as_secs_f64(),
        s.times.capture_ms,
        s.times.weights_ms,
        s.times.simplify_ms
    );
    let r = worker::check::check_cell(
        &scene,
        &grid,
        cell,
        &plan.cells,
        &plan.bake,
        &bake,
        views,
        res,
    )
    .map_err(failed)?;
    if let Some(dir) = &out {
        std::fs::create_dir_all(dir).map_err(failed)?;
        let w = &r.worst;
        for (name, px) in [
            ("reference", &w.reference),
            ("proxy", &w.proxy),
            ("diff", &w.diff),
        ] {
            let path = dir.join(format!("cell{cell}-view{}-{name}.png", w.view));
            worker::picture::write_rgba(&path, w.width, w.height, px).map_err(failed)?;
        }
    }
    let s = &bake.stats;
    if json {
        let v = serde_json::json!({
            "cell": cell,
            "per_view_psnr_y": r.per_view_psnr_y,
            "mean_psnr_y": r.mean,
            "pooled_psnr_y": r.pooled_psnr_y,
            "empty_views": r.empty_views,
            "worst_view": r.worst_view,
            "originals": s.originals, "sv": s.sv_count, "mv": s.mv_count,
            "clusters": s.cluster_count, "culled": s.culled,
            "proxy_triangles": s.sv_polygons + s.mv_polygons + s.cluster_polygons,
            "proxied_original_triangles": s.proxied_original_polygons,
        });
        println!("{}", serde_json::to_string_pretty(&v).expect("serializes"));
    } else {
        println!(
            "cell {cell}: {} originals, {} SV, {} MV, {} clusters, {} culled; proxies {} of {} triangles",
            s.originals, s.sv_count, s.mv_count, s.cluster_count, s.culled,
            s.sv_polygons + s.mv_polygons + s.cluster_polygons, s.proxied_original_polygons
        );
        for (i, p) in r.per_view_psnr_y.iter().enumerate() {
            println!("view {i:2}: PSNR(Y) {p:6.2} dB");
        }
        println!(
            "mean {:.2} dB, pooled {:.2} dB ({} views show only sky), worst view {}",
            r.mean, r.pooled_psnr_y, r.empty_views, r.worst_view
        );
    }
    Ok(())
}
