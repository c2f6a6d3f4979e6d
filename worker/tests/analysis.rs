//! Per-cell analysis of paper 000 §3.1.2–3.1.5 (issue 3 items 2–5): pixel classes,
//! vertex weights, the two visibility oracles, regional back-face culling and the
//! self-occluding error.
//!
//! Captures here do not come from the rasterizer: analytic shapes (spheres, boxes) are
//! ray cast exactly per pixel centre by [`analytic_capture`], meshes through obvhs by
//! `worker::visibility::ray_cast_capture`. Both follow the `raster::View` pixel
//! convention. Tests that need the bunny read it from `$HEXBAKE_MODELS` or
//! `<repo>/models` and skip through `testkit::skip` when it is absent (a failure under
//! `HEXBAKE_REQUIRE_MODELS=1`). Set `HEXBAKE_PICTURES=<dir>`
//! to get the bunny's class maps as PNGs.

mod common;
use common::{apothem, bunny, bunny_capture, bunny_view, look_at, CELL_SIZE, PIXELS_PER_RADIAN};
use glam::{DVec3, Mat4, Vec3};
use proptest::prelude::*;
use scene::park::SplitMix64;
use std::path::PathBuf;
use worker::backface::{
    all_culled, front_facing_from, front_facing_vertices, regional_backface_cull,
};
use worker::classify::{
    classify, classify_objects, ClassCounts, PixelClass, WindowDepth, DEFAULT_T_C0, DEFAULT_T_C1,
};
use worker::raster::{Capture, CullMode, DrawItem, View, BACKGROUND_ID};
use worker::selfocc::{
    choose_representation, object_distance_and_depth, object_self_occluding_error,
    self_occluding_error, transformed_aabb, Representation,
};
use worker::visibility::{
    agreement, agreement_report, pixel_index, project_to_pixel, ray_cast_capture, visible_by_depth,
    visible_by_rays, DepthTolerance,
};
use worker::weights::{vertex_states, vertex_weights, VertexState, INVISIBLE_WEIGHT};

// ---------------------------------------------------------------------------------
// Helpers: views, analytic captures, meshes (the bunny and `look_at`: common).
// ---------------------------------------------------------------------------------

/// A square view at DESIGN.md's angular resolution, `size` pixels wide.
fn design_view(eye: Vec3, target: Vec3, size: u32) -> View {
    look_at(
        eye,
        target,
        size as f32 / PIXELS_PER_RADIAN,
        size,
        size,
        apothem(),
    )
}

#[derive(Clone, Copy)]
enum Shape {
    Sphere { centre: Vec3, radius: f32 },
    Box { min: Vec3, max: Vec3 },
}

/// Exact ray casting of analytic solids into a capture (object id per solid; the
/// triangle id is the box face 0..6 (−x, +x, −y, +y, −z, +z) or 0 for a sphere).
fn analytic_capture(solids: &[(Shape, u32)], view: &View) -> Capture {
    let (w, h) = (view.width as usize, view.height as usize);
    let inverse = (view.proj * view.view).inverse();
    let forward = view
        .view
        .inverse()
        .transform_vector3(Vec3::NEG_Z)
        .normalize();
    let mut capture = Capture {
        view: *view,
        depth: vec![f32::INFINITY; w * h],
        color: vec![[0, 0, 0, 0]; w * h],
        object_id: vec![BACKGROUND_ID; w * h],
        triangle_id: vec![BACKGROUND_ID; w * h],
    };
    for y in 0..h {
        for x in 0..w {
            let ndc_x = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
            let ndc_y = 1.0 - (y as f32 + 0.5) / h as f32 * 2.0;
            let far = inverse.project_point3(Vec3::new(ndc_x, ndc_y, 1.0));
            let o = view.eye.as_dvec3();
            let d = (far - view.eye).normalize().as_dvec3();
            let cosine = d.dot(forward.as_dvec3());
            let mut best: Option<(f64, u32, u32)> = None;
            for &(shape, id) in solids {
                let hit = match shape {
                    Shape::Sphere { centre, radius } => {
                        let oc = o - centre.as_dvec3();
                        let b = oc.dot(d);
                        let c = oc.length_squared() - (radius as f64).powi(2);
                        let disc = b * b - c;
                        (disc >= 0.0).then(|| (-b - disc.sqrt(), 0))
                    }
                    Shape::Box { min, max } => {
                        let (min, max) = (min.as_dvec3(), max.as_dvec3());
                        let mut t_enter = f64::NEG_INFINITY;
                        let mut t_exit = f64::INFINITY;
                        let mut face = 0;
                        for k in 0..3 {
                            let t1 = (min[k] - o[k]) / d[k];
                            let t2 = (max[k] - o[k]) / d[k];
                            let (near, far, near_face) = if t1 < t2 {
                                (t1, t2, 2 * k as u32)
                            } else {
                                (t2, t1, 2 * k as u32 + 1)
                            };
                            if near > t_enter {
                                t_enter = near;
                                face = near_face;
                            }
                            t_exit = t_exit.min(far);
                        }
                        (t_enter <= t_exit).then_some((t_enter, face))
                    }
                };
                if let Some((t, tri)) = hit {
                    let depth = t * cosine;
                    if depth >= view.near as f64 && best.is_none_or(|(b, _, _)| depth < b) {
                        best = Some((depth, id, tri));
                    }
                }
            }
            if let Some((depth, id, tri)) = best {
                let i = y * w + x;
                capture.depth[i] = depth as f32;
                capture.object_id[i] = id;
                capture.triangle_id[i] = tri;
                capture.color[i] = [200, 200, 200, 255];
            }
        }
    }
    capture
}

fn class_char(class: PixelClass) -> char {
    match class {
        PixelClass::Background => '.',
        PixelClass::ExteriorSilhouette => 'E',
        PixelClass::InteriorSilhouette => 'C',
        PixelClass::SharpEdge => 'S',
        PixelClass::Interior => 'i',
    }
}

fn class_map_text(classes: &[PixelClass], width: usize) -> Vec<String> {
    classes
        .chunks(width)
        .map(|row| row.iter().map(|&c| class_char(c)).collect())
        .collect()
}

/// A mesh from positions and CCW triangles, smooth area-weighted normals, grey albedo.
fn mesh_from(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> format::Mesh {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in &triangles {
        let [a, b, c] = t.map(|i| Vec3::from(positions[i as usize]));
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    format::Mesh {
        normals: normals
            .iter()
            .map(|n| n.normalize_or(Vec3::Y).to_array())
            .collect(),
        albedo: vec![[180, 180, 180, 255]; positions.len()],
        positions,
        triangles,
    }
}

/// An axis-aligned box as 8 shared vertices and 12 outward CCW triangles.
fn box_mesh(min: Vec3, max: Vec3) -> format::Mesh {
    let p = |x: bool, y: bool, z: bool| {
        [
            if x { max.x } else { min.x },
            if y { max.y } else { min.y },
            if z { max.z } else { min.z },
        ]
    };
    // Vertex index = x | y<<1 | z<<2.
    let positions: Vec<[f32; 3]> = (0..8)
        .map(|i| p(i & 1 != 0, i & 2 != 0, i & 4 != 0))
        .collect();
    let quads = [
        [0, 4, 6, 2], // −x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // −y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // −z
        [4, 5, 7, 6], // +z
    ];
    let mut triangles = Vec::new();
    for q in quads {
        triangles.push([q[0], q[1], q[2]]);
        triangles.push([q[0], q[2], q[3]]);
    }
    let mesh = mesh_from(positions, triangles);
    // Every face's normal must point out of the box.
    let centre = (min + max) * 0.5;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| Vec3::from(mesh.positions[i as usize]));
        assert!((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0.0);
    }
    mesh
}

/// A UV sphere with outward CCW triangles.
fn sphere_mesh(centre: Vec3, radius: f32, rings: u32, segments: u32) -> format::Mesh {
    let mut positions = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push((centre + radius * n).to_array());
        }
    }
    let at = |r: u32, s: u32| r * segments + s % segments;
    let mut triangles = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s), at(r + 1, s + 1));
            if r != 0 {
                triangles.push([a, b, c]);
            }
            if r + 1 != rings {
                triangles.push([b, d, c]);
            }
        }
    }
    mesh_from(positions, triangles)
}

fn write_class_png(name: &str, classes: &[PixelClass], width: u32, height: u32) {
    let Some(dir) = std::env::var_os("HEXBAKE_PICTURES") else {
        return;
    };
    let palette = |c: PixelClass| match c {
        PixelClass::Background => [255, 255, 255],
        PixelClass::ExteriorSilhouette => [220, 30, 30],
        PixelClass::InteriorSilhouette => [240, 160, 0],
        PixelClass::SharpEdge => [30, 90, 220],
        PixelClass::Interior => [200, 200, 200],
    };
    let data: Vec<u8> = classes.iter().flat_map(|&c| palette(c)).collect();
    let path = PathBuf::from(dir).join(format!("{name}.png"));
    common::write_rgb_png(&path, width, height, &data);
}

// ---------------------------------------------------------------------------------
// Pixel classes (000 §3.1.3.1).
// ---------------------------------------------------------------------------------

/// Two boxes of one object: the near box's pixels are all interior silhouette (its
/// neighbours on the far box are 40 units farther), the far box's pixels next to it are
/// sharp edges (the second difference spans the jump), the far box's outline is
/// exterior silhouette. Geometry: eye at z = 300 looking down −z, 16×8 pixels of 2
/// units each at the far box's front face (z = 0, depth 300): pixel centres at
/// x = −15, −13, …, 15 and y = 7, 5, …, −7. Far box x, y ∈ [−12, 12] × [−6, 6] → columns
/// 2..=13, rows 1..=6. Near box front face at z = 40 (depth 260), x ∈ [2, 8] and
/// y ∈ [−2, 2], i.e. x ∈ [2.31, 9.23], y ∈ [−2.31, 2.31] scaled to depth 300 →
/// columns 9..=12, rows 3..=4.
fn two_boxes_view() -> View {
    let fov_y = 2.0 * (8.0f32 / 300.0).atan();
    look_at(
        Vec3::new(0.0, 0.0, 300.0),
        Vec3::ZERO,
        fov_y,
        16,
        8,
        apothem(),
    )
}

fn two_boxes(near_id: u32, far_id: u32) -> Capture {
    let far_box = Shape::Box {
        min: Vec3::new(-12.0, -6.0, -10.0),
        max: Vec3::new(12.0, 6.0, 0.0),
    };
    let near_box = Shape::Box {
        min: Vec3::new(2.0, -2.0, 30.0),
        max: Vec3::new(8.0, 2.0, 40.0),
    };
    analytic_capture(&[(far_box, far_id), (near_box, near_id)], &two_boxes_view())
}

#[test]
fn two_boxes_of_one_object_step_is_interior_silhouette() {
    let capture = two_boxes(1, 1);
    let classes = classify(&capture, 1, DEFAULT_T_C0, DEFAULT_T_C1);
    let expected = [
        "................",
        "..EEEEEEEEEEEE..",
        "..EiiiiiiSSSSE..",
        "..EiiiiiSCCCCE..",
        "..EiiiiiSCCCCE..",
        "..EiiiiiiSSSSE..",
        "..EEEEEEEEEEEE..",
        "................",
    ];
    assert_eq!(class_map_text(&classes, 16), expected);
}

/// The same scene with the boxes as two objects: other objects count as background, so
/// each box's coverage contour is its exterior silhouette (the hole the near box cuts
/// in the far box's coverage included — conservative, see classify.rs).
#[test]
fn two_objects_outline_each_other_as_exterior_silhouette() {
    let capture = two_boxes(2, 1);
    let far = class_map_text(&classify(&capture, 1, DEFAULT_T_C0, DEFAULT_T_C1), 16);
    assert_eq!(
        far,
        [
            "................",
            "..EEEEEEEEEEEE..",
            "..EiiiiiiEEEEE..",
            "..EiiiiiE....E..",
            "..EiiiiiE....E..",
            "..EiiiiiiEEEEE..",
            "..EEEEEEEEEEEE..",
            "................",
        ]
    );
    let near = class_map_text(&classify(&capture, 2, DEFAULT_T_C0, DEFAULT_T_C1), 16);
    assert_eq!(
        near,
        [
            "................",
            "................",
            "................",
            ".........EEEE...",
            ".........EEEE...",
            "................",
            "................",
            "................",
        ]
    );
    // A cluster of both behaves like one object.
    let cluster = classify_objects(
        &capture,
        &[1, 2],
        DEFAULT_T_C0,
        DEFAULT_T_C1,
        WindowDepth::of_view(&capture.view),
    );
    let one = classify(&two_boxes(1, 1), 1, DEFAULT_T_C0, DEFAULT_T_C1);
    assert_eq!(cluster, one);
}

/// A cube seen from a general direction 300 units away at the DESIGN.md resolution:
/// its three visible creases are sharp edges, its face centres interior, its outline
/// exterior silhouette, and no face is steep enough for C0 (per-pixel window-depth
/// steps n·p·tan α / z ≤ 43.3 · 1.02e-3 · 1.5 / 300 ≈ 2.2e-4 < T_C0).
#[test]
fn cube_creases_are_sharp_edges_outline_exterior_faces_interior() {
    let eye = Vec3::new(1.0, 0.9, 0.8).normalize() * 300.0;
    let view = design_view(eye, Vec3::ZERO, 128);
    let cube = Shape::Box {
        min: Vec3::splat(-10.0),
        max: Vec3::splat(10.0),
    };
    let capture = analytic_capture(&[(cube, 3)], &view);
    let classes = classify(&capture, 3, DEFAULT_T_C0, DEFAULT_T_C1);
    let class_at = |p: Vec3| {
        let point = project_to_pixel(&view, p).unwrap();
        classes[pixel_index(&view, point).unwrap()]
    };
    let near_corner = Vec3::splat(10.0);
    for end in [
        Vec3::new(-10.0, 10.0, 10.0),
        Vec3::new(10.0, -10.0, 10.0),
        Vec3::new(10.0, 10.0, -10.0),
    ] {
        for f in [0.25f32, 0.5, 0.75] {
            let p = near_corner.lerp(end, f);
            let point = project_to_pixel(&view, p).unwrap();
            let (cx, cy) = (point.x as i32, point.y as i32);
            let mut sharp = 0;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let i = ((cy + dy) * 128 + cx + dx) as usize;
                    assert_ne!(
                        classes[i],
                        PixelClass::Background,
                        "crease pixel off the cube"
                    );
                    sharp += (classes[i] == PixelClass::SharpEdge) as u32;
                }
            }
            assert!(
                sharp >= 1,
                "no sharp edge around the crease point {p} (pixel {cx},{cy})"
            );
        }
    }
    for face_centre in [Vec3::X * 10.0, Vec3::Y * 10.0, Vec3::Z * 10.0] {
        assert_eq!(
            class_at(face_centre),
            PixelClass::Interior,
            "face centre {face_centre}"
        );
    }
    let counts = ClassCounts::of(&classes);
    assert_eq!(counts.get(PixelClass::InteriorSilhouette), 0);
    // Along the image's middle row the first and last covered pixels are the outline.
    let row = &classes[64 * 128..65 * 128];
    let first = row
        .iter()
        .position(|&c| c != PixelClass::Background)
        .unwrap();
    let last = row
        .iter()
        .rposition(|&c| c != PixelClass::Background)
        .unwrap();
    assert_eq!(row[first], PixelClass::ExteriorSilhouette);
    assert_eq!(row[last], PixelClass::ExteriorSilhouette);
    assert_ne!(row[first + 1], PixelClass::ExteriorSilhouette);
    assert_ne!(row[last - 1], PixelClass::ExteriorSilhouette);
    // Sharp edges are the three creases only: a thin band, not the faces.
    let sharp = counts.percent_of_object(PixelClass::SharpEdge);
    assert!(
        sharp > 1.0 && sharp < 15.0,
        "sharp edges are {sharp:.1}% of the cube"
    );
}

/// A sphere 300 units away: its outline is exterior silhouette, everything within 80%
/// of its projected radius is interior (curvature radius 15 ≫ n·p²/T_C1 ≈ 0.36).
#[test]
fn sphere_inside_is_interior() {
    let centre = Vec3::new(0.0, 0.0, 0.0);
    let view = design_view(Vec3::new(0.0, 0.0, 300.0), centre, 128);
    let sphere = Shape::Sphere {
        centre,
        radius: 15.0,
    };
    let capture = analytic_capture(&[(sphere, 5)], &view);
    let classes = classify(&capture, 5, DEFAULT_T_C0, DEFAULT_T_C1);
    let c = project_to_pixel(&view, centre).unwrap();
    let radius_px = 15.0 / (300.0f32 * 300.0 - 225.0).sqrt() * PIXELS_PER_RADIAN;
    let mut inner = 0;
    for y in 0..128 {
        for x in 0..128 {
            let r = ((x as f32 + 0.5 - c.x).powi(2) + (y as f32 + 0.5 - c.y).powi(2)).sqrt();
            let class = classes[y * 128 + x];
            if r < 0.8 * radius_px {
                assert_eq!(
                    class,
                    PixelClass::Interior,
                    "pixel {x},{y} at r = {r:.1} px"
                );
                inner += 1;
            }
            if r > radius_px + 1.0 {
                assert_eq!(class, PixelClass::Background);
            }
        }
    }
    assert!(inner > 2000, "only {inner} inner pixels");
    let counts = ClassCounts::of(&classes);
    assert_eq!(counts.get(PixelClass::SharpEdge), 0);
    assert!(counts.get(PixelClass::ExteriorSilhouette) > 250);
}

/// Window depth is affine on a plane, so a slanted plane has no sharp edges however
/// oblique; a plane filling the image has no exterior silhouette (the image border is
/// not a contour).
#[test]
fn slanted_plane_filling_the_image_is_never_sharp_or_exterior() {
    for eye in [
        Vec3::new(0.0, 0.0, 300.0),
        Vec3::new(150.0, 40.0, 250.0),
        Vec3::new(-60.0, 200.0, 90.0),
    ] {
        let view = design_view(eye, Vec3::ZERO, 64);
        let plane = Shape::Box {
            min: Vec3::new(-500.0, -500.0, -1.0),
            max: Vec3::new(500.0, 500.0, 0.0),
        };
        let capture = analytic_capture(&[(plane, 1)], &view);
        assert!(capture.object_id.iter().all(|&id| id == 1));
        let counts = ClassCounts::of(&classify(&capture, 1, DEFAULT_T_C0, DEFAULT_T_C1));
        assert_eq!(counts.get(PixelClass::SharpEdge), 0, "eye {eye}");
        assert_eq!(counts.get(PixelClass::ExteriorSilhouette), 0, "eye {eye}");
        assert_eq!(counts.get(PixelClass::Background), 0);
    }
}

/// The thresholds apply to window depth of the given near/far: `classify` uses the
/// capture's, `WindowDepth::paper(c)` puts the near plane at the cell's side face.
#[test]
fn window_depth_normalisation_is_the_captures_or_the_papers() {
    let capture = two_boxes(1, 1);
    let paper = WindowDepth::paper(CELL_SIZE);
    assert!((paper.near - apothem()).abs() < 1e-4);
    assert_eq!(
        classify_objects(&capture, &[1], DEFAULT_T_C0, DEFAULT_T_C1, paper),
        classify(&capture, 1, DEFAULT_T_C0, DEFAULT_T_C1)
    );
    // Window-depth difference between depths 260 and 300 with n = 43.3, f = 5000:
    // f/(f−n) · n · (1/260 − 1/300) = 1.00874 · 43.30 · 5.128e-4 = 0.02240.
    let w = WindowDepth::of_view(&capture.view);
    let diff = w.offset_depth(300.0) - w.offset_depth(260.0);
    assert!((diff - 0.02240).abs() < 1e-5, "{diff}");
    // With a near plane 1000× closer the same step is 1000× smaller: below T_C0 it is
    // no interior silhouette any more.
    let tiny_near = WindowDepth {
        near: apothem() * 1e-3,
        far: 5000.0,
    };
    let classes = classify_objects(&capture, &[1], DEFAULT_T_C0, DEFAULT_T_C1, tiny_near);
    assert_eq!(
        ClassCounts::of(&classes).get(PixelClass::InteriorSilhouette),
        0
    );
}

/// The bunny at ≈ 1, 3 and 7 cells (100, 250, 600 units, c = 50) captured at the
/// DESIGN.md resolution with the paper's window depth (near plane at the cell's face):
/// outline, interior silhouettes and creases are marked; from 3 cells on (the paper's
/// SV distances start at 7) the body is mostly interior. At 1 cell, slopes steeper than
/// ≈ 37° already step by more than T_C0 per pixel (classify.rs). Prints the percentages.
#[test]
fn bunny_class_percentages() {
    let Some((mesh, transform)) = bunny() else {
        return;
    };
    let mut results = Vec::new();
    for distance in [100.0f32, 250.0, 600.0] {
        let view = bunny_view(distance, None);
        let capture = bunny_capture(&mesh, transform, &view);
        let classes = classify(&capture, 7, DEFAULT_T_C0, DEFAULT_T_C1);
        write_class_png(
            &format!("bunny-classes-{distance}"),
            &classes,
            view.width,
            view.height,
        );
        let counts = ClassCounts::of(&classes);
        let pct = |c| counts.percent_of_object(c);
        eprintln!(
            "bunny at {distance}: {}² px, {} object px: exterior {:.1}%, interior silhouette {:.1}%, sharp edge {:.1}%, interior {:.1}%",
            view.width,
            counts.object_pixels(),
            pct(PixelClass::ExteriorSilhouette),
            pct(PixelClass::InteriorSilhouette),
            pct(PixelClass::SharpEdge),
            pct(PixelClass::Interior),
        );
        results.push((distance, counts));
    }
    for &(distance, counts) in &results {
        let pct = |c| counts.percent_of_object(c);
        assert!(pct(PixelClass::ExteriorSilhouette) > 0.5);
        assert!(counts.get(PixelClass::InteriorSilhouette) > 0);
        assert!(counts.get(PixelClass::SharpEdge) > 0);
        if distance >= 250.0 {
            assert!(
                pct(PixelClass::Interior) > 70.0,
                "interior only {:.1}% at {distance}",
                pct(PixelClass::Interior)
            );
        }
    }
    // Window depth compresses with distance: the same slope is a smaller step farther
    // away, so interior silhouettes thin out (000's C0 is tuned for its SV distances).
    let c0 = |k: usize| {
        results[k]
            .1
            .percent_of_object(PixelClass::InteriorSilhouette)
    };
    assert!(c0(0) > c0(1) && c0(1) > c0(2));
}

// ---------------------------------------------------------------------------------
// Vertex weights (000 §3.1.3.2) and visibility.
// ---------------------------------------------------------------------------------

#[test]
fn pixel_convention_row_zero_is_the_top() {
    let view = look_at(Vec3::ZERO, Vec3::NEG_Z, 1.0, 100, 50, 1.0);
    let centre = project_to_pixel(&view, Vec3::new(0.0, 0.0, -10.0)).unwrap();
    assert!((centre.x - 50.0).abs() < 1e-4 && (centre.y - 25.0).abs() < 1e-4);
    assert!((centre.depth - 10.0).abs() < 1e-5);
    let up = project_to_pixel(&view, Vec3::new(0.0, 1.0, -10.0)).unwrap();
    assert!(up.y < centre.y, "world up must be a smaller row");
    let right = project_to_pixel(&view, Vec3::new(1.0, 0.0, -10.0)).unwrap();
    assert!(right.x > centre.x);
    assert_eq!(pixel_index(&view, centre), Some(25 * 100 + 50));
    assert!(project_to_pixel(&view, Vec3::new(0.0, 0.0, 10.0)).is_none());
}

/// A cube mesh seen from a general direction: the hidden far corner is back-facing
/// (0.5), the six outline corners are visible on the exterior silhouette (0.5), the
/// near corner where the creases meet is a sharp edge (0.25).
#[test]
fn cube_vertex_weights() {
    let mesh = box_mesh(Vec3::splat(-10.0), Vec3::splat(10.0));
    let eye = Vec3::new(1.0, 0.9, 0.8).normalize() * 300.0;
    let view = design_view(eye, Vec3::ZERO, 128);
    let (_, states, weights) = analyse_whole_mesh(&mesh, &view, 4);
    // Vertex index = x | y<<1 | z<<2 (box_mesh).
    let front = front_facing_vertices(&mesh, Mat4::IDENTITY, eye);
    assert_eq!(front, [false, true, true, true, true, true, true, true]);
    assert_eq!(states[0], VertexState::BackFacing);
    assert_eq!(states[7], VertexState::Visible(PixelClass::SharpEdge));
    for (v, &state) in states.iter().enumerate().take(7).skip(1) {
        assert_eq!(
            state,
            VertexState::Visible(PixelClass::ExteriorSilhouette),
            "vertex {v}"
        );
    }
    assert_eq!(weights, vec![0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.25]);
}

/// `mesh` (untransformed) drawn alone as `object_id` and ray-cast from `view`: the
/// capture and, at the default thresholds and tolerance, the vertex states and
/// weights.
fn analyse_whole_mesh(
    mesh: &format::Mesh,
    view: &View,
    object_id: u32,
) -> (Capture, Vec<VertexState>, Vec<f32>) {
    let item = DrawItem::whole(mesh, object_id);
    let capture = ray_cast_capture(&[item], view, CullMode::None);
    let classes = classify(&capture, object_id, DEFAULT_T_C0, DEFAULT_T_C1);
    let tolerance = DepthTolerance::default();
    let states = vertex_states(
        mesh,
        Mat4::IDENTITY,
        &capture,
        &classes,
        object_id,
        tolerance,
    );
    // As `vertex_weights`.
    let weights = states.iter().map(|s| s.weight()).collect();
    (capture, states, weights)
}

/// A 3×3 vertex grid in the plane z = 0 (spacing 20, centred, facing +z), then the
/// box `lo`..`hi` ([`box_mesh`]) in the same vertex and triangle lists.
fn grid_and_box(lo: Vec3, hi: Vec3) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut positions = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            positions.push([-20.0 + 20.0 * i as f32, -20.0 + 20.0 * j as f32, 0.0]);
        }
    }
    let mut triangles = common::quad_grid_triangles(2);
    let occluder = box_mesh(lo, hi);
    let base = positions.len() as u32;
    positions.extend(occluder.positions.iter().copied());
    triangles.extend(occluder.triangles.iter().map(|t| t.map(|i| i + base)));
    (positions, triangles)
}

/// A grid facing the eye with a box of the same object in front of its middle: the
/// middle vertex is front-facing but hidden (0.05); so is a vertex outside the window.
/// The ray oracle agrees.
#[test]
fn hidden_and_outside_front_facing_vertices_weigh_0_05() {
    // 3×3 grid in the plane z = 0, spacing 20, facing +z; then an occluder box.
    let (mut positions, mut triangles) =
        grid_and_box(Vec3::new(-5.0, -5.0, 20.0), Vec3::new(5.0, 5.0, 30.0));
    // A far-off vertex with its own front-facing triangle, outside the window.
    let off = positions.len() as u32;
    positions.extend([[500.0, 0.0, 0.0], [520.0, 0.0, 0.0], [500.0, 20.0, 0.0]]);
    triangles.push([off, off + 1, off + 2]);
    let mesh = mesh_from(positions, triangles);

    let view = design_view(Vec3::new(0.0, 0.0, 300.0), Vec3::ZERO, 256);
    let (capture, _, weights) = analyse_whole_mesh(&mesh, &view, 9);
    assert_eq!(weights[4], INVISIBLE_WEIGHT, "grid centre behind the box");
    assert_eq!(
        weights[off as usize], INVISIBLE_WEIGHT,
        "outside the window"
    );
    assert_eq!(weights[0], 0.5, "grid corner on the outline");
    assert_eq!(weights[1], 0.5, "grid edge midpoint on the outline");
    let depth = visible_by_depth(
        &mesh,
        Mat4::IDENTITY,
        &capture,
        9,
        DepthTolerance::default(),
    );
    let rays = visible_by_rays(
        &mesh,
        Mat4::IDENTITY,
        &view,
        DepthTolerance::default().footprint_px,
    );
    assert!(!depth[4] && !rays[4]);
    for v in [0, 1, 2, 3, 5, 6, 7, 8] {
        assert!(depth[v] && rays[v], "grid vertex {v}");
    }
    // The occluder's front corners are visible both ways, its back corners not (their
    // triangles face away; the rays pass through the box's front face).
    let base = 9; // the occluder's first vertex, after the grid's
    for v in 0..8u32 {
        let z_front = v & 4 != 0;
        assert_eq!(rays[(base + v) as usize], z_front, "occluder vertex {v}");
        assert_eq!(depth[(base + v) as usize], z_front, "occluder vertex {v}");
    }
}

/// A vertex 0.7 pixel behind an occluding edge is hidden both ways, although its own
/// triangles show in the pixels beside the edge (the depth test reads the surface at its
/// own pixel, not any pixel of the 3×3 showing one of its triangles).
#[test]
fn vertex_just_behind_an_occluding_edge_is_hidden() {
    // A 3×3 grid at z = 0 (spacing 20, facing +z) and a box in front of its left half
    // whose right edge passes 0.7 pixel to the right of the centre vertex in the image.
    let eye = Vec3::new(0.0, 0.0, 300.0);
    let view = design_view(eye, Vec3::ZERO, 256);
    let footprint = worker::visibility::pixel_footprint(&view, 300.0);
    let edge_x = 0.7 * footprint * 270.0 / 300.0; // box front face at depth 270
    let (positions, triangles) =
        grid_and_box(Vec3::new(-30.0, -30.0, 20.0), Vec3::new(edge_x, 30.0, 30.0));
    let mesh = mesh_from(positions, triangles);
    let item = DrawItem::whole(&mesh, 3);
    let capture = ray_cast_capture(&[item], &view, CullMode::None);

    // Preconditions: the centre vertex's own pixel shows the box, the pixel to its
    // right shows one of the vertex's own (grid) triangles.
    let point = project_to_pixel(&view, Vec3::ZERO).unwrap();
    let own = pixel_index(&view, point).unwrap();
    assert!(capture.triangle_id[own] >= 8, "own pixel shows the box");
    assert!(
        capture.triangle_id[own + 1] < 8,
        "right neighbour shows the grid"
    );
    let grid_vertex_4: Vec<u32> = (0..8u32)
        .filter(|&t| mesh.triangles[t as usize].contains(&4))
        .collect();
    assert!(grid_vertex_4.contains(&capture.triangle_id[own + 1]));

    let tolerance = DepthTolerance::default();
    let depth = visible_by_depth(&mesh, Mat4::IDENTITY, &capture, 3, tolerance);
    let rays = visible_by_rays(&mesh, Mat4::IDENTITY, &view, tolerance.footprint_px);
    assert!(!depth[4] && !rays[4], "centre vertex behind the edge");
    for v in [2, 5, 8] {
        assert!(depth[v] && rays[v], "grid vertex {v} right of the box");
    }
    for v in [0, 3, 6] {
        assert!(!depth[v] && !rays[v], "grid vertex {v} behind the box");
    }
}

/// Every front-facing vertex of a convex mesh is visible (the segment from an outside
/// eye meets a convex solid only at the vertex), including those on the contour
/// generator, where the line of sight grazes the surface; every back-facing one is
/// hidden. Both oracles must say so, whatever the sub-pixel position of the contour.
#[test]
fn convex_mesh_front_facing_vertices_are_visible_both_ways() {
    let mesh = sphere_mesh(Vec3::ZERO, 20.0, 48, 96);
    for (eye, size) in [
        (Vec3::new(0.0, 40.0, 300.0), 256),
        (Vec3::new(170.0, -60.0, 90.0), 320),
    ] {
        let view = design_view(eye, Vec3::ZERO, size);
        let item = DrawItem::whole(&mesh, 2);
        let capture = ray_cast_capture(&[item], &view, CullMode::None);
        let tolerance = DepthTolerance::default();
        let front = front_facing_vertices(&mesh, Mat4::IDENTITY, eye);
        let depth = visible_by_depth(&mesh, Mat4::IDENTITY, &capture, 2, tolerance);
        let rays = visible_by_rays(&mesh, Mat4::IDENTITY, &view, tolerance.footprint_px);
        let mut contour = 0;
        for v in 0..mesh.positions.len() {
            assert_eq!(depth[v], front[v], "depth test, vertex {v} from {eye}");
            assert_eq!(rays[v], front[v], "ray oracle, vertex {v} from {eye}");
            let tris = mesh.triangles.iter().filter(|t| t.contains(&(v as u32)));
            let facing: Vec<bool> = tris
                .map(|t| {
                    let [a, b, c] = t.map(|i| Vec3::from(mesh.positions[i as usize]));
                    (b - a).cross(c - a).dot(eye - a) > 0.0
                })
                .collect();
            contour += (facing.contains(&true) && facing.contains(&false)) as usize;
        }
        assert!(contour > 50, "{contour} vertices on the contour generator");
    }
}

/// The depth-buffer test and the ray oracle agree on ≥ 99% of the bunny's vertices
/// from a cell-centre eye at three distances (1024² tight captures; measured 99.13 /
/// 99.10 / 99.06 %; the rest change visibility within a pixel: visibility.rs,
/// "Agreement"). Both oracles also hide thousands of front-facing vertices (the ear,
/// the thigh, the far side): the agreement is not that of the facing rule alone.
#[test]
fn visibility_oracles_agree_on_the_bunny() {
    let Some((mesh, transform)) = bunny() else {
        return;
    };
    for distance in [100.0f32, 250.0, 600.0] {
        let view = bunny_view(distance, Some(1024));
        let capture = bunny_capture(&mesh, transform, &view);
        let report = agreement_report(&mesh, transform, &capture, 7);
        let visible = visible_by_rays(
            &mesh,
            transform,
            &view,
            DepthTolerance::default().footprint_px,
        )
        .iter()
        .filter(|&&v| v)
        .count();
        eprintln!(
            "bunny at {distance}: oracles agree on {:.3}% of {} vertices, {:.3}% of the {} off the contour generator ({visible} visible by rays, {} front-facing hidden both ways)",
            100.0 * report.overall(),
            report.inside,
            100.0 * report.away_from_contours(),
            report.inside - report.contour,
            report.front_facing_hidden,
        );
        assert_eq!(report.inside, mesh.positions.len());
        assert!(report.overall() >= 0.99, "{report:?} at {distance}");
        assert!(
            report.away_from_contours() >= 0.995,
            "{report:?} at {distance}"
        );
        assert!(
            report.front_facing_hidden > mesh.positions.len() / 20,
            "{report:?} at {distance}"
        );
        assert_eq!(agreement(&mesh, transform, &capture, 7), report.overall());
        assert!(visible > mesh.positions.len() / 4 && visible < mesh.positions.len() * 3 / 4);
    }
}

/// Weights of the bunny at the SV distance are a mix of every kind, and deterministic.
#[test]
fn bunny_weights_mix_every_kind() {
    let Some((mesh, transform)) = bunny() else {
        return;
    };
    let view = bunny_view(600.0, None);
    let capture = bunny_capture(&mesh, transform, &view);
    let classes = classify(&capture, 7, DEFAULT_T_C0, DEFAULT_T_C1);
    let states = vertex_states(
        &mesh,
        transform,
        &capture,
        &classes,
        7,
        DepthTolerance::default(),
    );
    let count = |s: VertexState| states.iter().filter(|&&x| x == s).count();
    let n = states.len() as f64;
    eprintln!(
        "bunny at 600: back-facing {:.1}%, exterior {:.1}%, interior silhouette {:.1}%, sharp {:.1}%, interior {:.1}%, invisible {:.1}%",
        100.0 * count(VertexState::BackFacing) as f64 / n,
        100.0 * count(VertexState::Visible(PixelClass::ExteriorSilhouette)) as f64 / n,
        100.0 * count(VertexState::Visible(PixelClass::InteriorSilhouette)) as f64 / n,
        100.0 * count(VertexState::Visible(PixelClass::SharpEdge)) as f64 / n,
        100.0 * count(VertexState::Visible(PixelClass::Interior)) as f64 / n,
        100.0 * count(VertexState::Invisible) as f64 / n,
    );
    for s in [
        VertexState::BackFacing,
        VertexState::Visible(PixelClass::ExteriorSilhouette),
        VertexState::Visible(PixelClass::Interior),
        VertexState::Invisible,
    ] {
        assert!(count(s) > 0, "{s:?}");
    }
    assert_eq!(count(VertexState::Visible(PixelClass::Background)), 0);
    let again = vertex_weights(
        &mesh,
        transform,
        &capture,
        &classes,
        7,
        DepthTolerance::default(),
    );
    assert_eq!(again, states.iter().map(|s| s.weight()).collect::<Vec<_>>());
}

// ---------------------------------------------------------------------------------
// Regional back-face culling (000 §3.1.5).
// ---------------------------------------------------------------------------------

/// The 12 corners of a flat-top hexagonal prism: centre (cx, cz), size c
/// (centre-to-corner), heights h0 < h1. Corner k of the hexagon is at angle 60°·k.
fn prism_corners(cx: f32, cz: f32, c: f32, h0: f32, h1: f32) -> [Vec3; 12] {
    let mut corners = [Vec3::ZERO; 12];
    for k in 0..6 {
        let a = std::f32::consts::PI / 3.0 * k as f32;
        corners[k] = Vec3::new(cx + c * a.cos(), h0, cz + c * a.sin());
        corners[k + 6] = Vec3::new(cx + c * a.cos(), h1, cz + c * a.sin());
    }
    corners
}

/// A uniform point of the prism: one of the hexagon's 6 equal triangles (centre,
/// corner k, corner k+1), a uniform point in it, a uniform height.
fn sample_prism(corners: &[Vec3; 12], rng: &mut SplitMix64) -> DVec3 {
    let bottom: Vec<DVec3> = corners[..6].iter().map(|c| c.as_dvec3()).collect();
    let centre = bottom.iter().sum::<DVec3>() / 6.0;
    let k = ((rng.next_f64() * 6.0) as usize).min(5);
    let (mut u, mut v) = (rng.next_f64(), rng.next_f64());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    let p = centre + u * (bottom[k] - centre) + v * (bottom[(k + 1) % 6] - centre);
    let (h0, h1) = (corners[0].y as f64, corners[6].y as f64);
    DVec3::new(p.x, h0 + rng.next_f64() * (h1 - h0), p.z)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Every triangle culled for a cell is back-facing from 10,000 random points of the
    /// cell's prism (checked independently in f64 with vertex a on the plane).
    #[test]
    fn culled_triangles_face_away_from_the_whole_prism(
        cx in -300.0f32..300.0, cz in -300.0f32..300.0,
        c in 5.0f32..100.0, h0 in 0.0f32..20.0, dh in 0.1f32..30.0,
        triangles in prop::collection::vec(
            prop::array::uniform3(prop::array::uniform3(-400.0f32..400.0)), 1..40),
        angle in 0.0f32..6.3, scale in 0.2f32..3.0,
        tx in -100.0f32..100.0, ty in -50.0f32..50.0, tz in -100.0f32..100.0,
        seed in any::<u64>(),
    ) {
        let corners = prism_corners(cx, cz, c, h0, h0 + dh);
        let positions: Vec<[f32; 3]> = triangles.iter().flatten().copied().collect();
        let tris: Vec<[u32; 3]> = (0..triangles.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let mesh = mesh_from(positions, tris);
        let transform = Mat4::from_translation(Vec3::new(tx, ty, tz))
            * Mat4::from_rotation_y(angle)
            * Mat4::from_scale(Vec3::splat(scale));
        let culled = regional_backface_cull(&mesh, transform, &corners);
        prop_assert_eq!(culled.len(), mesh.triangles.len());
        // The split step's short-circuit agrees with the per-triangle cull.
        prop_assert_eq!(all_culled(&mesh, transform, &corners), culled.iter().all(|&c| c));
        // splitmix64: a tiny deterministic generator for the 10,000 sample points.
        let mut rng = SplitMix64::new(seed);
        let points: Vec<DVec3> = (0..10_000).map(|_| sample_prism(&corners, &mut rng)).collect();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let [a, b, cc] = tri.map(|i| transform.transform_point3(Vec3::from(mesh.positions[i as usize])).as_dvec3());
            let normal = (b - a).cross(cc - a);
            if culled[t] {
                for p in &points {
                    // Back-facing from p: p lies strictly behind the plane.
                    prop_assert!(normal.dot(*p - a) < 0.0, "triangle {} faces {:?}", t, p);
                }
            } else {
                // Kept: front-facing (or edge-on) from at least one corner.
                prop_assert!(corners.iter().any(|k| normal.dot(k.as_dvec3() - a) >= 0.0));
            }
        }
    }
}

/// A sphere 300 units from a cell: the hemisphere facing the cell is kept, the far side
/// culled; from the cell's centre more is back-facing than from the whole cell.
#[test]
fn sphere_far_side_is_culled_for_the_cell() {
    let mesh = sphere_mesh(Vec3::new(300.0, 20.0, 0.0), 20.0, 24, 48);
    let corners = prism_corners(0.0, 0.0, 50.0, 1.0, 2.5);
    let culled = regional_backface_cull(&mesh, Mat4::IDENTITY, &corners);
    let front = front_facing_from(&mesh, Mat4::IDENTITY, Vec3::new(0.0, 1.7, 0.0));
    let n = mesh.triangles.len();
    let culled_count = culled.iter().filter(|&&c| c).count();
    let front_count = front.iter().filter(|&&f| f).count();
    assert!(
        culled_count > n / 3 && culled_count < n / 2,
        "{culled_count} of {n}"
    );
    assert!(
        front_count > n / 3 && front_count < n / 2 + n / 20,
        "{front_count} of {n}"
    );
    // Nothing culled is front-facing from the centre, and the cell keeps strictly more
    // than the centre sees.
    assert!(culled.iter().zip(&front).all(|(&c, &f)| !(c && f)));
    assert!(n - culled_count > front_count);
    // A triangle whose plane cuts the prism is never culled.
    let cutting = mesh_from(
        vec![[0.0, 0.0, 100.0], [10.0, 0.0, 100.0], [0.0, 0.0, -100.0]],
        vec![[0, 1, 2]],
    );
    assert_eq!(
        regional_backface_cull(&cutting, Mat4::from_translation(Vec3::Y * 2.0), &corners),
        vec![false]
    );
}

// ---------------------------------------------------------------------------------
// Self-occluding error (000 §3.1.2).
// ---------------------------------------------------------------------------------

#[test]
fn self_occluding_error_matches_hand_computed_values() {
    // c = 50, d = 300, l = 40, 1024 px: √3·50·40 / (2·300·340) · 1024
    //   = 3464.1016 / 204000 · 1024 = 0.0169809 · 1024 = 17.3884 px.
    let s = self_occluding_error(50.0, 300.0, 40.0, 1024);
    assert!((s - 17.3884).abs() < 1e-3, "{s}");
    assert_eq!(choose_representation(s, 5.0), Representation::Mv);
    // c = 100, d = 500, l = 10: √3·100·10 / (2·500·510) · 1024 = 1732.0508 / 510000 · 1024
    //   = 0.00339618 · 1024 = 3.47769 px → SV at T_s = 5, MV at T_s = 3.
    let s = self_occluding_error(100.0, 500.0, 10.0, 1024);
    assert!((s - 3.47769).abs() < 1e-4, "{s}");
    assert_eq!(choose_representation(s, 5.0), Representation::Sv);
    assert_eq!(choose_representation(s, 3.0), Representation::Mv);
    // The bunny (l ≈ 40) with c = 50, 1024 px becomes SV at T_s = 5 once
    // d(d + 40) > √3·50·40·1024/(2·5) = 354,724, i.e. d > 576 (≈ 7 cells, as Fig. 4).
    assert_eq!(
        choose_representation(self_occluding_error(50.0, 580.0, 40.0, 1024), 5.0),
        Representation::Sv
    );
    assert_eq!(
        choose_representation(self_occluding_error(50.0, 570.0, 40.0, 1024), 5.0),
        Representation::Mv
    );
    // Degenerate inputs: touching the object → ∞ (MV); flat object → 0; NaN → MV.
    assert_eq!(self_occluding_error(50.0, 0.0, 40.0, 1024), f32::INFINITY);
    assert_eq!(self_occluding_error(50.0, 100.0, 0.0, 1024), 0.0);
    assert_eq!(choose_representation(f32::NAN, 5.0), Representation::Mv);
}

#[test]
fn object_distance_and_depth_from_a_box() {
    // Cell centre at the origin, box [300, 340] × [0, 40] × [−10, 10]: the nearest box
    // point is (300, 0, 0) → d = 300. Direction to the box centre (320, 20, 0):
    // u = (0.998053, 0.0623783, 0); l = 0.998053·40 + 0.0623783·40 + 0·20 = 42.4172.
    // s = √3·50·42.4172 / (2·300·342.4172) · 1024 = 18.3091 px.
    let (lo, hi) = (Vec3::new(300.0, 0.0, -10.0), Vec3::new(340.0, 40.0, 10.0));
    let (d, l) = object_distance_and_depth(Vec3::ZERO, lo, hi);
    assert!(
        (d - 300.0).abs() < 1e-4 && (l - 42.4172).abs() < 1e-3,
        "{d} {l}"
    );
    let s = object_self_occluding_error(50.0, 1024, Vec3::ZERO, lo, hi);
    assert!((s - 18.3091).abs() < 1e-3, "{s}");
    // Inside the box → MV whatever the tolerance.
    assert_eq!(
        object_self_occluding_error(50.0, 1024, Vec3::new(320.0, 5.0, 0.0), lo, hi),
        f32::INFINITY
    );
    // A box rotated 90° about y: its world box swaps the x and z extents.
    let (wlo, whi) = transformed_aabb(
        Vec3::new(-1.0, 0.0, -3.0),
        Vec3::new(1.0, 2.0, 3.0),
        Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2),
    );
    assert!(
        (wlo - Vec3::new(-3.0, 0.0, -1.0)).abs().max_element() < 1e-5,
        "{wlo}"
    );
    assert!(
        (whi - Vec3::new(3.0, 2.0, 1.0)).abs().max_element() < 1e-5,
        "{whi}"
    );
}
