//! Stable-toolchain fallback of the `fuzz/` targets (scripts/fuzz.sh runs it when
//! `cargo fuzz` or nightly is missing): a deterministic random-mutation driver over
//! the golden sample packs — bit flips, interesting bytes and header/table fields,
//! truncations, insertions, deletions, splices of two packs, each optionally resealed
//! (checksums recomputed) so the content decoders are reached, and a quarter of the
//! time a structure-aware edit (`sample::mutate_decoded`: an interesting value in a
//! decoded field, the pack re-assembled with valid checksums) — for SECONDS seconds.
//! Any panic is a failure: the input is written to `fuzz/artifacts/` and the driver
//! exits 1.
//!
//!     cargo run -p format --example fuzz_packs -- SECONDS [SEED]

use format::pack::sample::{self, exercise_readers, reseal, SplitMix};
use std::time::{Duration, Instant};

fn mutate(rng: &mut SplitMix, input: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    let ops = 1 + rng.below(4);
    for _ in 0..ops {
        let len = input.len() as u64;
        match rng.below(9) {
            0 if len > 0 => {
                let i = rng.below(len) as usize;
                input[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len) as usize;
                input[i] = [0, 1, 0x7f, 0x80, 0xff, 0x40][rng.below(6) as usize];
            }
            2 => input.truncate(rng.below(len + 1) as usize),
            3 => {
                let at = rng.below(len + 1) as usize;
                let n = 1 + rng.below(70) as usize;
                let bytes: Vec<u8> = (0..n).map(|_| rng.below(256) as u8).collect();
                input.splice(at..at, bytes);
            }
            4 if len > 0 => {
                let at = rng.below(len) as usize;
                let n = (1 + rng.below(70) as usize).min(input.len() - at);
                input.drain(at..at + n);
            }
            5 => {
                // Splice: a prefix of this input and a suffix of another pack.
                let other = &seeds[rng.below(seeds.len() as u64) as usize];
                let cut = rng.below(len + 1) as usize;
                let from = rng.below(other.len() as u64 + 1) as usize;
                input.truncate(cut);
                input.extend_from_slice(&other[from..]);
            }
            6 | 7 if len >= 8 => {
                // An interesting little-endian u32/u64 in the header or table region.
                let region = len.min(64 + 64 * 10);
                let at = (rng.below(region.saturating_sub(7).max(1)) & !3) as usize;
                let v: u64 = [
                    0,
                    1,
                    63,
                    64,
                    65,
                    4096,
                    u32::MAX as u64,
                    u64::MAX,
                    len,
                    len + 1,
                ][rng.below(10) as usize];
                let width = if rng.below(2) == 0 { 4 } else { 8 };
                let end = (at + width).min(input.len());
                let bytes = v.to_le_bytes();
                input[at..end].copy_from_slice(&bytes[..end - at]);
            }
            _ => {}
        }
    }
    if rng.below(2) == 0 {
        reseal(input);
    }
    // Structure-aware (issue 19): a decoded field set to an interesting value and the
    // pack re-assembled, so the content validation itself is exercised.
    if rng.below(4) == 0 {
        if let Some(m) = sample::mutate_decoded(input, rng.next_u64()) {
            *input = m;
        }
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let seconds: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    let seed: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
    let seeds = vec![
        sample::small_base().encode().expect("sample base"),
        sample::small_base_textured()
            .encode()
            .expect("sample textured base"),
        sample::small_cell().encode().expect("sample cell"),
        sample::small_index().encode().expect("sample index"),
        sample::small_cell_v2().encode().expect("sample cell v2"),
        sample::small_group().encode_group().expect("sample group"),
        sample::small_index_v2().encode().expect("sample index v2"),
        sample::small_base_patches()
            .encode()
            .expect("sample base with patches"),
    ];
    for s in &seeds {
        assert_eq!(
            exercise_readers(s),
            1,
            "every seed pack is accepted by its own reader"
        );
    }
    // Panics are failures, not noise: report them ourselves.
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = SplitMix(seed);
    let deadline = Instant::now() + Duration::from_secs(seconds);
    let (mut execs, mut accepted) = (0u64, 0u64);
    while Instant::now() < deadline {
        for _ in 0..256 {
            let mut input = seeds[rng.below(seeds.len() as u64) as usize].clone();
            mutate(&mut rng, &mut input, &seeds);
            match std::panic::catch_unwind(|| exercise_readers(&input)) {
                Ok(n) => accepted += (n > 0) as u64,
                Err(e) => {
                    let msg = e
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    let dir =
                        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/artifacts");
                    let _ = std::fs::create_dir_all(&dir);
                    let path = dir.join(format!("fallback-crash-{seed}-{execs}.pack"));
                    let _ = std::fs::write(&path, &input);
                    eprintln!(
                        "fuzz_packs: PANIC after {execs} executions: {msg}; input saved to {}",
                        path.display()
                    );
                    std::process::exit(1);
                }
            }
            execs += 1;
        }
    }
    println!(
        "fuzz_packs: {execs} executions in {seconds} s (seed {seed}), {accepted} inputs accepted by a reader, no panic"
    );
}
