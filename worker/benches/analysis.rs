//! Benchmarks of the per-cell analysis (issue 3 item 7, "classification and weighting
//! time"): pixel classes and vertex weights of the bunny on a 1024² capture, plus the
//! other analysis kernels on the same data.
//!
//! The capture is the obvhs ray-cast reference (`visibility::ray_cast_capture`), which
//! holds the same buffers the rasterizer produces. Run:
//! `HEXBAKE_MODELS=… cargo bench -p worker --bench analysis -- --warm-up-time 1 --measurement-time 3`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Mat4, Vec3};
use std::hint::black_box;
use worker::backface::regional_backface_cull;
use worker::classify::{classify, DEFAULT_T_C0, DEFAULT_T_C1};
use worker::raster::{CullMode, DrawItem, View};
use worker::visibility::{ray_cast_capture, visible_by_rays, DepthTolerance};
use worker::weights::vertex_weights;

fn analysis(c: &mut Criterion) {
    // The model as the bake sees it (format's loader: welded, smooth normals, albedo).
    let Some(path) = testkit::model("bunny.obj") else {
        return;
    };
    let mesh = scene::load::load_model(&path).unwrap();
    // The paper's bunny: 43.2 units tall, base on y = 0; eye 250 units away at 1.7,
    // a 1024² square view just around its bounding sphere.
    let (lo, hi) = mesh.bounds().unwrap();
    let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
    let transform = Mat4::from_scale(Vec3::splat(43.2 / (hi.y - lo.y)))
        * Mat4::from_translation(Vec3::new(-(lo.x + hi.x) * 0.5, -lo.y, -(lo.z + hi.z) * 0.5));
    let target = Vec3::new(0.0, 21.6, 0.0);
    let cell_centre = Vec3::new(1.0, 0.0, 0.6).normalize() * 250.0;
    let eye = cell_centre + Vec3::new(0.0, 1.7, 0.0);
    let near = 0.5 * 3f32.sqrt() * 50.0;
    let fov = 2.0 * (35.0 / eye.distance(target)).asin();
    let view = View {
        eye,
        view: glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y),
        proj: glam::camera::rh::proj::opengl::perspective(fov, 1.0, near, 5000.0),
        near,
        far: 5000.0,
        width: 1024,
        height: 1024,
    };
    let item = DrawItem {
        mesh: &mesh,
        transform,
        tint: Vec3::ONE,
        object_id: 1,
        triangles: None,
        albedo_map: None,
    };
    let capture = ray_cast_capture(&[item], &view, CullMode::None);
    let classes = classify(&capture, 1, DEFAULT_T_C0, DEFAULT_T_C1);
    // The cell's prism: size 50, eye heights 1.0..2.5, around the cell centre.
    let corners: [Vec3; 12] = std::array::from_fn(|k| {
        let a = std::f32::consts::PI / 3.0 * (k % 6) as f32;
        let height = if k < 6 { 1.0 } else { 2.5 };
        cell_centre + Vec3::new(50.0 * a.cos(), height, 50.0 * a.sin())
    });

    let mut group = c.benchmark_group("bunny_1024");
    group.throughput(Throughput::Elements(1024 * 1024));
    group.bench_function("classify", |b| {
        b.iter(|| classify(black_box(&capture), 1, DEFAULT_T_C0, DEFAULT_T_C1))
    });
    group.throughput(Throughput::Elements(mesh.positions.len() as u64));
    group.bench_function("vertex_weights", |b| {
        b.iter(|| {
            vertex_weights(
                black_box(&mesh),
                transform,
                &capture,
                &classes,
                1,
                DepthTolerance::default(),
            )
        })
    });
    group.bench_function("visible_by_rays", |b| {
        b.iter(|| {
            visible_by_rays(
                black_box(&mesh),
                transform,
                &view,
                DepthTolerance::default().footprint_px,
            )
        })
    });
    group.throughput(Throughput::Elements(mesh.triangles.len() as u64));
    group.bench_function("regional_backface_cull", |b| {
        b.iter(|| regional_backface_cull(black_box(&mesh), transform, &corners))
    });
    group.throughput(Throughput::Elements(1024 * 1024));
    group.sample_size(10);
    group.bench_function("ray_cast_capture", |b| {
        b.iter(|| ray_cast_capture(black_box(&[item]), &view, CullMode::None))
    });
    group.finish();
}

criterion_group!(benches, analysis);
criterion_main!(benches);
