//! Cluster LOD (`--mode cluster-lod`, issue 30 item 1): the DAGs built with
//! meshoptimizer's clusterlod are monotone (every cluster's error and sphere within
//! its parent group's) and deterministic; a bad cache file is rebuilt, not a panic;
//! at τ = 0 the frames are `full`'s pixel for pixel; the per-cluster cone and
//! frustum tests change no pixel; a larger τ never adds triangles.

mod common;
use common::{demo_walk, open_player};
use player::bake::Bake;
use player::clusterlod::{build_dag, cache_path, ClusterSet, CACHE_DIR};
use player::compare::{compare, CompareOptions};
use player::frame::{cluster_list, originals_list, Mode};
use player::run::{camera_for, PSNR_CAP};
use player::testdata::write_synthetic_bake;

fn demo_bake(dir: &std::path::Path) -> Bake {
    write_synthetic_bake(dir).unwrap();
    Bake::open(dir, &player::DrawOptions::default()).unwrap()
}

#[test]
fn demo_dags_are_monotone_cover_the_originals_and_are_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let bake = demo_bake(dir.path());
    let set = ClusterSet::build(&bake.base, None);
    assert_eq!(set.dags.len(), bake.base.models.len());
    for (m, dag) in bake.base.models.iter().zip(&set.dags) {
        let levels = dag.groups.iter().map(|g| g.depth).max().unwrap_or(0) + 1;
        println!(
            "{}: {} triangles, {} clusters in {} groups, {} levels",
            m.name,
            m.mesh.triangles.len(),
            dag.clusters.len(),
            dag.groups.len(),
            levels
        );
        // The original clusters hold exactly the model's triangles.
        let mut original: Vec<[u32; 3]> = dag
            .clusters
            .iter()
            .filter(|c| c.refined < 0)
            .flat_map(|c| {
                dag.indices[c.first as usize..(c.first + c.count) as usize]
                    .chunks_exact(3)
                    .map(|t| {
                        // Rotation-invariant form of the triangle (winding kept).
                        let k = (0..3).min_by_key(|&k| t[k]).unwrap();
                        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
                    })
            })
            .collect();
        let mut expected: Vec<[u32; 3]> = m
            .mesh
            .triangles
            .iter()
            .map(|t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap();
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        original.sort_unstable();
        expected.sort_unstable();
        assert_eq!(original, expected, "{}", m.name);
        for c in &dag.clusters {
            assert!(c.count as usize / 3 <= player::clusterlod::MAX_CLUSTER_TRIANGLES);
            assert!(c.refined < c.group as i32, "{}: built bottom-up", m.name);
            let (own, parent) = (dag.own(c), dag.parent(c));
            assert!(
                own.error <= parent.error,
                "{}: own {own:?} parent {parent:?}",
                m.name
            );
            assert!(parent.contains(&own), "{}: {own:?} in {parent:?}", m.name);
            assert!(dag.indices[c.first as usize..(c.first + c.count) as usize]
                .iter()
                .all(|&i| (i as usize) < m.mesh.positions.len()));
        }
        if m.mesh.triangles.len() >= 1000 {
            assert!(levels >= 3, "{}: {levels} levels", m.name);
        }
    }
    // Deterministic and independent of threads: each model built alone on this
    // thread gives the DAG the scoped-thread build gave.
    for (m, dag) in bake.base.models.iter().zip(&set.dags) {
        assert_eq!(&build_dag(&m.mesh), dag, "{}", m.name);
    }
}

#[test]
fn cache_is_written_read_back_and_a_bad_file_is_rebuilt() {
    let dir = tempfile::tempdir().unwrap();
    let bake = demo_bake(dir.path());
    let cache = dir.path().join(CACHE_DIR);
    let first = ClusterSet::build(&bake.base, Some(&cache));
    assert_eq!(first.cache_hits, 0);
    assert_eq!(first.built, bake.base.models.len());
    let files = std::fs::read_dir(&cache).unwrap().count();
    assert!(
        files >= 1 && files <= bake.base.models.len(),
        "{files} files"
    );
    let on_disk: u64 = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    println!(
        "{} clusters, {} bytes in memory terms, {on_disk} bytes on disk, built in {:.0} ms",
        first.cluster_count(),
        first.bytes,
        first.build_ms
    );
    let second = ClusterSet::build(&bake.base, Some(&cache));
    assert_eq!(second.cache_hits, bake.base.models.len());
    assert_eq!(second.dags, first.dags);
    // Damage every file in a different way: truncated, garbage, another version,
    // a flipped byte, empty.
    let mesh = &bake.base.models[0].mesh;
    let p = cache_path(&cache, mesh);
    let good = std::fs::read(&p).unwrap();
    let mut other_version = good.clone();
    other_version[8] ^= 1;
    let mut flipped = good.clone();
    let mid = good.len() / 2;
    flipped[mid] ^= 0x80;
    for bad in [
        good[..good.len() / 3].to_vec(),
        b"not a cluster file at all".to_vec(),
        other_version,
        flipped,
        Vec::new(),
    ] {
        std::fs::write(&p, &bad).unwrap();
        let again = ClusterSet::build(&bake.base, Some(&cache));
        assert_eq!(again.dags, first.dags, "rebuilt to the same DAG");
        assert!(again.built >= 1);
        assert_eq!(std::fs::read(&p).unwrap(), good, "rewritten");
    }
    // A cache folder that cannot be made (a file is in its place): built, not
    // cached, no panic.
    let blocked = dir.path().join("base.pack");
    let uncached = ClusterSet::build(&bake.base, Some(&blocked));
    assert_eq!(uncached.dags, first.dags);
    assert_eq!(uncached.cache_hits, 0);
}

#[test]
fn a_larger_tau_never_adds_triangles_along_demo_walk() {
    let dir = tempfile::tempdir().unwrap();
    let bake = demo_bake(dir.path());
    let set = ClusterSet::build(&bake.base, None);
    let path = demo_walk();
    let taus = [0.0f32, 0.25, 1.0, 4.0, 1e6];
    let mut totals = vec![0u64; taus.len()];
    for f in path.frames() {
        let cam = camera_for(&f, &path, path.resolution, bake.extent);
        let tris: Vec<u64> = taus
            .iter()
            .map(|&t| {
                cluster_list(&bake, &set, &cam, t)
                    .clusters
                    .iter()
                    .map(|c| c.triangles)
                    .sum()
            })
            .collect();
        for (t, n) in totals.iter_mut().zip(&tris) {
            *t += n;
        }
    }
    println!("triangles along demo-walk per τ {taus:?}: {totals:?}");
    for w in totals.windows(2) {
        assert!(w[1] <= w[0], "{totals:?}");
    }
    assert!(
        totals[2] < totals[0] / 4,
        "1 px saves triangles: {totals:?}"
    );
}

/// τ = 0 draws exactly the original triangles: pixels equal `full`'s; with the
/// cluster cone and frustum tests on or off the frames are the same.
#[test]
fn tau_zero_equals_full_and_cluster_culling_is_conservative() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    let size = (160, 120);
    let Some(mut p) = open_player(dir.path(), size, &player::DrawOptions::default()) else {
        return;
    };
    let no_cull = player::DrawOptions {
        backface: false,
        frustum: false,
        ..Default::default()
    };
    let Some(mut q) = open_player(dir.path(), size, &no_cull) else {
        return;
    };
    let path = demo_walk();
    let frames = path.frames();
    let mut compared = 0;
    let mut culled_tris = (0u64, 0u64);
    for f in frames.iter().step_by(5) {
        let cam = camera_for(f, &path, size, p.bake.extent);
        p.draw(&cam, Mode::Full, None);
        let full = p.renderer.read_pixels().unwrap();
        p.cluster_tau = 0.0;
        let (_, tris0, _, _) = p.draw(&cam, Mode::ClusterLod, None);
        let clod0 = p.renderer.read_pixels().unwrap();
        let differing = full
            .chunks_exact(4)
            .zip(clod0.chunks_exact(4))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differing, 0, "t={:.2}s: τ = 0 differs from full", f.time_s);
        // The triangles are the frustum-visible instances' originals minus culled
        // clusters (the instances of `q`, whose originals are drawn whole).
        let visible: u64 = {
            let l = originals_list(&q.bake, &cam, true);
            l.originals
                .iter()
                .map(|(m, i)| {
                    p.bake.base.models[*m as usize].mesh.triangles.len() as u64 * i.len() as u64
                })
                .sum()
        };
        assert!(tris0 <= visible);
        // Culling is conservative at τ = 1 as at τ = 0.
        for tau in [0.0, 1.0] {
            p.cluster_tau = tau;
            q.cluster_tau = tau;
            let (_, a, _, _) = p.draw(&cam, Mode::ClusterLod, None);
            let culled = p.renderer.read_pixels().unwrap();
            let (_, b, _, _) = q.draw(&cam, Mode::ClusterLod, None);
            let all = q.renderer.read_pixels().unwrap();
            assert!(a <= b);
            culled_tris.0 += a;
            culled_tris.1 += b;
            assert!(
                culled == all,
                "t={:.2}s τ={tau}: culled clusters changed pixels",
                f.time_s
            );
        }
        compared += 1;
    }
    println!(
        "{compared} frames equal to full at τ = 0; cluster culling kept {} of {} triangles",
        culled_tris.0, culled_tris.1
    );
    assert!(culled_tris.0 < culled_tris.1, "culling removes something");
}

#[test]
fn cluster_lod_walk_of_the_demo_scene_reports_its_figures() {
    let dir = tempfile::tempdir().unwrap();
    write_synthetic_bake(dir.path()).unwrap();
    if common::renderer(8, 8).is_none() {
        return;
    }
    let path = demo_walk();
    let run = |tau: f32| {
        compare(
            dir.path(),
            &path,
            &CompareOptions {
                size: Some((128, 128)),
                mode: Mode::ClusterLod,
                cluster_tau: tau,
                reference_ss: 1,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let r = run(1.0);
    let c = r.cluster_lod.as_ref().expect("cluster-lod summary");
    println!(
        "cluster-lod τ=1: PSNR(Y) {:.2} (min {:.2}), object {:.2} dB, triangles {:.0} / {:.0}, draw calls {:.1}, clusters {:.0}, {c:?}",
        r.mean_psnr_y,
        r.min_psnr_y,
        r.object.object_psnr_y_db,
        r.mean_triangles,
        r.reference_triangles,
        r.mean_draw_calls,
        c.mean_clusters_drawn
    );
    assert_eq!(r.mode, "cluster-lod");
    assert_eq!(c.tau_px, 1.0);
    assert!(c.cluster_bytes > 0 && c.pack_bytes > 0 && c.resident_bytes > 0);
    assert!(c.mean_clusters_drawn > 0.0);
    assert!(r.mean_triangles < 0.2 * r.reference_triangles);
    assert!(r.mean_psnr_y >= 27.0, "mean PSNR(Y) {}", r.mean_psnr_y);
    let json = serde_json::to_value(&r).unwrap();
    assert!(json.get("cluster_lod").is_some());
    // τ = 0: the frame is the reference.
    let exact = run(0.0);
    assert_eq!(exact.mean_psnr_y, PSNR_CAP);
    assert_eq!(exact.object.object_psnr_y_db, PSNR_CAP);
    assert!(
        exact.cluster_lod.unwrap().cache_hits > 0,
        "second run reads the cache"
    );
}

/// The cut is a consistent one at every τ and pose: at the walk's poses every
/// cluster's own projected error is ≤ its parent group's (world spheres nested, so
/// each region of the surface is drawn at exactly one level); a coarser τ never
/// draws more; τ = 0 draws the original triangles; and at τ ≤ 1 px the drawn
/// surface keeps the original's area within 15 % (a sanity bound: the demo's thin
/// tubes lose area legitimately when simplified to fewer sides, 9 % for the far
/// torus at 94 of its 12,288 triangles; an overlap would double a region, a hole
/// drop one).
#[test]
fn every_cut_is_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let bake = demo_bake(dir.path());
    let set = ClusterSet::build(&bake.base, None);
    let path = demo_walk();
    let area = |mesh: &format::Mesh, idx: &mut dyn Iterator<Item = u32>| -> f64 {
        let idx: Vec<u32> = idx.collect();
        idx.chunks_exact(3)
            .map(|t| {
                let p = |k: usize| glam::Vec3::from(mesh.positions[t[k] as usize]).as_dvec3();
                0.5 * (p(1) - p(0)).cross(p(2) - p(0)).length()
            })
            .sum()
    };
    let (mut scratch, mut proj) = (Vec::new(), Vec::new());
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    for f in path.frames().iter().step_by(7) {
        let cam = camera_for(f, &path, path.resolution, bake.extent);
        for (i, inst) in bake.base.instances.iter().enumerate() {
            let mesh = &bake.base.models[inst.model as usize].mesh;
            let dag = &set.dags[inst.model as usize];
            set.projected_errors(inst.model, i as u32, &cam, &mut proj)
                .unwrap();
            for c in &dag.clusters {
                let own = usize::try_from(c.refined).map_or(0.0, |r| proj[r]);
                let parent = proj[c.group as usize];
                assert!(own <= parent, "instance {i}: own {own} > parent {parent}");
            }
            let full = area(mesh, &mut mesh.triangles.iter().flatten().copied());
            let mut prev = u64::MAX;
            for tau in [0.0f32, 0.25, 0.5, 1.0, 2.0, 8.0, 64.0, 1e9] {
                let sel = set
                    .select(inst.model, i as u32, &cam, tau, None, &mut scratch)
                    .unwrap();
                assert!(sel.triangles <= prev, "instance {i} τ {tau}");
                assert!(sel.triangles > 0, "instance {i} τ {tau}: nothing drawn");
                prev = sel.triangles;
                if tau == 0.0 {
                    assert_eq!(sel.triangles, mesh.triangles.len() as u64);
                    assert!(!sel.simplified);
                }
                if tau <= 1.0 {
                    let drawn = area(
                        mesh,
                        &mut sel.ranges.iter().flat_map(|&(a, b)| {
                            dag.indices[a as usize..b as usize].iter().copied()
                        }),
                    );
                    let ratio = drawn / full;
                    worst = worst.max((ratio - 1.0).abs());
                    assert!(
                        (0.85..=1.15).contains(&ratio),
                        "instance {i} ({}) τ {tau}: area ratio {ratio:.3}",
                        bake.base.models[inst.model as usize].name
                    );
                }
                checked += 1;
            }
        }
    }
    println!(
        "{checked} cuts checked; largest area change at τ ≤ 1: {:.2}%",
        100.0 * worst
    );
}
