//! Weighted half-edge collapse (000 §3.1.3.3, §3.1.4) on the Stanford bunny scaled
//! to the paper's 43 units, T_l = 4.5, 1024 pixels per 60°, uniform weights 0.125
//! (a stand-in for the capture's weights):
//!
//! - `sv_front_7cells`: SVMesh input, the triangles front-facing to the centre of
//!   the cell 7 cells away;
//! - `mv_front_1cell`: MVMesh input, the triangles front-facing to some corner of
//!   the cell 1 cell away, l′ over its 12 corners, view sets over 7 views;
//! - `sv_whole_7cells`: the whole 69,666-triangle mesh from 7 cells.
//!
//! `cargo bench -p worker --bench simplify -- --warm-up-time 1 --measurement-time 3`
//! (the bunny comes from `HEXBAKE_MODELS` or `<repo>/models`; skipped through `testkit::skip` when absent).

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use std::f32::consts::PI;
use std::hint::black_box;
use worker::simplify::{
    pixels_per_radian, simplify, ProjectedLength, SimplifyInput, SimplifyParams,
};

const CELL_SIZE: f32 = 50.0;

struct Bunny {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

/// The bunny as the bake sees it (format's loader), scaled to the paper's 43 units.
fn load_bunny() -> Option<Bunny> {
    let path = testkit::model("bunny.obj")?;
    let mut mesh = scene::load::load_model(&path).unwrap();
    scene::build::normalise(&mut mesh, [0.0; 3], 43.0).unwrap();
    Some(Bunny {
        positions: mesh.positions.iter().map(|&p| Vec3::from(p)).collect(),
        normals: mesh.normals.iter().map(|&n| Vec3::from(n)).collect(),
        triangles: mesh.triangles,
    })
}

fn front_facing(b: &Bunny, t: &[u32; 3], eye: Vec3) -> bool {
    let [p, q, r] = t.map(|i| b.positions[i as usize]);
    (q - p).cross(r - p).dot(eye - (p + q + r) / 3.0) > 0.0
}

fn cell_centre(k: u32) -> Vec3 {
    Vec3::new(0.0, 10.0, k as f32 * 3f32.sqrt() * CELL_SIZE)
}

fn bench_simplify(c: &mut Criterion) {
    let Some(bunny) = load_bunny() else {
        return;
    };
    let n = bunny.positions.len();
    let weights = vec![0.125f32; n];
    let ppr = pixels_per_radian(1024);

    // SV, 7 cells: front-facing triangles, l from the centre.
    let centre = cell_centre(7);
    let sv_tris: Vec<[u32; 3]> = bunny
        .triangles
        .iter()
        .filter(|t| front_facing(&bunny, t, centre))
        .copied()
        .collect();
    let sv_params = SimplifyParams {
        edge_length_tolerance_px: 4.5,
        length: ProjectedLength::FromPoint {
            eye: centre,
            pixels_per_radian: ppr,
        },
        deviation: None,
    };
    let sv = SimplifyInput {
        positions: &bunny.positions,
        normals: &bunny.normals,
        triangles: &sv_tris,
        weights: &weights,
        view_sets: None,
        locked: None,
    };
    c.bench_function("sv_front_7cells", |b| {
        b.iter(|| simplify(black_box(&sv), &sv_params).unwrap())
    });
    let whole = SimplifyInput {
        triangles: &bunny.triangles,
        ..sv
    };
    c.bench_function("sv_whole_7cells", |b| {
        b.iter(|| simplify(black_box(&whole), &sv_params).unwrap())
    });

    // MV, 1 cell: triangles front-facing to some prism corner, l′ over 12 corners,
    // vertex view sets = the views (centre + 6 neighbours) it faces.
    let centre = cell_centre(1);
    let corners: Vec<Vec3> = [5.0f32, 15.0]
        .iter()
        .flat_map(|&y| {
            (0..6).map(move |i| {
                let a = i as f32 * PI / 3.0;
                Vec3::new(
                    centre.x + CELL_SIZE * a.cos(),
                    y,
                    centre.z + CELL_SIZE * a.sin(),
                )
            })
        })
        .collect();
    let mut views = vec![centre];
    for i in 0..6 {
        let a = PI / 6.0 + i as f32 * PI / 3.0;
        views.push(centre + 3f32.sqrt() * CELL_SIZE * Vec3::new(a.cos(), 0.0, a.sin()));
    }
    let sets: Vec<u8> = (0..n)
        .map(|v| {
            let (p, nrm) = (bunny.positions[v], bunny.normals[v]);
            views
                .iter()
                .enumerate()
                .filter(|(_, &e)| nrm.dot(e - p) > 0.0)
                .fold(0u8, |s, (i, _)| s | 1 << i)
        })
        .collect();
    let mv_tris: Vec<[u32; 3]> = bunny
        .triangles
        .iter()
        .filter(|t| corners.iter().any(|&e| front_facing(&bunny, t, e)))
        .copied()
        .collect();
    let mv_params = SimplifyParams {
        edge_length_tolerance_px: 4.5,
        length: ProjectedLength::MaxOverPoints {
            eyes: corners,
            pixels_per_radian: ppr,
        },
        deviation: None,
    };
    let mv = SimplifyInput {
        positions: &bunny.positions,
        normals: &bunny.normals,
        triangles: &mv_tris,
        weights: &weights,
        view_sets: Some(&sets),
        locked: None,
    };
    c.bench_function("mv_front_1cell", |b| {
        b.iter(|| simplify(black_box(&mv), &mv_params).unwrap())
    });
}

criterion_group!(benches, bench_simplify);
criterion_main!(benches);
