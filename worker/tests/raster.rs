//! Software rasterizer tests (issue 3 item 1; paper 000 §3.1.3 captures).
//!
//! Set `HEXBAKE_PNG_DIR=/some/dir` to keep PNGs of the golden captures for a person
//! to look at.

mod common;
use common::in_pool;
use format::Mesh;
use glam::{Mat4, Vec2, Vec3, Vec4};
use proptest::prelude::*;
use std::path::PathBuf;
use worker::raster::{render, Capture, CullMode, DrawItem, View, BACKGROUND_ID};
use worker::shade::{linear_to_srgb, LIGHT_DIR, SKY};
use worker::view::frustum;

// ---------------------------------------------------------------- helpers

fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn hash_depth(c: &Capture) -> u64 {
    fnv1a(c.depth.iter().flat_map(|d| d.to_le_bytes()))
}
fn hash_ids(c: &Capture) -> u64 {
    fnv1a(
        c.object_id
            .iter()
            .chain(c.triangle_id.iter())
            .flat_map(|d| d.to_le_bytes()),
    )
}
fn hash_color(c: &Capture) -> u64 {
    fnv1a(c.color.iter().flatten().copied())
}

/// Writes colour, depth and object-id PNGs when `HEXBAKE_PNG_DIR` is set.
fn maybe_write_pngs(name: &str, c: &Capture) {
    let Some(dir) = std::env::var_os("HEXBAKE_PNG_DIR") else {
        return;
    };
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (c.view.width, c.view.height);
    let write = |suffix: &str, rgba: Vec<u8>| {
        let f = std::fs::File::create(dir.join(format!("{name}-{suffix}.png"))).unwrap();
        let mut enc = png::Encoder::new(std::io::BufWriter::new(f), w, h);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header().unwrap().write_image_data(&rgba).unwrap();
    };
    write("color", c.color.iter().flatten().copied().collect());
    let (lo, hi) = c
        .depth
        .iter()
        .filter(|d| d.is_finite())
        .fold((f32::INFINITY, 0.0f32), |(a, b), &d| (a.min(d), b.max(d)));
    write(
        "depth",
        c.depth
            .iter()
            .flat_map(|&d| {
                let g = if d.is_finite() {
                    (255.0 * (1.0 - (d - lo) / (hi - lo).max(1e-6))) as u8
                } else {
                    0
                };
                [g, g, g, 255]
            })
            .collect(),
    );
    write(
        "id",
        c.object_id
            .iter()
            .zip(&c.triangle_id)
            .flat_map(|(&o, &t)| {
                if o == BACKGROUND_ID {
                    [0, 0, 0, 255]
                } else {
                    let h = fnv1a(o.to_le_bytes().into_iter().chain(t.to_le_bytes()));
                    [h as u8, (h >> 8) as u8, (h >> 16) as u8, 255]
                }
            })
            .collect(),
    );
}

/// Procedural albedo over object-space position (a stand-in for the loaders').
fn pattern(p: Vec3) -> [u8; 4] {
    let s = ((p.x * 3.0).floor() + (p.y * 3.0).floor() + (p.z * 3.0).floor()) as i32;
    if s.rem_euclid(2) == 0 {
        [200, 120, 60, 255]
    } else {
        [90, 160, 220, 255]
    }
}

fn finish(positions: Vec<[f32; 3]>, normals: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Mesh {
    let albedo = positions.iter().map(|&p| pattern(Vec3::from(p))).collect();
    Mesh {
        positions,
        normals,
        albedo,
        triangles,
    }
}

/// The triangle (−h, −h, z), (h, −h, z), (0, h, z): counter-clockwise seen from +z,
/// normals +z.
fn upright_triangle(h: f32, z: f32) -> Mesh {
    finish(
        vec![[-h, -h, z], [h, -h, z], [0.0, h, z]],
        vec![[0.0, 0.0, 1.0]; 3],
        vec![[0, 1, 2]],
    )
}

/// Axis-aligned box with flat normals (24 vertices), counter-clockwise from outside.
fn box_mesh(lo: Vec3, hi: Vec3) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    let corners = worker::view::box_corners(lo, hi);
    // Each face: 4 corner indices counter-clockwise seen from outside, and its normal.
    let faces: [([usize; 4], Vec3); 6] = [
        ([0, 4, 6, 2], -Vec3::X),
        ([1, 3, 7, 5], Vec3::X),
        ([0, 1, 5, 4], -Vec3::Y),
        ([2, 6, 7, 3], Vec3::Y),
        ([0, 2, 3, 1], -Vec3::Z),
        ([4, 5, 7, 6], Vec3::Z),
    ];
    for (quad, n) in faces {
        let base = positions.len() as u32;
        for i in quad {
            positions.push(corners[i].to_array());
            normals.push(n.to_array());
        }
        triangles.push([base, base + 1, base + 2]);
        triangles.push([base, base + 2, base + 3]);
    }
    finish(positions, normals, triangles)
}

/// UV sphere, smooth normals, counter-clockwise from outside.
fn sphere_mesh(centre: Vec3, r: f32, stacks: u32, slices: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=stacks {
        let phi = std::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let th = 2.0 * std::f32::consts::PI * j as f32 / slices as f32;
            let n = Vec3::new(phi.sin() * th.cos(), phi.cos(), phi.sin() * th.sin());
            positions.push((centre + r * n).to_array());
            normals.push(n.to_array());
        }
    }
    let mut triangles = Vec::new();
    let row = slices + 1;
    for i in 0..stacks {
        for j in 0..slices {
            let a = i * row + j;
            let b = a + row;
            if i != 0 {
                triangles.push([a, a + 1, b]);
            }
            if i + 1 != stacks {
                triangles.push([a + 1, b + 1, b]);
            }
        }
    }
    finish(positions, normals, triangles)
}

fn item(mesh: &Mesh, object_id: u32) -> DrawItem<'_> {
    DrawItem::whole(mesh, object_id)
}

/// A view with an exact pixel mapping: eye at the origin looking down −z, a 90°
/// symmetric frustum, so a point (x, y, −size/2) lands on pixel (x + size/2,
/// size/2 − y) exactly (all factors are powers of two).
fn exact_view(size: u32) -> View {
    View {
        eye: Vec3::ZERO,
        view: Mat4::IDENTITY,
        proj: frustum(-1.0, 1.0, -1.0, 1.0, 1.0, 1000.0),
        near: 1.0,
        far: 1000.0,
        width: size,
        height: size,
    }
}

fn golden_view() -> View {
    View::look_at_fov(
        Vec3::new(2.2, 1.7, 3.1),
        Vec3::ZERO,
        Vec3::Y,
        45.0,
        64,
        64,
        0.5,
        50.0,
    )
    .unwrap()
}

// ---------------------------------------------------------------- coverage

/// Counts pixels covered by each triangle of `mesh` rendered alone.
fn coverage_per_pixel(view: &View, mesh: &Mesh) -> Vec<u32> {
    let mut count = vec![0u32; (view.width * view.height) as usize];
    for k in 0..mesh.triangles.len() as u32 {
        let subset = [k];
        let it = DrawItem {
            triangles: Some(&subset),
            ..item(mesh, 0)
        };
        let c = render(view, &[it], CullMode::None);
        for (n, &id) in count.iter_mut().zip(&c.triangle_id) {
            if id != BACKGROUND_ID {
                assert_eq!(id, k);
                *n += 1;
            }
        }
    }
    count
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Total covered pixel count of random triangles matches their analytic area
    /// within 1%, and each triangle is within a boundary-sized error.
    #[test]
    fn covered_area_matches_analytic_area(coords in prop::collection::vec(-60.0f32..60.0, 18 * 6)) {
        let view = exact_view(128);
        let mut total_px = 0.0f64;
        let mut total_area = 0.0f64;
        for t in coords.chunks(6) {
            let p = [Vec2::new(t[0], t[1]), Vec2::new(t[2], t[3]), Vec2::new(t[4], t[5])];
            let area = ((p[1] - p[0]).perp_dot(p[2] - p[0]) / 2.0).abs() as f64;
            let perimeter = (p[0].distance(p[1]) + p[1].distance(p[2]) + p[2].distance(p[0])) as f64;
            let mesh = finish(
                p.iter().map(|q| [q.x, q.y, -64.0]).collect(),
                vec![[0.0, 0.0, 1.0]; 3],
                vec![[0, 1, 2]],
            );
            let c = render(&view, &[item(&mesh, 0)], CullMode::None);
            let px = c.covered_pixels() as f64;
            prop_assert!((px - area).abs() <= 0.75 * perimeter + 2.0, "area {area} px {px} perimeter {perimeter}");
            total_px += px;
            total_area += area;
        }
        prop_assert!((total_px - total_area).abs() <= 0.01 * total_area, "{total_px} vs {total_area}");
    }

    /// A square tiled by triangles with random interior vertices (snapped to the
    /// half-pixel lattice so that many edges and vertices fall exactly on pixel
    /// centres) covers each pixel centre inside exactly once: no cracks, no double
    /// writes.
    #[test]
    fn shared_edges_cover_each_pixel_exactly_once(jitter in prop::collection::vec((-6i32..=6, -6i32..=6), 25), flip in prop::collection::vec(any::<bool>(), 32)) {
        let view = exact_view(64);
        // A 5×5 vertex lattice over [-24, 24]², interior vertices jittered by half pixels.
        let mut positions = Vec::new();
        for j in 0..5 {
            for i in 0..5 {
                let (mut x, mut y) = (-24.0 + 12.0 * i as f32, -24.0 + 12.0 * j as f32);
                if (1..4).contains(&i) && (1..4).contains(&j) {
                    let (dx, dy) = jitter[j * 5 + i];
                    x += dx as f32 * 0.5;
                    y += dy as f32 * 0.5;
                }
                positions.push([x, y, -32.0]);
            }
        }
        let mut triangles = Vec::new();
        for j in 0..4u32 {
            for i in 0..4u32 {
                let a = j * 5 + i;
                let (b, c, d) = (a + 1, a + 6, a + 5);
                if flip[(j * 4 + i) as usize] {
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                } else {
                    triangles.push([a, b, d]);
                    triangles.push([b, c, d]);
                }
            }
        }
        let mesh = finish(positions, vec![[0.0, 0.0, 1.0]; 25], triangles);
        let count = coverage_per_pixel(&view, &mesh);
        for y in 0..64 {
            for x in 0..64 {
                let n = count[y * 64 + x];
                // The square spans pixels [8, 56) on both axes (its edges lie on
                // pixel boundaries, not centres).
                let inside = (8..56).contains(&x) && (8..56).contains(&y);
                prop_assert_eq!(n, inside as u32, "pixel ({}, {})", x, y);
            }
        }
        // And the whole mesh in one render covers the same pixels.
        let c = render(&view, &[item(&mesh, 0)], CullMode::None);
        for (n, id) in count.iter().zip(&c.triangle_id) {
            prop_assert_eq!(*n == 1, *id != BACKGROUND_ID);
        }
    }
}

#[test]
fn fan_around_a_pixel_centre_vertex_covers_it_once() {
    // 8 triangles around a vertex placed exactly on a pixel centre, with spokes
    // exactly through pixel centres (horizontal, vertical, diagonal).
    let view = exact_view(32);
    let centre = [0.5f32, 0.5]; // pixel (16, 15)'s centre: x + 16 = 16.5, 16 − y = 15.5
    let mut positions = vec![[centre[0], centre[1], -16.0]];
    for k in 0..8 {
        let a = std::f32::consts::FRAC_PI_4 * k as f32;
        let (dx, dy) = (a.cos().round() * 6.0, a.sin().round() * 6.0);
        positions.push([centre[0] + dx, centre[1] + dy, -16.0]);
    }
    let triangles = (0..8u32).map(|k| [0, 1 + k, 1 + (k + 1) % 8]).collect();
    let mesh = finish(positions, vec![[0.0, 0.0, 1.0]; 9], triangles);
    let count = coverage_per_pixel(&view, &mesh);
    assert!(count.iter().all(|&n| n <= 1), "a pixel written twice");
    assert_eq!(count[15 * 32 + 16], 1);
    assert_eq!(
        count.iter().sum::<u32>(),
        12 * 12,
        "the 12×12 square of centres it spans"
    );
}

// ---------------------------------------------------------------- clipping, culling

#[test]
fn triangle_through_the_eye_plane_is_clipped_not_dropped() {
    // A floor triangle under the eye reaching from behind the eye (z = +20) to far
    // ahead (z = −100): its visible part must be drawn, with the right depth.
    let mesh = finish(
        vec![[-50.0, -1.0, 20.0], [50.0, -1.0, 20.0], [0.0, -1.0, -100.0]],
        vec![[0.0, 1.0, 0.0]; 3],
        vec![[0, 1, 2]],
    );
    let view = View::look_at_fov(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1, 1000.0).unwrap();
    let c = render(&view, &[item(&mesh, 7)], CullMode::Back);
    // Above the horizon: sky; the bottom row (closest to the eye): floor.
    assert!((0..64).all(|x| c.object_id[c.index(x, 0)] == BACKGROUND_ID));
    assert!((20..44).all(|x| c.object_id[c.index(x, 63)] == 7));
    assert!(c.covered_pixels() > 64 * 20);
    for (x, y) in [(32, 63), (10, 60), (40, 40)] {
        let i = c.index(x, y);
        let d = view.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
        let t = -1.0 / d.y;
        let expected = t * -d.z;
        assert!(
            (c.depth[i] - expected).abs() < 1e-3 * expected,
            "({x},{y}): {} vs {expected}",
            c.depth[i]
        );
    }
    // Entirely behind the eye: nothing.
    let behind = finish(
        vec![[-5.0, -1.0, 5.0], [5.0, -1.0, 5.0], [0.0, 1.0, 5.0]],
        vec![[0.0, 0.0, 1.0]; 3],
        vec![[0, 1, 2]],
    );
    assert_eq!(
        render(&view, &[item(&behind, 1)], CullMode::None).covered_pixels(),
        0
    );
}

#[test]
fn back_faces_are_culled_only_when_asked() {
    let view = exact_view(32);
    // Counter-clockwise seen from the eye (front) and its mirror (back).
    let front = upright_triangle(8.0, -16.0);
    let mut back = front.clone();
    back.triangles = vec![[0, 2, 1]];
    assert!(render(&view, &[item(&front, 0)], CullMode::Back).covered_pixels() > 50);
    assert_eq!(
        render(&view, &[item(&back, 0)], CullMode::Back).covered_pixels(),
        0
    );
    let a = render(&view, &[item(&front, 0)], CullMode::None);
    let b = render(&view, &[item(&back, 0)], CullMode::None);
    assert_eq!(a.object_id, b.object_id);
}

#[test]
fn nearer_surface_wins_and_equal_depth_goes_to_the_first_item() {
    let view = exact_view(32);
    let near = box_mesh(Vec3::new(-4.0, -4.0, -12.0), Vec3::new(4.0, 4.0, -10.0));
    let far = box_mesh(Vec3::new(-8.0, -8.0, -20.0), Vec3::new(8.0, 8.0, -18.0));
    let c = render(&view, &[item(&far, 2), item(&near, 1)], CullMode::Back);
    assert_eq!(c.object_id[c.index(16, 16)], 1);
    assert!((c.depth[c.index(16, 16)] - 10.0).abs() < 1e-4);
    assert_eq!(c.object_id[c.index(9, 9)], 2);
    assert!((c.depth[c.index(9, 9)] - 18.0).abs() < 1e-4);
    // Two copies at exactly the same place: the lower item index wins everywhere.
    let s = sphere_mesh(Vec3::new(0.0, 0.0, -20.0), 10.0, 12, 16);
    for order in [[5, 9], [9, 5]] {
        let c = render(
            &view,
            &[item(&s, order[0]), item(&s, order[1])],
            CullMode::Back,
        );
        assert!(c.covered_pixels() > 100);
        assert!(c
            .object_id
            .iter()
            .all(|&o| o == order[0] || o == BACKGROUND_ID));
    }
}

// ---------------------------------------------------------------- interpolation

#[test]
fn perspective_correct_albedo_on_a_grazing_quad() {
    // A floor quad from z = −2 to z = −60 under the eye; albedo black at the near
    // edge and white at the far edge; normals towards the light so the shading
    // factor is exactly 1 and the pixel colour is the interpolated albedo.
    let (z0, z1) = (-2.0f32, -60.0f32);
    let positions = vec![
        [-30.0, -1.0, z0],
        [30.0, -1.0, z0],
        [30.0, -1.0, z1],
        [-30.0, -1.0, z1],
    ];
    let mesh = Mesh {
        positions,
        normals: vec![LIGHT_DIR.to_array(); 4],
        albedo: vec![
            [0, 0, 0, 255],
            [0, 0, 0, 255],
            [255, 255, 255, 255],
            [255, 255, 255, 255],
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let view = View::look_at_fov(
        Vec3::ZERO,
        Vec3::new(0.0, -0.3, -1.0),
        Vec3::Y,
        60.0,
        96,
        96,
        0.1,
        100.0,
    )
    .unwrap();
    let c = render(&view, &[item(&mesh, 0)], CullMode::Back);
    let mut checked = 0;
    let mut affine_would_fail = false;
    for y in (0..96).step_by(5) {
        for x in (20..76).step_by(7) {
            let i = c.index(x, y);
            if c.object_id[i] == BACKGROUND_ID {
                continue;
            }
            let d = view.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            let hit = d * (-1.0 / d.y);
            let s = (hit.z - z0) / (z1 - z0); // linear albedo at the hit point
            let expected = linear_to_srgb(s);
            let got = c.color[i][0];
            assert!(
                (got as i32 - expected as i32).abs() <= 1,
                "({x},{y}): {got} vs {expected}"
            );
            // Screen-space (affine) interpolation along the quad would give the
            // fraction of the screen distance between the near and far edges.
            let sy = |z: f32| view.project(Vec3::new(hit.x, -1.0, z)).unwrap().0.y;
            let affine = (y as f32 + 0.5 - sy(z0)) / (sy(z1) - sy(z0));
            if (linear_to_srgb(affine.clamp(0.0, 1.0)) as i32 - expected as i32).abs() > 10 {
                affine_would_fail = true;
            }
            checked += 1;
        }
    }
    assert!(checked > 30, "only {checked} pixels checked");
    assert!(
        affine_would_fail,
        "the scene does not tell perspective from affine"
    );
}

#[test]
fn lit_colour_follows_the_design_formula() {
    // One big triangle facing +z with uniform albedo: colour = albedo·(0.3 + 0.7·n·L).
    let view = exact_view(16);
    let mut mesh = upright_triangle(6.0, -8.0);
    mesh.albedo = vec![[188, 188, 188, 255]; 3];
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let c = render(
        &view,
        &[DrawItem {
            tint,
            ..item(&mesh, 0)
        }],
        CullMode::Back,
    );
    let lin = worker::shade::srgb_to_linear(188);
    let f = 0.3 + 0.7 * LIGHT_DIR.z;
    let expected = [lin * f, lin * 0.5 * f, lin * 0.25 * f].map(linear_to_srgb);
    assert_eq!(&c.color[c.index(8, 8)][..3], &expected);
    assert_eq!(c.color[0], SKY, "corner pixel is sky");
}

// ---------------------------------------------------------------- views

#[test]
fn off_axis_window_maps_to_the_image_corners() {
    // A cell side face seen from a point that is not in front of its centre.
    let window = [
        Vec3::new(10.0, 1.0, -5.0),
        Vec3::new(10.0, 1.0, 5.0),
        Vec3::new(10.0, 9.0, 5.0),
        Vec3::new(10.0, 9.0, -5.0),
    ];
    let eye = Vec3::new(2.0, 3.0, 1.0);
    let view = View::off_axis(eye, window, 100, 80, 0.5, 500.0).unwrap();
    let mut seen = Vec::new();
    for p in window {
        let (s, depth) = view.project(p).unwrap();
        assert!((depth - 8.0).abs() < 1e-4, "window plane at distance 8");
        seen.push((s.x.round() as i32, s.y.round() as i32));
        assert!((s.x - s.x.round()).abs() < 1e-3 && (s.y - s.y.round()).abs() < 1e-3);
    }
    seen.sort();
    assert_eq!(seen, vec![(0, 0), (0, 80), (100, 0), (100, 80)]);
    // The window's own quad fills the whole image.
    let mesh = finish(
        window.iter().map(|p| p.to_array()).collect(),
        vec![[-1.0, 0.0, 0.0]; 4],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let c = render(&view, &[item(&mesh, 3)], CullMode::None);
    assert_eq!(c.covered_pixels(), 100 * 80);
}

#[test]
fn tight_view_has_the_capture_resolution_and_holds_the_box() {
    let (lo, hi) = (Vec3::new(40.0, 0.0, -6.0), Vec3::new(52.0, 15.0, 6.0));
    let eye = Vec3::new(0.0, 5.0, 0.0);
    let view = View::tight_around(eye, lo, hi, 1024).unwrap();
    // Angular extent × 1024 / (π/3) pixels: the box spans about 2·atan(6/40) ≈ 17°
    // horizontally (its near face is the widest), i.e. about 290 px.
    assert!((280..=300).contains(&view.width), "{}", view.width);
    let mut lo_px = Vec2::splat(f32::INFINITY);
    let mut hi_px = Vec2::splat(f32::NEG_INFINITY);
    for p in worker::view::box_corners(lo, hi) {
        let (s, depth) = view.project(p).unwrap();
        assert!(depth >= view.near && depth <= view.far);
        lo_px = lo_px.min(s);
        hi_px = hi_px.max(s);
    }
    assert!(lo_px.x.abs() < 1e-2 && lo_px.y.abs() < 1e-2);
    assert!(
        (hi_px.x - view.width as f32).abs() < 1e-2 && (hi_px.y - view.height as f32).abs() < 1e-2
    );
    // A box around the eye cannot be captured this way.
    assert!(View::tight_around(Vec3::ZERO, Vec3::splat(-1.0), Vec3::ONE, 1024).is_err());
}

/// Issue 29: a long wall beside the eye, off to one side, reaches behind the plane
/// through the eye across the axis to its centre; the view turns towards its
/// nearest point and still holds the whole box in front of the eye.
#[test]
fn tight_view_frames_a_long_box_beside_the_eye() {
    let (lo, hi) = (Vec3::new(-100.0, 0.0, 44.0), Vec3::new(1900.0, 8.0, 45.0));
    let eye = Vec3::new(0.0, 4.0, 0.0);
    let view = View::tight_around(eye, lo, hi, 256).unwrap();
    for p in worker::view::box_corners(lo, hi) {
        let (s, depth) = view.project(p).unwrap();
        assert!(
            depth >= view.near && depth <= view.far,
            "{p:?}: depth {depth}"
        );
        assert!(s.x > -0.5 && s.x < view.width as f32 + 0.5, "{p:?}: {s:?}");
        assert!(s.y > -0.5 && s.y < view.height as f32 + 0.5, "{p:?}: {s:?}");
    }
    // The eye straight above a wide slab: looking down.
    let view = View::tight_around(
        Vec3::new(0.0, 4.0, 0.0),
        Vec3::new(-30.0, -1.0, -30.0),
        Vec3::new(30.0, 1.0, 30.0),
        64,
    )
    .unwrap();
    assert!(view.near > 2.0 && view.near < 3.0, "{}", view.near);
}

// ---------------------------------------------------------------- goldens

fn golden_scenes() -> Vec<(&'static str, Capture)> {
    let view = golden_view();
    let cube = box_mesh(Vec3::splat(-0.7), Vec3::splat(0.7));
    let sphere = sphere_mesh(Vec3::ZERO, 0.9, 16, 24);
    let a = box_mesh(Vec3::new(-1.2, -0.6, -1.4), Vec3::new(-0.2, 0.8, -0.4));
    let b = box_mesh(Vec3::new(0.0, -0.5, 0.3), Vec3::new(0.9, 0.3, 1.0));
    vec![
        ("cube", render(&view, &[item(&cube, 1)], CullMode::Back)),
        ("sphere", render(&view, &[item(&sphere, 2)], CullMode::Back)),
        (
            "two-boxes",
            render(&view, &[item(&a, 3), item(&b, 4)], CullMode::Back),
        ),
    ]
}

/// Exact hashes (FNV-1a 64) of depth, ids and colour of the 64² golden captures,
/// recorded after looking at their PNGs.
const GOLDEN: [(&str, u64, u64, u64); 3] = [
    (
        "cube",
        0x8e8e29b5bfd4c5f8,
        0x5ef09a41ecbd375f,
        0x9c46a39870a54b7e,
    ),
    (
        "sphere",
        0xf1cf485cfc754f48,
        0x57bdae5cdf37cbc2,
        0x363fc7f3fd10cbb0,
    ),
    (
        "two-boxes",
        0x7db7dd8876bcb7c5,
        0x77ef3d0b5fbf3f51,
        0x252a2e1dd16e433c,
    ),
];

#[test]
fn golden_captures_hash_exactly() {
    let mut mismatches = Vec::new();
    for ((name, c), (gname, gd, gi, gc)) in golden_scenes().iter().zip(GOLDEN) {
        assert_eq!(*name, gname);
        maybe_write_pngs(name, c);
        let got = (hash_depth(c), hash_ids(c), hash_color(c));
        if got != (gd, gi, gc) {
            mismatches.push(format!(
                "(\"{name}\", {:#018x}, {:#018x}, {:#018x}),",
                got.0, got.1, got.2
            ));
        }
    }
    assert!(
        mismatches.is_empty(),
        "golden hashes changed:\n{}",
        mismatches.join("\n")
    );
}

#[test]
fn golden_scenes_have_the_expected_structure() {
    // Independent of the hashes: what a person checks in the PNGs.
    let scenes = golden_scenes();
    let view = golden_view();
    for (name, c) in &scenes {
        assert!(c.covered_pixels() > 400, "{name}");
        assert_eq!(c.color[0], SKY, "{name}: corner is sky");
        let centre = c.index(32, 32);
        assert_ne!(c.object_id[centre], BACKGROUND_ID, "{name}: centre covered");
    }
    // The cube's nearest corner (0.7, 0.7, 0.7) projects where the depth is smallest.
    let cube = &scenes[0].1;
    let (s, d) = view.project(Vec3::splat(0.7)).unwrap();
    let i = cube.index(s.x as u32, s.y as u32);
    let min = cube.depth.iter().cloned().fold(f32::INFINITY, f32::min);
    assert!((cube.depth[i] - d).abs() < 0.05 && (min - d).abs() < 0.05);
    // Sphere depth at the centre pixel: distance to the surface along the ray.
    let sphere = &scenes[1].1;
    let dir = view.ray_dir(32.5, 32.5);
    let (o, r) = (view.eye, 0.9f32);
    let b = o.dot(dir);
    let t = -b - (b * b - (o.length_squared() - r * r)).sqrt();
    let fwd = (Vec3::ZERO - view.eye).normalize();
    // The tessellation lies inside the sphere, by at most r·(1 − cos(π/16)).
    let excess = sphere.depth[sphere.index(32, 32)] - t * dir.dot(fwd);
    assert!((-1e-4..0.02).contains(&excess), "{excess}");
    // Two boxes: both visible, the nearer (b, towards the eye) occludes part of a.
    let two = &scenes[2].1;
    let n3 = two.object_id.iter().filter(|&&o| o == 3).count();
    let n4 = two.object_id.iter().filter(|&&o| o == 4).count();
    assert!(n3 > 100 && n4 > 100, "{n3} {n4}");
}

// ---------------------------------------------------------------- determinism

#[test]
fn output_is_identical_for_any_thread_count() {
    // Enough triangles for many setup chunks and bands, overlapping objects at equal
    // depth, a near-clipped floor and triangles larger than a band.
    let sphere = sphere_mesh(Vec3::new(0.0, 1.0, 0.0), 1.0, 120, 160);
    let floor = finish(
        vec![
            [-40.0, 0.0, 40.0],
            [40.0, 0.0, 40.0],
            [40.0, 0.0, -40.0],
            [-40.0, 0.0, -40.0],
        ],
        vec![[0.0, 1.0, 0.0]; 4],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let items = [
        item(&floor, 0),
        item(&sphere, 1),
        DrawItem {
            transform: Mat4::from_translation(Vec3::new(1.2, 0.0, -1.0)),
            tint: Vec3::new(1.0, 0.6, 0.6),
            ..item(&sphere, 2)
        },
        item(&sphere, 3), // exactly coincides with object 1
    ];
    let view = View::look_at_fov(
        Vec3::new(0.3, 1.2, 3.0),
        Vec3::new(0.3, 0.8, 0.0),
        Vec3::Y,
        60.0,
        200,
        150,
        0.05,
        100.0,
    )
    .unwrap();
    let one = in_pool(1, || render(&view, &items, CullMode::Back));
    let two = in_pool(2, || render(&view, &items, CullMode::Back));
    let three = in_pool(3, || render(&view, &items, CullMode::None));
    let three_back = in_pool(3, || render(&view, &items, CullMode::Back));
    assert!(one == two, "1 vs 2 threads differ");
    assert!(one == three_back, "1 vs 3 threads differ");
    assert_eq!(
        one.object_id, three.object_id,
        "closed meshes: culling changes nothing visible"
    );
    assert!(
        one.object_id.iter().all(|&o| o != 3),
        "the later coincident copy never wins"
    );
    assert!(one.covered_pixels() > 200 * 75);
}

#[test]
fn real_bunny_renders_deterministically() {
    let Some(path) = common::fetched_model("bunny.obj") else {
        return;
    };
    let bunny = scene::load::load_model(&path).unwrap();
    assert_eq!(bunny.triangles.len(), 69_666);
    let (lo, hi) = bunny.bounds().unwrap();
    let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
    let centre = 0.5 * (lo + hi);
    let eye = centre + Vec3::new(0.0, 0.0, 2.5 * (hi - lo).length());
    let view = View::tight_around(eye, lo, hi, 256).unwrap();
    let items = [item(&bunny, 0)];
    let one = in_pool(1, || render(&view, &items, CullMode::Back));
    let two = in_pool(2, || render(&view, &items, CullMode::Back));
    maybe_write_pngs("bunny", &one);
    assert!(one == two);
    let covered = one.covered_pixels();
    assert!(
        covered > one.depth.len() / 4,
        "bunny covers {covered} of {}",
        one.depth.len()
    );
    // Culling back faces of a closed-ish mesh barely changes what is visible.
    let none = render(&view, &items, CullMode::None);
    let differ = none
        .object_id
        .iter()
        .zip(&one.object_id)
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ * 100 < covered, "{differ} pixels differ");
}

#[test]
fn bad_indices_are_skipped_not_a_panic() {
    let view = exact_view(16);
    let mut mesh = upright_triangle(8.0, -8.0);
    mesh.triangles.push([0, 1, 99]);
    mesh.albedo.clear(); // missing albedo: white
    let subset = [1u32, 0, 1234];
    let c = render(
        &view,
        &[DrawItem {
            triangles: Some(&subset),
            ..item(&mesh, 0)
        }],
        CullMode::Back,
    );
    assert!(c.covered_pixels() > 20);
    assert!(c.triangle_id.iter().all(|&t| t == 0 || t == BACKGROUND_ID));
    // NaN vertices do not poison anything.
    mesh.positions[2] = [f32::NAN, 0.0, -8.0];
    let c = render(&view, &[item(&mesh, 0)], CullMode::None);
    assert_eq!(c.covered_pixels(), 0);
    let _ = Vec4::ZERO;
}
