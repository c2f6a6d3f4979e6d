//! Issue 29's second textured example (`manifests/terrain.ron`, built by
//! `scripts/build-terrain-scene.sh`: a textured terrain over the whole ground, an
//! L-shaped building block spanning more than ten cells, textured models standing on
//! the terrain) and its walk (`manifests/paths/terrain-walk.ron`), end to end through
//! the binaries: it bakes with no failed job, the terrain is drawn in every frame of
//! the walk, its chunks leave no crack, and the walk's object-pixel PSNR(Y) is within
//! 2 dB of the textured plaza's. Each test skips through `testkit::skip` when the
//! scene is not built (`HEXBAKE_REQUIRE_MODELS=1` makes that a failure) or when no
//! wgpu adapter is there (`HEXBAKE_REQUIRE_GPU=1`).

use std::path::{Path, PathBuf};

mod common;
use common::{repo, run, stderr, stdout};

use format::path::CameraPath;
use glam::{Vec2, Vec3};

const MANIFEST: &str = "manifests/terrain.ron";
const WALK: &str = "manifests/paths/terrain-walk.ron";
/// How far above the terrain mesh the walk's eyes are
/// (`scripts/build-terrain-scene.py`'s `EYE_ABOVE_GROUND`).
const EYE_ABOVE_GROUND: f32 = 2.2;

/// Whether the terrain scene was built; a skip (`Need::Models`) when not.
#[track_caller]
fn terrain_scene_built() -> bool {
    let scene = repo().join("models/terrain/terrain.gltf");
    let ok = scene.is_file();
    if !ok {
        testkit::skip(
            testkit::Need::Models,
            format_args!(
                "{} is missing (scripts/build-terrain-scene.sh, run by scripts/fetch-models.sh)",
                scene.display()
            ),
        );
    }
    ok
}

fn plan_of(manifest: &Path) -> format::manifest::Plan {
    format::manifest::parse_manifest(manifest).unwrap()
}

/// Instance indices of `scene` whose model's name starts with `prefix` (chunks of
/// the glTF node `prefix` are named `<prefix>@<instance>#<cell>`).
fn instances_named(scene: &format::Scene, prefix: &str) -> Vec<u32> {
    (0..scene.instances.len() as u32)
        .filter(|&i| {
            scene.models[scene.instances[i as usize].model as usize]
                .name
                .starts_with(prefix)
        })
        .collect()
}

/// The height of `scene`'s terrain chunks at (x, z): the triangle whose x–z
/// projection holds the point, interpolated; `None` off the terrain.
fn terrain_height(scene: &format::Scene, terrain: &[u32], p: Vec2) -> Option<f32> {
    let mut best: Option<f32> = None;
    for &i in terrain {
        let inst = &scene.instances[i as usize];
        let mesh = &scene.models[inst.model as usize].mesh;
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| {
                inst.transform
                    .transform_point3(Vec3::from(mesh.positions[v as usize]))
            });
            let (ab, ac, ap) = (b - a, c - a, Vec3::new(p.x, 0.0, p.y) - a);
            let det = ab.x * ac.z - ab.z * ac.x;
            if det.abs() < 1e-12 {
                continue;
            }
            let u = (ap.x * ac.z - ap.z * ac.x) / det;
            let v = (ab.x * ap.z - ab.z * ap.x) / det;
            if u >= -1e-5 && v >= -1e-5 && u + v <= 1.0 + 1e-5 {
                let y = a.y + u * ab.y + v * ac.y;
                best = Some(best.map_or(y, |b: f32| b.max(y)));
            }
        }
    }
    best
}

/// `manifests/terrain.ron` copied into `dir` with its scene path made absolute and
/// `extra` lines added (e.g. `split_wide_objects: false,`).
fn manifest_copy(dir: &Path, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo().join(MANIFEST)).unwrap();
    let scene = repo().join("models/terrain/terrain.gltf");
    let text = text
        .replace(
            "Gltf(\"../models/terrain/terrain.gltf\")",
            &format!("Gltf({:?})", scene.to_str().unwrap()),
        )
        .replace("    output: \"../out/terrain\",\n", extra);
    let path = dir.join("terrain.ron");
    std::fs::write(&path, text).unwrap();
    path
}

/// Reads an RGBA8 PNG the player or the worker wrote: (width, height, bytes).
fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba, "{}", path.display());
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// The colour both renderers draw the flat ground rectangle in (albedo
/// `shading::GROUND`, normal +y, DESIGN.md's Lambert term), sRGB8.
fn flat_ground_colour() -> [u8; 3] {
    let lit = format::shading::shade(
        format::srgb::srgb8_to_linear(format::shading::GROUND),
        Vec3::Y,
    );
    let [r, g, b, _] = format::srgb::linear_to_srgb8(lit);
    [r, g, b]
}

/// RGBA8 bytes as the `[u8; 4]` pixels `worker::picture` writes.
fn rgba_pixels(rgba: &[u8]) -> Vec<[u8; 4]> {
    rgba.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

/// Whether an RGB pixel is the sky or the flat ground rectangle (± 2 per channel,
/// for the GPU's rounding): what shows through where the terrain is not drawn.
fn shows_through(px: &[u8], ground: [u8; 3]) -> bool {
    let near = |c: [u8; 3]| (0..3).all(|k| px[k].abs_diff(c[k]) <= 2);
    near([
        format::shading::SKY[0],
        format::shading::SKY[1],
        format::shading::SKY[2],
    ]) || near(ground)
}

/// The scene as built and the walk: the terrain is one mesh split into a chunk per
/// cell, the building spans at least ten cells, and the walk's eyes follow the
/// terrain at `EYE_ABOVE_GROUND` within the cells' eye heights.
#[test]
fn issue29_terrain_example_scene_and_walk() {
    if !terrain_scene_built() {
        return;
    }
    let out = run("pipeline", &["scene", MANIFEST, "--json"], &repo());
    assert!(out.status.success(), "{}", stderr(&out));
    let summary: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(
        summary["chunks"]["split_objects"], 2,
        "{}",
        summary["chunks"]
    );
    let plan = plan_of(&repo().join(MANIFEST));
    let scene = scene::build_scene(&plan).unwrap();
    let terrain = instances_named(&scene, "terrain@");
    let building = instances_named(&scene, "building@");
    eprintln!(
        "terrain: {} chunks, building: {} chunks, {} instances",
        terrain.len(),
        building.len(),
        scene.instances.len()
    );
    assert!(terrain.len() >= 30, "{} terrain chunks", terrain.len());
    assert!(
        building.len() >= 10,
        "the building spans {} cells",
        building.len()
    );

    let path = CameraPath::load(&repo().join(WALK)).unwrap();
    let frames = path.frames();
    assert!(frames.len() > 200, "{} frames", frames.len());
    let cells = &plan.cells;
    for (k, f) in frames.iter().enumerate() {
        let ground = terrain_height(&scene, &terrain, Vec2::new(f.eye.x, f.eye.z))
            .unwrap_or_else(|| panic!("frame {k}: eye {} off the terrain", f.eye));
        let above = f.eye.y - ground;
        assert!(
            (above - EYE_ABOVE_GROUND).abs() < 1e-3,
            "frame {k}: eye {} is {above} above the terrain",
            f.eye
        );
        assert!(
            f.eye.y >= cells.min_eye_height && f.eye.y <= cells.max_eye_height,
            "frame {k}: eye height {} outside the cells' {}..{}",
            f.eye.y,
            cells.min_eye_height,
            cells.max_eye_height
        );
    }
}

/// No crack along chunk borders, on the example: the terrain and the building split
/// into chunks (the default) draw exactly the pixels of the unsplit meshes
/// (`split_wide_objects: false`) in `worker view` renders from every tenth eye of the
/// walk and from above the whole ground — so no background pixel lies between two
/// chunks where the unsplit mesh has none.
#[test]
fn issue29_terrain_example_chunks_draw_the_pixels_of_the_unsplit_meshes() {
    if !terrain_scene_built() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let split_dir = tmp.path().join("split");
    let whole_dir = tmp.path().join("whole");
    std::fs::create_dir_all(&split_dir).unwrap();
    std::fs::create_dir_all(&whole_dir).unwrap();
    let split = manifest_copy(&split_dir, "");
    let whole = manifest_copy(&whole_dir, "    split_wide_objects: false,\n");
    let path = CameraPath::load(&repo().join(WALK)).unwrap();
    let mut views: Vec<(Vec3, Vec3)> = path
        .frames()
        .iter()
        .step_by(10)
        .map(|f| (f.eye, f.eye + 10.0 * f.dir - Vec3::new(0.0, 1.0, 0.0)))
        .collect();
    views.push((Vec3::new(-40.0, 160.0, 280.0), Vec3::new(150.0, 0.0, 120.0)));
    let mut terrain_pixels = 0usize;
    for (k, (eye, target)) in views.iter().enumerate() {
        let v3 = |v: Vec3| format!("{},{},{}", v.x, v.y, v.z);
        let render = |manifest: &Path, png: &Path| {
            let o = run(
                "worker",
                &[
                    "view",
                    manifest.to_str().unwrap(),
                    &format!("--eye={}", v3(*eye)),
                    &format!("--target={}", v3(*target)),
                    "--size",
                    "192",
                    "--out",
                    png.to_str().unwrap(),
                ],
                &repo(),
            );
            assert!(o.status.success(), "{}", stderr(&o));
            read_png(png)
        };
        let (_, _, a) = render(&split, &split_dir.join(format!("{k}.png")));
        let (_, _, b) = render(&whole, &whole_dir.join(format!("{k}.png")));
        let differing = a
            .chunks_exact(4)
            .zip(b.chunks_exact(4))
            .filter(|(p, q)| p != q)
            .count();
        assert_eq!(differing, 0, "view {k} from {eye}: split and whole differ");
        terrain_pixels += a
            .chunks_exact(4)
            .filter(|p| !shows_through(p, flat_ground_colour()))
            .count();
    }
    assert!(
        terrain_pixels > views.len() * 192 * 192 / 3,
        "the views show the scene"
    );
}

/// `pipeline run manifests/terrain.ron` into `<dir>/terrain`: asserts that no job
/// failed, and returns the bake and its extent (the player's far plane), or `None`
/// after a skip when there is no wgpu adapter.
#[track_caller]
fn bake_terrain(dir: &Path) -> Option<(PathBuf, f32)> {
    let out = dir.join("terrain");
    let out_s = out.to_str().unwrap();
    let o = run(
        "pipeline",
        &["run", MANIFEST, "--quiet", "--out", out_s],
        &repo(),
    );
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        report["jobs_failed"],
        serde_json::json!([]),
        "{}",
        report["jobs_failed"]
    );
    assert_eq!(report["jobs_pending"], serde_json::json!([]));
    assert_eq!(report["cells"], report["grid_cells"]);
    use player::{gpu::GpuError, run::RunError};
    match player::run::Player::open(&out, (64, 64), &player::DrawOptions::default()) {
        Ok(p) => Some((out, p.bake.extent)),
        Err(RunError::Gpu(GpuError::NoAdapter(e))) => {
            testkit::skip(testkit::Need::Gpu, format_args!("no wgpu adapter ({e})"));
            None
        }
        Err(e) => panic!("the player cannot open {out_s}: {e}"),
    }
}

/// `player render BAKE --path WALK --png --mode hybrid` into `frames`: the walk's
/// frames, `{k:05}.png`.
fn render_walk(bake: &Path, frames: &Path) {
    let o = run(
        "player",
        &[
            "render",
            bake.to_str().unwrap(),
            "--path",
            WALK,
            "--frames",
            frames.to_str().unwrap(),
            "--png",
            "--mode",
            "hybrid",
        ],
        &repo(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Where the tests leave pictures for people: `target/terrain-walk/`.
fn pictures() -> PathBuf {
    let dir = repo().join("target/terrain-walk");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The example bakes with no failed job; along its walk the hybrid draws the terrain
/// in every frame (the lower quarter of every frame, the ground within about 10
/// units of the eye, has no sky and no flat-ground pixel); and the walk's
/// object-pixel PSNR(Y) (`player compare --reference-ss 1`) is within 2 dB of the
/// textured plaza's walk. Leaves frame 100 of the walk under `target/terrain-walk/`.
#[test]
fn issue29_terrain_example_bakes_draws_its_ground_in_every_frame_and_matches_the_plaza() {
    if !terrain_scene_built() {
        return;
    }
    let plaza_scene = repo().join("models/textured-plaza/textured-plaza.gltf");
    if !plaza_scene.is_file() {
        testkit::skip(
            testkit::Need::Models,
            format_args!(
                "{} is missing (scripts/fetch-models.sh)",
                plaza_scene.display()
            ),
        );
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    // 1. The bake: no failed job (or a skip without an adapter).
    let Some((out, _)) = bake_terrain(tmp.path()) else {
        return;
    };

    // 2. The walk in the hybrid: the terrain under the lower quarter of every frame.
    let frames_dir = tmp.path().join("frames");
    render_walk(&out, &frames_dir);
    let path = CameraPath::load(&repo().join(WALK)).unwrap();
    let (w, h) = path.resolution;
    let ground = flat_ground_colour();
    for (k, f) in path.frames().iter().enumerate() {
        let (fw, fh, px) = read_png(&frames_dir.join(format!("{k:05}.png")));
        assert_eq!((fw, fh), (w, h));
        let through = (3 * h / 4..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| shows_through(&px[4 * (y * w + x) as usize..], ground))
            .count();
        assert_eq!(
            through, 0,
            "frame {k} (eye {}): {through} sky or flat-ground pixels in its lower quarter",
            f.eye
        );
    }
    std::fs::copy(
        frames_dir.join("00100.png"),
        pictures().join("hybrid-00100.png"),
    )
    .unwrap();

    // 3. Object-pixel PSNR(Y) of the walk against the plaza's walk.
    let plaza = tmp.path().join("plaza");
    let o = run(
        "pipeline",
        &[
            "run",
            "manifests/textured-plaza.ron",
            "--quiet",
            "--out",
            plaza.to_str().unwrap(),
        ],
        &repo(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let object_psnr = |bake: &Path, walk: &str| {
        let o = run(
            "player",
            &[
                "compare",
                bake.to_str().unwrap(),
                "--path",
                walk,
                "--reference-ss",
                "1",
                "--no-crossings",
                "--json",
            ],
            &repo(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        v["object_psnr_y_db"].as_f64().unwrap()
    };
    let terrain_db = object_psnr(&out, WALK);
    let plaza_db = object_psnr(&plaza, "manifests/paths/textured-walk.ron");
    eprintln!("object-pixel PSNR(Y): terrain walk {terrain_db:.2} dB, plaza walk {plaza_db:.2} dB");
    assert!(
        terrain_db >= plaza_db - 2.0,
        "terrain walk {terrain_db:.2} dB, more than 2 dB under the plaza's {plaza_db:.2} dB"
    );
}

/// No crack between chunks in the hybrid: inside the terrain of the full-geometry
/// view (pixels whose 5 × 5 neighbourhood is all terrain in the CPU rasterizer's
/// render of the same camera), no frame of the walk shows sky or the flat ground.
///
/// Where two *proxied* terrain chunks meet, each simplified on its own, their
/// proxies left one-pixel lines of sky near the horizon (80 of the 317 frames, at
/// most 23 pixels in one) until each chunk's cut border was locked in
/// simplification (issue 29, `scene::chunk`; worker `tests/chunks.rs` checks the
/// proxies of two chunks keep their shared border). Each cracked frame is written
/// to `target/terrain-walk/crack-NNNNN-{hybrid,cpu}.png`, the crack pixels in red.
#[test]
fn issue29_terrain_example_hybrid_has_no_crack_between_chunks() {
    if !terrain_scene_built() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let Some((out, extent)) = bake_terrain(tmp.path()) else {
        return;
    };
    let frames_dir = tmp.path().join("frames");
    render_walk(&out, &frames_dir);
    let path = CameraPath::load(&repo().join(WALK)).unwrap();
    let (w, h) = path.resolution;
    let plan = plan_of(&repo().join(MANIFEST));
    let scene = scene::build_scene(&plan).unwrap();
    let terrain = instances_named(&scene, "terrain@");
    let ground_mesh = scene.ground.mesh();
    let items = worker::raster::DrawItem::scene_with_ground(&scene, &ground_mesh);
    let ground = flat_ground_colour();
    let pictures = pictures();
    let mut cracks = Vec::new();
    for (k, f) in path.frames().iter().enumerate() {
        let (_, _, px) = read_png(&frames_dir.join(format!("{k:05}.png")));
        let view = worker::raster::View::look_at_fov(
            f.eye,
            f.eye + f.dir,
            Vec3::Y,
            path.fov_y_deg,
            w,
            h,
            0.25,
            extent,
        )
        .unwrap();
        let cap = worker::raster::render(&view, &items, worker::raster::CullMode::Back);
        let is_terrain = |x: i64, y: i64| {
            x >= 0
                && y >= 0
                && x < w as i64
                && y < h as i64
                && terrain.contains(&cap.object_id[(y * w as i64 + x) as usize])
        };
        let crack: Vec<usize> = (0..h as i64)
            .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                (-2..=2).all(|dy| (-2..=2).all(|dx| is_terrain(x + dx, y + dy)))
                    && shows_through(&px[4 * (y as usize * w as usize + x as usize)..], ground)
            })
            .map(|(x, y)| y as usize * w as usize + x as usize)
            .collect();
        if !crack.is_empty() {
            // The frame with its crack pixels in red, beside the CPU render.
            let mut marked = rgba_pixels(&px);
            for &i in &crack {
                marked[i] = [255, 0, 0, 255];
            }
            for (name, image) in [("hybrid", &marked), ("cpu", &cap.color)] {
                let file = pictures.join(format!("crack-{k:05}-{name}.png"));
                worker::picture::write_rgba(&file, w, h, image).unwrap();
            }
            cracks.push((k, crack.len()));
        }
    }
    assert!(
        cracks.is_empty(),
        "{} frames with cracks (frame, pixels; marked in {}): {cracks:?}",
        cracks.len(),
        pictures.display()
    );
}
