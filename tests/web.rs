//! The browser viewer end to end (issue 33; paper 000 §3.2 run-time streaming and
//! rendering; pack bytes per format/README.md "Pack files"): the demo bake served by
//! `pipeline serve`, opened in Debian's headless Chromium (WebGPU on SwiftShader,
//! ../shared/WEB.md) by `player/web/test/drive.mjs` (playwright-core), compared
//! with `player view --headless --screenshot` at the same pose (PSNR(Y) ≥ 35 dB,
//! `format::metrics`), a walk along manifests/paths/demo-walk.ron whose overlay
//! shows the cell changing, and a truncated pack reported in the page.
//!
//! Skips without Chromium, node or `scripts/install-web.sh`'s packages
//! (`testkit::Need::Chromium`, a failure under `HEXBAKE_REQUIRE_WEB=1`) and without
//! a wgpu adapter for the native frame (`Need::Gpu`). PNGs and the drivers' JSON are
//! kept under `$CARGO_TARGET_TMPDIR/web/` for inspection.

mod common;

use common::{bin_dir, repo, run, stderr};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// Why the browser side cannot run here, if it cannot.
fn web_missing() -> Option<String> {
    let chromium = std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into());
    if !Path::new(&chromium).exists() {
        return Some(format!("{chromium} missing (apt-get install chromium)"));
    }
    if Command::new("node").arg("--version").output().is_err() {
        return Some("node missing".into());
    }
    let web = repo().join("player/web");
    for f in ["node_modules/playwright-core", "dist/viewer.js"] {
        if !web.join(f).exists() {
            return Some(format!(
                "player/web/{f} missing (run scripts/install-web.sh)"
            ));
        }
    }
    None
}

/// `pipeline serve` on a free port; killed on drop.
struct Server {
    child: Child,
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(out: &Path) -> Server {
    let mut child = Command::new(bin_dir().join("pipeline"))
        .args(["serve", out.to_str().unwrap(), "--port", "0", "--web"])
        .arg(repo().join("player/web"))
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("pipeline serve starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    // "serving <dir> at http://127.0.0.1:PORT/?bake=/bake/ (viewer …)"
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("pipeline serve printed {line:?}"))
        .to_string();
    Server { child, url }
}

/// Runs the browser driver; its JSON line and whether it succeeded.
fn drive(args: &[&str]) -> (serde_json::Value, bool) {
    let o = Command::new("node")
        .arg(repo().join("player/web/test/drive.mjs"))
        .args(args)
        .current_dir(repo().join("player/web"))
        .output()
        .expect("node runs");
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text.lines().last().unwrap_or("");
    let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| {
        panic!(
            "drive.mjs {args:?}: {e}; stdout {text:?}; stderr {}",
            String::from_utf8_lossy(&o.stderr)
        )
    });
    (v, o.status.success())
}

fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    let rgba = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        other => panic!("{}: colour type {other:?}", path.display()),
    };
    (info.width, info.height, rgba)
}

fn artefacts() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("web");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The demo at a fixed pose: the browser's frame matches the native player's
/// headless frame (PSNR(Y) ≥ 35 dB); a walk shows ≥ 3 cells in the overlay; a
/// truncated cell pack is reported in the page, not a crash.
#[test]
fn web_viewer_draws_the_demo_like_the_player() {
    if let Some(why) = web_missing() {
        testkit::skip(testkit::Need::Chromium, why);
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let o = run(
        "pipeline",
        &[
            "run",
            "manifests/demo.ron",
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ],
        &repo(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let art = artefacts();

    let (x, z, yaw) = (150.0, 120.0, 30.0);
    let server = serve(&out);
    let Some((psnr, v)) = native_vs_web(&out, &server, (x, z, yaw, 0.0), "demo") else {
        return;
    };
    eprintln!(
        "web vs native at ({x}, {z}, yaw {yaw}°): PSNR(Y) {psnr:.2} dB; first frame {} ms after navigation start, {} bytes fetched; PNGs in {}",
        v["stats"]["firstFrameMs"],
        v["stats"]["firstFrameBytes"],
        art.display()
    );
    assert!(psnr >= 35.0, "web vs native PSNR(Y) {psnr:.2} dB < 35");

    // A walk: the overlay shows at least three cells.
    std::fs::copy(
        repo().join("manifests/paths/demo-walk.ron"),
        out.join("demo-walk.ron"),
    )
    .unwrap();
    let url = format!("{}&path=/bake/demo-walk.ron&size=256x192", server.url);
    let (v, ok) = drive(&["walk", &url, "300"]);
    std::fs::write(art.join("walk.json"), v.to_string()).unwrap();
    assert!(ok, "walk: {v}");
    let cells: Vec<&str> = v["overlayCells"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|c| c.as_str())
        .filter(|c| *c != "-")
        .collect();
    eprintln!("walk: overlay cells {cells:?}; stats {}", v["stats"]);
    let mut distinct = cells.clone();
    distinct.sort();
    distinct.dedup();
    assert!(distinct.len() >= 3, "the overlay showed cells {cells:?}");

    // A tour through ≥ 10 cells: every frame drew its own cell's pack (no stand-in
    // frame), and the viewer went through every cell the path crosses, as the native
    // player does (the path's frames' cells on the bake's grid).
    std::fs::copy(
        repo().join("manifests/paths/demo-tour.ron"),
        out.join("demo-tour.ron"),
    )
    .unwrap();
    let path =
        format::path::CameraPath::load(&repo().join("manifests/paths/demo-tour.ron")).unwrap();
    let base = format::pack::Index::read(&out.join("index.pack"))
        .unwrap()
        .read_base(&out)
        .unwrap();
    let grid = format::grid::HexGrid::from_params(&base.grid).unwrap();
    let mut expected: Vec<u64> = path
        .frames()
        .iter()
        .filter_map(|f| grid.cell_at(glam::Vec2::new(f.eye.x, f.eye.z)))
        .map(u64::from)
        .collect();
    expected.dedup();
    let url = format!("{}&path=/bake/demo-tour.ron&size=256x192", server.url);
    let (v, ok) = drive(&["walk", &url, "600"]);
    std::fs::write(art.join("tour.json"), v.to_string()).unwrap();
    assert!(ok, "tour: {v}");
    let visited: Vec<u64> = v["stats"]["cellsVisited"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|c| c.as_u64())
        .collect();
    let mut distinct = visited.clone();
    distinct.sort();
    distinct.dedup();
    eprintln!(
        "tour: {} cells {visited:?} (the path's: {expected:?}); stats {}",
        distinct.len(),
        v["stats"]
    );
    assert!(distinct.len() >= 10, "the tour streamed cells {visited:?}");
    assert_eq!(
        v["stats"]["standInFrames"], 0,
        "frames drawn without their cell's pack: {v}"
    );
    for c in &expected {
        assert!(
            visited.contains(c),
            "cell {c} of the path was never drawn: {visited:?}"
        );
    }

    // A truncated pack: a clear message in the page.
    let index = std::fs::read_dir(out.join("cells")).unwrap();
    for f in index {
        let p = f.unwrap().path();
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    }
    let (v, ok) = drive(&[
        "shot",
        &server.url,
        art.join("broken.png").to_str().unwrap(),
        "60",
    ]);
    assert!(!ok, "a truncated pack must not settle: {v}");
    let err = v["stats"]["error"].as_str().unwrap_or_default();
    assert!(
        err.contains("cells/") && err.contains("truncated"),
        "the page's error names the pack: {v}"
    );
}

/// `player view --headless --no-overlay` and the viewer at pose (x, eye height, z,
/// yaw°, pitch°), 512 × 384: PSNR(Y) of the two frames (`format::metrics`) and the
/// driver's JSON; `None` (skipped) without a wgpu adapter. PNGs `<tag>-native.png`,
/// `<tag>-web.png` under [`artefacts`].
fn native_vs_web(
    out: &Path,
    server: &Server,
    (x, z, yaw, pitch): (f32, f32, f32, f32),
    tag: &str,
) -> Option<(f64, serde_json::Value)> {
    let (w, h) = (512, 384);
    let art = artefacts();
    let native_png = art.join(format!("{tag}-native.png"));
    let o = run(
        "player",
        &[
            "view",
            out.to_str().unwrap(),
            "--headless",
            "--no-overlay",
            "--screenshot",
            native_png.to_str().unwrap(),
            "--start",
            &format!("{x},{z}"),
            "--yaw-deg",
            &format!("{yaw}"),
            "--pitch-deg",
            &format!("{pitch}"),
            "--size",
            &format!("{w}x{h}"),
        ],
        &repo(),
    );
    if !o.status.success() {
        let err = stderr(&o);
        if err.contains("no graphics adapter") {
            testkit::skip(testkit::Need::Gpu, format_args!("no wgpu adapter ({err})"));
            return None;
        }
        panic!("player view --headless: {err}");
    }
    let web_png = art.join(format!("{tag}-web.png"));
    let url = format!("{}&pose={x},,{z},{yaw},{pitch}&size={w}x{h}", server.url);
    let (v, ok) = drive(&["shot", &url, web_png.to_str().unwrap(), "240"]);
    std::fs::write(art.join(format!("{tag}-shot.json")), v.to_string()).unwrap();
    assert!(ok, "{tag}: the viewer did not settle: {v}");
    let (nw, nh, native) = read_png(&native_png);
    let (ww, wh, web) = read_png(&web_png);
    assert_eq!((nw, nh), (ww, wh), "frame sizes");
    let mse = format::metrics::mse_y_rgba(&native, &web).unwrap();
    Some((format::metrics::psnr_of_mse(mse), v))
}

/// Issue 18's textured glTF sample (`scene::load::gltf_sample`: checker-textured
/// crates, REPEAT and MIRRORED_REPEAT wraps): the viewer samples the albedo
/// textures as the player does (PSNR(Y) ≥ 35 dB at a pose facing the crates).
#[test]
fn web_viewer_draws_textured_models_like_the_player() {
    if let Some(why) = web_missing() {
        testkit::skip(testkit::Need::Chromium, why);
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let manifest = scene::load::gltf_sample::write_textured_sample_manifest(dir.path()).unwrap();
    let out = dir.path().join("bake");
    let o = run(
        "pipeline",
        &[
            "run",
            manifest.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ],
        &repo(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let server = serve(&out);
    let Some((psnr, _)) = native_vs_web(&out, &server, (0.0, 8.0, -90.0, -10.0), "textured") else {
        return;
    };
    eprintln!("textured sample: web vs native PSNR(Y) {psnr:.2} dB");
    assert!(
        psnr >= 35.0,
        "textured: web vs native PSNR(Y) {psnr:.2} dB < 35"
    );
}

/// `/shader.wgsl` is exactly what the native player compiles.
#[test]
fn served_shader_is_the_players() {
    assert_eq!(
        pipeline::serve::shader_source(),
        player::gpu::shader_source()
    );
}

/// The browser's pack reader (`player/web/src/pack.ts`) decodes every golden pack of
/// tests/data and answers 6,600 truncations and byte edits of them with a
/// `PackError`, never another exception (`npm test`, node only).
#[test]
fn web_pack_reader_survives_hostile_edits() {
    let web = repo().join("player/web");
    if !web.join("node_modules/fzstd").exists() || !web.join("node_modules/esbuild").exists() {
        testkit::skip(
            testkit::Need::Chromium,
            "player/web/node_modules missing (run scripts/install-web.sh)",
        );
        return;
    }
    let o = Command::new("npm")
        .args(["test", "--silent"])
        .current_dir(&web)
        .output()
        .expect("npm runs");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "npm test: {text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(text.contains("0 non-PackError exceptions"), "{text}");
}
