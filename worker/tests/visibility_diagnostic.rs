//! Diagnostic, not a check (ignored): where the depth-buffer test and the ray oracle
//! disagree on the bunny (visibility.rs, "Agreement, and what the diagnostic found").
//! Per disagreeing vertex: which oracle says what, the facing of its incident triangles
//! (front / contour / back), the class of its own pixel, its distance to the nearest
//! pixel off the object, what the depth test saw there (the seen triangle's ring
//! distance from the vertex and the vertex's distance behind its plane) and what the
//! ray met (the occluder nearest the vertex: ring distance, gap along the line of sight
//! and the vertex's distance from its plane), all in pixel footprints at the vertex.
//!
//! `HEXBAKE_PICTURES=DIR cargo test -p worker --test visibility_diagnostic -- --ignored
//! --nocapture` also writes `DIR/disagree_<distance>.png`: the capture, dimmed, with
//! the vertices the depth test calls visible and the rays hidden in red, the others in
//! blue.

mod common;
use common::{bunny, bunny_capture, bunny_view};
use glam::{Vec3, Vec3A};
use obvhs::{bvh2::builder::build_bvh2_from_tris, ray::Ray, triangle::Triangle, BvhBuildParams};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use worker::classify::{classify, DEFAULT_T_C0, DEFAULT_T_C1};
use worker::raster::BACKGROUND_ID;
use worker::visibility::{
    depth_visibility, pixel_footprint, project_to_pixel, visible_by_rays, DepthTolerance,
    DepthVisibility,
};

/// Graph distance (≤ 6, else 99) from `v` to the nearest corner of each triangle.
fn ring_of(tri: [u32; 3], rings: &BTreeMap<u32, u32>) -> u32 {
    tri.iter()
        .map(|c| rings.get(c).copied().unwrap_or(99))
        .min()
        .unwrap_or(99)
}

fn rings_around(v: u32, adjacency: &[BTreeSet<u32>]) -> BTreeMap<u32, u32> {
    let mut rings = BTreeMap::from([(v, 0)]);
    let mut frontier = vec![v];
    for k in 1..=6 {
        let mut next = Vec::new();
        for u in frontier {
            for &w in &adjacency[u as usize] {
                rings.entry(w).or_insert_with(|| {
                    next.push(w);
                    k
                });
            }
        }
        frontier = next;
    }
    rings
}

fn plane_distance(a: Vec3, b: Vec3, c: Vec3, p: Vec3, eye: Vec3) -> f32 {
    let n = (b - a).cross(c - a).normalize_or_zero();
    let n = if n.dot(eye - a) >= 0.0 { n } else { -n };
    -n.dot(p - a)
}

#[test]
#[ignore]
fn diagnose_bunny_disagreements() {
    let Some((mesh, transform)) = bunny() else {
        return;
    };
    let world: Vec<Vec3> = mesh
        .positions
        .iter()
        .map(|&p| transform.transform_point3(Vec3::from(p)))
        .collect();
    let corner = |t: usize| mesh.triangles[t].map(|i| world[i as usize]);
    let tris: Vec<Triangle> = (0..mesh.triangles.len())
        .map(|t| {
            let [a, b, c] = corner(t);
            Triangle {
                v0: a.into(),
                v1: b.into(),
                v2: c.into(),
            }
        })
        .collect();
    let bvh = build_bvh2_from_tris(&tris, BvhBuildParams::fast_build(), &mut Default::default());
    let n = world.len();
    let mut adjacency = vec![BTreeSet::new(); n];
    for tri in &mesh.triangles {
        for k in 0..3 {
            adjacency[tri[k] as usize].insert(tri[(k + 1) % 3]);
            adjacency[tri[k] as usize].insert(tri[(k + 2) % 3]);
        }
    }
    let tolerance = DepthTolerance::default();
    for distance in [100.0f32, 250.0, 600.0] {
        // tests/analysis.rs's bunny view: a cell-centre eye at `distance`, 1024² tight.
        let view = bunny_view(distance, Some(1024));
        let eye = view.eye;
        let capture = bunny_capture(&mesh, transform, &view);
        let classes = classify(&capture, 7, DEFAULT_T_C0, DEFAULT_T_C1);
        let by_depth = depth_visibility(&mesh, transform, &capture, 7, tolerance);
        let by_rays = visible_by_rays(&mesh, transform, &view, tolerance.footprint_px);
        let width = view.width as i64;
        let mut counts: BTreeMap<String, usize> = BTreeMap::new();
        let mut rows = Vec::new();
        let mut marks = Vec::new();
        let mut inside = 0;
        for v in 0..n {
            if by_depth[v] == DepthVisibility::Outside {
                continue;
            }
            inside += 1;
            let (d, r) = (by_depth[v].is_visible(), by_rays[v]);
            let (mut front, mut back) = (0, 0);
            for tri in mesh.triangles.iter().filter(|t| t.contains(&(v as u32))) {
                let [a, b, c] = tri.map(|i| world[i as usize]);
                if (b - a).cross(c - a).dot(eye - (a + b + c) / 3.0) > 0.0 {
                    front += 1;
                } else {
                    back += 1;
                }
            }
            let kind = match (front, back) {
                (_, 0) => "front",
                (0, _) => "back",
                _ => "contour",
            };
            *counts.entry(format!("all {kind}")).or_default() += 1;
            if d == r {
                continue;
            }
            let p = world[v];
            let point = project_to_pixel(&view, p).unwrap();
            let footprint = pixel_footprint(&view, point.depth);
            let (cx, cy) = (point.x.floor() as i64, point.y.floor() as i64);
            let own = (cy * width + cx) as usize;
            marks.push((own, d));
            // Distance (pixels) to the nearest pixel off the object, within 12.
            let mut off_object = f32::INFINITY;
            for y in (cy - 12).max(0)..=(cy + 12).min(width - 1) {
                for x in (cx - 12).max(0)..=(cx + 12).min(width - 1) {
                    if capture.object_id[(y * width + x) as usize] != 7 {
                        let (dx, dy) = (x as f32 + 0.5 - point.x, y as f32 + 0.5 - point.y);
                        off_object = off_object.min((dx * dx + dy * dy).sqrt());
                    }
                }
            }
            let rings = rings_around(v as u32, &adjacency);
            let seen = if capture.object_id[own] == BACKGROUND_ID {
                "empty".to_string()
            } else {
                let t = capture.triangle_id[own] as usize;
                let [a, b, c] = corner(t);
                format!(
                    "ring {} behind {:.2}",
                    ring_of(mesh.triangles[t], &rings),
                    plane_distance(a, b, c, p, eye) / footprint
                )
            };
            // The crossing nearest to the vertex among non-incident triangles.
            let length = (p - eye).length();
            let ray = Ray::new(eye.into(), Vec3A::from((p - eye) / length), 0.0, length);
            let mut nearest: Option<(f32, usize)> = None;
            bvh.ray_traverse_miss(ray, |ray, id| {
                let t = bvh.primitive_indices[id] as usize;
                if !mesh.triangles[t].contains(&(v as u32)) {
                    let hit = tris[t].intersect(ray);
                    if hit.is_finite() && nearest.is_none_or(|(h, _)| hit > h) {
                        nearest = Some((hit, t));
                    }
                }
                f32::INFINITY
            });
            let met = match nearest {
                None => "nothing".to_string(),
                Some((hit, t)) => {
                    let [a, b, c] = corner(t);
                    format!(
                        "ring {} gap {:.1} off-plane {:.2}",
                        ring_of(mesh.triangles[t], &rings),
                        (length - hit) / footprint,
                        plane_distance(a, b, c, p, eye).abs() / footprint
                    )
                }
            };
            let says = if d {
                "depth visible, rays hidden"
            } else {
                "depth hidden, rays visible"
            };
            *counts
                .entry(format!(
                    "{says}: {kind}, {:?}, {} the outline",
                    classes[own],
                    if off_object < 2.0 {
                        "within 2 px of"
                    } else {
                        "away from"
                    }
                ))
                .or_default() += 1;
            rows.push(format!(
                "v{v} {says}: {kind} (f{front} b{back}), {:?}, {off_object:.2} px from the outline; seen {seen}; ray met {met}",
                classes[own]
            ));
        }
        eprintln!(
            "=== {distance}: {inside} vertices inside, {} disagree ({:.3}% agree)",
            rows.len(),
            100.0 * (inside - rows.len()) as f64 / inside as f64
        );
        for (key, count) in &counts {
            eprintln!("  {count:5} {key}");
        }
        for row in rows.iter().step_by((rows.len() / 30).max(1)) {
            eprintln!("  {row}");
        }
        if let Some(dir) = std::env::var_os("HEXBAKE_PICTURES") {
            let mut image: Vec<u8> = capture
                .color
                .iter()
                .flat_map(|c| [c[0] / 2 + 64, c[1] / 2 + 64, c[2] / 2 + 64])
                .collect();
            for (q, depth_visible) in marks {
                let colour = if depth_visible {
                    [255, 0, 0]
                } else {
                    [0, 80, 255]
                };
                image[q * 3..q * 3 + 3].copy_from_slice(&colour);
            }
            let path = PathBuf::from(dir).join(format!("disagree_{distance}.png"));
            common::write_rgb_png(&path, 1024, 1024, &image);
        }
    }
}
