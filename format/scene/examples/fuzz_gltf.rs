//! Stable fuzz driver of the glTF scene reader (issue 18; `scripts/fuzz.sh` runs it
//! when cargo-fuzz or nightly is missing): seeded mutations (bit flips, interesting
//! bytes, truncations, duplicated spans) of the textured sample scene's JSON
//! (`scene::load::gltf_sample`) and of the same document as a GLB, each parsed by
//! `scene::load::parse_gltf_scene`. A panic is a failure (exit status non-zero).
//!
//! Mode `graph` (issue 32 item 4) is structure-aware: each run spells a random node
//! graph from random bytes (`scene::load::gltf_sample::node_graph`: trees, DAGs,
//! cycles, chains around the depth limit, random edges, roots listed twice) and
//! checks the reader's verdict against the graph's (accepted with one instance per
//! reachable mesh node, or refused naming a node); a wrong verdict, a panic or a
//! read slower than a second is a failure.
//!
//!   cargo run -p scene --example fuzz_gltf -- SECONDS SEED [bytes|graph]

use format::pack::sample::SplitMix;
use std::time::{Duration, Instant};

fn main() {
    let mut args = std::env::args().skip(1);
    let seconds: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    let seed: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
    match args.next().as_deref() {
        None | Some("bytes") => mutate_bytes(seconds, seed),
        Some("graph") => graphs(seconds, seed),
        Some(other) => {
            eprintln!("fuzz_gltf: unknown mode {other:?} (bytes or graph)");
            std::process::exit(2);
        }
    }
}

/// The structure-aware mode: random node graphs against their expected verdicts.
fn graphs(seconds: u64, seed: u64) {
    use scene::load::gltf_sample::{check_node_graph, node_graph};
    let mut rng = SplitMix(seed);
    let deadline = Instant::now() + Duration::from_secs(seconds);
    let (mut runs, mut accepted) = (0u64, 0u64);
    while Instant::now() < deadline {
        let choices: Vec<u8> = (0..512).map(|_| rng.next_u64() as u8).collect();
        let graph = node_graph(&choices);
        let start = Instant::now();
        let verdict = check_node_graph(&graph);
        let took = start.elapsed();
        if let Err(what) = verdict {
            eprintln!(
                "fuzz_gltf graph: seed {seed}, run {runs}: {what}\n{}",
                graph.json
            );
            std::process::exit(1);
        }
        if took > Duration::from_secs(1) {
            eprintln!(
                "fuzz_gltf graph: seed {seed}, run {runs}: {took:?}\n{}",
                graph.json
            );
            std::process::exit(1);
        }
        accepted += u64::from(graph.expected.is_ok());
        runs += 1;
    }
    println!(
        "fuzz_gltf graph: seed {seed}: {runs} graphs in {seconds} s, {accepted} accepted, \
         every verdict as expected"
    );
}

/// Seeded byte mutations of the textured sample, JSON and GLB.
fn mutate_bytes(seconds: u64, seed: u64) {
    let dir = std::env::temp_dir().join(format!("hexbake-fuzz-gltf-{}", std::process::id()));
    let path = scene::load::gltf_sample::write_textured_sample(&dir).expect("sample scene");
    let json = std::fs::read(&path).expect("sample json");
    let bin = std::fs::read(dir.join("textured-sample.bin")).expect("sample bin");
    // The same document as a GLB: the buffer URI dropped, the bytes as the BIN chunk.
    let glb_json = String::from_utf8_lossy(&json)
        .replace("\"uri\": \"textured-sample.bin\", ", "")
        .into_bytes();
    let mut glb_json = glb_json;
    while !glb_json.len().is_multiple_of(4) {
        glb_json.push(b' ');
    }
    let mut glb = Vec::new();
    let total = 12 + 8 + glb_json.len() + 8 + bin.len();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(glb_json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&glb_json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let seeds = [(path.clone(), json), (dir.join("fuzz.glb"), glb)];
    for (p, bytes) in &seeds {
        scene::load::parse_gltf_scene(p, bytes).expect("the seeds parse");
    }
    // The gltf crate panics on some hostile inputs (index out of bounds in its
    // accessors, overflow in its GLB reader); the loader catches those and returns
    // `LoadError::ParserPanic`. Silence the default hook's message for them: a panic
    // that escapes still ends this driver with a non-zero status.
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = SplitMix(seed);
    let deadline = Instant::now() + Duration::from_secs(seconds);
    let (mut runs, mut accepted) = (0u64, 0u64);
    while Instant::now() < deadline {
        for (p, seed_bytes) in &seeds {
            let mut b = seed_bytes.clone();
            for _ in 0..1 + rng.next_u64() % 4 {
                let n = b.len().max(1);
                let i = (rng.next_u64() as usize) % n;
                match rng.next_u64() % 4 {
                    0 if !b.is_empty() => b[i] ^= 1 << (rng.next_u64() % 8),
                    1 if !b.is_empty() => {
                        b[i] = *[b'0', b'9', b'-', b'"', b'{', b'}', b'[', 0xff, 0]
                            .get((rng.next_u64() % 9) as usize)
                            .unwrap()
                    }
                    2 => b.truncate(i),
                    _ => {
                        let j = (i + 1 + (rng.next_u64() as usize) % 16).min(b.len());
                        let span = b[i.min(j)..j].to_vec();
                        b.splice(i..i, span);
                    }
                }
            }
            if scene::load::parse_gltf_scene(p, &b).is_ok() {
                accepted += 1;
            }
            runs += 1;
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("fuzz_gltf: seed {seed}: {runs} runs in {seconds} s, {accepted} accepted, no panic");
}
