//! Helpers shared by the worker's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};
use worker::raster::{Capture, CullMode, DrawItem, View};
use worker::visibility::ray_cast_capture;

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `fetched_model(name)`: a downloaded model file (`scripts/fetch-models.sh`;
/// `$HEXBAKE_MODELS`, else `models/` in the repository), or `None` after a skip
/// (`testkit::skip`: a failure under HEXBAKE_REQUIRE_MODELS=1).
pub use testkit::model as fetched_model;

/// Runs `f` in a rayon pool of `threads` threads (determinism across thread counts).
pub fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// The triangles of an `n` × `n` grid of quads over `(n + 1)²` vertices numbered
/// row by row (vertex (x, y) = y·(n + 1) + x), two per quad.
pub fn quad_grid_triangles(n: u32) -> Vec<[u32; 3]> {
    let mut triangles = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let v = y * (n + 1) + x;
            triangles.push([v, v + 1, v + n + 2]);
            triangles.push([v, v + n + 2, v + n + 1]);
        }
    }
    triangles
}

/// Writes `data` (RGB8, row-major) as a PNG at `path` and says so on stderr.
pub fn write_rgb_png(path: &Path, width: u32, height: u32, data: &[u8]) {
    let file = std::fs::File::create(path).unwrap();
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder
        .write_header()
        .unwrap()
        .write_image_data(data)
        .unwrap();
    eprintln!("wrote {}", path.display());
}

// ---------------------------------------------------------------------------------
// Views and the paper's bunny (tests/analysis.rs, tests/visibility_diagnostic.rs).
// ---------------------------------------------------------------------------------

/// The paper's cell size (000 §4.1.2) and its apothem, the distance of the capture
/// window (the near plane whose window depth the thresholds apply to).
pub const CELL_SIZE: f32 = 50.0;
pub fn apothem() -> f32 {
    0.5 * 3f32.sqrt() * CELL_SIZE
}

/// DESIGN.md capture resolution: 1024 pixels per 60°.
pub const PIXELS_PER_RADIAN: f32 = 1024.0 / (std::f32::consts::PI / 3.0);

/// A perspective view from `eye` towards `target` (up +y), vertical field of view
/// `fov_y` radians, near plane `near`, far plane 5000.
pub fn look_at(eye: Vec3, target: Vec3, fov_y: f32, width: u32, height: u32, near: f32) -> View {
    let far = 5000.0;
    View {
        eye,
        view: glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y),
        proj: glam::camera::rh::proj::opengl::perspective(
            fov_y,
            width as f32 / height as f32,
            near,
            far,
        ),
        near,
        far,
        width,
        height,
    }
}

/// The bunny placed like the paper's (000 Table 2: 43.2 units tall), base on y = 0,
/// centred in x–z; `None` (after a skip) when the model is not fetched. A fetched
/// bunny that does not load fails the test.
#[track_caller]
pub fn bunny() -> Option<(format::Mesh, Mat4)> {
    let path = fetched_model("bunny.obj")?;
    let mesh = scene::load::load_model(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (lo, hi) = mesh.bounds().unwrap();
    let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
    let scale = 43.2 / (hi.y - lo.y);
    let offset = Vec3::new(-(lo.x + hi.x) * 0.5, -lo.y, -(lo.z + hi.z) * 0.5);
    let transform = Mat4::from_scale(Vec3::splat(scale)) * Mat4::from_translation(offset);
    Some((mesh, transform))
}

/// Eye on the ground plane direction (1, 0, 0.6) at horizontal distance `distance` from
/// the bunny, 1.7 units above ground (a cell centre), looking at the bunny's middle.
pub fn bunny_eye(distance: f32) -> (Vec3, Vec3) {
    let target = Vec3::new(0.0, 21.6, 0.0);
    let dir = Vec3::new(1.0, 0.0, 0.6).normalize();
    (Vec3::new(0.0, 1.7, 0.0) + dir * distance, target)
}

/// A tight square view around the bunny's bounding sphere: `pixels` wide, or at the
/// DESIGN.md angular resolution when `pixels` is `None`.
pub fn bunny_view(distance: f32, pixels: Option<u32>) -> View {
    let (eye, target) = bunny_eye(distance);
    let radius = 0.5 * Vec3::new(43.6, 43.2, 33.8).length();
    let fov = 2.0 * (radius / eye.distance(target)).min(0.99).asin() * 1.05;
    let size = pixels.unwrap_or((fov * PIXELS_PER_RADIAN).ceil() as u32);
    look_at(eye, target, fov, size, size, apothem())
}

/// The bunny alone (object id 7) placed by `transform`, ray-cast from `view`.
pub fn bunny_capture(mesh: &format::Mesh, transform: Mat4, view: &View) -> Capture {
    let item = DrawItem {
        mesh,
        transform,
        tint: Vec3::ONE,
        object_id: 7,
        triangles: None,
        albedo_map: None,
    };
    ray_cast_capture(&[item], view, CullMode::None)
}

/// `manifests/demo.ron`: its scene, grid, cell and bake parameters.
pub fn demo() -> (
    format::Scene,
    worker::grid::HexGrid,
    format::manifest::CellParams,
    format::manifest::BakeParams,
) {
    let plan = format::manifest::parse_manifest(&repo().join("manifests/demo.ron")).unwrap();
    let scene = scene::build_scene(&plan).unwrap();
    let grid = worker::grid::HexGrid::new(plan.ground, plan.cells.cell_size);
    (scene, grid, plan.cells, plan.bake)
}
