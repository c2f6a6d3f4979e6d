//! `player compare --modes` (issue 30 item 3, "one table, one run"): one walk
//! renders one reference and a row per mode and sweep value; the triangles each LOD
//! mode needs to reach the hybrid's object PSNR are interpolated right; the CLI
//! refuses unknown modes, repeated modes and sweeps without their mode.

mod common;
use clap::Parser;
use common::demo_walk;
use player::cmd::compare::{multi_compare, runs_of};
use player::cmd::CompareArgs;
use player::compare::{compare, CompareOptions, CompareRun};
use player::frame::Mode;
use player::metrics::PSNR_CAP;
use player::table::{reaches, triangles_to_reach, Reach, TableRow};
use player::testdata::write_synthetic_bake;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    compare: CompareArgs,
}

fn args(extra: &[&str]) -> Result<CompareArgs, clap::Error> {
    let mut v = vec!["compare", "/nonexistent", "--path", "p.ron"];
    v.extend_from_slice(extra);
    Cli::try_parse_from(v).map(|c| c.compare)
}

#[test]
fn interpolation_over_a_hand_made_sweep() {
    // (triangles, PSNR dB), out of order as a τ sweep lists them (coarse τ first).
    let sweep = [(400.0, 38.0), (100.0, 30.0), (200.0, 34.0)];
    assert_eq!(triangles_to_reach(&sweep, 36.0), Reach::Interpolated(300.0));
    assert_eq!(triangles_to_reach(&sweep, 31.0), Reach::Interpolated(125.0));
    assert_eq!(triangles_to_reach(&sweep, 34.0), Reach::Interpolated(200.0));
    assert_eq!(triangles_to_reach(&sweep, 38.0), Reach::Interpolated(400.0));
    assert_eq!(triangles_to_reach(&sweep, 29.0), Reach::AtMost(100.0));
    assert_eq!(triangles_to_reach(&sweep, 38.5), Reach::NotReached);
    assert_eq!(triangles_to_reach(&[], 30.0), Reach::NotReached);
    assert_eq!(
        triangles_to_reach(&[(f64::NAN, 40.0), (10.0, f64::NAN)], 30.0),
        Reach::NotReached
    );
    // The reach of each LOD mode against the hybrid's row.
    let row = |mode: &str, triangles: f64, psnr: f64| TableRow {
        label: mode.into(),
        mode: mode.into(),
        cluster_tau_px: None,
        lod_pixel_error: None,
        triangles,
        draw_calls: 1.0,
        object_psnr_y_db: psnr,
        object_ssim: 1.0,
        against: "full".into(),
        disk_bytes: None,
        resident_bytes: None,
        frame_ms: 1.0,
        frustum_frame_ms: 1.0,
        list_ms: 0.5,
        frustum_list_ms: 0.5,
    };
    let rows = [
        row("hybrid", 50.0, 36.0),
        row("cluster-lod", 400.0, 38.0),
        row("cluster-lod", 200.0, 34.0),
        row("lod", 1000.0, 35.0),
    ];
    let r = reaches(&rows);
    assert_eq!(r.len(), 2);
    assert_eq!(
        (r[0].mode.as_str(), r[0].reach, r[0].sweep_points),
        ("cluster-lod", Reach::Interpolated(300.0), 2)
    );
    assert_eq!((r[1].mode.as_str(), r[1].reach), ("lod", Reach::NotReached));
    assert!(reaches(&rows[1..]).is_empty(), "no hybrid row, no reach");
    let json = serde_json::to_value(r[0].reach).unwrap();
    assert_eq!(json["status"], "interpolated");
    assert_eq!(json["triangles"], 300.0);
}

#[test]
fn modes_and_sweeps_parse_into_runs_and_bad_input_is_refused() {
    let a = args(&[
        "--modes",
        "hybrid,cluster-lod,lod",
        "--cluster-tau-sweep",
        "0.5,1,2",
        "--lod-pixel-error-sweep",
        "1,4",
    ])
    .unwrap();
    let runs = runs_of(&a).unwrap().unwrap();
    let labels: Vec<String> = runs.iter().map(|r| r.label()).collect();
    assert_eq!(
        labels,
        [
            "hybrid",
            "cluster-lod τ=0.5",
            "cluster-lod τ=1",
            "cluster-lod τ=2",
            "lod 1px",
            "lod 4px"
        ]
    );
    // A plain compare stays a single-mode compare.
    assert!(runs_of(&args(&["--mode", "lod"]).unwrap())
        .unwrap()
        .is_none());
    assert!(runs_of(&args(&[]).unwrap()).unwrap().is_none());
    // Unknown mode: the error lists the modes.
    let e = args(&["--modes", "hybrid,nanite"])
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("nanite") && e.contains("full, frustum, hybrid, lod, cluster-lod"),
        "{e}"
    );
    let e = runs_of(&args(&["--modes", "lod,hybrid,lod"]).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("lod listed more than once"), "{e}");
    let e = runs_of(&args(&["--modes", "hybrid", "--cluster-tau-sweep", "1"]).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("needs cluster-lod"), "{e}");
    assert!(args(&["--modes", "lod", "--cluster-tau-sweep", "-1"]).is_err());
    assert!(args(&["--modes", "lod", "--mode", "hybrid"]).is_err());
}

/// A short piece of the demo walk (a few frames, crossing no more than a cell).
fn short_walk() -> format::path::CameraPath {
    let mut p = demo_walk();
    p.waypoints = vec![(30.0, 40.0), (54.0, 58.0)];
    p
}

#[test]
fn one_reference_a_row_per_mode_and_each_row_as_its_single_mode_compare() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    if common::renderer(8, 8).is_none() {
        return;
    }
    let path = short_walk();
    let opts = CompareOptions {
        size: Some((64, 64)),
        reference_ss: 2,
        ..Default::default()
    };
    let run = |mode, cluster_tau, lod_pixel_error| CompareRun {
        mode,
        cluster_tau,
        lod_pixel_error,
    };
    let runs = [
        run(Mode::Hybrid, 1.0, 1.0),
        run(Mode::ClusterLod, 0.0, 1.0),
        run(Mode::ClusterLod, 4.0, 1.0),
        run(Mode::Lod, 1.0, 2.0),
    ];
    let m = multi_compare(dir.path(), &path, &opts, &runs).unwrap();
    print!("{}", player::table::markdown(&m, "short demo walk"));
    assert_eq!(m.rows.len(), runs.len());
    assert_eq!(m.reports.len(), runs.len());
    let frames = path.frames().len();
    assert!(frames >= 3, "{frames} frames");
    // The same reference for every row: the same frames, reference triangles and
    // aliased-full-vs-anti-aliased figures, frame by frame.
    for r in &m.reports {
        assert_eq!(r.frames, frames);
        let aa = r.aa_reference.as_ref().unwrap();
        let aa0 = m.reports[0].aa_reference.as_ref().unwrap();
        assert_eq!(aa.full, aa0.full);
        for (f, f0) in r.per_frame.iter().zip(&m.reports[0].per_frame) {
            assert_eq!(f.reference_triangles, f0.reference_triangles);
            assert_eq!(f.reference_frame_ms, f0.reference_frame_ms);
            assert_eq!(
                f.aa_reference.as_ref().unwrap().full,
                f0.aa_reference.as_ref().unwrap().full
            );
        }
    }
    // Each row drawn at its own setting: τ = 0 is the reference pixel for pixel,
    // τ = 4 draws fewer triangles.
    assert_eq!(m.reports[1].object.object_psnr_y_db, PSNR_CAP);
    assert_eq!(m.reports[1].cluster_lod.as_ref().unwrap().tau_px, 0.0);
    assert_eq!(m.reports[2].cluster_lod.as_ref().unwrap().tau_px, 4.0);
    assert!(m.rows[2].triangles < m.rows[1].triangles);
    assert_eq!(m.reports[3].lod_pixel_error, Some(2.0));
    assert!(m.reports[3].lod_build_ms.is_some() && m.reports[0].lod_build_ms.is_none());
    let modes: Vec<&str> = m.rows.iter().map(|r| r.mode.as_str()).collect();
    assert_eq!(modes, ["hybrid", "cluster-lod", "cluster-lod", "lod"]);
    assert!(m.rows.iter().all(|r| r.against == "aa 2x2"));
    assert!(m.rows[0].disk_bytes.unwrap() > 0 && m.rows[1].disk_bytes.unwrap() > 0);
    assert!(m.rows[3].disk_bytes.is_none() && m.rows[3].resident_bytes.is_some());
    assert_eq!(m.reach.len(), 2);
    let json = serde_json::to_value(&m).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 4);
    assert_eq!(json["reports"][1]["mode"], "cluster-lod");
    // Each row's figures (timing aside) are those of its single-mode compare.
    for (k, r) in runs.iter().enumerate() {
        let single = compare(
            dir.path(),
            &path,
            &CompareOptions {
                mode: r.mode,
                cluster_tau: r.cluster_tau,
                lod_pixel_error: r.lod_pixel_error,
                ..opts.clone()
            },
        )
        .unwrap();
        let multi = &m.reports[k];
        assert_eq!(single.object, multi.object, "{}", r.label());
        assert_eq!(single.aa_reference, multi.aa_reference, "{}", r.label());
        assert_eq!(single.mean_triangles, multi.mean_triangles, "{}", r.label());
        assert_eq!(
            single.mean_draw_calls,
            multi.mean_draw_calls,
            "{}",
            r.label()
        );
        assert_eq!(single.mode, multi.mode);
    }
}
