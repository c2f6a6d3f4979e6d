//! Raster throughput (issue 3 item 7): the bunny and the elephant at near / middle /
//! far distances in a 1024², 60° view (object spanning about 900 / 300 / 60 px), plus
//! a tight far capture (DESIGN.md "Capture resolution": ~100 × 100 px), single
//! thread (rayon pool of 1) and the default pool.
//!
//! Criterion reports triangles/s (throughput = the mesh's triangles); the covered
//! pixel count of each case is printed once so pixels/s = covered × renders/s.
//!
//! `cargo bench -p worker --bench raster -- --warm-up-time 1 --measurement-time 3`
//! Models come from `HEXBAKE_MODELS` or `<repo>/models`; absent models are skipped
//! (`testkit::skip`).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use format::Mesh;
use glam::{Mat4, Vec3};
use worker::raster::{render, render_into, CullMode, DrawItem, Shading, View};

/// The fetched model `name` as the bake sees it (format's loader: welded, smooth
/// normals, albedo); `None` after a skip when it was not fetched.
fn load(name: &str) -> Option<Mesh> {
    let path = testkit::model(name)?;
    Some(scene::load::load_model(&path).unwrap())
}

fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(f),
        None => f(),
    }
}

/// CPU time of this process so far (sum over its threads, from
/// `/proc/self/task/*/schedstat`), in seconds; `None` where unavailable. Used to
/// report per-core throughput that a loaded machine's wall clock would distort.
fn cpu_seconds() -> Option<f64> {
    let mut ns: u64 = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        ns += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(ns as f64 * 1e-9)
}

/// Renders repeatedly on a pool of one thread for about `budget_s` CPU seconds and
/// returns CPU seconds per render.
/// With `reuse`, renders into one capture's buffers ([`render_into`]).
fn cpu_time_per_render(view: &View, items: &[DrawItem], budget_s: f64, reuse: bool) -> Option<f64> {
    in_pool(Some(1), || {
        let mut capture = render(view, items, CullMode::Back); // warm up
        let start = cpu_seconds()?;
        let mut n = 0u32;
        loop {
            if reuse {
                render_into(view, items, CullMode::Back, Shading::Lit, &mut capture);
            } else {
                capture = render(view, items, CullMode::Back);
            }
            std::hint::black_box(&capture);
            n += 1;
            let spent = cpu_seconds()? - start;
            if spent >= budget_s || n >= 2000 {
                return Some(spent / n as f64);
            }
        }
    })
}

fn bench_raster(c: &mut Criterion) {
    let mut group = c.benchmark_group("raster");
    for name in ["bunny.obj", "refined_elephant.off"] {
        let Some(mesh) = load(name) else {
            continue;
        };
        let (lo, hi) = mesh.bounds().unwrap();
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        let centre = 0.5 * (lo + hi);
        let diameter = (hi - lo).length();
        let items = [DrawItem {
            mesh: &mesh,
            transform: Mat4::IDENTITY,
            tint: Vec3::ONE,
            object_id: 0,
            triangles: None,
            albedo_map: None,
        }];
        let tan = (30f32).to_radians().tan();
        let mut views = Vec::new();
        for (label, span_px) in [("near", 900.0f32), ("middle", 300.0), ("far", 60.0)] {
            // The bounding sphere's diameter spans `span_px` of the 1024 px, 60° view.
            let d = diameter * 1024.0 / (span_px * 2.0 * tan);
            let eye = centre + Vec3::new(0.3, 0.2, 1.0).normalize() * d;
            let view =
                View::look_at_fov(eye, centre, Vec3::Y, 60.0, 1024, 1024, d * 0.01, d * 10.0)
                    .unwrap();
            views.push((label, view));
        }
        // A tight far capture of about 100 × 100 px at image_res 1024.
        let d = diameter * 1024.0 / (100.0 * 2.0 * tan);
        let eye = centre + Vec3::new(0.3, 0.2, 1.0).normalize() * d;
        views.push(("far-tight", View::tight_around(eye, lo, hi, 1024).unwrap()));
        group.throughput(Throughput::Elements(mesh.triangles.len() as u64));
        for (label, view) in &views {
            let covered = render(view, &items, CullMode::Back).covered_pixels();
            let tris = mesh.triangles.len();
            eprintln!(
                "{name} {label}: {tris} triangles, {}×{} px view, {covered} px covered",
                view.width, view.height
            );
            for (how, reuse) in [("render", false), ("render_into", true)] {
                if let Some(t) = cpu_time_per_render(view, &items, 1.0, reuse) {
                    eprintln!(
                        "  {how:<11} per core (CPU time, pool of 1): {:.3} ms/render, {:.1} M triangles/s, {:.1} M covered px/s, {:.1} M view px/s",
                        t * 1e3,
                        tris as f64 / t * 1e-6,
                        covered as f64 / t * 1e-6,
                        (view.width as f64 * view.height as f64) / t * 1e-6
                    );
                }
            }
            for (threads_label, threads) in [("1-thread", Some(1)), ("default", None)] {
                let id = BenchmarkId::new(format!("{name}/{label}"), threads_label);
                group.bench_with_input(id, view, |b, view| {
                    in_pool(threads, || b.iter(|| render(view, &items, CullMode::Back)));
                });
            }
        }
    }
    group.finish();
}

criterion_group!(benches, bench_raster);
criterion_main!(benches);
