//! End-to-end tests that run hexbake's binaries, each in its own temp dir
//! (STYLE.md habit 10). Tests that need the real meshes, Slurm or a wgpu adapter
//! skip through `testkit::skip` without them (`scripts/fetch-models.sh`,
//! `scripts/slurm-local.sh`, lavapipe); CI sets `HEXBAKE_REQUIRE_MODELS=1`,
//! `HEXBAKE_REQUIRE_SLURM=1` and `HEXBAKE_REQUIRE_GPU=1`, which make them fail instead.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{bin_dir, generation_files, repo, run, stderr, stdout};

/// Whether `models/` was fetched (the parks read it); a skip when not.
#[track_caller]
fn models_present() -> bool {
    let dir = repo().join("models");
    let ok = dir.join("bunny.obj").exists();
    if !ok {
        testkit::skip(
            testkit::Need::Models,
            format_args!(
                "{} not fetched (run scripts/fetch-models.sh)",
                dir.display()
            ),
        );
    }
    ok
}

fn scene_json(manifest: &str) -> serde_json::Value {
    let out = run("pipeline", &["scene", manifest, "--json"], &repo());
    assert!(
        out.status.success(),
        "pipeline scene {manifest}: {}",
        stderr(&out)
    );
    serde_json::from_str(&stdout(&out)).expect("scene --json prints JSON")
}

#[test]
fn scene_of_demo_needs_no_download() {
    let v = scene_json("manifests/demo.ron");
    assert!(v["instances"].as_u64().unwrap() > 0);
    assert!(v["triangles"].as_u64().unwrap() > 0);
    let grid = v["grid"].as_array().unwrap();
    let cells = grid[0].as_u64().unwrap() * grid[1].as_u64().unwrap();
    assert_eq!(v["cells"].as_u64().unwrap(), cells);
    for m in v["models"].as_array().unwrap() {
        assert!(
            m["source"].as_str().unwrap().starts_with("procedural:"),
            "{m}"
        );
    }
}

/// Issue 2: the parks reproduce the paper's Table 2 (64 / 132 / 253 instances,
/// 2.0M / 4.2M / 8.0M triangles within 5%, 22 × 24 cells).
#[test]
fn park_scenes_match_the_paper() {
    if !models_present() {
        return;
    }
    for (name, instances, triangles) in [
        ("park-2m", 64, 2_017_700.0),
        ("park-4m", 132, 4_188_885.0),
        ("park-8m", 253, 8_004_863.0),
    ] {
        let v = scene_json(&format!("manifests/{name}.ron"));
        assert_eq!(v["instances"].as_u64().unwrap(), instances, "{name}");
        let t = v["triangles"].as_u64().unwrap() as f64;
        assert!(
            (t / triangles - 1.0).abs() <= 0.05,
            "{name}: {t} triangles, paper {triangles}"
        );
        assert_eq!(v["grid"], serde_json::json!([22, 24]), "{name}");
        assert_eq!(v["models"].as_array().unwrap().len(), 8, "{name}");
    }
}

/// Issue 2: 2M ⊂ 4M ⊂ 8M — every instance of the smaller park stands at the same
/// place with the same model and tint in the larger one.
#[test]
fn park_scenes_are_nested() {
    if !models_present() {
        return;
    }
    let load = |name: &str| {
        let plan = format::manifest::parse_manifest(&repo().join(format!("manifests/{name}.ron")))
            .unwrap();
        scene::build_scene(&plan).unwrap()
    };
    let scenes = [load("park-2m"), load("park-4m"), load("park-8m")];
    for pair in scenes.windows(2) {
        let (small, big) = (&pair[0], &pair[1]);
        for inst in &small.instances {
            let name = &small.models[inst.model as usize].name;
            assert!(
                big.instances
                    .iter()
                    .any(|b| big.models[b.model as usize].name == *name
                        && b.transform == inst.transform
                        && b.tint == inst.tint),
                "instance of {name} at {:?} missing from the larger park",
                inst.transform.w_axis
            );
        }
    }
}

#[test]
fn misspelled_manifest_field_exits_2_with_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("manifests/demo.ron"))
        .unwrap()
        .replacen("cell_size", "cel_size", 1);
    let line = text
        .lines()
        .position(|l| l.contains("cel_size"))
        .expect("demo.ron has a cell_size")
        + 1;
    let path = dir.path().join("typo.ron");
    std::fs::write(&path, text).unwrap();
    let out = run("pipeline", &["scene", path.to_str().unwrap()], dir.path());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "one readable line: {err}");
    assert!(err.contains(&format!("typo.ron:{line}:")), "{err}");
    assert!(err.contains("cel_size"), "{err}");
}

#[test]
fn missing_manifest_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("pipeline", &["scene", "nope.ron"], dir.path());
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("nope.ron"), "{}", stderr(&out));
}

#[test]
fn player_prints_its_version() {
    let out = run("player", &["--version"], &repo());
    assert!(out.status.success());
    assert!(stdout(&out).contains(env!("CARGO_PKG_VERSION")));
}

// ---------------------------------------------------------------------------
// Issue 6: pipeline run — determinism, resume, lock, Slurm.

/// Every file of a bake that must be byte-identical across runs, executors and
/// thread counts: base, index and cell packs (the report and job records hold
/// times and are excluded).
fn bake_files(out: &Path) -> Vec<(String, Vec<u8>)> {
    generation_files(out)
}

fn assert_same_bake(a: &Path, b: &Path) {
    let (fa, fb) = (bake_files(a), bake_files(b));
    assert_eq!(
        fa.iter().map(|f| &f.0).collect::<Vec<_>>(),
        fb.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "same files"
    );
    for ((name, x), (_, y)) in fa.iter().zip(&fb) {
        assert!(
            x == y,
            "{name} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

fn run_manifest(manifest: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["run", manifest, "--quiet", "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    run("pipeline", &args, &repo())
}

/// `tests/data/tiny.ron`: 9 cells in 6 jobs, baked in seconds (tests that bake often).
const TINY: &str = "tests/data/tiny.ron";

fn run_tiny(out: &Path, extra: &[&str]) -> Output {
    run_manifest(TINY, out, extra)
}

#[test]
fn run_is_identical_for_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("t1"), dir.path().join("t2"));
    let o = run_tiny(&a, &["--threads", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_tiny(&b, &["--threads", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bake(&a, &b);
    for f in ["report.md", "report.json", "report.png"] {
        assert!(a.join(f).exists(), "{f} written");
    }
    // One thread: each job has the process to itself and a CPU time of its own. Two:
    // jobs bake side by side, and the report says it has no per-job CPU.
    let cpu = |out: &Path| {
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
        r["job_cpu_s"].clone()
    };
    assert!(cpu(&a).as_f64().is_some_and(|s| s > 0.0), "{}", cpu(&a));
    assert!(cpu(&b).is_null(), "{}", cpu(&b));
    let md = std::fs::read_to_string(b.join("report.md")).unwrap();
    assert!(md.contains("CPU not measured per job"), "{md}");
    // A second run skips every job and changes nothing.
    let o = run_tiny(&a, &["--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["jobs_baked"], 0, "{v}");
    assert_same_bake(&a, &b);
}

/// An `Instances` scene of procedural models (no download) with instance 2 at `x2`.
fn instances_manifest(x2: f32) -> String {
    let at = [
        (30.0, 40.0),
        (120.0, 30.0),
        (x2, 100.0),
        (40.0, 120.0),
        (130.0, 120.0),
    ];
    let models = ["torus_knot", "column", "sphere", "vase", "torus_knot"];
    let instances: Vec<String> = at
        .iter()
        .zip(models)
        .map(|(&(x, z), m)| {
            format!(
                "(model: Procedural(\"{m}\"), target_height: 14.0, translation: ({x:.1}, 0.0, {z:.1}), rotation_y_deg: 20.0)"
            )
        })
        .collect();
    format!(
        "(name: \"moves\", ground: (min: (0.0, 0.0), max: (160.0, 150.0)),\n scene: Instances([{}]),\n cells: (cell_size: 50.0, min_eye_height: 4.0, max_eye_height: 10.0),\n bake: (image_res: 128), cells_per_job: 2)\n",
        instances.join(",\n ")
    )
}

/// Summed over the output's job records: (proxies reused, proxies).
fn reused_proxies(out: &Path) -> (u64, u64) {
    let (mut reused, mut all) = (0, 0);
    for e in std::fs::read_dir(out.join("jobs")).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_some_and(|x| x == "json") {
            let r: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
            let groups = r["groups"].as_array().cloned().unwrap_or_default();
            for c in r["cells"].as_array().unwrap().iter().chain(&groups) {
                reused += c["report"]["reused_proxies"].as_u64().unwrap();
                all += c["report"]["proxy_keys"].as_array().unwrap().len() as u64;
            }
        }
    }
    (reused, all)
}

/// `pipeline scene --as-instances` writes a generated park as an instance list that
/// bakes to the same bytes (the way to edit one statue of a park).
#[test]
fn park_as_instances_bakes_identically() {
    let dir = tempfile::tempdir().unwrap();
    let o = run("pipeline", &["scene", TINY, "--as-instances"], &repo());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("Instances(["), "{text}");
    let listed = dir.path().join("tiny-instances.ron");
    std::fs::write(&listed, text).unwrap();
    let (a, b) = (dir.path().join("park"), dir.path().join("list"));
    let o = run_tiny(&a, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_manifest(listed.to_str().unwrap(), &b, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bake(&a, &b);
}

/// Issue 13, per-proxy content-addressed cache: after one instance moves, a rerun
/// on the same output derives only the proxies whose key changed (the moved
/// object's, in every cell) and reuses the others from the old packs; the result
/// is byte-identical to a bake of the changed manifest from scratch.
#[test]
fn moving_one_instance_rebakes_only_its_proxies_identically() {
    let dir = tempfile::tempdir().unwrap();
    let (before, after) = (dir.path().join("before.ron"), dir.path().join("after.ron"));
    std::fs::write(&before, instances_manifest(80.0)).unwrap();
    std::fs::write(&after, instances_manifest(95.0)).unwrap();
    let (inc, fresh) = (dir.path().join("inc"), dir.path().join("fresh"));
    let o = run_manifest(before.to_str().unwrap(), &inc, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(reused_proxies(&inc).0, 0, "a first bake reuses nothing");
    let o = run_manifest(after.to_str().unwrap(), &inc, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_manifest(after.to_str().unwrap(), &fresh, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bake(&inc, &fresh);
    let (reused, all) = reused_proxies(&inc);
    eprintln!("incremental rebake: {reused} of {all} proxies reused");
    // The report says the same.
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(inc.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["proxies_reused"], reused, "{report}");
    assert_eq!(report["proxies"], all, "{report}");
    // Issue 32 item 2: reused proxies carry their measurements and texture bytes, so
    // every cell line equals the clean bake's but for times.
    let fresh_report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fresh.join("report.json")).unwrap()).unwrap();
    let lines = |r: &serde_json::Value| -> Vec<serde_json::Value> {
        let mut lines = r["cell_lines"].as_array().unwrap().clone();
        for l in &mut lines {
            let l = l.as_object_mut().unwrap();
            l.remove("bake_ms");
            l.remove("stage_ms");
        }
        lines
    };
    assert_eq!(lines(&report), lines(&fresh_report));
    assert_eq!(report["worst_cells"], fresh_report["worst_cells"]);
    assert!(lines(&report)
        .iter()
        .any(|l| l["measured_proxies"].as_f64() > Some(0.0)));
    // Per cell at most the moved object's proxy and a cluster it left change;
    // some cells' proxies of it changed, so not everything is reused.
    assert!(reused > 0 && reused < all, "{reused} of {all}");
    let cells = format::pack::Index::read(&inc.join("index.pack"))
        .unwrap()
        .cells
        .len() as u64;
    assert!(
        all - reused <= 2 * cells,
        "{} derived in {cells} cells",
        all - reused
    );
}

/// The finished job records in `out/jobs` (`<id>.json`; temp files start with `.`).
fn job_records(out: &Path) -> usize {
    std::fs::read_dir(out.join("jobs")).map_or(0, |d| {
        d.filter(|e| {
            let name = e.as_ref().unwrap().file_name();
            let name = name.to_string_lossy();
            name.ends_with(".json") && !name.starts_with('.')
        })
        .count()
    })
}

/// Starts `pipeline run manifest --out out` on 2 threads, quietly, in the background.
fn spawn_run(manifest: &str, out: &Path) -> std::process::Child {
    Command::new(bin_dir().join("pipeline"))
        .args(["run", manifest, "--quiet", "--threads", "2", "--out"])
        .arg(out)
        .current_dir(repo())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap()
}

/// Starts `pipeline run` of the tiny scene into `out` and SIGKILLs it after
/// `delay_ms`, or as soon as `out` holds more than `records` job records, whichever
/// comes first. Returns whether the run was still going when killed.
fn kill_tiny_run(out: &Path, delay_ms: u64, records: usize) -> bool {
    let mut child = spawn_run(TINY, out);
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_millis(delay_ms)
        && job_records(out) <= records
    {
        if child.try_wait().unwrap().is_some() {
            return false; // it finished (or failed) on its own
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let _ = child.kill(); // SIGKILL
    let _ = child.wait();
    true
}

/// SIGKILL at several moments, then a normal run: the output is byte-identical to
/// an uninterrupted bake. The kills land mid-bake for certain: before the resume,
/// some but not all of the jobs are done. Five runs are killed at random moments
/// (20 ms to 1.5 s, but as soon as the first job record appears), mostly while
/// planning or writing the base; the sixth as soon as it has finished a job of its
/// own, so at least one job is done and, with 2 threads, most are still to do.
#[test]
fn killed_runs_resume_to_identical_output() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("ref");
    let o = run_tiny(&reference, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let total = job_records(&reference);
    assert!(total >= 4, "the tiny bake has {total} jobs");
    let out = dir.path().join("killed");
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..5 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let delay_ms = 20 + seed % 1500;
        kill_tiny_run(&out, delay_ms, 0);
    }
    let before = job_records(&out);
    assert!(
        kill_tiny_run(&out, 120_000, before),
        "the run finished before it could be killed"
    );
    let done = job_records(&out);
    assert!(
        done > before && done < total,
        "the kill did not land mid-bake: {done} of {total} jobs done ({before} before the last run)"
    );
    eprintln!("killed mid-bake: {done} of {total} jobs done before the resume");
    // A kill between a pack's temp file and its rename leaves the temp file (the
    // delays above hit that window only sometimes): plant one for certain.
    let cells = out.join("cells");
    std::fs::create_dir_all(&cells).unwrap();
    let planted = cells.join(format::pack::temp_name("1.pack", 999_999_999, 0));
    std::fs::write(&planted, b"half a pack").unwrap();
    // Likewise the lock's temp file (the lock itself is published whole by a link).
    let lock_tmp = out.join(format::pack::temp_name(".lock", 999_999_999, 0));
    std::fs::write(&lock_tmp, b"999999999 ").unwrap();
    let o = run_tiny(&out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bake(&reference, &out);
    for d in [out.clone(), cells, out.join("jobs")] {
        for e in std::fs::read_dir(&d).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            assert!(
                !name.contains(".tmp-") && name != ".lock",
                "{}: {name} left behind",
                d.display()
            );
        }
    }
}

/// Issue 32 item 1, a bake is one snapshot: 100 SIGKILLs at random moments of
/// incremental rebakes (one instance moved back and forth between two manifests).
/// While each run goes, and after each kill, a reader sees one clean bake's
/// generation whole: `index.pack` and every file it names equal those of a clean
/// bake of one manifest or the other. After each kill `pipeline inspect` verifies
/// the bake, and after every tenth the player's hybrid frame is one of the two clean
/// bakes' frames. Then a run to the end gives the clean bake's generation and report
/// (times aside). Before version 7 a kill after the rebake wrote `base.pack` left
/// the old cells over the new scene, and `inspect` passed.
#[test]
fn killed_rebakes_leave_one_generation_whole() {
    let dir = tempfile::tempdir().unwrap();
    let manifests = [dir.path().join("a.ron"), dir.path().join("b.ron")];
    std::fs::write(&manifests[0], instances_manifest(80.0)).unwrap();
    std::fs::write(&manifests[1], instances_manifest(95.0)).unwrap();
    let manifest = |k: usize| manifests[k].to_str().unwrap().to_string();
    // The two clean bakes: their generations, reports and frames.
    let mut clean = Vec::new();
    for k in 0..2 {
        let out = dir.path().join(format!("clean{k}"));
        let o = run_manifest(&manifest(k), &out, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        clean.push(out);
    }
    let gens: Vec<_> = clean.iter().map(|c| generation_files(c)).collect();
    assert_ne!(gens[0], gens[1], "moving the instance changes the bake");
    let frames: Vec<Option<Vec<u8>>> = clean.iter().map(|c| hybrid_frame(c)).collect();
    if let [Some(a), Some(b)] = &frames[..] {
        assert_ne!(a, b, "the frame shows the moved instance");
        eprintln!("frames of both clean bakes differ; every tenth kill is drawn");
    }
    let which = |out: &Path| -> usize {
        let g = generation_files(out);
        gens.iter().position(|x| *x == g).unwrap_or_else(|| {
            let names: Vec<&String> = g.iter().map(|f| &f.0).collect();
            panic!(
                "{}: a generation of neither clean bake: {names:?}",
                out.display()
            )
        })
    };
    let report = |d: &Path| {
        let mut r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("report.json")).unwrap()).unwrap();
        strip_times(&mut r);
        r
    };
    // The output starts as a bake of manifest 0; a rebake of 1 is timed whole.
    let out = dir.path().join("out");
    assert!(run_manifest(&manifest(0), &out, &[]).status.success());
    let start = std::time::Instant::now();
    assert!(run_manifest(&manifest(1), &out, &[]).status.success());
    let whole_ms = start.elapsed().as_millis() as u64;
    assert_eq!(which(&out), 1);
    assert_eq!(report(&out), report(&clean[1]));
    let (mut target, mut seed, mut killed, mut reads) = (0usize, 0x2545_f491_4f6c_dd1du64, 0, 0u64);
    let mut seen = [0usize; 2];
    while killed < 100 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        // Up to 1.2 whole rebakes: most runs are killed, some finish.
        let delay = std::time::Duration::from_millis(seed % (whole_ms * 6 / 5 + 1));
        let mut child = spawn_run(&manifest(target), &out);
        let start = std::time::Instant::now();
        let mut finished = false;
        // A reader beside the run: whatever it reads is one generation whole.
        while start.elapsed() < delay {
            if child.try_wait().unwrap().is_some() {
                finished = true;
                break;
            }
            seen[which(&out)] += 1;
            reads += 1;
        }
        if finished {
            assert_eq!(
                which(&out),
                target,
                "a finished run committed its generation"
            );
            assert_eq!(
                report(&out),
                report(&clean[target]),
                "a resumed rebake's report is the clean bake's (times aside)"
            );
            target = 1 - target;
            continue;
        }
        let _ = child.kill(); // SIGKILL
        let _ = child.wait();
        killed += 1;
        let now = which(&out);
        let o = run("pipeline", &["inspect", out.to_str().unwrap()], &repo());
        assert!(o.status.success(), "kill {killed}: inspect: {}", stderr(&o));
        if killed % 10 == 0 {
            if let (Some(frame), Some(expected)) = (hybrid_frame(&out), &frames[now]) {
                assert!(
                    frame == *expected,
                    "kill {killed}: the player's frame is not generation {now}'s"
                );
            }
        }
    }
    eprintln!(
        "100 kills; {reads} reads beside the runs saw generation 0 {} and 1 {} times",
        seen[0], seen[1]
    );
    // Resumed to the end: the clean bake's generation and report.
    let o = run_manifest(&manifest(target), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(which(&out), target);
    assert_eq!(report(&out), report(&clean[target]));
}

/// Removes every time (keys ending `_ms` or `_s`, stage times) and reuse count from a
/// report, which differ between a resumed and a clean bake of the same packs.
fn strip_times(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| {
                !(k.ends_with("_ms")
                    || k.ends_with("_s")
                    || k.contains("reused")
                    || k == "wall"
                    || k == "cpu")
            });
            m.values_mut().for_each(strip_times);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_times),
        _ => {}
    }
}

/// The player's hybrid frame of the bake at `out` (96², looking at the moved
/// instance from the first cell), or `None` without a GPU adapter.
fn hybrid_frame(out: &Path) -> Option<Vec<u8>> {
    use player::camera::Camera;
    use player::stream::{StreamConfig, Streamer};
    let mut p = open_player(out, (96, 96))?;
    let cam = Camera {
        eye: glam::Vec3::new(40.0, 6.0, 50.0),
        dir: glam::Vec3::new(50.0, -2.0, 50.0),
        fov_y_deg: 60.0,
        width: 96,
        height: 96,
        near: 0.25,
        far: p.bake.extent,
    };
    let mut s = Streamer::new(
        &p.bake,
        StreamConfig {
            prefetch: false,
            upload_budget_bytes: 1 << 30,
            ..Default::default()
        },
    );
    p.draw(&cam, player::frame::Mode::Hybrid, Some(&mut s));
    Some(p.renderer.read_pixels().unwrap())
}

#[test]
fn a_second_run_on_the_same_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    std::fs::create_dir_all(&out).unwrap();
    // This test process is alive: its pid in the lock means "held".
    let host = format::pack::hostname();
    std::fs::write(
        out.join(".lock"),
        format!("{} {host}\n", std::process::id()),
    )
    .unwrap();
    let o = run_tiny(&out, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("holds this output"), "{}", stderr(&o));
    // A lock left by a dead process is taken over.
    std::fs::write(out.join(".lock"), format!("999999999 {host}\n")).unwrap();
    let o = run_tiny(&out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!out.join(".lock").exists(), "lock released");
}

#[test]
fn corrupt_cell_pack_is_rebaked() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    assert!(run_tiny(&out, &[]).status.success());
    let reference = bake_files(&out);
    let cell = out.join("cells/5.pack");
    let mut bytes = std::fs::read(&cell).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x40;
    std::fs::write(&cell, bytes).unwrap();
    let o = run_tiny(&out, &["--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["jobs_baked"], 1, "only the corrupt cell's job: {v}");
    assert!(bake_files(&out) == reference);
    // inspect names the bad section of a corrupted copy.
    let copy = dir.path().join("bad.pack");
    let mut bytes = std::fs::read(&cell).unwrap();
    bytes[last] ^= 0x40;
    std::fs::write(&copy, bytes).unwrap();
    let o = run("pipeline", &["inspect", copy.to_str().unwrap()], &repo());
    assert_eq!(o.status.code(), Some(1));
}

/// The Slurm tests need a running Slurm (`scripts/slurm-local.sh start`, which CI
/// runs) and SLURM_CONF; they skip otherwise (`testkit::skip`: a failure under
/// HEXBAKE_REQUIRE_SLURM=1).
#[track_caller]
fn slurm_available() -> bool {
    let why = if std::env::var_os("SLURM_CONF").is_none() {
        Some("SLURM_CONF is not set".to_string())
    } else {
        match Command::new("sinfo").arg("-h").output() {
            Ok(o) if o.status.success() => None,
            Ok(o) => Some(format!("sinfo -h failed: {}", stderr(&o).trim())),
            Err(e) => Some(format!("cannot run sinfo: {e}")),
        }
    };
    if let Some(why) = &why {
        testkit::skip(
            testkit::Need::Slurm,
            format_args!("no Slurm ({why}; scripts/slurm-local.sh start, export SLURM_CONF=...)"),
        );
    }
    why.is_none()
}

/// Slurm tests share one one-node cluster: run them one at a time.
static SLURM: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The one-at-a-time hold on the cluster, or `None` (the test skips) without Slurm.
#[track_caller]
fn slurm_turn() -> Option<std::sync::MutexGuard<'static, ()>> {
    slurm_available().then(|| SLURM.lock().unwrap_or_else(|e| e.into_inner()))
}

/// A Slurm test's turn on the cluster and its two outputs, `<tmp>/local` and
/// `<tmp>/slurm`; `None` (the test skips) without Slurm.
type SlurmSetup = (
    std::sync::MutexGuard<'static, ()>,
    tempfile::TempDir,
    PathBuf,
    PathBuf,
);

#[track_caller]
fn slurm_setup() -> Option<SlurmSetup> {
    let turn = slurm_turn()?;
    let dir = tempfile::tempdir().unwrap();
    let (local, slurm) = (dir.path().join("local"), dir.path().join("slurm"));
    Some((turn, dir, local, slurm))
}

#[test]
fn slurm_bake_equals_local_bake() {
    let Some((_one, _dir, local, slurm)) = slurm_setup() else {
        return;
    };
    let demo = "manifests/demo.ron";
    assert!(run_manifest(demo, &local, &[]).status.success());
    let o = run_manifest(
        demo,
        &slurm,
        &["--executor", "slurm", "--wait-timeout-s", "600"],
    );
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    assert_same_bake(&local, &slurm);
}

#[test]
fn slurm_resubmits_only_the_cancelled_task() {
    let Some((_one, _dir, local, out)) = slurm_setup() else {
        return;
    };
    assert!(run_tiny(&local, &[]).status.success());
    // Submit held, cancel task 2, release the rest.
    let o = run_tiny(&out, &["--executor", "slurm", "--hold"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let sub: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("slurm/submitted.json")).unwrap()).unwrap();
    let array = sub["array_job"].as_str().unwrap().to_string();
    let fin = sub["finalize_job"].as_str().unwrap().to_string();
    let jobs = sub["jobs"].as_array().unwrap().len();
    assert!(jobs >= 3, "{sub}");
    // While its tasks are queued, no other run may start on that output.
    for extra in [&[][..], &["--executor", "slurm"][..]] {
        let o = run_tiny(&out, extra);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("tasks of Slurm array job {array}")),
            "{}",
            stderr(&o)
        );
    }
    assert!(Command::new("scancel")
        .arg(format!("{array}_2"))
        .status()
        .unwrap()
        .success());
    assert!(Command::new("scontrol")
        .args(["release", &array])
        .status()
        .unwrap()
        .success());
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    loop {
        let q = Command::new("squeue")
            .args(["-h", "-o", "%i", "-j", &format!("{array},{fin}")])
            .output()
            .unwrap();
        if String::from_utf8_lossy(&q.stdout).trim().is_empty() {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "Slurm jobs did not finish"
        );
        std::thread::sleep(std::time::Duration::from_millis(300));
    }
    let st = run(
        "pipeline",
        &["status", out.to_str().unwrap(), "--json"],
        &repo(),
    );
    let st: serde_json::Value = serde_json::from_slice(&st.stdout).unwrap();
    assert_eq!(st["pending"], serde_json::json!([2]), "{st}");
    assert_eq!(st["done"].as_array().unwrap().len(), jobs - 1, "{st}");
    assert_eq!(
        st["index_written"], false,
        "finalize must not run after a cancelled task: {st}"
    );
    // Running again submits only job 2 and completes the bake.
    let o = run_tiny(&out, &["--executor", "slurm", "--wait-timeout-s", "600"]);
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    let sub: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("slurm/submitted.json")).unwrap()).unwrap();
    assert_eq!(sub["jobs"], serde_json::json!([2]), "{sub}");
    assert_same_bake(&local, &out);
}

// ---------------------------------------------------------------------------
// Issue 7: the player — same shading as the CPU rasterizer, compare on a real bake.

/// GPU tests skip without an adapter (`testkit::skip`: a failure under
/// HEXBAKE_REQUIRE_GPU=1, which CI sets: Mesa's lavapipe is always there). Any
/// other error of the player fails the test.
#[track_caller]
fn open_player(dir: &Path, size: (u32, u32)) -> Option<player::run::Player> {
    use player::{gpu::GpuError, run::RunError};
    match player::run::Player::open(dir, size, &player::DrawOptions::default()) {
        Ok(p) => Some(p),
        Err(RunError::Gpu(GpuError::NoAdapter(e))) => {
            testkit::skip(testkit::Need::Gpu, format_args!("no wgpu adapter ({e})"));
            None
        }
        Err(e) => panic!("the player cannot open {}: {e}", dir.display()),
    }
}

/// The CPU rasterizer's render of `scene` and the player's full-geometry frame of
/// its bake from `eye` towards `target` (60° high, `size`², near 0.25, far the
/// bake's extent; both draw the ground, issue 18) as RGBA8 bytes, and the pixels the
/// CPU render covers.
fn cpu_and_gpu_frames(
    p: &mut player::run::Player,
    scene: &format::Scene,
    eye: glam::Vec3,
    target: glam::Vec3,
    size: u32,
) -> (Vec<u8>, Vec<u8>, usize) {
    let far = p.bake.extent;
    let view =
        worker::raster::View::look_at_fov(eye, target, glam::Vec3::Y, 60.0, size, size, 0.25, far)
            .unwrap();
    let ground = scene.ground.mesh();
    let items = worker::raster::DrawItem::scene_with_ground(scene, &ground);
    let cap = worker::raster::render(&view, &items, worker::raster::CullMode::Back);
    let cpu: Vec<u8> = cap.color.iter().flatten().copied().collect();
    let cam = player::camera::Camera {
        eye,
        dir: target - eye,
        fov_y_deg: 60.0,
        width: size,
        height: size,
        near: 0.25,
        far,
    };
    p.draw(&cam, player::frame::Mode::Full, None);
    let gpu = p.renderer.read_pixels().unwrap();
    (cpu, gpu, cap.covered_pixels())
}

/// The player's full-geometry frame and the CPU rasterizer's capture of the same
/// view agree (PSNR(Y) ≥ 40 dB): one shading formula on both paths (DESIGN.md).
#[test]
fn player_renders_like_the_cpu_rasterizer() {
    use glam::Vec3;
    let dir = tempfile::tempdir().unwrap();
    player::testdata::write_synthetic_bake(dir.path()).unwrap();
    let Some(mut p) = open_player(dir.path(), (256, 256)) else {
        return;
    };
    let scene = scene::build_scene(&player::testdata::demo_park_plan().unwrap()).unwrap();
    let views = [
        (Vec3::new(150.0, 8.0, 130.0), Vec3::new(40.0, 8.0, 60.0)),
        (Vec3::new(30.0, 6.0, 40.0), Vec3::new(150.0, 6.0, 120.0)),
        (Vec3::new(200.0, 10.0, 20.0), Vec3::new(150.0, 3.0, 200.0)),
    ];
    for (k, &(eye, target)) in views.iter().enumerate() {
        let (cpu, gpu, covered) = cpu_and_gpu_frames(&mut p, &scene, eye, target, 256);
        assert!(covered > 500, "view {k} shows objects");
        let psnr = player::metrics::psnr_y(&cpu, &gpu);
        eprintln!("view {k}: CPU vs GPU PSNR(Y) {psnr:.2} dB");
        assert!(psnr >= 40.0, "view {k}: {psnr:.2} dB");
    }
}

/// Issue 18: a textured glTF scene (`scene::load::gltf_sample`: a checker-textured
/// crate used by three nodes, one mirrored, REPEAT / MIRRORED_REPEAT wrap) bakes with
/// `pipeline run`, and the player's full-geometry frame of it agrees with the CPU
/// rasterizer's render of the same view (both sample the albedo texture bilinearly
/// after sRGB decoding and draw the ground). Writes both frames as PNGs under
/// `target/textured-cpu-gpu/` for people to look at.
#[test]
fn textured_gltf_scene_bakes_and_renders_alike_on_cpu_and_gpu() {
    use glam::Vec3;
    let dir = tempfile::tempdir().unwrap();
    let manifest = scene::load::gltf_sample::write_textured_sample_manifest(dir.path()).unwrap();
    let out = dir.path().join("bake");
    let o = run_manifest(manifest.to_str().unwrap(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let base = format::pack::BasePack::read(&out.join("base.pack")).unwrap();
    // Textured / plain × as is / mirrored: the scale 1.5 stays in the instance
    // (issue 29 item 3), the mirror is baked into a model.
    assert_eq!(base.models.len(), 4);
    assert_eq!(base.instances.len(), 6);
    assert!(base.models[0].albedo_map.is_some());
    let Some(mut p) = open_player(&out, (192, 192)) else {
        return;
    };
    let plan = format::manifest::parse_manifest(&manifest).unwrap();
    let scene = scene::build_scene(&plan).unwrap();
    let pictures = repo().join("target/textured-cpu-gpu");
    std::fs::create_dir_all(&pictures).unwrap();
    let views = [
        (Vec3::new(0.0, 4.0, 9.0), Vec3::new(0.0, 1.0, 0.0)),
        (Vec3::new(-8.0, 2.0, 5.0), Vec3::new(-4.0, 1.0, 0.0)),
        (Vec3::new(7.0, 5.0, -6.0), Vec3::new(3.0, 0.5, 0.5)),
    ];
    for (k, &(eye, target)) in views.iter().enumerate() {
        let (cpu, gpu, covered) = cpu_and_gpu_frames(&mut p, &scene, eye, target, 192);
        assert!(covered > 2000, "view {k} shows the crates");
        for (name, rgba) in [("cpu", &cpu), ("gpu", &gpu)] {
            worker::picture::write_rgba(
                &pictures.join(format!("view{k}-{name}.png")),
                192,
                192,
                &rgba_pixels(rgba),
            )
            .unwrap();
        }
        let psnr = player::metrics::psnr_y(&cpu, &gpu);
        eprintln!("textured view {k}: CPU vs GPU PSNR(Y) {psnr:.2} dB");
        assert!(psnr >= 45.0, "view {k}: {psnr:.2} dB");
    }
}

/// RGBA8 bytes as the `[u8; 4]` pixels `worker::picture` writes.
fn rgba_pixels(rgba: &[u8]) -> Vec<[u8; 4]> {
    rgba.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

/// `pipeline run manifests/demo.ron` into `<dir>/demo` (asserts success).
fn bake_demo(dir: &Path) -> PathBuf {
    let out = dir.join("demo");
    let o = run_manifest("manifests/demo.ron", &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    out
}

/// Issue 16: the demo bake (README's first command) holds every representation —
/// originals, SV mesh, MV mesh, cluster, layered impostor and culled objects — and
/// the player draws each where the packs say: from a cell holding a kind, facing one
/// of its objects, the frame drawn with representation colours (`player view`'s C
/// key) shows that kind's colour; an object the cell culled (the vase hidden behind
/// the demo's block, occlusion culling) is in none of the frame's draw lists.
#[test]
fn demo_bake_holds_every_representation_and_the_player_draws_each() {
    use format::pack::{CellPack, PackFile, ProxyKind};
    use player::overlay::Representation;
    let dir = tempfile::tempdir().unwrap();
    let out = bake_demo(dir.path());
    let drawn_kinds = [
        Representation::Original,
        Representation::SvMesh,
        Representation::Cluster,
        Representation::MvMesh,
        Representation::LayeredImpostor,
    ];
    let read = |path: PathBuf, group: bool| {
        let file = PackFile::open(&path).unwrap();
        if group {
            CellPack::decode_group(&file).unwrap()
        } else {
            CellPack::decode(&file).unwrap()
        }
    };
    let Some(p) = open_player(&out, (320, 240)) else {
        return;
    };
    let grid = p.bake.grid.clone();
    let n = p.bake.instances.len();
    let cells: Vec<CellPack> = (0..grid.cell_count())
        .map(|c| read(out.join(format!("cells/{c}.pack")), false))
        .collect();

    // Per cell: what the packs draw (its own and its group's proxies) and the
    // outside objects it culls (neither original nor a member of any of them).
    let mut first_cell: Vec<Option<(u32, u32)>> = vec![None; 5]; // kind → (cell, instance)
    let mut culled: Vec<(u32, u32)> = Vec::new();
    for (c, cell) in cells.iter().enumerate() {
        // Its far-field groups, every level (each group names its parent).
        let mut group: Vec<CellPack> = Vec::new();
        let mut next = cell.far_group;
        while let Some(g) = next {
            let pack = read(out.join(format!("groups/{g}.pack")), true);
            next = pack.far_group;
            group.push(pack);
        }
        let mut drawn = vec![false; n];
        for &i in &cell.originals {
            drawn[i as usize] = true;
            first_cell[Representation::Original as usize].get_or_insert((c as u32, i));
        }
        for proxy in cell
            .proxies
            .iter()
            .chain(group.iter().flat_map(|g| &g.proxies))
        {
            let r = match proxy.kind {
                ProxyKind::SvMesh => Representation::SvMesh,
                ProxyKind::Cluster => Representation::Cluster,
                ProxyKind::MvMesh => Representation::MvMesh,
                ProxyKind::LayeredImpostor => Representation::LayeredImpostor,
            };
            for m in &proxy.members {
                drawn[m.instance as usize] = true;
            }
            first_cell[r as usize].get_or_insert((c as u32, proxy.members[0].instance));
        }
        culled.extend(
            (0..n as u32)
                .filter(|&i| !drawn[i as usize])
                .map(|i| (c as u32, i)),
        );
    }
    for r in drawn_kinds {
        assert!(
            first_cell[r as usize].is_some(),
            "no {r:?} in the demo bake"
        );
    }
    assert!(!culled.is_empty(), "the demo bake culls nothing");

    // The player, facing one object of each kind from inside a cell that has it: the
    // cell's centre and twelve points around it (another object may hide it from
    // some of them), pitch 0 so that the ground (as white as an original in this
    // colouring) stays below the horizon, where originals are not counted.
    let opts = player::view::ViewOptions {
        size: (320, 240),
        colours: true,
        overlay: false,
        ..player::view::ViewOptions::new(out.clone())
    };
    let mut s = player::view::ViewSession::new(p, &opts);
    let eye_h = grid.params().min_eye_height;
    let face = |s: &mut player::view::ViewSession, eye: glam::Vec2, instance: u32| {
        let b = s.player.bake.instance_bounds[instance as usize];
        let target = 0.5 * (b.min + b.max);
        s.eye = glam::Vec3::new(eye.x, eye_h, eye.y);
        s.yaw = (target.z - eye.y).atan2(target.x - eye.x);
        s.pitch = 0.0;
        // A few frames: the first ones stream the cell and upload its textures.
        let mut frame = Vec::new();
        for _ in 0..4 {
            frame = s.frame().unwrap().0;
        }
        frame
    };
    let eyes = |cell: u32| {
        let c = grid.centre(cell);
        let inner = 0.5 * 0.5 * 3f32.sqrt() * grid.cell_size();
        let outer = 0.9 * grid.cell_size();
        // The centre, six points halfway to the edges' midpoints and six near the
        // corners (the hexagons have corners at 0°, 60°, …).
        std::iter::once(c).chain((0..12).map(move |k| {
            let (deg, r) = if k < 6 {
                (30.0 + 60.0 * k as f32, inner)
            } else {
                (60.0 * (k - 6) as f32, outer)
            };
            let a = f32::to_radians(deg);
            c + r * glam::Vec2::new(a.cos(), a.sin())
        }))
    };
    // The original to look at: the tallest of any cell (most of it above the horizon).
    let height = |i: u32| s.player.bake.instance_bounds[i as usize].max.y;
    first_cell[Representation::Original as usize] = cells
        .iter()
        .enumerate()
        .flat_map(|(c, cell)| cell.originals.iter().map(move |&i| (c as u32, i)))
        .max_by(|a, b| height(a.1).total_cmp(&height(b.1)));
    let drawn = |s: &mut player::view::ViewSession, cell: u32, instance: u32, r: Representation| {
        eyes(cell)
            .map(|eye| {
                let frame = face(s, eye, instance);
                // An original's colour is the ground's: above the horizon only.
                let counted = match r {
                    Representation::Original => &frame[..frame.len() / 2],
                    _ => &frame[..],
                };
                Representation::count_pixels(counted)[r as usize]
            })
            .max()
            .unwrap()
    };
    for r in drawn_kinds {
        let (cell, instance) = first_cell[r as usize].unwrap();
        let pixels = drawn(&mut s, cell, instance, r);
        eprintln!("{r:?}: cell {cell}, instance {instance}: {pixels} pixels");
        assert!(pixels >= 20, "{r:?} not drawn ({pixels} pixels)");
    }

    // Culled: at a cell that culls an object whose model nothing else uses (the
    // hidden vase), no draw list of the hybrid frame holds that model.
    let base = s.player.bake.base.clone();
    let model_of = |i: u32| base.instances[i as usize].model;
    let unique = |i: u32| {
        (0..n as u32)
            .filter(|&k| model_of(k) == model_of(i))
            .count()
            == 1
    };
    let &(cell, instance) = culled
        .iter()
        .find(|&&(_, i)| unique(i))
        .expect("a culled object with a model of its own (the demo's hidden vase)");
    face(&mut s, grid.centre(cell), instance);
    let cam = s.camera();
    let pending = s.streamer.config().pending;
    let (current, _) = s
        .streamer
        .begin_frame(&s.player.renderer, &s.player.bake, &cam);
    let list = player::frame::hybrid_list(&s.player.bake, &cam, &current, pending);
    let model = model_of(instance);
    assert!(list.originals.iter().all(|(m, _)| *m != model));
    assert!(list.patched.iter().all(|d| d.model != model));
    assert!(list.levels.is_empty());
}

/// `player compare` on the demo bake along demo-walk.ron (≥ 3 cell crossings):
/// the JSON contract and PSNR floors (measured 46.5 dB mean on lavapipe; 26.7 dB over
/// object pixels).
#[test]
fn player_compare_on_the_demo_bake() {
    let dir = tempfile::tempdir().unwrap();
    let out = bake_demo(dir.path());
    if open_player(&out, (64, 64)).is_none() {
        return;
    }
    let worst = dir.path().join("worst");
    let o = run(
        "player",
        &[
            "compare",
            out.to_str().unwrap(),
            "--path",
            "manifests/paths/demo-walk.ron",
            "--json",
            "--pops",
            "--worst",
            worst.to_str().unwrap(),
        ],
        &repo(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in format::schema::compare::REQUIRED_KEYS {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    // Measured 46.5 dB on lavapipe (47.5 dB before); floor 44 dB (a 2.5 dB margin for
    // other adapters).
    let mean = v["mean_psnr_y"].as_f64().unwrap();
    eprintln!("player compare on the demo bake: mean PSNR(Y) {mean:.2} dB");
    assert!(mean >= 44.0, "mean PSNR(Y) {mean}");
    assert!(v["mean_ssim"].as_f64().unwrap() > 0.9, "{v}");
    assert!(
        v["mean_triangles"].as_f64().unwrap() < 0.25 * v["reference_triangles"].as_f64().unwrap(),
        "{v}"
    );
    assert!(
        v["crossing_prefetch"]["crossings"].as_u64().unwrap() >= 3,
        "{v}"
    );
    // Issue 14: object pixels (not diluted by sky) and the anti-aliased reference.
    // Measured on lavapipe: 26.7 dB pooled over object pixels (8.4% of the pixels);
    // against the 4 × 4 reference 25.5 dB, full geometry itself 25.8 dB.
    let f = |x: &serde_json::Value| x.as_f64().unwrap_or_else(|| panic!("not a number: {v}"));
    let object = f(&v["object_psnr_y_db"]);
    assert!(object <= mean && object >= 20.0, "object PSNR(Y) {object}");
    assert!(f(&v["min_object_psnr_y_db"]) <= f(&v["min_psnr_y"]), "{v}");
    assert!(v["worst_object_frame"].as_u64().is_some(), "{v}");
    let fraction = f(&v["object_pixel_fraction"]);
    assert!(fraction > 0.0 && fraction < 0.5, "{v}");
    let aa = &v["aa_reference"];
    assert_eq!(aa["supersampling_factor"].as_u64(), Some(4), "{v}");
    for side in ["compared", "full"] {
        let q = &aa[side];
        for key in [
            "mean_psnr_y_db",
            "min_psnr_y_db",
            "mean_ssim",
            "mean_object_ssim",
        ] {
            f(&q[key]);
        }
        assert!(f(&q["object_psnr_y_db"]) <= f(&q["mean_psnr_y_db"]), "{v}");
    }
    assert!(f(&aa["full"]["object_psnr_y_db"]) < 100.0, "{v}");
    assert!(
        std::fs::read_dir(&worst).unwrap().count() >= 4,
        "worst frames written (reference, hybrid, difference, anti-aliased reference)"
    );
    // Issue 31: a pop per crossing (a frame whose cell differs from the previous
    // frame's), each a real image change below the cap, and the worst pair written.
    let cells: Vec<Option<u64>> = v["per_frame"]
        .as_array()
        .unwrap()
        .iter()
        .map(|fr| fr["cell"].as_u64())
        .collect();
    let crossings: Vec<usize> = (1..cells.len())
        .filter(|&i| cells[i - 1].is_some() && cells[i].is_some() && cells[i - 1] != cells[i])
        .collect();
    assert!(
        crossings.len() >= 3,
        "demo-walk crosses at least 3 cells: {cells:?}"
    );
    let pops = &v["pops"];
    let measured: Vec<usize> = pops["crossings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["frame"].as_u64().unwrap() as usize)
        .collect();
    assert_eq!(measured, crossings, "{pops}");
    for c in pops["crossings"].as_array().unwrap() {
        assert_ne!(c["from_cell"], c["to_cell"], "{c}");
        let (pop, shift) = (
            f(&c["pop_object_psnr_y_db"]),
            f(&c["shift_object_psnr_y_db"]),
        );
        assert!(
            pop > 5.0 && pop < 100.0,
            "the two cells draw different proxies: {c}"
        );
        assert!(
            shift > 5.0 && shift < 100.0,
            "a one-pixel turn moves every edge: {c}"
        );
    }
    assert!(
        f(&pops["worst_pop_psnr_y_db"]) <= f(&pops["mean_pop_psnr_y_db"]),
        "{pops}"
    );
    // Issue 31 item 2: the walk was drawn with the default cross-fade, and the
    // frames in a band whose blend changed without a crossing are its steps.
    assert_eq!(
        f(&pops["fade"]) as f32,
        player::stream::DEFAULT_FADE,
        "{pops}"
    );
    assert!(pops["fade_steps"].as_u64().unwrap() >= 1, "{pops}");
    let (worst_step, mean_step) = (
        f(&pops["worst_step_psnr_y_db"]),
        f(&pops["mean_step_psnr_y_db"]),
    );
    assert!(worst_step <= mean_step && mean_step < 100.0, "{pops}");
    assert!(pops["worst_step_frame"].as_u64().is_some(), "{pops}");
    let worst_frame = pops["worst_frame"].as_u64().unwrap();
    for part in ["from", "to", "diff"] {
        let png = worst.join(format!("{worst_frame:05}-pop-{part}.png"));
        assert!(png.exists(), "{} written", png.display());
    }
    // Issue 32 item 3: no cell fell back to originals on the whole bake; with the
    // pack of a cell the walk visits removed, the report names that cell.
    assert!(v.get("fallback_cells").is_none(), "{v}");
    let visited = cells.iter().flatten().copied().max().unwrap();
    let index = format::pack::Index::read(&out.join("index.pack")).unwrap();
    std::fs::remove_file(out.join(&index.cell(visited as u32).unwrap().file)).unwrap();
    let o = run(
        "player",
        &[
            "compare",
            out.to_str().unwrap(),
            "--path",
            "manifests/paths/demo-walk.ron",
            "--json",
            "--no-crossings",
            "--reference-ss",
            "1",
        ],
        &repo(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["fallback_cells"], serde_json::json!([visited]), "{v}");
}

mod random_manifests {
    //! Issue 19: random values — extreme, zero, negative and non-finite included — in
    //! every numeric field of a manifest: `pipeline scene` and a one-cell bake either
    //! succeed or exit 2 with a message that names the manifest; never a panic
    //! (exit 101) and never exit 1 with an internal message.
    use super::*;
    use proptest::prelude::*;

    /// Mostly `nominal` (so that some manifests are valid and get baked), else any
    /// value in a wide range or an extreme one.
    fn number(nominal: &'static str) -> BoxedStrategy<String> {
        prop_oneof![
            20 => Just(nominal.to_string()),
            1 => (-300.0f32..300.0).prop_map(|v| format!("{v:?}")),
            1 => prop::sample::select(vec![
                "0.0", "-0.0", "-1.0", "1e-30", "1e30", "-1e38", "3.4e38", "NaN", "inf", "-inf",
                "1e7", "0.001",
            ])
            .prop_map(String::from),
        ]
        .boxed()
    }

    /// Nominal values of the 21 numeric fields of [`manifest`], in order.
    const NOMINAL: [&str; 21] = [
        "0.0", "0.0", "120.0", "100.0", // ground
        "10.0", "30.0", "0.0", "30.0", "20.0", "1.0", "0.9", "0.8", "0.7", // instance
        "40.0", "4.0", "10.0", // cells
        "5.0", "4.5", "3.4e-4", "1.28e-4", "0.5", // bake
    ];

    fn integer() -> impl Strategy<Value = String> {
        prop_oneof![
            10 => Just("64".to_string()),
            1 => (1u32..300).prop_map(|v| v.to_string()),
            1 => prop::sample::select(vec!["0", "1", "100000", "4294967295"]).prop_map(String::from),
        ]
    }

    fn manifest(n: &[String], i: &[String]) -> String {
        format!(
            "(name: \"random\", ground: (min: ({}, {}), max: ({}, {})),\n\
             scene: Instances([\n\
               (model: Procedural(\"sphere\"), target_height: {}, translation: ({}, {}, {}), rotation_y_deg: {}, scale: {}, tint: ({}, {}, {})),\n\
               (model: Procedural(\"box\"), target_height: 6.0, translation: (60.0, 0.0, 40.0), rotation_y_deg: 0.0)]),\n\
             cells: (cell_size: {}, min_eye_height: {}, max_eye_height: {}),\n\
             bake: (image_res: {}, self_occluding_tolerance_px: {}, edge_length_tolerance_px: {}, t_c0: {}, t_c1: {}, max_deviation_px: {}),\n\
             cells_per_job: {})\n",
            n[0], n[1], n[2], n[3], n[4], n[5], n[6], n[7], n[8], n[9], n[10], n[11], n[12],
            n[13], n[14], n[15], i[0], n[16], n[17], n[18], n[19], n[20], i[1]
        )
    }

    fn check(o: &Output, what: &str) -> Result<(), TestCaseError> {
        let code = o.status.code();
        prop_assert!(
            code == Some(0) || code == Some(2),
            "{what}: exit {code:?}\n{}",
            stderr(o)
        );
        if code == Some(2) {
            prop_assert!(
                stderr(o).contains("m.ron"),
                "{what}: names no file: {}",
                stderr(o)
            );
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        #[test]
        fn random_manifests_succeed_or_exit_2_with_a_position(
            n in NOMINAL.iter().map(|&v| number(v)).collect::<Vec<_>>(),
            i in prop::collection::vec(integer(), 2),
        ) {
            let dir = tempfile::tempdir().unwrap();
            let m = dir.path().join("m.ron");
            std::fs::write(&m, manifest(&n, &i)).unwrap();
            let m = m.to_str().unwrap();
            let o = run("pipeline", &["scene", m], &repo());
            check(&o, "pipeline scene")?;
            if o.status.success() {
                eprintln!("random manifest valid: baking cell 0");
                let out = dir.path().join("out");
                let o = run("pipeline", &["run", m, "--cells", "0", "--quiet", "--out", out.to_str().unwrap()], &repo());
                check(&o, "pipeline run --cells 0")?;
            }
        }
    }
}
