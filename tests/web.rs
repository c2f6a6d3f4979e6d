//! The browser viewer end to end (issue 33; paper 000 §3.2 run-time streaming and
//! rendering; pack bytes per format/README.md "Pack files"): the demo bake served by
//! `pipeline serve`, opened in Debian's headless Chromium (WebGPU on SwiftShader,
//! ../shared/WEB.md) by `player/web/test/drive.mjs` (playwright-core), compared
//! with `player view --headless --screenshot` at the same pose (PSNR(Y) ≥ 35 dB,
//! `format::metrics`), a walk over 12 cells in which every frame draws the
//! camera's cell from its own packs, and a truncated pack reported in the page.
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
    serve_with(out, &[])
}

/// [`serve`] with more `pipeline serve` arguments (`--static`).
fn serve_with(out: &Path, more: &[&str]) -> Server {
    let mut child = Command::new(bin_dir().join("pipeline"))
        .args(["serve", out.to_str().unwrap(), "--port", "0", "--web"])
        .arg(repo().join("player/web"))
        .args(more)
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

/// A serpentine walk over the demo's 4 × 4 cells (ground 300 × 260, cell size 50)
/// that enters 12 of them.
const LONG_WALK: &str = "(
    eye_height: 6.0,
    fov_y_deg: 60.0,
    resolution: (256, 256),
    max_speed: 40.0,
    max_turn_deg_per_s: 90.0,
    frame_rate: 5.0,
    waypoints: [(20.0, 20.0), (280.0, 20.0), (280.0, 130.0), (20.0, 130.0), (20.0, 230.0), (280.0, 230.0)],
)
";

/// The demo at a fixed pose: the browser's frame matches the native player's
/// headless frame (PSNR(Y) ≥ 35 dB); a walk streams ≥ 10 cells and every frame of
/// it draws the camera's cell from its own packs; a truncated cell pack is reported
/// in the page, not a crash.
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

    // The same pose from a static host (`--static`: no derived `.vertices` and
    // `.textures`; base.pack ranges and single store files instead): the same
    // pixels, in more requests.
    let fast_requests = v["stats"]["requests"].as_u64().unwrap();
    let fallback = serve_with(&out, &["--static"]);
    let static_png = art.join("demo-web-static.png");
    let url = format!("{}&pose={x},,{z},{yaw},0&size=512x384", fallback.url);
    let (vs, ok) = drive(&["shot", &url, static_png.to_str().unwrap(), "240"]);
    assert!(ok, "static host: the viewer did not settle: {vs}");
    assert_eq!(
        read_png(&static_png),
        read_png(&art.join("demo-web.png")),
        "the frame from a static host differs from the one with derived files"
    );
    let static_requests = vs["stats"]["requests"].as_u64().unwrap();
    eprintln!("requests by the first settled frame: {fast_requests} with derived files, {static_requests} from a static host");
    assert!(
        fast_requests < static_requests,
        "derived files did not save requests: {fast_requests} vs {static_requests}"
    );
    drop(fallback);

    // A walk that streams ≥ 10 cells (issue 33): every frame from the walk's start
    // draws the camera's cell from its own packs, far field included (no stand-in,
    // no fallback), and the overlay shows the cell changing.
    std::fs::write(out.join("long-walk.ron"), LONG_WALK).unwrap();
    let url = format!("{}&path=/bake/long-walk.ron&size=256x192", server.url);
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
    let log = v["stats"]["walkLog"].as_array().expect("walkLog");
    let frame = |f: &serde_json::Value| -> Vec<i64> {
        f.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_i64().unwrap())
            .collect()
    };
    let frames: Vec<Vec<i64>> = log.iter().map(frame).collect();
    let missing: Vec<&Vec<i64>> = frames
        .iter()
        .filter(|f| f[0] < 0 || f[1] != f[0] || f[2] != 1)
        .collect();
    let mut distinct: Vec<i64> = frames.iter().map(|f| f[0]).collect();
    distinct.sort();
    distinct.dedup();
    let stats = &v["stats"];
    eprintln!(
        "walk: {} frames, {} cells {distinct:?}, overlay cells {cells:?}; {} B in {} requests ({} B before the first frame); proxies waiting for textures in {} frames",
        frames.len(),
        distinct.len(),
        stats["fetched"],
        stats["requests"],
        stats["firstFrameBytes"],
        stats["pendingFrames"],
    );
    assert!(
        distinct.len() >= 10,
        "the walk streamed {} cells: {distinct:?}",
        distinct.len()
    );
    assert!(
        missing.is_empty(),
        "{} of {} frames did not draw the camera's cell from its packs ([cell, drawn cell, far field in, proxies waiting]): {:?}",
        missing.len(),
        frames.len(),
        &missing[..missing.len().min(10)]
    );
    assert_eq!(stats["standInFrames"], 0, "stand-in frames: {stats}");
    let mut shown = cells.clone();
    shown.sort();
    shown.dedup();
    assert!(shown.len() >= 3, "the overlay showed cells {cells:?}");

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
